//! Writing output files atomically: the content goes to a temporary file in the destination's
//! folder, which is renamed over the destination only once it is complete, so a failed or
//! interrupted write never leaves a partial file behind.

use std::path::{Path, PathBuf};

/// Why an output file could not be written.
#[derive(Debug, thiserror::Error)]
#[error("{}: cannot write: {reason}", path.display())]
pub struct WriteError {
    pub path: PathBuf,
    pub reason: String,
}

/// Calls `write` with a temporary path next to `path`, then renames it to `path`. The
/// temporary file keeps `path`'s extension (libraries that choose the format by extension
/// still work). On any error the temporary file is removed and `path` is untouched.
pub fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<(), String>) -> Result<(), WriteError> {
    let err = |reason: String| WriteError { path: path.to_path_buf(), reason };
    let dir = folder_of(path);
    if !dir.is_dir() {
        return Err(err(format!("folder {} does not exist", dir.display())));
    }
    let name = path.file_name().ok_or_else(|| err("no file name".into()))?.to_string_lossy().into_owned();
    let tmp = dir.join(format!(".{}.tmp.{name}", std::process::id()));
    if let Err(reason) = write(&tmp) {
        let _ = std::fs::remove_file(&tmp);
        return Err(err(reason));
    }
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        err(e.to_string())
    })
}

/// The folder a file at `path` goes into (`.` for a bare file name).
fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Fails early — before a long computation — when a file could not be written at `path`: the
/// folder is missing or not a folder, `path` is a folder, or the folder does not accept a new
/// file (a probe file is created and removed). [`write_atomically`] checks again when writing.
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
    let name = path.file_name().ok_or_else(|| err("no file name".into()))?.to_string_lossy().into_owned();
    let probe = dir.join(format!(".{name}.{}.probe", std::process::id()));
    std::fs::OpenOptions::new().write(true).create_new(true).open(&probe).map_err(|e| err(e.to_string()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// Writes `contents` to `path` atomically.
pub fn write_file(path: &Path, contents: &[u8]) -> Result<(), WriteError> {
    write_atomically(path, |tmp| std::fs::write(tmp, contents).map_err(|e| e.to_string()))
}
