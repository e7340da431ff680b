//! Reading an accumulator back: its header and claimed size first, then its sums and hit points,
//! checked against the checksum it was written with.

use super::header::{ATTRIBUTE_PREFIX, crc, data_crc, entries, entry, info_from};
use super::{CHANNELS, HitPointState, PartInfo, Snapshot, bad};
use crate::error::Result;
use crate::film::Film;
use std::path::Path;

/// What an accumulator's header says it is, and its size, without reading its pixels.
pub fn read_info(path: &Path) -> Result<(PartInfo, (u32, u32))> {
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| bad(path, format!("not a readable EXR accumulator: {e}")))?;
    let header = meta
        .headers
        .iter()
        .find(|h| h.own_attributes.layer_name.as_ref().is_some_and(|n| *n == *"accumulator"))
        .ok_or_else(|| {
            bad(path, "no accumulator part: not a caustica accumulator (written with --part)".into())
        })?;
    let info = info_from(&header.own_attributes, path)?;
    let (width, height) = (header.layer_size.width(), header.layer_size.height());
    let pixels = width as u64 * height as u64;
    // A checkpoint's hit points are read whole too: every word of every point counts.
    let hit_point_bytes = meta
        .headers
        .iter()
        .filter(|h| h.own_attributes.layer_name.as_ref().is_some_and(|n| *n == *"hit_points"))
        .map(|h| {
            let words = h.channels.list.len() as u64;
            (h.layer_size.width() as u64 * h.layer_size.height() as u64)
                .saturating_mul(words)
                .saturating_mul(4)
        })
        .fold(0u64, u64::saturating_add);
    check_claimed_size(path, pixels, hit_point_bytes)?;
    Ok((info, (width as u32, height as u32)))
}

/// Refuse an accumulator whose header claims more than its file can hold, before anything of that
/// size is allocated: every pixel is [`Snapshot::BYTES_PER_PIXEL`] bytes of channels, a checkpoint
/// adds `hit_point_bytes`, and zlib (EXR's ZIP) packs at most 1032 to 1, so a file holds at most
/// 1100 × its length.
fn check_claimed_size(path: &Path, pixels: u64, hit_point_bytes: u64) -> Result<()> {
    const MAX_RATIO: u64 = 1100;
    let length = std::fs::metadata(path).map_err(|e| bad(path, e.to_string()))?.len();
    let sums = pixels.saturating_mul(Snapshot::BYTES_PER_PIXEL);
    let claimed = sums.saturating_add(hit_point_bytes);
    if claimed > length.saturating_mul(MAX_RATIO) {
        let hit_points = if hit_point_bytes > 0 {
            format!(" and {hit_point_bytes} bytes of hit points")
        } else {
            String::new()
        };
        return Err(bad(
            path,
            format!(
                "its header claims {pixels} pixels ({sums} bytes of sums){hit_points}, more than a file of {length} bytes can hold"
            ),
        ));
    }
    Ok(())
}

/// Read an accumulator: its film and what it is of. A file that is not one (an ordinary image, a
/// truncated file, a newer format) is an error naming it.
pub fn read_part(path: &Path) -> Result<(Film, PartInfo)> {
    read_checkpoint(path).map(|(film, info, _)| (film, info))
}

/// Read an accumulator with the hit points a checkpoint of a progressive mapper holds, if any.
pub fn read_checkpoint(path: &Path) -> Result<(Film, PartInfo, Option<HitPointState>)> {
    use exr::prelude::*;
    // The header and its claimed size first: the pixels are read whole.
    read_info(path)?;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .map_err(|e| bad(path, format!("not a readable EXR accumulator: {e}")))?;
    let named = |name: &str| {
        image.layer_data.iter().find(|l| l.attributes.layer_name.as_ref().is_some_and(|n| *n == *name))
    };
    let layer = named("accumulator").ok_or_else(|| {
        bad(path, "no accumulator part: not a caustica accumulator (written with --part)".into())
    })?;
    let info = info_from(&layer.attributes, path)?;
    let (width, height) = (layer.size.width() as u32, layer.size.height() as u32);
    let channel = |name: &str| -> crate::error::Result<&[u32]> {
        match layer.channel_data.list.iter().find(|c| c.name == *name).map(|c| &c.sample_data) {
            Some(FlatSamples::U32(v)) => Ok(v),
            _ => Err(bad(path, format!("no uint channel '{name}'"))),
        }
    };
    let film = Film::new(width, height);
    let words: Vec<[&[u32]; 3]> = CHANNELS
        .iter()
        .map(|c| {
            Ok([
                channel(&format!("sum.{c}.0"))?,
                channel(&format!("sum.{c}.1"))?,
                channel(&format!("sum.{c}.2"))?,
            ])
        })
        .collect::<crate::error::Result<_>>()?;
    let count = channel("count")?;
    for i in 0..width as usize * height as usize {
        let sum = |c: usize| {
            let bits =
                words[c][0][i] as u128 | (words[c][1][i] as u128) << 32 | (words[c][2][i] as u128) << 64;
            ((bits << 32) as i128) >> 32
        };
        film.add_sums(i as u32, [sum(0), sum(1), sum(2)], count[i]);
    }
    let hit_points = match named("hit_points") {
        None => None,
        Some(layer) => {
            let entries = entries(&layer.attributes);
            let number = |key: &str| -> crate::error::Result<u32> {
                match entry(&entries, key) {
                    Some(value) => value.parse().map_err(|_| bad(path, format!("unreadable {key}"))),
                    None => Err(bad(path, format!("hit points without {ATTRIBUTE_PREFIX}{key}"))),
                }
            };
            let per = number("words_per_point")? as usize;
            let channels = (0..per)
                .map(|w| {
                    match layer
                        .channel_data
                        .list
                        .iter()
                        .find(|c| c.name == *format!("w.{w:03}").as_str())
                        .map(|c| &c.sample_data)
                    {
                        Some(FlatSamples::U32(v)) => Ok(v.clone()),
                        _ => Err(bad(path, format!("no hit-point word channel w.{w:03}"))),
                    }
                })
                .collect::<crate::error::Result<_>>()?;
            Some(HitPointState {
                points_per_pixel: number("points_per_pixel")?,
                r0: f32::from_bits(number("r0")?),
                channels,
            })
        }
    };
    // Files of the per-key form came before any checksum, and `checksum` (the pixels alone) before
    // `crc` (the pixels and the header).
    let entries = entries(&layer.attributes);
    let (written, read) = match (entry(&entries, "crc"), entry(&entries, "checksum")) {
        (Some(written), _) => {
            (written, crc(&data_crc(&film, hit_points.as_ref()), &info, hit_points.as_ref()))
        }
        (None, Some(written)) => {
            (written, format!("{:08x}", data_crc(&film, hit_points.as_ref()).finalize()))
        }
        (None, None) => return Ok((film, info, hit_points)),
    };
    if written != read {
        return Err(bad(path, format!("checksum {read}, written {written}: the file is damaged")));
    }
    Ok((film, info, hit_points))
}
