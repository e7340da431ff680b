//! The temporary files that writes are filling (`.NAME.XXXX.partial`, renamed over the output when
//! complete), so that a process that must end at once, before a write completes (a second Ctrl-C),
//! can remove them and leave no leftovers beside the outputs.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

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
