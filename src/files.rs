//! Whether two paths name one file, and the refusal to write over a file a run reads: compared by
//! identity (the same file reached as `./ref.exr`, through a symbolic link or by a hard link), not
//! as text.

use std::path::Path;

/// Whether `a` and `b` are the same file: one existing file by any path, or, where either does not
/// exist yet, the same name in the same folder (two outputs that would be one file).
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(a), Ok(b)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return a.dev() == b.dev() && a.ino() == b.ino();
        }
    }
    match (resolved(a), resolved(b)) {
        (Some(a), Some(b)) => a == b,
        _ => false,
    }
}

/// The path with its folder resolved: the file's own canonical path when it exists, else its
/// folder's joined with its name.
fn resolved(path: &Path) -> Option<std::path::PathBuf> {
    if let Ok(path) = std::fs::canonicalize(path) {
        return Some(path);
    }
    let folder = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    Some(std::fs::canonicalize(folder).ok()?.join(path.file_name()?))
}

/// The files a scene loaded from `scene_path` with the settings `run` reads: the scene file, the
/// run file's glTF and its environment map (named beside the scene, or from the working folder as a
/// command line names it).
pub fn scene_inputs(scene_path: &Path, run: &crate::scene::RunFile) -> Vec<std::path::PathBuf> {
    let beside = |p: &Path| scene_path.parent().unwrap_or(Path::new("")).join(p);
    let environment = run.environment.file.as_deref();
    [
        Some(scene_path.to_path_buf()),
        run.gltf.as_deref().map(beside),
        environment.map(beside),
        environment.map(Path::to_path_buf),
    ]
    .into_iter()
    .flatten()
    .collect()
}

/// The first of `read` that `written` would overwrite, if any.
pub fn overwritten_input<'a>(written: &Path, read: impl IntoIterator<Item = &'a Path>) -> Option<&'a Path> {
    read.into_iter().find(|input| same_file(written, input))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_is_the_same_by_any_path_and_a_missing_one_is_none() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("ref.exr");
        std::fs::write(&file, b"x").unwrap();
        let dotted = dir.path().join(".").join("ref.exr");
        let linked = dir.path().join("hard.exr");
        std::fs::hard_link(&file, &linked).unwrap();
        assert!(same_file(&file, &dotted) && same_file(&file, &linked));
        let other = dir.path().join("other.exr");
        std::fs::write(&other, b"x").unwrap();
        assert!(!same_file(&file, &other));
        let missing = dir.path().join("missing.exr");
        assert!(same_file(&missing, &dir.path().join(".").join("missing.exr")), "two names of one new file");
        assert!(!same_file(&missing, &file));
        assert_eq!(overwritten_input(&dotted, [other.as_path(), linked.as_path()]), Some(linked.as_path()));
    }
}
