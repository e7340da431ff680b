//! Reading a glTF file: the JSON or GLB container, its buffers and its images, and the URIs they name,
//! each failure naming the buffer or image.

use super::label;
use crate::error::{Error, Result};
use std::path::Path;

/// Reads the file, its buffers and its images, naming the buffer or image that fails; the file and
/// its external buffers are read only within `budget` bytes, and fallibly.
pub(super) fn import(
    path: &Path,
    budget: u64,
) -> Result<(gltf::Document, Vec<gltf::buffer::Data>, Vec<gltf::image::Data>)> {
    let gltf_error = |message: String| Error::Gltf { path: path.to_path_buf(), message };
    // A device (a run file's gltf = "/dev/zero") never ends, and the file is read whole.
    // (A missing file is left to the read, whose error says so.)
    if path.exists() {
        check_regular_file(path, budget).map_err(gltf_error)?;
    }
    let bytes = read_fallibly(path, u64::MAX, budget).map_err(|e| match e {
        Unread::Io(source) => Error::Io { path: path.to_path_buf(), source },
        Unread::Memory(problem) => gltf_error(problem),
    })?;
    let bytes = without_pointer_channels(bytes).map_err(gltf_error)?;
    let gltf::Gltf { document, mut blob } =
        gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| gltf_error(describe(&e)))?;
    // gltf-json 1.4's validation indexes `accessors` with each POSITION index before checking it
    // (a panic on an index out of range), so check those first, then validate.
    let json = document.as_json();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position =
                primitive.attributes.get(&gltf::json::validation::Checked::Valid(gltf::Semantic::Positions));
            if let Some(index) = position
                && index.value() >= json.accessors.len()
            {
                return Err(gltf_error(format!(
                    "{} primitive {p}: POSITION is accessor {}, but the file has {} accessors",
                    label("mesh", mesh.name.as_deref(), m),
                    index.value(),
                    json.accessors.len()
                )));
            }
        }
    }
    // Its validation checks a channel's sampler but not its target, which the gltf crate unwraps.
    for (a, animation) in json.animations.iter().enumerate() {
        for (c, channel) in animation.channels.iter().enumerate() {
            let target = &channel.target;
            let problem = if target.node.value() >= json.nodes.len() {
                format!("targets node #{}, but the file has {} nodes", target.node.value(), json.nodes.len())
            } else if !matches!(target.path, gltf::json::validation::Checked::Valid(_)) {
                "targets a path other than translation, rotation, scale or weights".to_owned()
            } else {
                continue;
            };
            return Err(gltf_error(format!(
                "{} channel {c} {problem}",
                label("animation", animation.name.as_deref(), a)
            )));
        }
    }
    // A file that requires an extension Caustica lacks is valid glTF all the same: say which.
    let lacking: Vec<&str> = json
        .extensions_required
        .iter()
        .map(String::as_str)
        .filter(|e| !super::SUPPORTED_EXTENSIONS.contains(e))
        .collect();
    if !lacking.is_empty() {
        return Err(Error::InvalidScene {
            path: path.to_path_buf(),
            object: "extensionsRequired".to_owned(),
            problem: format!(
                "the file requires {}, which Caustica does not support (it supports {})",
                lacking.join(", "),
                super::SUPPORTED_EXTENSIONS.join(", ")
            ),
        });
    }
    // gltf-json's validation knows only the extensions compiled into it: those the loader reads
    // from the raw JSON itself (KHR_materials_unlit, KHR_node_visibility, …) are checked above.
    let mut root = document.into_json();
    root.extensions_required.retain(|e| !super::SUPPORTED_EXTENSIONS.contains(&e.as_str()));
    let document = validate(root).map_err(|e| gltf_error(describe(&e)))?;
    let version = &document.as_json().asset.version;
    if !version.starts_with("2.") {
        return Err(gltf_error(format!("asset.version is \"{version}\", only 2.x is supported")));
    }
    let base = path.parent().unwrap_or(Path::new("."));
    let mut buffers = Vec::with_capacity(document.buffers().len());
    for buffer in document.buffers() {
        let object = label("buffer", buffer.name(), buffer.index());
        if let gltf::buffer::Source::Uri(uri) = buffer.source() {
            check_uri(uri).map_err(|problem| gltf_error(format!("{object}: {problem}")))?;
            if let Some(file) = read_external(uri, base, buffer.length(), budget)
                .map_err(|problem| gltf_error(format!("{object} ({}): {problem}", describe_uri(uri, base))))?
            {
                buffers.push(file);
                continue;
            }
        }
        let data = gltf::buffer::Data::from_source_and_blob(buffer.source(), Some(base), &mut blob).map_err(
            |e| {
                let source = match buffer.source() {
                    gltf::buffer::Source::Uri(uri) => describe_uri(uri, base),
                    gltf::buffer::Source::Bin => "the GLB BIN chunk".to_owned(),
                };
                gltf_error(format!("{object} ({source}): {}", describe(&e)))
            },
        )?;
        if data.len() < buffer.length() {
            return Err(gltf_error(format!(
                "{object}: holds {} bytes but byteLength says {}",
                data.len(),
                buffer.length()
            )));
        }
        buffers.push(data);
    }
    // The gltf crate computes view ends unchecked and slices image views without a bounds check.
    for view in document.views() {
        let buffer = view.buffer();
        if view.offset().checked_add(view.length()).is_none_or(|end| end > buffer.length()) {
            return Err(gltf_error(format!(
                "{}: byteOffset {} + byteLength {} is past the end of {} ({} bytes)",
                label("bufferView", view.name(), view.index()),
                view.offset(),
                view.length(),
                label("buffer", buffer.name(), buffer.index()),
                buffer.length()
            )));
        }
    }
    // The gltf crate unwraps these (its validation does not check them), so reject them before it panics.
    for (index, image) in document.as_json().images.iter().enumerate() {
        let object = label("image", image.name.as_deref(), index);
        let problem = match (&image.uri, &image.buffer_view, &image.mime_type) {
            (None, None, _) => "has neither uri nor bufferView",
            (Some(_), Some(_), _) => "has both uri and bufferView",
            (None, Some(_), None) => "has a bufferView but no mimeType",
            (Some(uri), None, _) => match check_uri(uri) {
                Ok(()) => continue,
                Err(problem) => return Err(gltf_error(format!("{object}: {problem}"))),
            },
            _ => continue,
        };
        return Err(gltf_error(format!("{object} {problem}")));
    }
    let mut images = Vec::with_capacity(document.images().len());
    for image in document.images() {
        if let gltf::image::Source::Uri { uri, .. } = image.source()
            && !uri.starts_with("data:")
        {
            let object = label("image", image.name(), image.index());
            check_regular_file(&base.join(decode_uri(uri)), MAX_IMAGE_FILE_BYTES).map_err(|problem| {
                gltf_error(format!("{object} ({}): {problem}", describe_uri(uri, base)))
            })?;
        }
        let data = gltf::image::Data::from_source(image.source(), Some(base), &buffers).map_err(|e| {
            let source = match image.source() {
                gltf::image::Source::Uri { uri, .. } => describe_uri(uri, base),
                gltf::image::Source::View { view, .. } => {
                    format!("bufferView #{}", view.index())
                }
            };
            gltf_error(format!(
                "{} ({source}): {}",
                label("image", image.name(), image.index()),
                describe(&e)
            ))
        })?;
        images.push(data);
    }
    Ok((document, buffers, images))
}

/// gltf-json's validation, except that it requires a bufferView on every accessor that is not sparse, where glTF 2.0
/// defines an accessor without one as all zeros (which [`read`] supplies).
fn validate(json: gltf::json::Root) -> Result<gltf::Document, gltf::Error> {
    use gltf::json::validation::{Error as Invalid, Validate};
    let mut errors = Vec::new();
    json.validate(&json, gltf::json::Path::new, &mut |path, error| {
        let path = path();
        let zeros = matches!(error, Invalid::Missing)
            && path.as_str().starts_with("accessors[")
            && path.as_str().ends_with("].bufferView");
        if !zeros {
            errors.push((path, error));
        }
    });
    if errors.is_empty() {
        Ok(gltf::Document::from_json_without_validation(json))
    } else {
        Err(gltf::Error::Validation(errors))
    }
}

fn describe(error: &gltf::Error) -> String {
    match error {
        gltf::Error::Deserialize(e) => format!("invalid JSON or wrong glTF structure: {e}"),
        gltf::Error::Validation(errors) => {
            let first: Vec<String> = errors.iter().take(5).map(|(path, e)| format!("{path}: {e}")).collect();
            let more = errors.len().saturating_sub(first.len());
            let more = if more > 0 { format!(" (and {more} more)") } else { String::new() };
            format!("invalid glTF: {}{more}", first.join("; "))
        }
        other => other.to_string(),
    }
}

/// Largest image file a glTF may name: decoding reads it whole.
const MAX_IMAGE_FILE_BYTES: u64 = 1 << 31;

/// An external buffer (a relative or `file:` URI), read to its declared `length` and no further: the
/// gltf crate would read the whole file, and a URI naming a device (`/dev/zero`) never ends. None for
/// a `data:` URI, which the gltf crate decodes from the JSON itself.
fn read_external(
    uri: &str,
    base: &Path,
    length: usize,
    budget: u64,
) -> Result<Option<gltf::buffer::Data>, String> {
    if uri.starts_with("data:") {
        return Ok(None);
    }
    let path = match uri.strip_prefix("file://") {
        Some(absolute) => std::path::PathBuf::from(absolute),
        None => base.join(decode_uri(uri)),
    };
    let size = check_regular_file(&path, u64::MAX)?;
    if size < length as u64 {
        return Err(format!("holds {size} bytes but byteLength says {length}"));
    }
    // A sparse file can be as long as it likes; what is read must fit in the budget.
    if length as u64 > budget {
        return Err(format!(
            "byteLength {length} is over the memory budget of {} MiB (--memory-budget-mib)",
            budget.div_ceil(1 << 20)
        ));
    }
    let mut bytes = read_fallibly(&path, length as u64, budget).map_err(|e| match e {
        Unread::Io(e) => format!("cannot read it: {e}"),
        Unread::Memory(problem) => problem,
    })?;
    // The gltf crate keeps buffers padded to 4 bytes.
    bytes.resize(length.next_multiple_of(4), 0);
    Ok(Some(gltf::buffer::Data(bytes)))
}

/// Why a file was not read.
enum Unread {
    Io(std::io::Error),
    /// Its bytes are more than the allocator has (`ulimit -v`, a budget raised past the machine).
    Memory(String),
}

/// The first `most` bytes of `path`, in one allocation asked for fallibly: a file the budget let
/// through that the process cannot hold is an error, not an abort.
fn read_fallibly(path: &Path, most: u64, budget: u64) -> std::result::Result<Vec<u8>, Unread> {
    use std::io::Read;
    let file = std::fs::File::open(path).map_err(Unread::Io)?;
    let length = file.metadata().map_err(Unread::Io)?.len().min(most);
    let mut bytes = Vec::new();
    // Room for the padding to 4 bytes the gltf crate keeps buffers in, so that it costs no copy.
    bytes.try_reserve_exact((length as usize).next_multiple_of(4)).map_err(|_| {
        Unread::Memory(format!(
            "cannot allocate its {} MiB within the memory budget of {} MiB: the machine or this process's \
             limit (ulimit -v) has not got it",
            length.div_ceil(1 << 20),
            budget.div_ceil(1 << 20)
        ))
    })?;
    file.take(length).read_to_end(&mut bytes).map_err(Unread::Io)?;
    Ok(bytes)
}

/// That `path` is a regular file (not a device, a pipe or a folder) of at most `max` bytes; its size.
fn check_regular_file(path: &Path, max: u64) -> Result<u64, String> {
    let meta = std::fs::metadata(path).map_err(|e| format!("cannot read it: {e}"))?;
    if !meta.is_file() {
        return Err("is not a regular file".into());
    }
    if meta.len() > max {
        return Err(format!("is {} bytes, over the {max} it may have", meta.len()));
    }
    Ok(meta.len())
}

/// A relative URI percent-decoded (glTF URIs are; `check_uri` has made sure the bytes are UTF-8).
fn decode_uri(uri: &str) -> String {
    String::from_utf8_lossy(&percent_decode(uri)).into_owned()
}

/// The bytes a percent-encoded URI stands for.
fn percent_decode(uri: &str) -> Vec<u8> {
    let (bytes, mut decoded) = (uri.as_bytes(), Vec::with_capacity(uri.len()));
    let hex = |i: usize| bytes.get(i).and_then(|&b| char::from(b).to_digit(16));
    let mut i = 0;
    while i < bytes.len() {
        match (bytes[i], hex(i + 1), hex(i + 2)) {
            (b'%', Some(high), Some(low)) => {
                decoded.push((high * 16 + low) as u8);
                i += 3;
            }
            (b, _, _) => {
                decoded.push(b);
                i += 1;
            }
        }
    }
    decoded
}

/// The gltf crate unwraps the UTF-8 decoding of a percent-encoded relative URI, so reject those it would panic on.
fn check_uri(uri: &str) -> Result<(), String> {
    // Only relative references are percent-decoded; `data:` and `file:` URIs are taken as they are.
    if uri.contains(':') {
        return Ok(());
    }
    match String::from_utf8(percent_decode(uri)) {
        Ok(_) => Ok(()),
        Err(_) => Err(format!("URI '{uri}' percent-decodes to bytes that are not UTF-8")),
    }
}

fn describe_uri(uri: &str, base: &Path) -> String {
    if uri.starts_with("data:") {
        "embedded data URI".to_owned()
    } else {
        format!("'{uri}', resolved to {}", base.join(uri).display())
    }
}

/// The file's bytes without its KHR_animation_pointer channels, which target a JSON pointer (a
/// material's colour, a light's intensity) instead of a node and which gltf-json cannot parse
/// ("missing field `node`"). Caustica animates nodes only: the channels are dropped with one
/// warning naming their animations, and the rest of the file loads. A file that never names the
/// extension is passed through untouched, unparsed.
fn without_pointer_channels(bytes: Vec<u8>) -> std::result::Result<Vec<u8>, String> {
    const EXTENSION: &[u8] = b"KHR_animation_pointer";
    if !bytes.windows(EXTENSION.len()).any(|w| w == EXTENSION) {
        return Ok(bytes);
    }
    let glb = bytes.starts_with(b"glTF");
    let (json, bin) = if glb {
        let glb = gltf::binary::Glb::from_slice(&bytes).map_err(|e| describe(&e))?;
        (glb.json.into_owned(), glb.bin.map(std::borrow::Cow::into_owned))
    } else {
        (bytes, None)
    };
    let mut root: gltf::json::Value =
        gltf::json::deserialize::from_slice(&json).map_err(|e| format!("not valid JSON: {e}"))?;
    let mut dropped = Vec::new();
    if let Some(animations) = root.get_mut("animations").and_then(|a| a.as_array_mut()) {
        for (a, animation) in animations.iter_mut().enumerate() {
            let name = animation.get("name").and_then(|n| n.as_str()).map(str::to_owned);
            let Some(channels) = animation.get_mut("channels").and_then(|c| c.as_array_mut()) else {
                continue;
            };
            let before = channels.len();
            channels
                .retain(|channel| channel.get("target").is_none_or(|target| target.get("node").is_some()));
            if channels.len() < before {
                dropped.push((label("animation", name.as_deref(), a), before - channels.len()));
            }
        }
        // An animation left without channels animates nothing (and glTF requires one).
        animations.retain(|a| a.get("channels").and_then(|c| c.as_array()).is_none_or(|c| !c.is_empty()));
    }
    if dropped.is_empty() {
        return Ok(if glb { rebuild_glb(&json, bin)? } else { json });
    }
    tracing::warn!(
        "KHR_animation_pointer channels animate material, light and camera properties, which Caustica \
         does not: ignored {}",
        dropped.iter().map(|(what, n)| format!("{n} channel(s) of {what}")).collect::<Vec<_>>().join(", ")
    );
    let json = gltf::json::serialize::to_vec(&root).map_err(|e| e.to_string())?;
    if glb { rebuild_glb(&json, bin) } else { Ok(json) }
}

/// A GLB container of `json` and `bin`.
fn rebuild_glb(json: &[u8], bin: Option<Vec<u8>>) -> std::result::Result<Vec<u8>, String> {
    use std::borrow::Cow;
    let glb = gltf::binary::Glb {
        header: gltf::binary::Header { magic: *b"glTF", version: 2, length: 0 },
        json: Cow::Borrowed(json),
        bin: bin.map(Cow::Owned),
    };
    glb.to_vec().map_err(|e| describe(&e))
}
