//! Enums that users choose by name, in run files and on the command line.
//!
//! The names live here, with the enums, so that the core needs no command-line crate: the binary
//! builds its parsers and help from [`Choice::CHOICES`], and run files read the same names through
//! serde (a test holds the two to the same spelling).

/// An enum whose variants have names and one line of help each.
pub trait Choice: Copy + PartialEq + Send + Sync + 'static {
    /// Every variant, its name, and its help.
    const CHOICES: &'static [(Self, &'static str, &'static str)];

    /// The variant's name.
    fn name(self) -> &'static str {
        Self::CHOICES.iter().find(|(v, _, _)| *v == self).map_or("?", |(_, name, _)| name)
    }

    /// The variant named `name`, if any.
    fn from_name(name: &str) -> Option<Self> {
        Self::CHOICES.iter().find(|(_, n, _)| *n == name).map(|(v, _, _)| *v)
    }

    /// Every variant, in the order of [`Choice::CHOICES`].
    fn all() -> impl Iterator<Item = Self> {
        Self::CHOICES.iter().map(|&(variant, _, _)| variant)
    }

    /// Every name, comma-separated (for messages).
    fn names() -> String {
        Self::CHOICES.iter().map(|(_, name, _)| *name).collect::<Vec<_>>().join(", ")
    }
}

/// Test that each of `T`'s names reads back, through a run file's serde, as the variant it names:
/// the command line and run files spell every choice alike. Each choice's module calls it.
#[cfg(test)]
pub(crate) fn assert_names_match_serde<T: Choice + std::fmt::Debug + for<'de> serde::Deserialize<'de>>() {
    #[derive(serde::Deserialize)]
    struct Table<T> {
        v: T,
    }
    for &(variant, name, _) in T::CHOICES {
        let table: Table<T> = toml::from_str(&format!("v = \"{name}\"")).expect(name);
        assert_eq!(table.v, variant, "{name}");
        assert_eq!(T::from_name(name), Some(variant));
        assert_eq!(variant.name(), name);
    }
}
