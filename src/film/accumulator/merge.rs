//! Merging the accumulators of a split render into the film of the whole.

use super::{PartInfo, read_info, read_part};
use crate::error::{Error, Result};
use crate::film::Film;
use std::path::Path;

/// Merge accumulators into the film of the whole render, checking first that they make one: the
/// same fingerprint, size and split, each share once, none missing, each complete. The sums are
/// integers, so the order of `paths` cannot change a bit.
pub fn merge_parts(paths: &[impl AsRef<Path>]) -> Result<(Film, PartInfo)> {
    let merge_err = |problem: String| Error::Merge { problem };
    // The headers first: a foreign, duplicate or missing part is found before any pixel is read.
    let mut headers = Vec::new();
    for path in paths {
        let (info, size) = read_info(path.as_ref())?;
        headers.push((path.as_ref(), info, size));
    }
    let Some((first_path, base, size)) = headers.first().cloned() else {
        return Err(merge_err("no parts given".into()));
    };
    // Sorted by share, not a slot per share: a header may claim four billion shares.
    let mut given: Vec<(u32, &Path)> = Vec::with_capacity(headers.len());
    for (path, info, part_size) in &headers {
        let differs = |what: &str| {
            merge_err(format!(
                "{} is not a part of the same render as {}: its {what} differs",
                path.display(),
                first_path.display()
            ))
        };
        if info.fingerprint != base.fingerprint {
            return Err(differs("scene or settings (fingerprint)"));
        }
        if info.parts != base.parts || info.spp != base.spp || info.per_unit != base.per_unit {
            return Err(differs("split (parts or samples per pixel)"));
        }
        if *part_size != size {
            return Err(differs("image size"));
        }
        if info.part == 0
            || info.part > info.parts
            || info.samples != PartInfo::share(info.part, info.parts, info.spp)
        {
            return Err(merge_err(format!(
                "{}: part {}/{} with samples {:?} is not a share this build makes",
                path.display(),
                info.part,
                info.parts,
                info.samples
            )));
        }
        given.push((info.part, path));
    }
    given.sort_by_key(|&(part, _)| part);
    if let Some(pair) = given.windows(2).find(|pair| pair[0].0 == pair[1].0) {
        return Err(merge_err(format!(
            "part {}/{} is given twice: {} and {}",
            pair[0].0,
            base.parts,
            pair[0].1.display(),
            pair[1].1.display()
        )));
    }
    let missing_count = base.parts as u64 - given.len() as u64;
    if missing_count > 0 {
        const NAMED: usize = 10;
        let mut missing = Vec::new();
        let mut next = 1u64;
        for part in given.iter().map(|&(part, _)| part as u64).chain([base.parts as u64 + 1]) {
            missing.extend((next..part).take(NAMED - missing.len()).map(|i| format!("{i}/{}", base.parts)));
            next = part + 1;
        }
        let more = missing_count.saturating_sub(missing.len() as u64);
        return Err(merge_err(format!(
            "missing part{} {}{}",
            if missing_count > 1 { "s" } else { "" },
            missing.join(", "),
            if more > 0 { format!(" and {more} more") } else { String::new() }
        )));
    }
    // Then the pixels, one part at a time: memory for the whole film and one part.
    let (width, height) = size;
    // The parts' size is the files' word: what a render of it would have been let through (half
    // the machine) bounds it, and an allocator that has not got it is an error, not an abort.
    let whole = Film::try_new(width, height, crate::memory::physical_bytes() / 2)?;
    for (path, _, _) in &headers {
        let (film, info) = read_part(path)?;
        let want = info.samples.len() as u32 * info.per_unit;
        if let Some(pixel) = (0..width * height).find(|&i| film.samples(i) != want) {
            return Err(merge_err(format!(
                "{}: part {}/{} is incomplete: pixel ({}, {}) has {} of its {want} samples (was it stopped before its end?)",
                path.display(),
                info.part,
                info.parts,
                pixel % width,
                pixel / width,
                film.samples(pixel)
            )));
        }
        for i in 0..width * height {
            let (sums, count) = film.sums(i);
            whole.add_sums(i, sums, count);
        }
    }
    Ok((whole, PartInfo { part: 1, parts: 1, samples: 0..base.spp, ..base }))
}
