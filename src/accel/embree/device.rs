//! An Embree device: the library instance that owns scenes, geometries and the build
//! threads (TBB). Errors are reported through a callback registered at creation (as Embree's
//! tutorials do), so no call is checked one by one and the ray queries never are.
//!
//! The callback's user pointer is a `Box<ErrorLog>` owned by the [`Device`]. It stays valid
//! as long as the native device can call back, because every scene holds an `Arc<Device>`:
//! the native device is released (by [`Drop`]) only after the last scene, and the box is freed
//! only after that.

use std::ffi::{CStr, c_char, c_void};
use std::ptr;
use std::sync::{Arc, Mutex, MutexGuard, OnceLock};

use super::sys;

/// At most this many error messages are kept (the count keeps going).
const MAX_KEPT: usize = 32;

/// Errors reported by Embree's error callback (from any thread, including TBB workers).
#[derive(Default)]
struct ErrorLog {
    inner: Mutex<(usize, Vec<String>)>,
}

impl ErrorLog {
    fn lock(&self) -> MutexGuard<'_, (usize, Vec<String>)> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// Called by Embree on an error; `user` is the device's `ErrorLog`. Must not unwind.
unsafe extern "C" fn error_callback(user: *mut c_void, code: sys::RTCError, message: *const c_char) {
    let text = if message.is_null() {
        String::new()
    } else {
        // SAFETY: Embree passes a NUL-terminated C string that lives for the duration of the
        // callback; it is copied out before returning.
        unsafe { CStr::from_ptr(message) }.to_string_lossy().into_owned()
    };
    let line = format!("Embree error {} ({}): {text}", code.0, error_name(code));
    eprintln!("{line}");
    if user.is_null() {
        return;
    }
    // SAFETY: `user` is the `Box<ErrorLog>` registered in `Device::new`; the box outlives the
    // native device (see the module docs), so the pointer is valid. Only `&` access is made,
    // and `ErrorLog` is `Sync` (a mutex), so concurrent callbacks from TBB threads are fine.
    let log = unsafe { &*(user as *const ErrorLog) };
    let mut g = log.lock();
    g.0 += 1;
    if g.1.len() < MAX_KEPT {
        g.1.push(line);
    }
}

fn error_name(code: sys::RTCError) -> &'static str {
    match code {
        sys::RTCError::RTC_ERROR_NONE => "none",
        sys::RTCError::RTC_ERROR_UNKNOWN => "unknown",
        sys::RTCError::RTC_ERROR_INVALID_ARGUMENT => "invalid argument",
        sys::RTCError::RTC_ERROR_INVALID_OPERATION => "invalid operation",
        sys::RTCError::RTC_ERROR_OUT_OF_MEMORY => "out of memory",
        sys::RTCError::RTC_ERROR_UNSUPPORTED_CPU => "unsupported CPU",
        sys::RTCError::RTC_ERROR_CANCELLED => "cancelled",
        _ => "other",
    }
}

/// An Embree device. Shared by the scenes built on it through `Arc<Device>`.
pub struct Device {
    raw: sys::RTCDevice,
    errors: Box<ErrorLog>,
    /// Serialises every call that creates or modifies Embree objects (scenes, geometries,
    /// buffers, commits) on this device. Embree's API is not thread safe for calls on the same
    /// object, and pir gains nothing from concurrent builds (a commit already uses all cores).
    build_lock: Mutex<()>,
}

// SAFETY: `RTCDevice` is a handle to a heap object that is not tied to the creating thread
// (Embree uses no thread-local state for device ownership; its reference count is atomic), so
// the device may be moved to and released from another thread.
unsafe impl Send for Device {}
// SAFETY: Embree's rule (maintainers, RenderKit/embree#207): "API calls to the same object are
// not thread safe in general … the rtcIntersect/rtcOccluded calls can be invoked from multiple
// threads". Through `&Device`, pir only (a) reads properties (`rtcGetDeviceProperty`, a pure
// query) and (b) creates/modifies objects while holding `build_lock`, so no two threads ever
// modify Embree state of this device at once. The error log is a mutex.
unsafe impl Sync for Device {}

impl Device {
    /// Creates a device with Embree's default configuration and registers the error callback.
    pub fn new() -> Result<Arc<Device>, String> {
        // SAFETY: a null config string is documented as "use the defaults".
        let raw = unsafe { sys::rtcNewDevice(ptr::null()) };
        if raw.is_null() {
            // SAFETY: `rtcGetDeviceError(NULL)` returns the error of the last failed
            // `rtcNewDevice` on this thread, as documented.
            let code = unsafe { sys::rtcGetDeviceError(ptr::null_mut()) };
            return Err(format!("rtcNewDevice failed: Embree error {} ({})", code.0, error_name(code)));
        }
        let errors = Box::new(ErrorLog::default());
        let user = &*errors as *const ErrorLog as *mut c_void;
        // SAFETY: `raw` is a live device; `error_callback` has the `RTCErrorFunction` signature
        // and `user` points to the boxed log, whose lifetime exceeds the device's (see module
        // docs). The box's heap address does not change when the `Device` is moved.
        unsafe { sys::rtcSetDeviceErrorFunction(raw, Some(error_callback), user) };
        Ok(Arc::new(Device { raw, errors, build_lock: Mutex::new(()) }))
    }

    /// The process-wide device, created on first use (one set of TBB threads for all scenes).
    pub fn shared() -> Result<Arc<Device>, String> {
        static SHARED: OnceLock<Result<Arc<Device>, String>> = OnceLock::new();
        SHARED.get_or_init(Device::new).clone()
    }

    pub(super) fn raw(&self) -> sys::RTCDevice {
        self.raw
    }

    /// Holds the lock under which Embree objects of this device are created and committed.
    pub(super) fn build_guard(&self) -> MutexGuard<'_, ()> {
        self.build_lock.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Number of errors reported so far by the callback.
    pub fn error_count(&self) -> usize {
        self.errors.lock().0
    }

    /// The first error messages reported by the callback (at most 32 kept).
    pub fn errors(&self) -> Vec<String> {
        self.errors.lock().1.clone()
    }

    /// Messages of the errors numbered `from..` (as counted by [`Device::error_count`]).
    pub(super) fn errors_since(&self, from: usize) -> Vec<String> {
        let g = self.errors.lock();
        if g.0 <= from {
            return Vec::new();
        }
        let mut v: Vec<String> = g.1.iter().skip(from).cloned().collect();
        if v.is_empty() {
            v.push(format!("{} Embree error(s) (messages not kept)", g.0 - from));
        }
        v
    }

    // `ssize_t` is `c_long` in the bindings: the cast is a no-op on LP64 only.
    #[allow(clippy::unnecessary_cast)]
    fn property(&self, p: sys::RTCDeviceProperty) -> isize {
        // SAFETY: `raw` is live; reading a device property has no side effects.
        unsafe { sys::rtcGetDeviceProperty(self.raw, p) as isize }
    }

    /// The library's version, from `RTC_DEVICE_PROPERTY_VERSION` (e.g. 31305 → "3.13.5").
    pub fn version(&self) -> String {
        let v = self.property(sys::RTCDeviceProperty::RTC_DEVICE_PROPERTY_VERSION);
        format!("{}.{}.{}", v / 10000, (v / 100) % 100, v % 100)
    }

    /// Packet widths the device's ISA supports natively, widest last (e.g. `[4, 8, 16]`).
    pub fn native_packet_widths(&self) -> Vec<usize> {
        use sys::RTCDeviceProperty::*;
        [
            (4, RTC_DEVICE_PROPERTY_NATIVE_RAY4_SUPPORTED),
            (8, RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED),
            (16, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED),
        ]
        .into_iter()
        .filter(|&(_, p)| self.property(p) != 0)
        .map(|(w, _)| w)
        .collect()
    }

    /// The tasking system used for builds ("TBB", "internal", "PPL").
    pub fn tasking_system(&self) -> &'static str {
        match self.property(sys::RTCDeviceProperty::RTC_DEVICE_PROPERTY_TASKING_SYSTEM) {
            0 => "internal",
            1 => "TBB",
            2 => "PPL",
            _ => "unknown",
        }
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: `raw` came from `rtcNewDevice` and is released exactly once, here. Every
        // scene holds an `Arc<Device>`, so no scene of ours outlives this call; after it the
        // callback can no longer fire, and only then is `errors` (the user pointer) freed.
        unsafe { sys::rtcReleaseDevice(self.raw) };
    }
}
