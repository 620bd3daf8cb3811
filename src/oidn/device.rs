//! RAII handles: [`Device`] (an OIDN CPU device) and [`Filter`] (a filter on it, borrowing the
//! images it reads and writes for as long as it lives).
//!
//! OIDN reports errors per device *and per calling thread* ("the first unqueried error since
//! the last `oidnGetDeviceError` on the current thread"): every step below queries right after
//! its calls, on the same thread, so an error is attributed to the step that caused it. The one
//! callback registered is a filter's progress monitor ([`Filter::cancel_when`]), which only
//! reads an atomic flag: it cannot panic, so it never unwinds into OIDN.

use super::error::{DenoiseError, ErrorCode};
use super::ffi::{self, Api, OidnDevice, OidnFilter};
use glam::Vec3;
use std::ffi::{CStr, c_char, c_int, c_void};
use std::marker::PhantomData;
use std::sync::atomic::{AtomicBool, Ordering};

// OIDN_FORMAT_FLOAT3 images are read as three packed f32 per pixel; glam's Vec3 is exactly that.
const _: () = assert!(size_of::<Vec3>() == 12 && align_of::<Vec3>() == 4);

/// An OIDN device. Owns one reference, released on drop.
pub(super) struct Device {
    api: &'static Api,
    raw: OidnDevice,
}

// SAFETY: OIDN's API documentation: "All API calls are thread-safe, but operations that use the
// same device will be serialized". Error codes are kept per calling thread, and every method
// here queries the error on the thread that made the calls; `Api` is a table of function
// pointers into a library that is never unloaded.
unsafe impl Send for Device {}
// SAFETY: see `Send`; no method hands out anything that aliases device state.
unsafe impl Sync for Device {}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: `raw` is a valid device we own one reference to; filters borrow the Device,
        // so none outlives it.
        unsafe { (self.api.oidnReleaseDevice)(self.raw) };
    }
}

/// Takes OIDN's first unqueried error of `device` (NULL: the thread's global error, e.g. a
/// failed device creation) for this thread.
fn take_error(api: &Api, device: OidnDevice) -> Option<(ErrorCode, String)> {
    let mut message: *const c_char = std::ptr::null();
    // SAFETY: `device` is a valid device or NULL (allowed: the global error); `message` is a
    // valid place for OIDN to store a string pointer.
    let code = unsafe { (api.oidnGetDeviceError)(device, &mut message) };
    if code == ffi::ERROR_NONE {
        return None;
    }
    let message = if message.is_null() {
        String::from("(no message)")
    } else {
        // SAFETY: OIDN returns a NUL-terminated string, valid until its next call of
        // oidnGetDeviceError on this thread; it is copied right away.
        unsafe { CStr::from_ptr(message) }.to_string_lossy().into_owned()
    };
    Some((ErrorCode(code), message))
}

impl Device {
    /// Creates and commits a CPU device: `threads` sets OIDN's `numThreads` (0 or `None`: OIDN
    /// chooses), `set_affinity` its `setAffinity` (`None`: OIDN's default, on).
    pub(super) fn new_cpu(
        api: &'static Api,
        threads: Option<u32>,
        set_affinity: Option<bool>,
    ) -> Result<Device, DenoiseError> {
        // Clear a stale global error of this thread, so that a NULL device reports its own.
        let _ = take_error(api, std::ptr::null_mut());
        // SAFETY: OIDN_DEVICE_TYPE_CPU is a valid device type.
        let raw = unsafe { (api.oidnNewDevice)(ffi::DEVICE_TYPE_CPU) };
        if raw.is_null() {
            let (code, message) = take_error(api, std::ptr::null_mut())
                .unwrap_or((ErrorCode(ffi::ERROR_UNKNOWN), String::from("oidnNewDevice returned NULL")));
            return Err(DenoiseError::DeviceCreation { code, message });
        }
        let device = Device { api, raw };
        if let Some(n) = threads {
            let n = c_int::try_from(n)
                .map_err(|_| DenoiseError::InvalidInput(format!("{n} denoiser threads is too many")))?;
            // SAFETY: valid device, NUL-terminated name; an int parameter of CPU devices.
            unsafe { (api.oidnSetDeviceInt)(raw, c"numThreads".as_ptr(), n) };
        }
        if let Some(on) = set_affinity {
            // SAFETY: valid device, NUL-terminated name; a bool parameter of CPU devices.
            unsafe { (api.oidnSetDeviceBool)(raw, c"setAffinity".as_ptr(), on) };
        }
        device.check(|| String::from("setting the device's parameters"))?;
        // SAFETY: valid device, committed once.
        unsafe { (api.oidnCommitDevice)(raw) };
        device.check(|| String::from("committing the CPU device"))?;
        Ok(device)
    }

    /// Turns this thread's pending error of the device, if any, into an `Err`.
    pub(super) fn check(&self, during: impl FnOnce() -> String) -> Result<(), DenoiseError> {
        match take_error(self.api, self.raw) {
            None => Ok(()),
            Some((ErrorCode(ffi::ERROR_CANCELLED), _)) => Err(DenoiseError::Cancelled),
            Some((code, message)) => Err(DenoiseError::Api { during: during(), code, message }),
        }
    }

    /// An integer device parameter such as `"versionMajor"` or `"numThreads"`.
    pub(super) fn int(&self, name: &CStr) -> Result<i32, DenoiseError> {
        // SAFETY: valid device, NUL-terminated name.
        let v = unsafe { (self.api.oidnGetDeviceInt)(self.raw, name.as_ptr()) };
        self.check(|| format!("reading the device parameter {name:?}"))?;
        Ok(v)
    }

    /// What the library was loaded as (a full path, or the bare name on the standard path).
    pub(super) fn library(&self) -> &'static str {
        &self.api.file
    }
}

/// A filter on a device. `'img` is the lifetime of the images it has been given: they are
/// borrowed (outputs mutably) until the filter is dropped, since OIDN keeps their pointers.
pub(super) struct Filter<'img> {
    device: &'img Device,
    raw: OidnFilter,
    width: usize,
    height: usize,
    _images: PhantomData<&'img mut [Vec3]>,
}

impl Drop for Filter<'_> {
    fn drop(&mut self) {
        // SAFETY: `raw` is a valid filter we own one reference to. Execution is synchronous on
        // the CPU device, so nothing reads the images after this.
        unsafe { (self.device.api.oidnReleaseFilter)(self.raw) };
    }
}

impl<'img> Filter<'img> {
    /// A new filter of `kind` (e.g. `c"RT"`) for `width` x `height` images.
    pub(super) fn new(device: &'img Device, kind: &CStr, width: usize, height: usize) -> Result<Self, DenoiseError> {
        // SAFETY: valid device, NUL-terminated filter type.
        let raw = unsafe { (device.api.oidnNewFilter)(device.raw, kind.as_ptr()) };
        device.check(|| format!("creating a {kind:?} filter"))?;
        if raw.is_null() {
            return Err(DenoiseError::Api {
                during: format!("creating a {kind:?} filter"),
                code: ErrorCode(ffi::ERROR_UNKNOWN),
                message: String::from("oidnNewFilter returned NULL"),
            });
        }
        Ok(Filter { device, raw, width, height, _images: PhantomData })
    }

    fn set_image(&mut self, name: &CStr, ptr: *mut c_void, len: usize) -> Result<(), DenoiseError> {
        if len != self.width * self.height {
            return Err(DenoiseError::InvalidInput(format!(
                "the {name:?} image has {len} pixels, expected {}x{} = {}",
                self.width,
                self.height,
                self.width * self.height
            )));
        }
        // SAFETY: valid filter; `ptr` points to `width * height` packed FLOAT3 pixels (checked
        // above, and Vec3 is three packed f32), borrowed for 'img, which the filter does not
        // outlive. Offset 0 and strides 0: tightly packed, OIDN computes the strides.
        unsafe {
            (self.device.api.oidnSetSharedFilterImage)(
                self.raw,
                name.as_ptr(),
                ptr,
                ffi::FORMAT_FLOAT3,
                self.width,
                self.height,
                0,
                0,
                0,
            )
        };
        self.device.check(|| format!("setting the {name:?} image"))
    }

    /// Sets an input image (`"color"`, `"albedo"`, `"normal"`); OIDN only reads it.
    pub(super) fn input(&mut self, name: &CStr, image: &'img [Vec3]) -> Result<(), DenoiseError> {
        // OIDN takes `void*` for inputs and outputs alike; it does not write an input image.
        self.set_image(name, image.as_ptr() as *mut c_void, image.len())
    }

    /// Sets the `"output"` image.
    pub(super) fn output(&mut self, image: &'img mut [Vec3]) -> Result<(), DenoiseError> {
        self.set_image(c"output", image.as_mut_ptr() as *mut c_void, image.len())
    }

    /// Sets `image` as both the input `name` and the output: filtered in place (OIDN allows
    /// the output to be one of the inputs).
    pub(super) fn in_place(&mut self, name: &CStr, image: &'img mut [Vec3]) -> Result<(), DenoiseError> {
        let (ptr, len) = (image.as_mut_ptr() as *mut c_void, image.len());
        self.set_image(name, ptr, len)?;
        self.set_image(c"output", ptr, len)
    }

    pub(super) fn set_bool(&mut self, name: &CStr, value: bool) -> Result<(), DenoiseError> {
        // SAFETY: valid filter, NUL-terminated name.
        unsafe { (self.device.api.oidnSetFilterBool)(self.raw, name.as_ptr(), value) };
        self.device.check(|| format!("setting the filter parameter {name:?}"))
    }

    pub(super) fn set_int(&mut self, name: &CStr, value: i32) -> Result<(), DenoiseError> {
        // SAFETY: valid filter, NUL-terminated name.
        unsafe { (self.device.api.oidnSetFilterInt)(self.raw, name.as_ptr(), value) };
        self.device.check(|| format!("setting the filter parameter {name:?}"))
    }

    /// Makes the filter's execution stop early, with [`DenoiseError::Cancelled`], once `flag`
    /// is set (OIDN asks its progress monitor between steps).
    pub(super) fn cancel_when(&mut self, flag: &'img AtomicBool) -> Result<(), DenoiseError> {
        /// Whether OIDN may go on: the flag, given as `user`, is not set.
        unsafe extern "C" fn go_on(user: *mut c_void, _done: f64) -> bool {
            // SAFETY: `user` is the `&AtomicBool` given below, borrowed for 'img, which the
            // filter (and so any execution calling this) does not outlive.
            let flag = unsafe { &*(user as *const AtomicBool) };
            !flag.load(Ordering::Relaxed)
        }
        // SAFETY: valid filter; the callback only reads the flag `user` points to, which
        // outlives the filter (see `go_on`), and cannot unwind.
        unsafe {
            (self.device.api.oidnSetFilterProgressMonitorFunction)(
                self.raw,
                Some(go_on),
                flag as *const AtomicBool as *mut c_void,
            )
        };
        self.device.check(|| String::from("setting the filter's progress monitor"))
    }

    /// Commits the parameters, then runs the filter (synchronously on the CPU device).
    pub(super) fn run(&mut self, what: &str) -> Result<(), DenoiseError> {
        // SAFETY: valid filter.
        unsafe { (self.device.api.oidnCommitFilter)(self.raw) };
        self.device.check(|| format!("committing the {what} filter"))?;
        // SAFETY: valid committed filter; its images are borrowed for 'img, so they are alive
        // and (outputs) not otherwise accessed while OIDN writes them.
        unsafe { (self.device.api.oidnExecuteFilter)(self.raw) };
        self.device.check(|| format!("running the {what} filter"))
    }
}
