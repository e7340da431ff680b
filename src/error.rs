//! Everything a user can get wrong, one variant each; every message names the file and the object.

use std::path::PathBuf;

/// A user-facing error: bad input, never a broken internal assumption.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read.
    #[error("{path}: cannot read file: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A glTF file is malformed or not glTF at all.
    #[error("{path}: not a valid glTF 2.0 file: {message}")]
    Gltf {
        /// The file.
        path: PathBuf,
        /// What the parser said.
        message: String,
    },
    /// A scene file whose type the loader does not know (by its extension).
    #[error("{path}: unknown scene file type: expected a run file (.toml) or glTF 2.0 (.gltf, .glb)")]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// A run file is not valid TOML or has unknown or mistyped keys.
    #[error("{path}: invalid run file: {message}")]
    RunFile {
        /// The file.
        path: PathBuf,
        /// What is wrong, with the key.
        message: String,
    },
    /// A data file for `caustica density` cannot be read as numbers.
    #[error("{path}: {message}")]
    Data {
        /// The file.
        path: PathBuf,
        /// What is wrong, with the line and token.
        message: String,
    },
    /// Some value in a scene breaks a constraint (NaN transform, bad primitive mode, ...).
    #[error("{path}: {object}: {problem}")]
    InvalidScene {
        /// The file.
        path: PathBuf,
        /// The object: node/mesh/material name and index, or TOML key.
        object: String,
        /// The constraint that failed.
        problem: String,
    },
    /// A setting given on the command line or by a host is out of range (the run file's own are
    /// `RunFile` errors naming the file).
    #[error("invalid setting: {problem} (given on the command line or by the caller)")]
    Override {
        /// The key and the constraint that failed.
        problem: String,
    },
    /// A setting is out of range (spp 0, width 0, ...).
    #[error("invalid setting {name}: {problem}")]
    Setting {
        /// The setting.
        name: String,
        /// The constraint that failed.
        problem: String,
    },
    /// An image (reference, environment map) could not be read or decoded.
    #[error("{path}: cannot read image: {message}")]
    Image {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// An image could not be written.
    #[error("{path}: cannot write image: {message}")]
    Output {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// An accumulator file (a partial render) is unreadable or not one.
    #[error("{path}: {message}")]
    Accumulator {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The denoiser is missing (a build without feature `denoise`) or failed.
    #[error("cannot denoise: {problem}")]
    Denoise {
        /// Why.
        problem: String,
    },
    /// Memory the budget let through that the machine, or the process's limit (`ulimit -v`), has not
    /// got: refused before anything of it is used, never an abort.
    #[error(
        "cannot allocate {what}: {} MiB, within the memory budget of {} MiB, but the machine or this \
         process's limit (ulimit -v) has not got it; lower the resolution or the photon counts, or free memory",
        bytes.div_ceil(1 << 20),
        budget.div_ceil(1 << 20)
    )]
    OutOfMemory {
        /// What was to be allocated.
        what: String,
        /// Its size, bytes.
        bytes: u64,
        /// The budget it was checked against, bytes.
        budget: u64,
    },
    /// Parts given to a merge that do not make one whole render.
    #[error("cannot merge: {problem}")]
    Merge {
        /// Which parts, and what is wrong with them.
        problem: String,
    },
}

/// Result with [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
