use super::ffi;
use std::fmt;

/// An `RTCError` code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ErrorCode(pub u32);

impl ErrorCode {
    pub fn name(self) -> &'static str {
        match self.0 {
            ffi::ERROR_NONE => "RTC_ERROR_NONE",
            ffi::ERROR_UNKNOWN => "RTC_ERROR_UNKNOWN",
            ffi::ERROR_INVALID_ARGUMENT => "RTC_ERROR_INVALID_ARGUMENT",
            ffi::ERROR_INVALID_OPERATION => "RTC_ERROR_INVALID_OPERATION",
            ffi::ERROR_OUT_OF_MEMORY => "RTC_ERROR_OUT_OF_MEMORY",
            ffi::ERROR_UNSUPPORTED_CPU => "RTC_ERROR_UNSUPPORTED_CPU",
            ffi::ERROR_CANCELLED => "RTC_ERROR_CANCELLED",
            _ => "RTC_ERROR (unknown code)",
        }
    }
}

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({})", self.name(), self.0)
    }
}

/// Everything that can go wrong in the Embree layer.
#[derive(Clone, Debug, thiserror::Error, PartialEq)]
pub enum EmbreeError {
    /// Embree reported an error through its error callback.
    #[error("Embree error {code}: {message}")]
    Api { code: ErrorCode, message: String },
    /// `rtcNewDevice` returned NULL. Embree 3 reports only the code in that case.
    #[error("Embree refused to create a device with config {config:?}: {code}")]
    DeviceCreation { config: String, code: ErrorCode },
    /// A Rust callback (bounds, intersect, occluded) panicked; Embree was given a miss (or an
    /// empty box) instead and the scene should not be trusted.
    #[error("a user-geometry callback panicked: {0}")]
    CallbackPanic(String),
    /// The running library's version is not one whose ray-hit memory layout this build knows
    /// (see `layout.rs`); using it could let Embree write past the memory the layer hands it.
    #[error(
        "Embree {version} is not a version this build knows the ray-hit layout of \
         (the {backend} build knows {known}); refusing to use it rather than risk memory corruption"
    )]
    UnsupportedVersion { version: String, backend: String, known: String },
    /// Input rejected before it reached Embree.
    #[error("invalid geometry: {0}")]
    InvalidInput(String),
}
