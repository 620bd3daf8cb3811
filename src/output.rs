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
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
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

/// Writes `contents` to `path` atomically.
pub fn write_file(path: &Path, contents: &[u8]) -> Result<(), WriteError> {
    write_atomically(path, |tmp| std::fs::write(tmp, contents).map_err(|e| e.to_string()))
}
