//! `--set KEY=VALUE` (and the Python package's keyword overrides): assignments written into a run
//! file's tables before it is read, by dotted key or by a short key that names its table.

use super::{RunFile, describe_toml_error};

impl RunFile {
    /// As [`RunFile::parse`], with `sets` (`KEY=VALUE`, the key dotted through tables) written into
    /// the text's tables first. The error says which assignment failed.
    pub fn parse_with_sets(text: &str, sets: &[String]) -> std::result::Result<RunFile, String> {
        let mut table: toml::Table = toml::from_str(text).map_err(|e| describe_toml_error(&e, text))?;
        for set in sets {
            let (key, value) = set
                .split_once('=')
                .ok_or_else(|| format!("--set {set}: needs KEY=VALUE, as render.spp=16"))?;
            let (key, value) = (key.trim(), value.trim());
            // A TOML value as written (16, true, [0, 1, 3], "pt"), else the text as a string (pt).
            // A value that parses into more than `v` (a newline and another assignment) is no one value.
            let value = match toml::from_str::<toml::Table>(&format!("v = {value}")) {
                Ok(mut t) if t.len() == 1 => {
                    t.remove("v").unwrap_or_else(|| toml::Value::String(value.to_owned()))
                }
                Ok(_) => {
                    return Err(format!("--set {key}: the value holds more than one value (a line break?)"));
                }
                Err(_) => toml::Value::String(value.to_owned()),
            };
            let mut parts: Vec<&str> = key.split('.').collect();
            if let [short] = parts[..] {
                let Some(&(_, table)) = SHORT_KEYS.iter().find(|(k, _)| *k == short) else {
                    let known: Vec<&str> = SHORT_KEYS.iter().map(|(k, _)| *k).collect();
                    return Err(format!(
                        "--set {short}: not a key without its table; give TABLE.KEY (render.spp) or one of {}",
                        known.join(", ")
                    ));
                };
                parts = vec![table, short];
            }
            // A run file's keys are a table and a key (`render.spp`, `camera.eye`); a deeper one names
            // nothing, and a very deep one would nest tables deeper than reading them back can recurse.
            if parts.len() > MAX_KEY_DEPTH {
                let shown: String = key.chars().take(40).collect();
                return Err(format!(
                    "--set {shown}…: a key of {} dotted parts; run-file keys have at most {MAX_KEY_DEPTH}",
                    parts.len()
                ));
            }
            let last = parts.pop().filter(|p| !p.is_empty()).ok_or_else(|| format!("--set {set}: no key"))?;
            let mut node = &mut table;
            for part in parts {
                node = node
                    .entry(part)
                    .or_insert_with(|| toml::Value::Table(toml::Table::new()))
                    .as_table_mut()
                    .ok_or_else(|| format!("--set {set}: {part} is not a table"))?;
            }
            node.insert(last.to_owned(), value);
        }
        let run: RunFile = toml::Value::Table(table)
            .try_into()
            .map_err(|e: toml::de::Error| format!("--set {}: {}", sets.join(" "), e.message().trim_end()))?;
        run.check_settings().map_err(|problem| format!("{problem} (after --set {})", sets.join(" ")))?;
        Ok(run)
    }
}

/// Whether one of `sets` (`KEY=VALUE`) assigns the dotted key `dotted` (`render.spp`), written in
/// full or by its short key (`spp`).
pub fn assigns(sets: &[String], dotted: &str) -> bool {
    sets.iter().filter_map(|set| set.split_once('=')).any(|(key, _)| {
        let key = key.trim();
        key == dotted
            || SHORT_KEYS.iter().any(|(short, table)| key == *short && dotted == format!("{table}.{short}"))
    })
}

/// The keys `--set` (and Python's keyword overrides) take without their table, as Mitsuba's `-D
/// spp=…` does, with their tables: the one list, which the Python package reads too.
pub const SHORT_KEYS: &[(&str, &str)] = &[
    ("integrator", "render"),
    ("spp", "render"),
    ("seed", "render"),
    ("max_depth", "render"),
    ("rr_depth", "render"),
    ("light_selection", "render"),
    ("sampler", "render"),
    ("time_limit", "render"),
    ("memory_budget_mib", "render"),
    ("noise_threshold", "render"),
    ("min_spp", "render"),
    ("chunk", "render"),
    ("width", "film"),
    ("height", "film"),
    ("filter", "film"),
    ("exposure", "film"),
    ("eye", "camera"),
    ("target", "camera"),
    ("up", "camera"),
    ("yfov_degrees", "camera"),
    ("aperture_radius", "camera"),
    ("focus_distance", "camera"),
    ("shutter", "camera"),
    ("photons", "photons"),
    ("caustic_photons", "photons"),
    ("k", "photons"),
    ("max_radius", "photons"),
    ("kernel", "photons"),
    ("final_gather", "photons"),
    ("passes", "progressive"),
    ("photons_per_pass", "progressive"),
    ("alpha", "progressive"),
    ("initial_radius", "progressive"),
    ("hit_points_per_pixel", "progressive"),
    ("order", "schedule"),
    ("nee", "schedule"),
    ("caustic_map", "schedule"),
];

/// Most dotted parts a `--set` key may have: a table, a key, and room for a nested table's key.
const MAX_KEY_DEPTH: usize = 4;

#[cfg(test)]
mod tests {
    use super::RunFile;

    /// A key of 60 000 dotted parts once nested tables deeper than reading them back could recurse
    /// (a stack overflow, the process gone); deeply nested values fall back to text and are refused.
    #[test]
    fn deep_keys_and_values_are_refused_not_a_stack_overflow() {
        let deep_key = format!("{}.b=1", vec!["a"; 60_000].join("."));
        let message = RunFile::parse_with_sets("", &[deep_key]).unwrap_err();
        assert!(message.contains("60001 dotted parts"), "{message}");
        let deep_value = format!("render.spp={}{}", "[".repeat(20_000), "]".repeat(20_000));
        assert!(RunFile::parse_with_sets("", &[deep_value]).is_err());
        assert_eq!(RunFile::parse_with_sets("", &["render.spp=3".into()]).unwrap().render.spp, 3);
    }

    /// A value with a line break and another assignment was one TOML table whose extra key was
    /// dropped silently; an exposure the writer refuses was refused only after the whole render.
    #[test]
    fn a_set_value_is_one_value_and_an_unwritable_exposure_is_refused_before_rendering() {
        let message = RunFile::parse_with_sets("", &["render.spp=3\nfilm.width=500".into()]).unwrap_err();
        assert!(message.contains("more than one value"), "{message}");
        let message = RunFile::parse_with_sets("", &["film.exposure=1e30".into()]).unwrap_err();
        assert!(message.contains("film.exposure") && message.contains("±64"), "{message}");
        assert_eq!(RunFile::parse_with_sets("", &["film.exposure=-3".into()]).unwrap().film.exposure, -3.0);
    }

    /// `spp=4` is `render.spp=4` (as Python's `spp=` and Mitsuba's `-D spp=`), every short key sets
    /// its own table's key, and an unknown one is refused listing those it could be.
    #[test]
    fn short_keys_set_their_tables_keys() {
        let run =
            RunFile::parse_with_sets("", &["spp=4".into(), "width=9".into(), "passes=7".into()]).unwrap();
        assert_eq!((run.render.spp, run.film.width, run.progressive.passes), (4, Some(9), 7));
        for (key, table) in super::SHORT_KEYS {
            let text = format!("[{table}]\n");
            let short =
                RunFile::parse_with_sets(&text, &[format!("{key}=\"x\"")]).map_err(|e| e.replace(key, "KEY"));
            let dotted = RunFile::parse_with_sets(&text, &[format!("{table}.{key}=\"x\"")])
                .map_err(|e| e.replace(&format!("{table}.{key}"), "KEY"));
            // The same outcome either way: both refused for the same reason, or both taken.
            assert_eq!(short.is_ok(), dotted.is_ok(), "{key}: {short:?} vs {dotted:?}");
        }
        let message = RunFile::parse_with_sets("", &["spd=4".into()]).unwrap_err();
        assert!(message.contains("spd") && message.contains("spp"), "{message}");
    }
}
