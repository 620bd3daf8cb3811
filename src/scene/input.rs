//! Reading input files: only regular files are opened (a FIFO or device would block or never
//! end), and reading problems become [`SceneError`]s naming the file.

use super::SceneError;
use std::path::Path;

/// The length of `path` if it is a regular file (symbolic links followed).
pub(super) fn regular_file_len(path: &Path) -> Result<u64, SceneError> {
    let meta = std::fs::metadata(path).map_err(|e| SceneError::io(path, &e))?;
    if meta.is_dir() {
        return Err(SceneError::new(path, None, "is a directory, expected a file"));
    }
    if !meta.is_file() {
        return Err(SceneError::new(path, None, "is not a regular file (a FIFO, socket or device?)"));
    }
    Ok(meta.len())
}

/// The bytes of the regular file `path`.
pub(super) fn read(path: &Path) -> Result<Vec<u8>, SceneError> {
    regular_file_len(path)?;
    std::fs::read(path).map_err(|e| SceneError::io(path, &e))
}

/// The text of the regular file `path`, which must be UTF-8.
pub(super) fn read_to_string(path: &Path) -> Result<String, SceneError> {
    let bytes = read(path)?;
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        SceneError::new(path, Some(line), "is not UTF-8 text")
    })
}
