//! Writing output files atomically and safely: the content goes to a new temporary file in the
//! destination's folder, which is renamed over the destination only once it is complete, so a
//! failed or interrupted write never leaves a partial file behind.
//!
//! Temporary files are created exclusively (`O_CREAT | O_EXCL`: never through an existing name
//! or a symbolic link someone planted) under an unpredictable name, and written through the
//! handle that created them, never reopened by name. The rename replaces the destination's
//! directory entry: a symbolic link at the destination is replaced, the file it pointed to is
//! not touched.
//!
//! Every temporary file is registered while it exists ([`register_live`]); a process that has
//! to exit at once, without running destructors (a second Ctrl-C), removes them with
//! [`remove_live_files`].

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

/// Why an output file could not be written.
#[derive(Debug, thiserror::Error)]
#[error("{}: cannot write: {reason}", path.display())]
pub struct WriteError {
    pub path: PathBuf,
    pub reason: String,
}

/// Paths to remove if the process exits at once (temporary files, lock files).
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn live() -> MutexGuard<'static, Vec<PathBuf>> {
    LIVE.lock().unwrap_or_else(|e| e.into_inner())
}

/// A path registered with [`register_live`]; dropping this only unregisters it (whoever
/// created the file removes it).
#[derive(Debug)]
pub struct LiveFile(PathBuf);

impl Drop for LiveFile {
    fn drop(&mut self) {
        let mut live = live();
        if let Some(i) = live.iter().position(|p| *p == self.0) {
            live.swap_remove(i);
        }
    }
}

/// Registers `path` to be removed by [`remove_live_files`] until the returned guard drops.
pub fn register_live(path: &Path) -> LiveFile {
    live().push(path.to_path_buf());
    LiveFile(path.to_path_buf())
}

/// Removes every registered file, for a process about to exit without running destructors
/// (`crate::posix::exit_now`). The registry stays locked: a write that would rename its
/// temporary file into place waits (and never happens: the process exits), so no file is
/// half-renamed while the process ends.
pub fn remove_live_files() -> MutexGuard<'static, Vec<PathBuf>> {
    remove_registered(|_| true)
}

fn remove_registered(which: impl Fn(&Path) -> bool) -> MutexGuard<'static, Vec<PathBuf>> {
    let live = live();
    for p in live.iter().filter(|p| which(p)) {
        let _ = std::fs::remove_file(p);
    }
    live
}

/// The paths registered now (for tests).
pub fn live_files() -> Vec<PathBuf> {
    live().clone()
}

/// The longest file name, in bytes, that the file systems ember writes to take (Linux's
/// `NAME_MAX`): every name ember makes must fit.
pub const NAME_MAX: usize = 255;

/// Random characters in a temporary file's name.
const TEMPORARY_RANDOM_CHARS: usize = 10;

/// The largest index at most `at` that is a character boundary of `s`.
fn floor_char_boundary(s: &str, at: usize) -> usize {
    (0..=at.min(s.len())).rev().find(|&i| s.is_char_boundary(i)).unwrap_or(0)
}

/// Refuses an output whose file name, or the name of a file ember writes beside it
/// (`companions`: each path, longer than `output`'s, and what it holds, e.g. `its checkpoint`),
/// has more than [`NAME_MAX`] bytes: the file system would refuse it only when it is written —
/// a checkpoint at the first interruption, and the render with it.
pub fn check_name_length(output: &Path, companions: &[(&Path, &str)]) -> Result<(), WriteError> {
    let len = |p: &Path| p.file_name().map_or(0, |n| n.len());
    let too_long = |what: String, longest: usize| WriteError {
        path: output.to_path_buf(),
        reason: format!(
            "{what}, more than the {NAME_MAX} a file name may have: choose a shorter name (at most {} bytes)",
            longest.min(NAME_MAX)
        ),
    };
    let extra = companions.iter().map(|(p, _)| len(p).saturating_sub(len(output))).max().unwrap_or(0);
    if len(output) > NAME_MAX {
        return Err(too_long(format!("the file name is {} bytes long", len(output)), NAME_MAX - extra));
    }
    match companions.iter().find(|(p, _)| len(p) > NAME_MAX) {
        Some((p, what)) => Err(too_long(
            format!("ember also writes {what} beside it, whose name would be {} bytes long", len(p)),
            NAME_MAX - extra,
        )),
        None => Ok(()),
    }
}

/// A new, empty temporary file beside `path`, created exclusively with an unpredictable name
/// `.NAME.XXXXXX.tmp.EXT` (the destination's extension last, for tools that go by it), mode
/// 0666 less the umask like any new file, and registered with [`register_live`].
fn temporary_beside(path: &Path, dir: &Path, kind: &str) -> std::io::Result<(tempfile::NamedTempFile, LiveFile)> {
    use std::os::unix::fs::PermissionsExt;
    let mut name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let mut suffix = match path.extension() {
        Some(ext) => format!(".{kind}.{}", ext.to_string_lossy()),
        None => format!(".{kind}"),
    };
    // A long destination name is cut short (at a character) so that the temporary name fits in
    // NAME_MAX: it stays unpredictable, only less telling.
    suffix.truncate(floor_char_boundary(&suffix, NAME_MAX / 4));
    let room = NAME_MAX - 2 - TEMPORARY_RANDOM_CHARS - suffix.len();
    name.truncate(floor_char_boundary(&name, room));
    // Created and registered under the registry's lock: a process that exits meanwhile (see
    // `remove_live_files`) either finds the file registered or stops this before it exists.
    let mut live = live();
    let file = tempfile::Builder::new()
        .prefix(&format!(".{name}."))
        .suffix(&suffix)
        .rand_bytes(TEMPORARY_RANDOM_CHARS)
        .permissions(std::fs::Permissions::from_mode(0o666))
        .tempfile_in(dir)?;
    live.push(file.path().to_path_buf());
    drop(live);
    let guard = LiveFile(file.path().to_path_buf());
    Ok((file, guard))
}

/// Calls `write` with a new temporary file beside `path` (see the module documentation), then
/// flushes it to disk and renames it to `path`. On any error the temporary file is removed
/// and `path` is untouched.
pub fn write_atomically(path: &Path, write: impl FnOnce(&mut File) -> Result<(), String>) -> Result<(), WriteError> {
    let err = |reason: String| WriteError { path: path.to_path_buf(), reason };
    let dir = folder_of(path);
    if !dir.is_dir() {
        return Err(err(format!("folder {} does not exist", dir.display())));
    }
    if path.file_name().is_none() {
        return Err(err("no file name".into()));
    }
    // Field order: the file is removed (if not persisted) before it is unregistered.
    let (mut tmp, registered) = temporary_beside(path, dir, "tmp").map_err(|e| err(e.to_string()))?;
    write(tmp.as_file_mut()).map_err(err)?;
    tmp.as_file().sync_all().map_err(|e| err(e.to_string()))?;
    // Renamed and unregistered under the registry's lock (see `remove_live_files`).
    let mut live = live();
    let persisted = tmp.persist(path);
    live.retain(|p| *p != registered.0);
    drop(live);
    persisted.map_err(|e| err(e.error.to_string()))?;
    Ok(())
}

/// The folder a file at `path` goes into (`.` for a bare file name).
pub fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Fails early — before a long computation — when a file could not be written at `path`: the
/// folder is missing or not a folder, `path` is a folder, or the folder does not accept a new
/// file (a probe file is created, as temporary files are, and removed). [`write_atomically`]
/// checks again when writing.
pub fn check_writable(path: &Path) -> Result<(), WriteError> {
    let err = |reason: String| WriteError { path: path.to_path_buf(), reason };
    if path.is_dir() {
        return Err(err("is a directory".into()));
    }
    let dir = folder_of(path);
    if !dir.exists() {
        return Err(err(format!("folder {} does not exist", dir.display())));
    }
    if !dir.is_dir() {
        return Err(err(format!("{} is not a folder", dir.display())));
    }
    if path.file_name().is_none() {
        return Err(err("no file name".into()));
    }
    let probe = temporary_beside(path, dir, "probe").map_err(|e| err(e.to_string()))?;
    drop(probe);
    Ok(())
}

/// Writes `contents` to `path` atomically.
pub fn write_file(path: &Path, contents: &[u8]) -> Result<(), WriteError> {
    write_atomically(path, |f| f.write_all(contents).map_err(|e| e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::symlink;

    fn fresh(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("ember-atomic-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn names(d: &Path) -> Vec<String> {
        let mut v: Vec<String> =
            std::fs::read_dir(d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }

    #[test]
    fn replaces_a_symlink_without_writing_through_it() {
        let d = fresh("symlink");
        let victim = d.join("victim");
        std::fs::write(&victim, "precious").unwrap();
        let out = d.join("out.png");
        symlink(&victim, &out).unwrap();
        write_file(&out, b"image").unwrap();
        assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
        assert!(!std::fs::symlink_metadata(&out).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read(&out).unwrap(), b"image");
        assert_eq!(names(&d), ["out.png", "victim"]);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn temporary_names_keep_the_extension_and_vanish_on_failure() {
        let d = fresh("fail");
        let out = d.join("out.exr");
        let mut seen = None;
        let e = write_atomically(&out, |f| {
            f.write_all(b"partial").unwrap();
            seen = Some(live_files());
            Err("encoder failed".into())
        })
        .unwrap_err();
        assert_eq!(e.to_string(), format!("{}: cannot write: encoder failed", out.display()));
        let seen: Vec<PathBuf> = seen.unwrap().into_iter().filter(|p| p.starts_with(&d)).collect();
        assert_eq!(seen.len(), 1, "{seen:?}");
        let name = seen[0].file_name().unwrap().to_string_lossy().into_owned();
        assert!(name.starts_with(".out.exr.") && name.ends_with(".tmp.exr"), "{name}");
        assert!(!live_files().contains(&seen[0]), "unregistered");
        assert!(names(&d).is_empty(), "{:?}", names(&d));
        // A destination that cannot be replaced (a folder): the temporary file goes too.
        std::fs::create_dir(&out).unwrap();
        assert!(write_file(&out, b"x").is_err());
        assert_eq!(names(&d), ["out.exr"]);
        check_writable(&d.join("other.png")).unwrap();
        assert_eq!(names(&d), ["out.exr"]);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_hard_exit_removes_registered_files() {
        let d = fresh("hard-exit");
        let (tmp, guard) = temporary_beside(&d.join("x.png"), &d, "tmp").unwrap();
        let path = tmp.path().to_path_buf();
        assert!(path.is_file());
        // What the hard-exit path does (limited to this test's folder: other tests run in
        // this process); `keep` stands for the destructor that never runs.
        let (_file, kept) = tmp.keep().unwrap();
        drop(remove_registered(|p| p.starts_with(&d)));
        assert!(!kept.exists(), "{} survived", kept.display());
        drop(guard);
        assert!(!live_files().contains(&path));
        std::fs::remove_dir_all(&d).unwrap();
    }
}
