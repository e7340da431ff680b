//! What a render writes, named and checked before it starts: the outputs from the flags or the run
//! file, an animation's frames, a part's accumulator, the denoised copies; none of them an input.

use crate::args::RenderArgs;
use anyhow::Result;
use caustica::files::{overwritten_input, same_file};
use caustica::film::output;
use caustica::scene::RunFile;
use std::path::{Path, PathBuf};

/// Whether `path` names an EXR.
pub(crate) fn is_exr(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

/// `out/NAME.EXT` → `out/NAME-denoised.EXT`.
pub(crate) fn denoised_path(path: &Path) -> PathBuf {
    let stem = path.file_stem().map_or("image".into(), |s| s.to_string_lossy().into_owned());
    let name = match path.extension() {
        Some(ext) => format!("{stem}-denoised.{}", ext.to_string_lossy()),
        None => format!("{stem}-denoised"),
    };
    path.with_file_name(name)
}

/// A part writes one accumulator, so it takes exactly one `-o`, an .exr.
pub(crate) fn check_part_output(outputs: &[PathBuf]) -> Result<()> {
    match outputs {
        [one] if one.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) => {}
        [one] => anyhow::bail!(
            "{}: --part writes an accumulator, an EXR of exact sums: name it FILE.exr (`caustica merge` \
             writes the PNG)",
            one.display()
        ),
        _ => {
            anyhow::bail!("--part writes one accumulator file: give one -o FILE.exr (got {})", outputs.len())
        }
    }
    Ok(())
}

/// The files a render reads: its outputs must not be any of them.
pub(crate) fn inputs(args: &RenderArgs, run: &RunFile, scene_path: &Path) -> Vec<PathBuf> {
    let mut inputs = caustica::files::scene_inputs(scene_path, run);
    inputs.extend(args.reference.iter().chain(&args.resume).cloned());
    inputs
}

/// Every output is a format we write, in a place we can write, and not one of the inputs (a reference
/// or an environment map overwritten by the render it was meant for is lost).
pub(crate) fn check_outputs(outputs: &[PathBuf], inputs: &[PathBuf]) -> Result<()> {
    for (i, path) in outputs.iter().enumerate() {
        if let Some(input) = overwritten_input(path, inputs.iter().map(PathBuf::as_path)) {
            anyhow::bail!(
                "{}: the output is also an input ({}): refusing to overwrite it",
                path.display(),
                input.display()
            );
        }
        if outputs[..i].iter().any(|other| other == path || same_file(other, path)) {
            anyhow::bail!("{}: named twice as an output", path.display());
        }
        output::check_output_path(path)?;
    }
    Ok(())
}

/// Most frames one command renders: a million is 11.6 hours of film at 24 fps. (A range beyond it
/// is a typo, and listing its outputs would stall before the first frame.)
const MAX_FRAMES: usize = 1_000_000;

/// [`check_outputs`] for an animation's frames: each pattern's first frame checked in full (the
/// folder writable, no two patterns the same file), and every frame's name neither an input nor
/// another output (`a.png` writes `a-0001.png` at frame 1, which `a-####.png` names too). Linear in
/// the frames: the names are compared by their folder, resolved once a pattern, and file name.
pub(crate) fn check_frame_outputs(
    patterns: &[PathBuf],
    range: std::ops::Range<u32>,
    inputs: &[PathBuf],
) -> Result<()> {
    if range.len() > MAX_FRAMES {
        anyhow::bail!(
            "--frames {}:{} asks for {} frames; one command renders at most {MAX_FRAMES}",
            range.start,
            range.end,
            range.len()
        );
    }
    let first: Vec<PathBuf> = patterns.iter().map(|p| crate::frames::frame_path(p, range.start)).collect();
    check_outputs(&first, inputs)?;
    let resolved: Vec<PathBuf> = patterns
        .iter()
        .map(|p| {
            let folder = p.parent().filter(|f| !f.as_os_str().is_empty()).unwrap_or(Path::new("."));
            folder.canonicalize().unwrap_or_else(|_| folder.to_path_buf())
        })
        .collect();
    // Each pattern's folder as the first pattern's index with the same one.
    let folders: Vec<usize> =
        resolved.iter().map(|f| resolved.iter().position(|g| g == f).expect("itself")).collect();
    let mut named = std::collections::HashSet::new();
    for frame in range {
        for (pattern, folder) in patterns.iter().zip(&folders) {
            let path = crate::frames::frame_path(pattern, frame);
            if let Some(input) = overwritten_input(&path, inputs.iter().map(PathBuf::as_path)) {
                anyhow::bail!(
                    "{} (frame {frame}): the output is also an input ({}): refusing to overwrite it",
                    path.display(),
                    input.display()
                );
            }
            if !named.insert((*folder, path.file_name().map(|n| n.to_os_string()))) {
                anyhow::bail!("{} (frame {frame}): named twice as an output", path.display());
            }
        }
    }
    Ok(())
}

/// `-o` flags, else the run file's `[output]`, else `out/<scene>.exr` and `.png`.
pub(crate) fn output_paths(args: &RenderArgs, run: &RunFile, scene_path: &Path) -> Vec<PathBuf> {
    if !args.output.is_empty() {
        return args.output.clone();
    }
    let listed: Vec<PathBuf> = [&run.output.exr, &run.output.png].into_iter().flatten().cloned().collect();
    let defaults = if listed.is_empty() {
        let stem = scene_path.file_stem().map_or("render".into(), |s| s.to_string_lossy().into_owned());
        vec![PathBuf::from(format!("out/{stem}.exr")), PathBuf::from(format!("out/{stem}.png"))]
    } else {
        listed
    };
    // An integrator chosen on the command line names the outputs it did not choose: `--integrator
    // sppm` beside a pt run then writes cornell-spheres-sppm.png and leaves cornell-spheres.png be.
    match args.integrator {
        Some(kind) => {
            defaults.iter().map(|path| with_suffix(path, caustica::integrators::of(kind).name())).collect()
        }
        None => defaults,
    }
}

/// `dir/name.ext` → `dir/name-suffix.ext`.
fn with_suffix(path: &Path, suffix: &str) -> PathBuf {
    let stem = path.file_stem().map_or(String::new(), |s| s.to_string_lossy().into_owned());
    let name = match path.extension() {
        Some(ext) => format!("{stem}-{suffix}.{}", ext.to_string_lossy()),
        None => format!("{stem}-{suffix}"),
    };
    path.with_file_name(name)
}
