//! The documents a user reads against the code they describe: the integrator table and the usage
//! line list exactly the registered integrators, and every path the architecture names exists.

use std::path::Path;

fn read(relative: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(relative);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn registered() -> Vec<&'static str> {
    caustica::integrators::names().collect()
}

/// The names in the first column of the README's integrator table, in its order.
fn readme_table_names(readme: &str) -> Vec<String> {
    let table = readme.split("| name | what it is | when to use it |").nth(1).expect("the integrator table");
    table
        .lines()
        .skip(2)
        .take_while(|line| line.starts_with('|'))
        .map(|row| row.split('`').nth(1).expect("a name in backquotes").to_owned())
        .collect()
}

#[test]
fn the_readme_lists_every_registered_integrator_once_in_the_registry_order() {
    let readme = read("README.md");
    assert_eq!(readme_table_names(&readme), registered(), "README.md's integrator table");
    let usage = format!("[--integrator {}]", registered().join("|"));
    assert!(readme.contains(&usage), "README.md's usage line should read {usage}");
}

#[test]
fn the_architecture_names_every_integrator_in_its_phase_table() {
    let architecture = read("docs/architecture.md");
    let table: String = architecture
        .lines()
        .skip_while(|line| !line.starts_with("| integrator |"))
        .take_while(|line| line.starts_with('|'))
        .collect::<Vec<_>>()
        .join("\n");
    assert!(!table.is_empty(), "docs/architecture.md has no `| integrator |` table");
    for name in registered() {
        assert!(table.contains(&format!("`{name}`")), "docs/architecture.md's phase table omits `{name}`");
    }
}

/// The folders whose files and subfolders docs/architecture.md must name, each one level deep.
const DRAWN: [&str; 3] = ["src", "systems", "cli"];

/// The repository paths a document names: words that start with a top-level folder of the
/// repository and a slash, up to the first character that cannot be in a path.
fn named_paths(text: &str) -> Vec<String> {
    const ROOTS: [&str; 9] =
        ["src/", "systems/", "cli/", "python/", "tests/", "scenes/", "benches/", "examples/", "docs/"];
    let is_path_char = |c: char| c.is_ascii_alphanumeric() || "_./-".contains(c);
    let mut paths = Vec::new();
    for (start, _) in text.char_indices() {
        let rest = &text[start..];
        let at_word_start = text[..start].chars().next_back().is_none_or(|c| !is_path_char(c));
        if at_word_start && ROOTS.iter().any(|root| rest.starts_with(root)) {
            let end = rest.find(|c: char| !is_path_char(c)).unwrap_or(rest.len());
            paths.push(rest[..end].trim_end_matches(['.', '-']).to_owned());
        }
    }
    paths
}

#[test]
fn every_path_the_architecture_names_exists() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let architecture = read("docs/architecture.md");
    let missing: Vec<String> =
        named_paths(&architecture).into_iter().filter(|path| !root.join(path).exists()).collect();
    assert!(missing.is_empty(), "docs/architecture.md names paths that do not exist: {missing:?}");
}

#[test]
fn the_architecture_names_every_module_of_the_three_crates() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let named = named_paths(&read("docs/architecture.md"));
    let mut unnamed = Vec::new();
    for folder in DRAWN {
        for entry in std::fs::read_dir(root.join(folder)).expect(folder) {
            let entry = entry.expect(folder);
            let name = entry.file_name().to_string_lossy().into_owned();
            let is_dir = entry.path().is_dir();
            let holds_code = |dir: &Path| {
                std::fs::read_dir(dir).is_ok_and(|mut files| {
                    files.any(|f| f.is_ok_and(|f| f.path().extension().is_some_and(|x| x == "rs")))
                })
            };
            let code = if is_dir { holds_code(&entry.path()) } else { name.ends_with(".rs") };
            if !code || ["lib.rs", "main.rs", "build.rs"].contains(&&*name) {
                continue;
            }
            let path = if is_dir { format!("{folder}/{name}/") } else { format!("{folder}/{name}") };
            if !named.iter().any(|n| n == &path || n.starts_with(&path) || format!("{n}/") == path) {
                unnamed.push(path);
            }
        }
    }
    unnamed.sort();
    assert!(unnamed.is_empty(), "docs/architecture.md does not name {unnamed:?}");
}

#[test]
fn named_paths_are_found_whole_and_only_at_a_word_start() {
    let text = "see `src/kernel/` and systems/driver/mod.rs. Not mysrc/x, but (cli/args/).";
    assert_eq!(named_paths(text), ["src/kernel/", "systems/driver/mod.rs", "cli/args/"]);
}
