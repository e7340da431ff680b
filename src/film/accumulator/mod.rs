//! Accumulator files: a film's exact sums, written by a partial render and merged later.
//!
//! An accumulator is an ordinary OpenEXR file with one part, so any EXR viewer opens it:
//! - `R`, `G`, `B` (float): the part's own mean image, for looking at;
//! - `sum.R.0`, `sum.R.1`, `sum.R.2` (and the same for `G` and `B`; uint): a channel's fixed-point
//!   sum ([`super::fixed`]), 96-bit two's complement in three 32-bit words, least significant first;
//! - `count` (uint): samples in the pixel.
//!
//! The header's attribute `caustica`, a list of `key=value` texts in a fixed order (so the same sums
//! are the same bytes in any process; files written before it have a text attribute `caustica.KEY`
//! per entry, and are read too), says what the sums are of: the format version, a
//! fingerprint of the scene and every setting that changes the image, the share (`part` of
//! `parts`), the samples it covers (`samples`, a range of sample indices per pixel) and the whole
//! render's (`spp`). That is what makes a merge safe: parts of different scenes or settings, a part
//! given twice, or a missing one are refused by name. 52 bytes a pixel before compression.

use super::Film;
use crate::error::{Error, Result};
use std::collections::HashMap;
use std::path::Path;

mod checkpoint;
mod merge;

pub use checkpoint::{HitPointState, write_checkpoint};
pub use merge::merge_parts;

/// Version of the layout above.
pub const FORMAT_VERSION: u32 = 1;

/// What an accumulator holds, beyond its sums.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PartInfo {
    /// Fingerprint of the scene and the settings that change the image (hex).
    pub fingerprint: String,
    /// Integrator name, for messages.
    pub integrator: String,
    /// This share, from 1.
    pub part: u32,
    /// Shares in all.
    pub parts: u32,
    /// Units of progress this share covers: sample indices per pixel, or pass indices (`pppm`).
    pub samples: std::ops::Range<u32>,
    /// Units of the whole render: samples per pixel, or passes.
    pub spp: u32,
    /// Camera samples a pixel gets per unit (`pm`'s final-gather samples, `pppm`'s hit points per
    /// pixel): what a complete share's pixels count.
    pub per_unit: u32,
}

impl PartInfo {
    /// Share `part` (from 1) of `parts` of the render `run` sets up of `scene`, of `units` samples
    /// per pixel or passes in all: its units, and the fingerprint a merge checks; `per_unit` is 1
    /// until the renderer says more. The problem, if the share cannot exist.
    pub fn of_share(
        scene: &crate::scene::Scene,
        run: &crate::scene::RunFile,
        units: u32,
        part: u32,
        parts: u32,
    ) -> std::result::Result<Self, String> {
        if part == 0 || part > parts {
            return Err(format!("part {part}/{parts}: parts are numbered 1 to {parts}"));
        }
        if parts > units {
            return Err(format!(
                "part {part}/{parts}: {parts} parts of {units} samples per pixel (or passes) would leave some parts empty"
            ));
        }
        Ok(Self {
            fingerprint: crate::scene::fingerprint::fingerprint(scene, run),
            integrator: format!("{:?}", run.render.integrator).to_lowercase(),
            part,
            parts,
            samples: Self::share(part, parts, units),
            spp: units,
            per_unit: 1,
        })
    }

    /// The samples per pixel of share `part` (from 1) of `parts` of a render of `spp` samples: as
    /// even as integers allow, in order, together exactly `0..spp`.
    pub fn share(part: u32, parts: u32, spp: u32) -> std::ops::Range<u32> {
        let at = |i: u32| (i as u64 * spp as u64 / parts as u64) as u32;
        at(part - 1)..at(part)
    }
}

const ATTRIBUTE_PREFIX: &str = "caustica.";
/// The name of the attribute that holds a layer's entries.
const ENTRIES_ATTRIBUTE: &str = "caustica";
const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// Write `film` with `info` to `path` (a temporary file beside it, renamed over it once complete),
/// ZIP-compressed: a part travels between machines.
pub fn write_part(film: &Film, info: &PartInfo, path: &Path) -> Result<()> {
    Snapshot::of(film, None).write(info, path, exr::prelude::Encoding::SMALL_LOSSLESS)
}

/// An accumulator's channels copied out of a film (and a progressive mapper's hit points) between
/// passes, as they will be written: the one copy a checkpoint makes, so its writer thread encodes
/// it while the render goes on and needs nothing more ([`Snapshot::BYTES_PER_PIXEL`] a pixel plus
/// the hit points' words).
pub struct Snapshot {
    width: u32,
    height: u32,
    /// `R`, `G`, `B`, then each channel's three sum words, then `count`: [`CHANNELS`]' order.
    channels: Vec<(String, exr::prelude::FlatSamples)>,
    data_crc: crc32fast::Hasher,
    hit_points: Option<HitPointState>,
}

impl Snapshot {
    /// Bytes a pixel's channels take: three f32 colours, nine words of sums and a count.
    pub const BYTES_PER_PIXEL: u64 = 52;

    /// Copy `film` and `hit_points` as they are now.
    pub fn of(film: &Film, hit_points: Option<HitPointState>) -> Self {
        use exr::prelude::FlatSamples;
        let n = film.width as usize * film.height as usize;
        let mut colour = [(); 3].map(|_| Vec::with_capacity(n));
        let mut words = [(); 9].map(|_| Vec::with_capacity(n));
        let mut count = Vec::with_capacity(n);
        for pixel in 0..n as u32 {
            let (sums, samples) = film.sums(pixel);
            let mean = film.mean(pixel);
            for c in 0..3 {
                colour[c].push(mean[c]);
                for word in 0..3 {
                    words[3 * c + word].push((sums[c] as u128 >> (32 * word)) as u32);
                }
            }
            count.push(samples);
        }
        let mut channels = Vec::with_capacity(13);
        let mut words = words.into_iter();
        for (name, colour) in CHANNELS.iter().zip(colour) {
            channels.push((name.to_string(), FlatSamples::F32(colour)));
            for word in 0..3 {
                channels
                    .push((format!("sum.{name}.{word}"), FlatSamples::U32(words.next().unwrap_or_default())));
            }
        }
        channels.push(("count".into(), FlatSamples::U32(count)));
        let data_crc = data_crc(film, hit_points.as_ref());
        Self { width: film.width, height: film.height, channels, data_crc, hit_points }
    }

    /// Write it with `info` to `path` (a temporary file beside it, renamed over it once complete).
    pub fn write(self, info: &PartInfo, path: &Path, encoding: exr::prelude::Encoding) -> Result<()> {
        use exr::prelude::*;
        let out_err = |message: String| crate::error::Error::Output { path: path.to_path_buf(), message };
        // An accumulator is an EXR: under another name it would be an EXR that viewers misread.
        if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
            return Err(out_err(
                "an accumulator (a part or a checkpoint) is an EXR: name it FILE.exr".into(),
            ));
        }
        let (width, height) = (self.width as usize, self.height as usize);
        let channels = self
            .channels
            .into_iter()
            .map(|(name, samples)| AnyChannel::new(name.as_str(), samples))
            .collect();
        let mut attributes = LayerAttributes::named("accumulator");
        attributes.other = entries_attribute(&[
            ("crc", crc(&self.data_crc, info, self.hit_points.as_ref())),
            ("format", FORMAT_VERSION.to_string()),
            ("fingerprint", info.fingerprint.clone()),
            ("integrator", info.integrator.clone()),
            ("part", format!("{}/{}", info.part, info.parts)),
            ("samples", format!("{}..{}", info.samples.start, info.samples.end)),
            ("spp", info.spp.to_string()),
            ("per_unit", info.per_unit.to_string()),
        ]);
        let layer = Layer::new(
            (width, height),
            attributes,
            encoding,
            AnyChannels::sort(SmallVec::from_vec(channels)),
        );
        let mut partial = super::partial::PartialFile::beside(path).map_err(out_err)?;
        let mut layers = vec![layer];
        if let Some(state) = self.hit_points {
            let width = width * state.points_per_pixel as usize;
            let points = width * height;
            if state.channels.is_empty() || state.channels.iter().any(|c| c.len() != points) {
                return Err(out_err(format!("hit-point channels do not fill {width}x{height}")));
            }
            let (words_per_point, points_per_pixel, r0) =
                (state.channels.len(), state.points_per_pixel, state.r0);
            let channels: Vec<_> = state
                .channels
                .into_iter()
                .enumerate()
                .map(|(w, words)| AnyChannel::new(format!("w.{w:03}").as_str(), FlatSamples::U32(words)))
                .collect();
            let mut attributes = LayerAttributes::named("hit_points");
            attributes.other = entries_attribute(&[
                ("words_per_point", words_per_point.to_string()),
                ("points_per_pixel", points_per_pixel.to_string()),
                ("r0", r0.to_bits().to_string()),
            ]);
            layers.push(Layer::new(
                (width, height),
                attributes,
                encoding,
                AnyChannels::sort(SmallVec::from_vec(channels)),
            ));
        }
        Image::from_layers(ImageAttributes::new(IntegerBounds::from_dimensions((width, height))), layers)
            .write()
            .non_parallel()
            .to_buffered(partial.file())
            .map_err(|e| out_err(e.to_string()))?;
        partial.finish(path).map_err(out_err)
    }
}

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

fn bad(path: &Path, message: String) -> Error {
    Error::Accumulator { path: path.to_path_buf(), message }
}

/// CRC-32 of everything a resumed render or a merge takes from an accumulator's pixels: every
/// pixel's sums and count, and the hit points' words (the `checksum` entry of files written before
/// the header was covered too; [`crc`] goes on from here).
fn data_crc(film: &Film, hit_points: Option<&HitPointState>) -> crc32fast::Hasher {
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
fn crc(data: &crc32fast::Hasher, info: &PartInfo, hit_points: Option<&HitPointState>) -> String {
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
fn entries_attribute(
    entries: &[(&str, String)],
) -> HashMap<exr::prelude::Text, exr::prelude::AttributeValue> {
    use exr::prelude::{AttributeValue, Text};
    let list = entries.iter().map(|(key, value)| Text::from(format!("{key}={value}").as_str())).collect();
    HashMap::from([(Text::from(ENTRIES_ATTRIBUTE), AttributeValue::TextVector(list))])
}

/// A layer's entries: the one list attribute, or in files written before it, a text attribute per
/// key (`caustica.format`, …).
fn entries(attributes: &exr::meta::header::LayerAttributes) -> Vec<(String, String)> {
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
fn entry<'a>(entries: &'a [(String, String)], key: &str) -> Option<&'a str> {
    entries.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
}

fn info_from(attributes: &exr::meta::header::LayerAttributes, path: &Path) -> Result<PartInfo> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn an_accumulator_reads_back_to_the_same_sums() {
        let film = Film::new(3, 2);
        film.add(0, Vec3::new(1.5, 2.0e9, 3.25e-7));
        film.add(0, Vec3::new(1.0e14, 0.0, -2.0));
        film.add(5, Vec3::splat(0.125));
        let info = PartInfo {
            fingerprint: "00ff".into(),
            integrator: "pt".into(),
            part: 2,
            parts: 3,
            samples: 5..9,
            spp: 16,
            per_unit: 1,
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("part.exr");
        write_part(&film, &info, &path).unwrap();
        let (back, back_info) = read_part(&path).unwrap();
        assert_eq!(back_info, info);
        assert_eq!((back.width, back.height), (3, 2));
        for i in 0..6 {
            assert_eq!(back.sums(i), film.sums(i), "pixel {i}");
        }
    }

    #[test]
    fn shares_cover_the_samples_once_in_order() {
        for (parts, spp) in [(1, 7), (4, 64), (3, 10), (8, 5), (64, 1000)] {
            let shares: Vec<_> = (1..=parts).map(|i| PartInfo::share(i, parts, spp)).collect();
            assert_eq!(shares[0].start, 0);
            assert_eq!(shares[parts as usize - 1].end, spp);
            assert!(shares.windows(2).all(|w| w[0].end == w[1].start));
        }
    }
}
