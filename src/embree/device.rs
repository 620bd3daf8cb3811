use super::error::{EmbreeError, ErrorCode};
use super::sys;
use std::ffi::{CStr, CString, c_char, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::{Arc, Mutex};

/// An Embree device. Cheap to clone (reference counted); scenes keep their device alive, so
/// devices and scenes may be dropped in any order.
#[derive(Clone)]
pub struct Device {
    pub(super) inner: Arc<DeviceInner>,
}

pub(super) struct DeviceInner {
    pub(super) raw: sys::RTCDevice,
    /// Where the error callback records errors. Boxed: Embree holds a pointer to it.
    sink: Box<ErrorSink>,
}

#[derive(Default)]
struct ErrorSink {
    first: Mutex<Option<EmbreeError>>,
}

// SAFETY: an RTCDevice may be used from any thread: Embree's API documentation states that
// device-level calls (creating scenes and geometries, querying properties and errors) are
// thread safe. The error sink is behind a Mutex.
unsafe impl Send for DeviceInner {}
// SAFETY: see `Send`; no method gives out unsynchronised interior mutability.
unsafe impl Sync for DeviceInner {}

impl Drop for DeviceInner {
    fn drop(&mut self) {
        // SAFETY: `raw` is a valid device we own one reference to; the error callback is unset
        // first so that Embree never calls into the sink after this box is freed.
        unsafe {
            sys::rtcSetDeviceErrorFunction(self.raw, None, std::ptr::null_mut());
            sys::rtcReleaseDevice(self.raw);
        }
    }
}

/// Called by Embree on any thread when an API call fails. Never unwinds.
unsafe extern "C" fn on_error(user: *mut c_void, code: sys::RTCError, message: *const c_char) {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        if user.is_null() {
            return;
        }
        // SAFETY: `user` is the `ErrorSink` box registered in `Device::with_config`, alive until
        // the callback is unset in `DeviceInner::drop`.
        let sink = unsafe { &*(user as *const ErrorSink) };
        let message = if message.is_null() {
            String::new()
        } else {
            // SAFETY: Embree passes a NUL-terminated string valid for the call.
            unsafe { CStr::from_ptr(message) }.to_string_lossy().into_owned()
        };
        let mut first = sink.first.lock().unwrap_or_else(|e| e.into_inner());
        if first.is_none() {
            *first = Some(EmbreeError::Api { code: ErrorCode(code), message });
        }
    }));
}

impl Device {
    /// A device with Embree's default configuration.
    pub fn new() -> Result<Device, EmbreeError> {
        Device::with_config("")
    }

    /// A device with an Embree configuration string such as `"threads=2,verbose=0"`.
    pub fn with_config(config: &str) -> Result<Device, EmbreeError> {
        let c = CString::new(config).map_err(|_| EmbreeError::DeviceCreation {
            config: config.to_string(),
            code: ErrorCode(sys::RTC_ERROR_INVALID_ARGUMENT),
        })?;
        // SAFETY: `c` is a valid NUL-terminated string for the duration of the call.
        let raw = unsafe { sys::rtcNewDevice(c.as_ptr()) };
        if raw.is_null() {
            // SAFETY: with a NULL device Embree returns the error of the failed creation on
            // this thread.
            let code = unsafe { sys::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(EmbreeError::DeviceCreation { config: config.to_string(), code: ErrorCode(code) });
        }
        let sink = Box::new(ErrorSink::default());
        // SAFETY: `raw` is valid; the sink pointer stays valid (boxed, owned by DeviceInner)
        // until the callback is unset in Drop.
        unsafe {
            sys::rtcSetDeviceErrorFunction(raw, Some(on_error), &*sink as *const ErrorSink as *mut c_void);
        }
        Ok(Device { inner: Arc::new(DeviceInner { raw, sink }) })
    }

    /// Takes the first error Embree reported since the last call, if any.
    pub(super) fn take_error(&self) -> Result<(), EmbreeError> {
        let recorded = self.inner.sink.first.lock().unwrap_or_else(|e| e.into_inner()).take();
        // SAFETY: `raw` is a valid device; this reads and clears its error code.
        let code = unsafe { sys::rtcGetDeviceError(self.inner.raw) };
        match recorded {
            Some(e) => Err(e),
            None if code != sys::RTC_ERROR_NONE => {
                Err(EmbreeError::Api { code: ErrorCode(code), message: String::from("(no message)") })
            }
            None => Ok(()),
        }
    }

    fn property(&self, prop: sys::RTCDeviceProperty) -> isize {
        // SAFETY: `raw` is a valid device and `prop` a property defined by the header.
        unsafe { sys::rtcGetDeviceProperty(self.inner.raw, prop) }
    }

    /// The Embree library version as "major.minor.patch", read from the running library.
    pub fn version(&self) -> String {
        format!(
            "{}.{}.{}",
            self.property(sys::RTC_DEVICE_PROPERTY_VERSION_MAJOR),
            self.property(sys::RTC_DEVICE_PROPERTY_VERSION_MINOR),
            self.property(sys::RTC_DEVICE_PROPERTY_VERSION_PATCH)
        )
    }

    /// Whether the library was built with the ROBUST-capable intersectors, user geometry and
    /// triangle support this crate relies on.
    pub fn supports_required_features(&self) -> bool {
        self.property(sys::RTC_DEVICE_PROPERTY_TRIANGLE_GEOMETRY_SUPPORTED) != 0
            && self.property(sys::RTC_DEVICE_PROPERTY_USER_GEOMETRY_SUPPORTED) != 0
    }
}

impl std::fmt::Debug for Device {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Device(Embree {})", self.version())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embree_api_errors_arrive_with_code_and_message() {
        let d = Device::new().unwrap();
        assert_eq!(d.take_error(), Ok(()));
        // SAFETY: a valid device; an invalid geometry type makes Embree report an error
        // through the callback and return NULL.
        let g = unsafe { sys::rtcNewGeometry(d.inner.raw, 9999) };
        assert!(g.is_null());
        match d.take_error() {
            Err(EmbreeError::Api { code, message }) => {
                assert_ne!(code, ErrorCode(sys::RTC_ERROR_NONE));
                assert!(!message.is_empty());
                eprintln!("Embree said: {message}");
            }
            other => panic!("expected an API error, got {other:?}"),
        }
        // Taken once: the next check is clean.
        assert_eq!(d.take_error(), Ok(()));
    }
}
