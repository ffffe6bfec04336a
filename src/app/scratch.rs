//! Folders of a command's own that must not outlive it (`grade`'s references and the
//! students' outputs): each holds a lock while its command lives, and is removed when
//! dropped, when the command is interrupted ([`remove_for_exit`], from the signal handlers,
//! which also kill the process group that is running), and, where a SIGKILL left one behind,
//! by the next command that makes one ([`Scratch::new`] removes every folder of its prefix
//! whose lock no living process holds, the kernel dropping a lock with its holder, and that
//! is older than a folder being made).

use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicI32, Ordering};
use std::sync::{Mutex, PoisonError};

const LOCK: &str = ".lock";
/// How old a folder's lock must be before a free lock means its command died.
const MATURE: std::time::Duration = std::time::Duration::from_secs(10);

/// The folders alive now, for the signal handlers.
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
/// The process group a line runs in, 0 when none: an interrupt kills it before the folders
/// it writes into go.
static RUNNING_GROUP: AtomicI32 = AtomicI32::new(0);

/// A private folder under the system's temporary folder, removed when dropped.
pub struct Scratch {
    dir: Option<tempfile::TempDir>,
    _lock: File,
}

impl Scratch {
    /// A new folder named `PREFIX…`, after removing the stale ones of the same prefix.
    pub fn new(prefix: &str) -> std::io::Result<Scratch> {
        remove_stale(&std::env::temp_dir(), prefix);
        let dir = tempfile::Builder::new().prefix(prefix).tempdir()?;
        let lock = File::create(dir.path().join(LOCK))?;
        lock.try_lock().map_err(std::io::Error::other)?;
        LIVE.lock().unwrap_or_else(PoisonError::into_inner).push(dir.path().to_path_buf());
        Ok(Scratch { dir: Some(dir), _lock: lock })
    }

    pub fn path(&self) -> &Path {
        self.dir.as_ref().expect("alive until dropped").path()
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if let Some(dir) = self.dir.take() {
            LIVE.lock().unwrap_or_else(PoisonError::into_inner).retain(|p| p != dir.path());
            let path = dir.path().to_path_buf();
            if dir.close().is_err() {
                let _ = remove_all(&path);
            }
        }
    }
}

/// Removes every folder `dir/PREFIX…` that is ours and whose lock is free. A folder of
/// another user's, or whose lock a living command holds, is left alone.
fn remove_stale(dir: &Path, prefix: &str) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let named = entry.file_name().to_string_lossy().starts_with(prefix);
        let is_ours_and_a_folder = entry.metadata().is_ok_and(|m| m.is_dir() && owned_by_us(&m));
        if !named || !is_ours_and_a_folder {
            continue;
        }
        let lock = File::options().read(true).write(true).open(entry.path().join(LOCK));
        // A folder made a moment ago may not be locked yet by the command making it.
        let young = |lock: &File| {
            lock.metadata().and_then(|m| m.modified()).is_ok_and(|t| t.elapsed().is_ok_and(|age| age < MATURE))
        };
        if lock.is_ok_and(|lock| !young(&lock) && lock.try_lock().is_ok()) {
            let _ = remove_all(&entry.path());
        }
    }
}

#[cfg(unix)]
fn owned_by_us(metadata: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::MetadataExt;
    // SAFETY: geteuid has no preconditions.
    metadata.uid() == unsafe { libc::geteuid() }
}

#[cfg(not(unix))]
fn owned_by_us(_: &std::fs::Metadata) -> bool {
    true
}

/// Removes `path` and all it holds, making folders writable first (a student's program may
/// have left one without write permission).
fn remove_all(path: &Path) -> std::io::Result<()> {
    if std::fs::remove_dir_all(path).is_ok() {
        return Ok(());
    }
    for entry in walk_folders(path) {
        if let Ok(metadata) = std::fs::symlink_metadata(&entry) {
            let mut permissions = metadata.permissions();
            #[allow(clippy::permissions_set_readonly_false)]
            permissions.set_readonly(false);
            let _ = std::fs::set_permissions(&entry, permissions);
        }
    }
    std::fs::remove_dir_all(path)
}

/// `path` and every folder under it, links not followed.
fn walk_folders(path: &Path) -> Vec<PathBuf> {
    let mut folders = vec![path.to_path_buf()];
    let mut k = 0;
    while k < folders.len() {
        if let Ok(entries) = std::fs::read_dir(&folders[k]) {
            let inner = entries.flatten().filter(|e| e.file_type().is_ok_and(|t| t.is_dir())).map(|e| e.path());
            folders.extend(inner.collect::<Vec<_>>());
        }
        k += 1;
    }
    folders
}

/// The process group now running a line, killed by [`remove_for_exit`]; `None` when the
/// line has ended.
pub fn set_running_group(group: Option<u32>) {
    let group = group.and_then(|g| i32::try_from(g).ok()).unwrap_or(0);
    RUNNING_GROUP.store(group, Ordering::SeqCst);
}

/// For the signal handlers: kills the running line's processes, then removes every live
/// folder. The process ends right after.
pub fn remove_for_exit() {
    kill_group(RUNNING_GROUP.swap(0, Ordering::SeqCst));
    let live = std::mem::take(&mut *LIVE.lock().unwrap_or_else(PoisonError::into_inner));
    for path in live {
        let _ = remove_all(&path);
    }
}

#[cfg(unix)]
fn kill_group(group: i32) {
    if group > 0 {
        // SAFETY: kill takes plain integers; a group that has gone gives ESRCH.
        unsafe { libc::kill(-group, libc::SIGKILL) };
    }
}

#[cfg(not(unix))]
fn kill_group(_: i32) {}

#[cfg(test)]
mod tests {
    use super::*;

    /// A folder whose command died holding it (its lock free) is removed by the next one;
    /// a folder whose lock is held, and one of another prefix, are not.
    #[test]
    fn stale_folders_are_removed_and_live_ones_kept() {
        let temp = tempfile::tempdir().unwrap();
        let stale = temp.path().join("raycaster-test-stale");
        let live = temp.path().join("raycaster-test-live");
        let other = temp.path().join("other-stale");
        for dir in [&stale, &live, &other] {
            std::fs::create_dir_all(dir.join("inside")).unwrap();
            File::create(dir.join(LOCK)).unwrap();
        }
        let held = File::options().write(true).open(live.join(LOCK)).unwrap();
        held.try_lock().unwrap();
        let long_ago = std::time::SystemTime::now() - 2 * MATURE;
        for dir in [&stale, &live, &other] {
            File::options().write(true).open(dir.join(LOCK)).unwrap().set_modified(long_ago).unwrap();
        }
        let young = temp.path().join("raycaster-test-young");
        std::fs::create_dir(&young).unwrap();
        File::create(young.join(LOCK)).unwrap();
        remove_stale(temp.path(), "raycaster-test-");
        assert!(!stale.exists(), "the stale folder is removed");
        assert!(live.join("inside").exists(), "the held one is kept");
        assert!(other.exists(), "another prefix is not ours to remove");
        assert!(young.exists(), "a folder made a moment ago may not be locked yet");
    }

    #[test]
    fn a_scratch_folder_goes_when_dropped_or_at_exit() {
        let scratch = Scratch::new("raycaster-test-scratch-").unwrap();
        let path = scratch.path().to_path_buf();
        std::fs::write(path.join("f"), b"x").unwrap();
        drop(scratch);
        assert!(!path.exists());
        let scratch = Scratch::new("raycaster-test-scratch-").unwrap();
        let path = scratch.path().to_path_buf();
        remove_for_exit();
        assert!(!path.exists());
        std::mem::forget(scratch);
    }
}
