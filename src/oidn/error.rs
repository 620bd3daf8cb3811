use super::ffi;
use std::fmt;
use std::path::PathBuf;

/// An `OIDNError` code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ErrorCode(pub i32);

impl ErrorCode {
    pub fn name(self) -> &'static str {
        match self.0 {
            ffi::ERROR_NONE => "OIDN_ERROR_NONE",
            ffi::ERROR_UNKNOWN => "OIDN_ERROR_UNKNOWN",
            ffi::ERROR_INVALID_ARGUMENT => "OIDN_ERROR_INVALID_ARGUMENT",
            ffi::ERROR_INVALID_OPERATION => "OIDN_ERROR_INVALID_OPERATION",
            ffi::ERROR_OUT_OF_MEMORY => "OIDN_ERROR_OUT_OF_MEMORY",
            ffi::ERROR_UNSUPPORTED_HARDWARE => "OIDN_ERROR_UNSUPPORTED_HARDWARE",
            ffi::ERROR_CANCELLED => "OIDN_ERROR_CANCELLED",
            _ => "OIDN_ERROR (unknown code)",
        }
    }
}

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({})", self.name(), self.0)
    }
}

/// One place the loader looked for the library, and why it was not used.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Attempt {
    /// The file (a full path, or the bare name given to the dynamic loader).
    pub file: String,
    /// Where this place came from: `EMBER_OIDN_DIR`, the build-time default, the standard path.
    pub source: &'static str,
    /// "does not exist", or the dynamic loader's message.
    pub reason: String,
}

impl fmt::Display for Attempt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({}): {}", self.file, self.source, self.reason)
    }
}

/// Everything that can go wrong in the denoiser layer.
#[derive(Clone, Debug, thiserror::Error, PartialEq)]
pub enum DenoiseError {
    /// The library could not be loaded from any of the places ember looks.
    #[error(
        "Intel Open Image Denoise is not available, so ember cannot denoise (everything else works \
         without it). Looked at {}. Install it with `{}` (or `scripts/install-deps.sh`), which puts it in {}, \
         where ember looks by default; or set EMBER_OIDN_DIR to a folder holding {} (OIDN 2.x)",
        attempts.iter().map(|a| a.to_string()).collect::<Vec<_>>().join("; "),
        super::locate::FETCH_SCRIPT,
        super::locate::default_dir_display(),
        ffi::LIBRARY_NAME
    )]
    LibraryNotFound { attempts: Vec<Attempt> },
    /// The library loaded but lacks a function this layer calls (not OIDN 2.x?).
    #[error("{library}: not a usable Open Image Denoise 2.x library: symbol {symbol} is missing ({reason})")]
    MissingSymbol { library: PathBuf, symbol: String, reason: String },
    /// The library is not a major version whose C API this layer declares.
    #[error(
        "{library}: Open Image Denoise {version} is not supported (this build declares the OIDN 2.x API); \
         install 2.x with `{}`",
        super::locate::FETCH_SCRIPT
    )]
    UnsupportedVersion { library: PathBuf, version: String },
    /// `oidnNewDevice` returned NULL (e.g. the CPU lacks SSE4.1).
    #[error("Open Image Denoise could not create a CPU device: {code}: {message}")]
    DeviceCreation { code: ErrorCode, message: String },
    /// An API call failed; `during` says which step.
    #[error("Open Image Denoise error while {during}: {code}: {message}")]
    Api { during: String, code: ErrorCode, message: String },
    /// Stopped early: the flag given to [`super::Denoiser::cancel_when`] was set.
    #[error("denoising was cancelled")]
    Cancelled,
    /// Input rejected before it reached the library.
    #[error("invalid denoiser input: {0}")]
    InvalidInput(String),
}
