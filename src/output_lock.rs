//! One render per output: a render holds an advisory lock (`flock`) on `OUT.lock` beside its
//! output while it runs, so a second render to the same output is refused instead of
//! overwriting the first one's checkpoint. The lock file is removed when the render ends
//! (success, error or interruption; a process killed outright leaves it, unlocked, and the
//! next render takes it over). A symbolic link at that name is never followed.
//!
//! A lock file says it is one ([`MARKER`], its first line): a file at `OUT.lock` that does not
//! — someone's data that happens to have the name — is never taken over nor removed; the render
//! is refused instead.

use crate::atomic_write::{LiveFile, register_live};
use std::fs::File;
use std::io::{Read, Write};
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

/// The first bytes of a lock file: what tells it from a file of someone else's.
pub const MARKER: &[u8] = b"ember lock file: an ember render or merge writing the file named without .lock holds it\n";

/// Where the lock of a render writing `output` lives: next to it.
pub fn lock_path(output: &Path) -> PathBuf {
    let mut name = output.file_name().map(|n| n.to_os_string()).unwrap_or_default();
    name.push(".lock");
    output.with_file_name(name)
}

#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error(
        "{}: another render is writing this output (it holds the lock {}); wait for it to end or choose another output",
        output.display(),
        lock.display()
    )]
    Busy { output: PathBuf, lock: PathBuf },
    #[error(
        "{}: {} is in the way: a file that is not a lock file of ember's (which writes that name while it renders \
         this output); move it away or choose another output",
        output.display(),
        lock.display()
    )]
    Foreign { output: PathBuf, lock: PathBuf },
    #[error("{}: cannot lock: {reason}", path.display())]
    Io { path: PathBuf, reason: String },
}

/// The lock on an output, held until dropped (which removes the lock file).
#[derive(Debug)]
pub struct OutputLock {
    path: PathBuf,
    /// (device, inode) of the file locked.
    id: (u64, u64),
    // Dropped after `Drop::drop` removed the path: closing the file releases the lock.
    _file: File,
    _live: LiveFile,
}

impl OutputLock {
    /// Takes the lock of `output` ([`lock_path`]), or fails at once if another process holds
    /// it or a file that is not a lock file is at that name.
    pub fn acquire(output: &Path) -> Result<OutputLock, LockError> {
        use std::os::unix::fs::OpenOptionsExt;
        let path = lock_path(output);
        let io = |reason: String| LockError::Io { path: path.clone(), reason };
        // Times an existing file was found locked by nobody and empty: a render that has just
        // made it and not yet locked it, or not a lock file (see below).
        let mut empty = 0;
        for _ in 0..200 {
            let open = |create: bool| {
                std::fs::OpenOptions::new()
                    .read(true)
                    .write(true)
                    .create_new(create)
                    .mode(0o666)
                    .custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK | libc::O_NOCTTY)
                    .open(&path)
            };
            let (file, created) = match open(true) {
                Ok(f) => (f, true),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => match open(false) {
                    Ok(f) => (f, false),
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
                    // A symbolic link (planted or left there): replaced, never followed.
                    Err(e) if e.raw_os_error() == Some(libc::ELOOP) => match std::fs::remove_file(&path) {
                        Ok(()) => continue,
                        Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
                        Err(e) => return Err(io(format!("cannot replace the symbolic link there: {e}"))),
                    },
                    Err(e) => return Err(io(e.to_string())),
                },
                Err(e) => return Err(io(e.to_string())),
            };
            // A file this process made is removed by a signal that quits from here on (it is
            // unregistered, not removed, if this attempt fails): registered only once locked,
            // a signal in between left it behind.
            let made = created.then(|| register_live(&path));
            let meta = file.metadata().map_err(|e| io(e.to_string()))?;
            if !meta.is_file() {
                return Err(io("is not a regular file".into()));
            }
            match file.try_lock() {
                Ok(()) => {}
                // A file this process has just made, opened by another one in between: that
                // one finds it empty and lets go (below).
                Err(std::fs::TryLockError::WouldBlock) if created => {
                    // Unregistered first: once removed, the name may be another's lock file.
                    drop(made);
                    drop(file);
                    let _ = std::fs::remove_file(&path);
                    std::thread::sleep(std::time::Duration::from_millis(5));
                    continue;
                }
                Err(std::fs::TryLockError::WouldBlock) => {
                    return Err(LockError::Busy { output: output.to_path_buf(), lock: path });
                }
                Err(std::fs::TryLockError::Error(e)) => return Err(io(e.to_string())),
            }
            let id = (meta.dev(), meta.ino());
            if created {
                (&file).write_all(MARKER).map_err(|e| io(e.to_string()))?;
            } else {
                // Unlocked: a lock file a render killed outright left (taken over), or a file
                // that is not a lock file at all (left alone).
                let mut head = Vec::new();
                (&file).take(MARKER.len() as u64).read_to_end(&mut head).map_err(|e| io(e.to_string()))?;
                if head.is_empty() && empty < 20 {
                    // Perhaps made this instant by a render that has not locked it yet.
                    empty += 1;
                    drop(file);
                    std::thread::sleep(std::time::Duration::from_millis(10));
                    continue;
                }
                if head != MARKER {
                    return Err(LockError::Foreign { output: output.to_path_buf(), lock: path });
                }
            }
            // The render that held it may have removed the file between our open and our
            // lock (and another may have made a new one): then this lock guards nothing.
            if names(&path, id) {
                let live = made.unwrap_or_else(|| register_live(&path));
                return Ok(OutputLock { path, id, _file: file, _live: live });
            }
        }
        Err(io("the lock file keeps changing under this process".into()))
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Whether `path` (not followed if a link) is the file `id`.
fn names(path: &Path, id: (u64, u64)) -> bool {
    std::fs::symlink_metadata(path).is_ok_and(|m| (m.dev(), m.ino()) == id)
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        // Removed while still locked: a process that opened it meanwhile finds, once it gets
        // the lock, that the path no longer names its file, and starts again.
        if names(&self.path, self.id) {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_holder_at_a_time_and_no_file_left() {
        let d = std::env::temp_dir().join(format!("ember-lock-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        let out = d.join("out.png");
        // A planted link is replaced, and what it points to is untouched.
        let victim = d.join("victim");
        std::fs::write(&victim, "precious").unwrap();
        std::os::unix::fs::symlink(&victim, lock_path(&out)).unwrap();
        let held = OutputLock::acquire(&out).unwrap();
        assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
        assert!(std::fs::symlink_metadata(held.path()).unwrap().is_file());
        // flock locks belong to the open file: a second open in this process conflicts too.
        let e = OutputLock::acquire(&out).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "{}: another render is writing this output (it holds the lock {}); wait for it to end or choose \
                 another output",
                out.display(),
                lock_path(&out).display()
            )
        );
        drop(held);
        assert!(!lock_path(&out).exists());
        // A stale lock file (a render killed outright) is taken over.
        std::fs::write(lock_path(&out), MARKER).unwrap();
        let again = OutputLock::acquire(&out).unwrap();
        drop(again);
        // A file that is not a lock file is left as it is, empty or not.
        for data in ["data\n", ""] {
            std::fs::write(lock_path(&out), data).unwrap();
            let e = OutputLock::acquire(&out).unwrap_err().to_string();
            assert!(e.contains("is in the way: a file that is not a lock file of ember's"), "{e}");
            assert_eq!(std::fs::read_to_string(lock_path(&out)).unwrap(), data);
        }
        std::fs::remove_file(lock_path(&out)).unwrap();
        let mut left: Vec<_> = std::fs::read_dir(&d).unwrap().map(|e| e.unwrap().file_name()).collect();
        left.sort();
        assert_eq!(left, ["victim"]);
        std::fs::remove_dir_all(&d).unwrap();
    }
}
