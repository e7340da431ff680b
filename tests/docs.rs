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
