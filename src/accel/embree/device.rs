//! [`Device`]: an owned `RTCDevice` plus the state its error callback writes
//! to, and the conversion of Embree errors into [`Error::Backend`].
//!
//! Embree API reference: `rtcNewDevice`, `rtcSetDeviceErrorFunction`,
//! `rtcGetDeviceError`, `rtcReleaseDevice`
//! (<https://github.com/RenderKit/embree/blob/v3.13.5/doc/src/api.md>).

use super::sys;
use crate::error::{Error, Result};
use std::ffi::{CStr, CString, c_char, c_void};
use std::ptr::NonNull;
use std::sync::atomic::{AtomicI64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

/// An error of the Embree backend.
pub(super) fn backend_error(message: String) -> Error {
    Error::Backend {
        backend: "embree",
        message,
    }
}

/// What the error callback records: the first error since the last
/// [`Device::check`]. Embree may call the callback from its own worker
/// threads (during a scene build), hence the mutex.
///
/// It also holds the byte count of the memory monitor callback
/// (`rtcSetDeviceMemoryMonitorFunction`), which Embree calls from any thread
/// whenever it allocates or frees.
#[derive(Debug, Default)]
struct ErrorState {
    first: Mutex<Option<String>>,
    bytes: AtomicI64,
}

impl ErrorState {
    fn take(&self) -> Option<String> {
        self.first
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take()
    }
}

/// The error callback registered with `rtcSetDeviceErrorFunction`. It must
/// not unwind (it is `extern "C"`, so a panic would abort); nothing in it
/// panics.
unsafe extern "C" fn record_error(user: *mut c_void, code: sys::RTCError, text: *const c_char) {
    // SAFETY: `user` is `Arc::as_ptr` of the device's `ErrorState` (set in
    // `Device::new`). The device holds that `Arc` and detaches this callback
    // in `Drop` before the `Arc` is released, so the pointee is alive here; it
    // is only ever accessed through shared references.
    let state = unsafe { &*user.cast_const().cast::<ErrorState>() };
    let text = if text.is_null() {
        String::new()
    } else {
        // SAFETY: Embree passes a NUL-terminated message that stays valid for
        // the duration of the callback; we copy it out before returning.
        unsafe { CStr::from_ptr(text) }
            .to_string_lossy()
            .into_owned()
    };
    let mut first = state.first.lock().unwrap_or_else(PoisonError::into_inner);
    first.get_or_insert_with(|| format!("{code:?}: {text}"));
}

/// The memory monitor registered with `rtcSetDeviceMemoryMonitorFunction`:
/// adds `bytes` (negative when freeing) to the device's count and never
/// refuses an allocation. Must not unwind; nothing in it panics.
unsafe extern "C" fn record_memory(user: *mut c_void, bytes: isize, post: bool) -> bool {
    // Embree reports each allocation twice (before, then with `post`) and
    // each free once with `post`; count the pre-allocation call and frees.
    if !post || bytes < 0 {
        // SAFETY: as in `record_error`: `user` points to the device's live
        // `ErrorState`, detached in `Drop` before it is freed.
        let state = unsafe { &*user.cast_const().cast::<ErrorState>() };
        state.bytes.fetch_add(bytes as i64, Ordering::Relaxed);
    }
    true
}

/// An Embree device (`RTCDevice`), the factory of scenes and geometries.
/// A [`super::scene::Scene`] owns the device it was created on, so the
/// device is released only after the scene.
#[derive(Debug)]
pub(super) struct Device {
    handle: NonNull<sys::RTCDeviceTy>,
    /// Target of the error callback's user pointer. An `Arc` rather than a
    /// `Box` so that moving the `Device` never asserts unique access to the
    /// pointee while Embree holds a pointer to it.
    errors: Arc<ErrorState>,
}

impl Device {
    /// A device created with Embree's configuration string `config` (empty for
    /// the defaults; for example `"threads=1,isa=sse4.2"` pins the build
    /// thread count and instruction set, see `rtcNewDevice`).
    pub(super) fn new(config: &str) -> Result<Device> {
        let c_config = CString::new(config).map_err(|_| {
            Error::Settings(format!(
                "Embree device config {config:?} contains a NUL byte"
            ))
        })?;
        // SAFETY: `c_config` is a NUL-terminated string that outlives the
        // call; Embree parses it during the call and keeps no pointer to it.
        let raw = unsafe { sys::rtcNewDevice(c_config.as_ptr()) };
        let Some(handle) = NonNull::new(raw) else {
            // SAFETY: passing NULL is how the API reports why `rtcNewDevice`
            // failed (the error is stored per thread, without a device).
            let code = unsafe { sys::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(backend_error(format!(
                "rtcNewDevice({config:?}) failed: {code:?}"
            )));
        };
        let device = Device {
            handle,
            errors: Arc::default(),
        };
        let user = Arc::as_ptr(&device.errors).cast_mut().cast::<c_void>();
        // SAFETY: `handle` is a live device; `record_error` has the
        // `RTCErrorFunction` signature; `user` stays valid until `Drop`
        // detaches the callback (see `record_error`).
        unsafe { sys::rtcSetDeviceErrorFunction(handle.as_ptr(), Some(record_error), user) };
        // SAFETY: as above, with `record_memory` of the
        // `RTCMemoryMonitorFunction` signature.
        unsafe {
            sys::rtcSetDeviceMemoryMonitorFunction(handle.as_ptr(), Some(record_memory), user)
        };
        Ok(device)
    }

    /// The raw handle, for the Embree calls of this module's siblings. Valid
    /// for as long as `self` is.
    pub(super) fn raw(&self) -> sys::RTCDevice {
        self.handle.as_ptr()
    }

    /// Whether this device traces 16-wide packets natively (AVX-512), not
    /// as two 8-wide halves or four 4-wide quarters.
    pub(super) fn native_ray16(&self) -> bool {
        // SAFETY: `self.handle` is a live device; reading a property changes
        // nothing and takes no pointers.
        let value = unsafe {
            sys::rtcGetDeviceProperty(self.raw(), sys::RTCDeviceProperty::NATIVE_RAY16_SUPPORTED)
        };
        value != 0
    }

    /// The library's version, as Embree encodes it (`40400` for 4.4.0).
    pub(super) fn version(&self) -> u64 {
        // SAFETY: `self.handle` is a live device; reading a property changes
        // nothing and takes no pointers.
        let value =
            unsafe { sys::rtcGetDeviceProperty(self.raw(), sys::RTCDeviceProperty::VERSION) };
        value as u64
    }

    /// Bytes Embree currently holds for this device, as its memory monitor
    /// reported them.
    pub(super) fn memory_bytes(&self) -> usize {
        self.errors.bytes.load(Ordering::Relaxed).max(0) as usize
    }

    /// `Err` naming `call` when Embree reported an error since the last check
    /// (through the callback or `rtcGetDeviceError`, which both clear it).
    pub(super) fn check(&self, call: &str) -> Result<()> {
        let recorded = self.errors.take();
        // SAFETY: `self.handle` is a live device.
        let code = unsafe { sys::rtcGetDeviceError(self.raw()) };
        match (recorded, code) {
            (None, sys::RTCError::NONE) => Ok(()),
            (Some(message), _) => Err(backend_error(format!("{call} failed: {message}"))),
            (None, code) => Err(backend_error(format!("{call} failed: {code:?}"))),
        }
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: `self.handle` is live and this is its last use. Detaching
        // the callback first means no error reported after this point (by an
        // object Embree might still keep alive internally) can reach
        // `self.errors`, which is freed after this function returns.
        unsafe {
            sys::rtcSetDeviceErrorFunction(self.raw(), None, std::ptr::null_mut());
            sys::rtcSetDeviceMemoryMonitorFunction(self.raw(), None, std::ptr::null_mut());
            sys::rtcReleaseDevice(self.raw());
        }
    }
}
