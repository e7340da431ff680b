//! The temporary files that writes are filling (`.NAME.XXXX.partial`, renamed over the output when
//! complete), so that a process that must end at once, before a write completes (a second Ctrl-C),
//! can remove them and leave no leftovers beside the outputs.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// A file being written beside `path` under a name of its own (`.NAME.XXXX.partial`), listed while it
/// is, and renamed over `path` once complete: a failed or cut write leaves the previous file as it was
/// and nothing else, and two processes writing one output cannot mix their bytes.
pub struct PartialFile {
    file: tempfile::NamedTempFile,
    _listed: Pending,
}

impl PartialFile {
    /// A new partial file beside `path` (beside what it points to, if it is a symbolic link: see
    /// [`through_links`]), its folder made if need be; the problem, if it cannot be.
    pub fn beside(path: &Path) -> Result<Self, String> {
        let path = &through_links(path);
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        std::fs::create_dir_all(dir).map_err(|e| format!("cannot create folder: {e}"))?;
        let name = path.file_name().map_or("output".into(), |n| n.to_string_lossy().into_owned());
        let prefix = format!(".{name}.");
        let mut builder = tempfile::Builder::new();
        builder.prefix(&prefix).suffix(".partial");
        // An ordinary file, readable as the umask allows, not the 0600 of a temporary one.
        #[cfg(unix)]
        builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
        // Made and listed under the list's lock: a process exiting at once holds it from removing
        // the listed files to its end, so no file is made after it that it would leave behind.
        let mut list = lock();
        let file = builder
            .tempfile_in(dir)
            .map_err(|e| format!("cannot create a file in {}: {e}", dir.display()))?;
        list.push(file.path().to_path_buf());
        drop(list);
        let listed = Pending(file.path().to_path_buf());
        Ok(Self { file, _listed: listed })
    }

    /// Where the bytes go.
    pub fn file(&mut self) -> &mut std::fs::File {
        self.file.as_file_mut()
    }

    /// On disk, then renamed over `path` (over what it points to, if it is a symbolic link).
    pub fn finish(self, path: &Path) -> Result<(), String> {
        let path = &through_links(path);
        let Self { file, _listed } = self;
        file.as_file().sync_all().map_err(|e| e.to_string())?;
        // Renamed under the list's lock, as it was made: once a process exiting at once has removed
        // the partial files, no rename of one (into place, or failing because it is gone, an error
        // that raced the exit's status) happens.
        let list = lock();
        let renamed = file.persist(path).map(drop).map_err(|e| e.error.to_string());
        drop(list);
        renamed
    }
}

/// Where a write to `path` goes: `path` itself, or, if it is a symbolic link, the file it points to
/// (followed through further links; a dangling link's target is made). Renaming the finished file
/// over the link would replace the link with a file, and the file it pointed to would keep the old
/// image: `cp` and shell redirection write through a link, and so do we.
pub fn through_links(path: &Path) -> PathBuf {
    let mut path = path.to_path_buf();
    // A bound on the links followed: a loop of links ends in the last one, whose write then fails.
    for _ in 0..40 {
        let Ok(target) = std::fs::read_link(&path) else { break };
        path = match path.parent() {
            Some(dir) if target.is_relative() => dir.join(target),
            _ => target,
        };
    }
    path
}

static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// A temporary file being written, listed until this is dropped (the write completed or failed).
pub struct Pending(PathBuf);

/// List `path` while it is written.
pub fn pending(path: &Path) -> Pending {
    lock().push(path.to_path_buf());
    Pending(path.to_path_buf())
}

impl Drop for Pending {
    fn drop(&mut self) {
        let mut pending = lock();
        if let Some(i) = pending.iter().position(|p| *p == self.0) {
            pending.swap_remove(i);
        }
    }
}

/// Remove every temporary file still being written; for a process about to exit without
/// finishing its writes.
pub fn remove_all() {
    remove_listed(&mut lock());
}

/// Remove every temporary file still being written and exit with `code`, holding the list's lock to
/// the end: a write cannot begin or complete meanwhile (a frame loop or a checkpoint writer running
/// on other threads), so none is left behind or renamed into place after the removal.
pub fn remove_all_and_exit(code: i32) -> ! {
    let mut list = lock();
    remove_listed(&mut list);
    std::process::exit(code)
}

/// Remove the files of `list`, emptying it.
fn remove_listed(list: &mut Vec<PathBuf>) {
    for path in list.drain(..) {
        let _ = std::fs::remove_file(path);
    }
}

/// The list, even if a thread panicked while holding it (a list of paths cannot be left half-changed).
fn lock() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    PENDING.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The list itself is the process's: other tests' writes are in it too, so this one looks only at
    /// its own entries and removes from a copy.
    #[test]
    fn a_pending_file_is_listed_until_written_and_removed_if_not() {
        let dir = tempfile::tempdir().unwrap();
        let (written, cut) = (dir.path().join("a.partial"), dir.path().join("b.partial"));
        std::fs::write(&written, b"done").unwrap();
        std::fs::write(&cut, b"half").unwrap();
        drop(pending(&written));
        let _cut = pending(&cut);
        let mut listed: Vec<PathBuf> = lock().iter().filter(|p| p.starts_with(dir.path())).cloned().collect();
        assert_eq!(
            listed,
            std::slice::from_ref(&cut),
            "a completed write is still listed, or a running one is not"
        );
        remove_listed(&mut listed);
        assert!(written.exists() && !cut.exists());
    }
}
