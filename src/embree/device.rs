use super::error::{EmbreeError, ErrorCode};
use super::ffi;
use super::kernels::Kernels;
use super::layout::{EmbreeVersion, RayHitLayout};
use std::ffi::{CStr, CString, c_char, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicI64, Ordering};
use std::sync::{Arc, Mutex};

/// An Embree device. Cheap to clone (reference counted); scenes keep their device alive, so
/// devices and scenes may be dropped in any order.
#[derive(Clone)]
pub struct Device {
    pub(super) inner: Arc<DeviceInner>,
}

pub(super) struct DeviceInner {
    pub(super) raw: ffi::RTCDevice,
    /// The running library's version and, decided from it, its ray-hit layout.
    version: EmbreeVersion,
    pub(super) layout: RayHitLayout,
    /// The kernel set the configuration names (`isa=…`), the widest the CPU runs if none.
    kernels: Kernels,
    /// Where the error callback records errors. Boxed: Embree holds a pointer to it.
    sink: Box<ErrorSink>,
    /// The bytes Embree holds for this device's scenes (BVHs, geometry buffers), kept by the
    /// memory monitor callback. Boxed: Embree holds a pointer to it.
    memory: Box<AtomicI64>,
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
            ffi::rtcSetDeviceErrorFunction(self.raw, None, std::ptr::null_mut());
            ffi::rtcSetDeviceMemoryMonitorFunction(self.raw, None, std::ptr::null_mut());
            ffi::rtcReleaseDevice(self.raw);
        }
    }
}

/// Called by Embree on any thread when an API call fails. Never unwinds.
unsafe extern "C" fn on_error(user: *mut c_void, code: u32, message: *const c_char) {
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

/// Called by Embree, on any thread, before or after it allocates (`bytes` > 0) or frees
/// (`bytes` < 0) a block: counts the bytes and lets the allocation go ahead. Never unwinds
/// (an atomic add cannot panic).
unsafe extern "C" fn on_memory(user: *mut c_void, bytes: isize, _post: bool) -> bool {
    if !user.is_null() {
        // SAFETY: `user` is the counter box registered in `Device::with_config`, alive until
        // the callback is unset in `DeviceInner::drop`.
        let memory = unsafe { &*(user as *const AtomicI64) };
        memory.fetch_add(bytes as i64, Ordering::Relaxed);
    }
    true
}

impl Device {
    /// A device running the widest kernel set the CPU has (the one Embree picks by itself),
    /// named in its configuration.
    pub fn new() -> Result<Device, EmbreeError> {
        Device::with_kernels(Kernels::widest())
    }

    /// A device running the kernel set `kernels` (which the CPU must run:
    /// [`Kernels::runs_here`]).
    pub fn with_kernels(kernels: Kernels) -> Result<Device, EmbreeError> {
        // Elsewhere than x86-64 Embree has one set of its own (Kernels::widest names it SSE4.2).
        Device::with_config(&if cfg!(target_arch = "x86_64") { format!("isa={kernels}") } else { String::new() })
    }

    /// The kernel set the device runs.
    pub fn kernels(&self) -> Kernels {
        self.inner.kernels
    }

    /// A device with an Embree configuration string such as `"threads=2,isa=avx2"`; without
    /// `isa=`, Embree runs the widest kernel set the CPU has.
    ///
    /// Fails with [`EmbreeError::UnsupportedVersion`] if the running library is not a version
    /// whose ray-hit layout this build knows (see [`RayHitLayout::for_library`]).
    pub fn with_config(config: &str) -> Result<Device, EmbreeError> {
        let c = CString::new(config).map_err(|_| EmbreeError::DeviceCreation {
            config: config.to_string(),
            code: ErrorCode(ffi::ERROR_INVALID_ARGUMENT),
        })?;
        // SAFETY: `c` is a valid NUL-terminated string for the duration of the call.
        let raw = unsafe { ffi::rtcNewDevice(c.as_ptr()) };
        if raw.is_null() {
            // SAFETY: with a NULL device Embree returns the error of the failed creation on
            // this thread.
            let code = unsafe { ffi::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(EmbreeError::DeviceCreation { config: config.to_string(), code: ErrorCode(code) });
        }
        let property = |prop| {
            // SAFETY: `raw` is a valid device and `prop` a property defined by the header.
            let v = unsafe { ffi::rtcGetDeviceProperty(raw, prop) };
            u32::try_from(v).unwrap_or(u32::MAX)
        };
        let version = EmbreeVersion::new(
            property(ffi::PROPERTY_VERSION_MAJOR),
            property(ffi::PROPERTY_VERSION_MINOR),
            property(ffi::PROPERTY_VERSION_PATCH),
        );
        let layout = match RayHitLayout::for_library(ffi::MAJOR, version) {
            Ok(layout) => layout,
            Err(e) => {
                // SAFETY: `raw` is a valid device we own the only reference to; nothing was
                // built on it.
                unsafe { ffi::rtcReleaseDevice(raw) };
                return Err(e);
            }
        };
        let sink = Box::new(ErrorSink::default());
        let memory = Box::new(AtomicI64::new(0));
        // SAFETY: `raw` is valid; the sink and counter pointers stay valid (boxed, owned by
        // DeviceInner) until the callbacks are unset in Drop. `on_error` has the C signature
        // of RTCErrorFunction, with the enum code as the u32 it is; `on_memory` that of
        // RTCMemoryMonitorFunction.
        unsafe {
            ffi::rtcSetDeviceErrorFunction(raw, Some(on_error), &*sink as *const ErrorSink as *mut c_void);
            ffi::rtcSetDeviceMemoryMonitorFunction(raw, Some(on_memory), &*memory as *const AtomicI64 as *mut c_void);
        }
        let kernels = config
            .split(',')
            .find_map(|word| word.trim().strip_prefix("isa=").and_then(Kernels::from_name))
            .unwrap_or_else(Kernels::widest);
        Ok(Device { inner: Arc::new(DeviceInner { raw, version, layout, kernels, sink, memory }) })
    }

    /// Takes the first error Embree reported since the last call, if any.
    pub(super) fn take_error(&self) -> Result<(), EmbreeError> {
        let recorded = self.inner.sink.first.lock().unwrap_or_else(|e| e.into_inner()).take();
        // SAFETY: `raw` is a valid device; this reads and clears its error code.
        let code = unsafe { ffi::rtcGetDeviceError(self.inner.raw) };
        match recorded {
            Some(e) => Err(e),
            None if code != ffi::ERROR_NONE => {
                Err(EmbreeError::Api { code: ErrorCode(code), message: String::from("(no message)") })
            }
            None => Ok(()),
        }
    }

    fn property(&self, prop: ffi::RTCDeviceProperty) -> isize {
        // SAFETY: `raw` is a valid device and `prop` a property defined by the header.
        unsafe { ffi::rtcGetDeviceProperty(self.inner.raw, prop) }
    }

    /// The Embree library version as "major.minor.patch", read from the running library
    /// (`rtcGetDeviceProperty`) when the device was created.
    pub fn version(&self) -> String {
        self.inner.version.to_string()
    }

    /// The running library's version as numbers.
    pub fn embree_version(&self) -> EmbreeVersion {
        self.inner.version
    }

    /// The bytes Embree holds now for the scenes built on this device: their BVHs and the
    /// geometry buffers it allocated (as its memory monitor callback reports them).
    pub fn memory_in_use(&self) -> u64 {
        self.inner.memory.load(Ordering::Relaxed).max(0) as u64
    }

    /// The ray-hit memory layout of the running library, decided from its version.
    pub fn ray_hit_layout(&self) -> RayHitLayout {
        self.inner.layout
    }

    /// Which bindings this build uses: `"embree3"` (bindgen, Debian's headers) or `"embree4"`
    /// (`embree4-sys`, cargo feature `embree4`).
    pub fn backend(&self) -> &'static str {
        ffi::NAME
    }

    /// Whether the library was built with the ROBUST-capable intersectors, user geometry and
    /// triangle support this crate relies on.
    pub fn supports_required_features(&self) -> bool {
        self.property(ffi::PROPERTY_TRIANGLES) != 0 && self.property(ffi::PROPERTY_USER_GEOMETRY) != 0
    }
}

impl std::fmt::Debug for Device {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Device(Embree {}, {})", self.version(), self.inner.layout)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embree_api_errors_arrive_with_code_and_message() {
        let d = Device::new().unwrap();
        assert_eq!(d.take_error(), Ok(()));
        // SAFETY: a valid device; a triangle geometry is not a user geometry, so setting its
        // user primitive count makes Embree report an error through the callback.
        unsafe {
            let g = ffi::rtcNewGeometry(d.inner.raw, ffi::GEOMETRY_TYPE_TRIANGLE);
            assert!(!g.is_null());
            ffi::rtcSetGeometryUserPrimitiveCount(g, 1);
            ffi::rtcReleaseGeometry(g);
        }
        match d.take_error() {
            Err(EmbreeError::Api { code, message }) => {
                assert_ne!(code, ErrorCode(ffi::ERROR_NONE));
                assert!(!message.is_empty());
                eprintln!("Embree said: {message}");
            }
            other => panic!("expected an API error, got {other:?}"),
        }
        // Taken once: the next check is clean.
        assert_eq!(d.take_error(), Ok(()));
    }
}
