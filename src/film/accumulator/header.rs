//! The header's `key=value` entries, written in one fixed order and read from either form, and the
//! checksum that covers the pixels and those entries together.

use super::{FORMAT_VERSION, HitPointState, PartInfo, bad};
use crate::error::Result;
use crate::film::Film;
use std::collections::HashMap;
use std::path::Path;

/// The prefix of the per-key text attributes that files written before the one list have.
pub(super) const ATTRIBUTE_PREFIX: &str = "caustica.";
/// The name of the attribute that holds a layer's entries.
const ENTRIES_ATTRIBUTE: &str = "caustica";

/// CRC-32 of everything a resumed render or a merge takes from an accumulator's pixels: every
/// pixel's sums and count, and the hit points' words (the `checksum` entry of files written before
/// the header was covered too; [`crc`] goes on from here).
pub(super) fn data_crc(film: &Film, hit_points: Option<&HitPointState>) -> crc32fast::Hasher {
    let mut crc = crc32fast::Hasher::new();
    let mut bytes = Vec::with_capacity(28 * film.width as usize);
    for pixel in 0..film.width * film.height {
        let (sums, count) = (film.sums(pixel).0, film.samples(pixel));
        bytes.extend(sums.iter().flat_map(|s| s.to_le_bytes()));
        bytes.extend(count.to_le_bytes());
        if bytes.len() >= 1 << 16 {
            crc.update(&bytes);
            bytes.clear();
        }
    }
    for channel in hit_points.iter().flat_map(|state| &state.channels) {
        bytes.extend(channel.iter().flat_map(|w| w.to_le_bytes()));
        crc.update(&bytes);
        bytes.clear();
    }
    crc.update(&bytes);
    crc
}

/// The `crc` entry: [`data_crc`] followed by what the header says the sums are (the share, its
/// samples, the render's units, the fingerprint, the hit points' layout and radius), in canonical
/// form, so that an edited `samples=0..1` is damage like a flipped bit in the sums: resumed, it would
/// take one pass for two and make another image.
pub(super) fn crc(data: &crc32fast::Hasher, info: &PartInfo, hit_points: Option<&HitPointState>) -> String {
    let mut crc = data.clone();
    let header = format!(
        "format={FORMAT_VERSION}\nfingerprint={}\nintegrator={}\npart={}/{}\nsamples={}..{}\nspp={}\nper_unit={}\n",
        info.fingerprint,
        info.integrator,
        info.part,
        info.parts,
        info.samples.start,
        info.samples.end,
        info.spp,
        info.per_unit
    );
    crc.update(header.as_bytes());
    if let Some(state) = hit_points {
        let hit = format!(
            "words_per_point={}\npoints_per_pixel={}\nr0={}\n",
            state.channels.len(),
            state.points_per_pixel,
            state.r0.to_bits()
        );
        crc.update(hit.as_bytes());
    }
    format!("{:08x}", crc.finalize())
}

/// The attribute that holds a layer's `key=value` entries, in their order. One attribute, because
/// the EXR writer writes a layer's attributes in the order of a `HashMap`, which differs from process
/// to process: several would make the same sums different bytes run to run.
pub(super) fn entries_attribute(
    entries: &[(&str, String)],
) -> HashMap<exr::prelude::Text, exr::prelude::AttributeValue> {
    use exr::prelude::{AttributeValue, Text};
    let list = entries.iter().map(|(key, value)| Text::from(format!("{key}={value}").as_str())).collect();
    HashMap::from([(Text::from(ENTRIES_ATTRIBUTE), AttributeValue::TextVector(list))])
}

/// A layer's entries: the one list attribute, or in files written before it, a text attribute per
/// key (`caustica.format`, …).
pub(super) fn entries(attributes: &exr::meta::header::LayerAttributes) -> Vec<(String, String)> {
    use exr::prelude::{AttributeValue, Text};
    if let Some(AttributeValue::TextVector(list)) = attributes.other.get(&Text::from(ENTRIES_ATTRIBUTE)) {
        return list
            .iter()
            .filter_map(|t| t.to_string().split_once('=').map(|(k, v)| (k.to_owned(), v.to_owned())))
            .collect();
    }
    attributes
        .other
        .iter()
        .filter_map(|(name, value)| match value {
            AttributeValue::Text(t) => {
                name.to_string().strip_prefix(ATTRIBUTE_PREFIX).map(|key| (key.to_owned(), t.to_string()))
            }
            _ => None,
        })
        .collect()
}

/// The value of `key` among `entries`.
pub(super) fn entry<'a>(entries: &'a [(String, String)], key: &str) -> Option<&'a str> {
    entries.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
}

pub(super) fn info_from(attributes: &exr::meta::header::LayerAttributes, path: &Path) -> Result<PartInfo> {
    let entries = entries(attributes);
    let attribute = |key: &str| -> Result<String> {
        match entry(&entries, key) {
            Some(value) => Ok(value.to_owned()),
            None => Err(bad(
                path,
                format!(
                    "no {ATTRIBUTE_PREFIX}{key} attribute: not a caustica accumulator (written with --part)"
                ),
            )),
        }
    };
    let format: u32 =
        attribute("format")?.parse().map_err(|_| bad(path, "unreadable format version".into()))?;
    if format != FORMAT_VERSION {
        return Err(bad(
            path,
            format!("accumulator format {format}; this build reads format {FORMAT_VERSION}"),
        ));
    }
    let number = |s: &str| s.parse::<u32>().map_err(|_| bad(path, format!("'{s}' is not a count")));
    let part = attribute("part")?;
    let (i, k) = part.split_once('/').ok_or_else(|| bad(path, format!("part '{part}' is not I/K")))?;
    let samples = attribute("samples")?;
    let (s0, s1) =
        samples.split_once("..").ok_or_else(|| bad(path, format!("samples '{samples}' is not A..B")))?;
    Ok(PartInfo {
        fingerprint: attribute("fingerprint")?,
        integrator: attribute("integrator")?,
        part: number(i)?,
        parts: number(k)?,
        samples: number(s0)?..number(s1)?,
        spp: number(&attribute("spp")?)?,
        per_unit: number(&attribute("per_unit")?)?,
    })
}
