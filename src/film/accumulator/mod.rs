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
use header::{crc, data_crc, entries_attribute};
use std::path::Path;

mod checkpoint;
mod header;
mod merge;
mod read;

pub use checkpoint::{HitPointState, write_checkpoint};
pub use merge::merge_parts;
pub use read::{read_checkpoint, read_info, read_part};

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
    /// Share `part` (from 1) of `parts` of a render of `units` samples per pixel or passes in all,
    /// by `integrator`, whose scene and settings `fingerprint` names (the merge checks it): its
    /// units; `per_unit` is 1 until the renderer says more. The problem, if the share cannot exist.
    pub fn of_share(
        fingerprint: String,
        integrator: &str,
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
            fingerprint,
            integrator: integrator.to_owned(),
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

fn bad(path: &Path, message: String) -> Error {
    Error::Accumulator { path: path.to_path_buf(), message }
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
