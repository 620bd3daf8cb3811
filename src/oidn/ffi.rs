//! The part of Open Image Denoise's C API (`OpenImageDenoise/oidn.h`, 2.x) that ember calls,
//! declared by hand (the wheel the library comes from has no headers), and its loading.
//!
//! Nothing is linked at build time: [`load`] opens the library with `dlopen` (through
//! `libloading`) and resolves every function below by name, so a binary without the library
//! still starts, and only denoising fails. A loaded library is never closed: OIDN's CPU device
//! runs TBB worker threads inside code that `dlclose` could unmap, and the resolved function
//! pointers are then valid for the rest of the process.
//!
//! Signatures as in the 2.x header (checked against a 2.x `oidn.h` of RenderKit/oidn and the
//! symbols the 2.5.1 library exports): C enums are `int` on the targets ember builds for, so
//! enum arguments and results are `c_int` here (an error code the declarations do not list
//! stays a number, never an invalid Rust enum); `bool` is C's `_Bool`; `size_t` is `usize`.

use super::error::DenoiseError;
use std::ffi::{c_char, c_int, c_void};
use std::path::PathBuf;
use std::sync::Mutex;

/// The file name of OIDN 2.x's API library (its soname).
pub(super) const LIBRARY_NAME: &str = "libOpenImageDenoise.so.2";

/// `OIDNDevice`: an opaque handle.
#[repr(C)]
pub(super) struct DeviceImpl {
    _opaque: [u8; 0],
}
pub(super) type OidnDevice = *mut DeviceImpl;

/// `OIDNFilter`: an opaque handle.
#[repr(C)]
pub(super) struct FilterImpl {
    _opaque: [u8; 0],
}
pub(super) type OidnFilter = *mut FilterImpl;

/// `OIDNProgressMonitorFunction`: called by OIDN while a filter runs with the share done;
/// returning false cancels the execution (`OIDN_ERROR_CANCELLED`).
pub(super) type ProgressMonitor = unsafe extern "C" fn(user: *mut c_void, n: f64) -> bool;

// OIDNDeviceType
pub(super) const DEVICE_TYPE_CPU: c_int = 1;

// OIDNError
pub(super) const ERROR_NONE: c_int = 0;
pub(super) const ERROR_UNKNOWN: c_int = 1;
pub(super) const ERROR_INVALID_ARGUMENT: c_int = 2;
pub(super) const ERROR_INVALID_OPERATION: c_int = 3;
pub(super) const ERROR_OUT_OF_MEMORY: c_int = 4;
pub(super) const ERROR_UNSUPPORTED_HARDWARE: c_int = 5;
pub(super) const ERROR_CANCELLED: c_int = 6;

// OIDNFormat
pub(super) const FORMAT_FLOAT3: c_int = 3;

// OIDNQuality
pub(super) const QUALITY_HIGH: c_int = 6;

/// Declares the function table once: each entry's C signature is both the field type and the
/// type the symbol is resolved as.
macro_rules! api {
    ($( $name:ident : fn($($arg:ty),*) $(-> $ret:ty)? ; )*) => {
        /// The OIDN functions ember calls, resolved from one loaded library.
        #[allow(non_snake_case)]
        pub(super) struct Api {
            $( pub(super) $name: unsafe extern "C" fn($($arg),*) $(-> $ret)?, )*
            /// What was handed to the dynamic loader: a full path, or the bare library name
            /// (standard library path).
            pub(super) file: String,
        }

        impl Api {
            fn resolve(lib: &libloading::Library, file: &str) -> Result<Api, DenoiseError> {
                Ok(Api {
                    $( $name: {
                        // SAFETY: the type is the function's C signature in the OIDN 2.x header
                        // (see the module comment); the caller keeps `lib` loaded for the rest
                        // of the process, so the copied function pointer never dangles.
                        let symbol = unsafe {
                            lib.get::<unsafe extern "C" fn($($arg),*) $(-> $ret)?>(stringify!($name))
                        };
                        *symbol.map_err(|e| DenoiseError::MissingSymbol {
                            library: PathBuf::from(file),
                            symbol: stringify!($name).to_string(),
                            reason: e.to_string(),
                        })?
                    }, )*
                    file: file.to_string(),
                })
            }
        }
    };
}

api! {
    oidnNewDevice: fn(c_int) -> OidnDevice;
    oidnReleaseDevice: fn(OidnDevice);
    oidnSetDeviceBool: fn(OidnDevice, *const c_char, bool);
    oidnSetDeviceInt: fn(OidnDevice, *const c_char, c_int);
    oidnGetDeviceInt: fn(OidnDevice, *const c_char) -> c_int;
    oidnGetDeviceError: fn(OidnDevice, *mut *const c_char) -> c_int;
    oidnCommitDevice: fn(OidnDevice);
    oidnNewFilter: fn(OidnDevice, *const c_char) -> OidnFilter;
    oidnReleaseFilter: fn(OidnFilter);
    oidnSetSharedFilterImage: fn(OidnFilter, *const c_char, *mut c_void, c_int, usize, usize, usize, usize, usize);
    oidnSetFilterBool: fn(OidnFilter, *const c_char, bool);
    oidnSetFilterInt: fn(OidnFilter, *const c_char, c_int);
    oidnSetFilterProgressMonitorFunction: fn(OidnFilter, Option<ProgressMonitor>, *mut c_void);
    oidnCommitFilter: fn(OidnFilter);
    oidnExecuteFilter: fn(OidnFilter);
}

/// Libraries loaded so far, by the name they were loaded under; never unloaded.
static LOADED: Mutex<Vec<&'static Api>> = Mutex::new(Vec::new());

/// Why a file could not be used: it could not be opened (the dynamic loader's message), or it
/// opened but is not a usable OIDN 2.x library.
pub(super) enum LoadFailure {
    Open(String),
    Unusable(DenoiseError),
}

/// Loads the library `file` (a full path, or a bare name for the standard library path) and
/// resolves the API, or returns the table loaded before under the same name.
pub(super) fn load(file: &str) -> Result<&'static Api, LoadFailure> {
    let mut loaded = LOADED.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(api) = loaded.iter().find(|a| a.file == file) {
        return Ok(api);
    }
    // SAFETY: loading runs the library's initialisers. The file is OIDN's API library (found
    // by its OIDN file name in a folder the user or scripts/fetch-oidn.sh chose); its
    // initialisers and those of its dependencies (the OIDN core, TBB, the C++ runtime) only set
    // up their own state. Loading is not racing another dlopen of ours (LOADED is locked).
    let lib = unsafe { libloading::Library::new(file) }.map_err(|e| LoadFailure::Open(dl_message(&e)))?;
    let api = Api::resolve(&lib, file).map_err(LoadFailure::Unusable)?;
    // Never closed: the function pointers in `api` stay valid, and TBB threads started by the
    // library never run in unmapped code.
    std::mem::forget(lib);
    let api: &'static Api = Box::leak(Box::new(api));
    loaded.push(api);
    Ok(api)
}

/// The dynamic loader's own message, without libloading's generic prefix.
fn dl_message(e: &libloading::Error) -> String {
    use std::error::Error as _;
    match e.source() {
        Some(src) => src.to_string(),
        None => e.to_string(),
    }
}
