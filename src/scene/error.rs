use std::fmt;
use std::path::{Path, PathBuf};

/// A problem with an input file, located by path and (where known) line.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    pub path: PathBuf,
    pub line: Option<usize>,
    pub message: String,
}

impl SceneError {
    pub fn new(path: impl AsRef<Path>, line: Option<usize>, message: impl Into<String>) -> Self {
        SceneError { path: path.as_ref().to_path_buf(), line, message: message.into() }
    }

    /// An I/O failure reading `path`, with a readable reason.
    pub fn io(path: impl AsRef<Path>, e: &std::io::Error) -> Self {
        let path = path.as_ref();
        let reason = if path.is_dir() {
            "is a directory, expected a file".to_string()
        } else {
            match e.kind() {
                std::io::ErrorKind::NotFound => "no such file".to_string(),
                std::io::ErrorKind::PermissionDenied => "permission denied".to_string(),
                _ => format!("cannot read: {e}"),
            }
        };
        SceneError::new(path, None, reason)
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(l) => write!(f, "{}:{}: {}", self.path.display(), l, self.message),
            None => write!(f, "{}: {}", self.path.display(), self.message),
        }
    }
}

impl std::error::Error for SceneError {}
