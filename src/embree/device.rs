//! The Embree device and the translation of Embree's errors into Rust errors.

use super::ffi;
use std::ffi::{c_char, c_void, CStr};
use std::sync::atomic::{AtomicI64, Ordering};
use std::sync::{Arc, Mutex};

/// An error reported by Embree, or found by this layer before a call reached Embree.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EmbreeError {
    /// Embree reported an error through its error callback.
    #[error("Embree error {code}: {message}")]
    Embree {
        /// Embree's `RTCError` code.
        code: u32,
        /// Embree's message.
        message: String,
    },
    /// Embree ran out of memory building a BVH: the message says of how many triangles, within
    /// what limit, and what would need less.
    #[error("{0}")]
    BvhOutOfMemory(String),
    /// A mesh handed to the scene builder is malformed (Embree would drop it silently).
    #[error("invalid mesh: {0}")]
    InvalidMesh(String),
}

/// The first error Embree reported since it was last taken. Shared with the error callback.
type ErrorSlot = Mutex<Option<EmbreeError>>;

/// Called by Embree on any thread. It must not unwind into C: it only stores the error.
extern "C" fn error_callback(user_ptr: *mut c_void, code: ffi::RTCError, message: *const c_char) {
    let _ = std::panic::catch_unwind(|| {
        let text = if message.is_null() {
            String::from("(no message)")
        } else {
            // SAFETY: Embree passes a NUL-terminated string that lives for the duration of the call.
            unsafe { CStr::from_ptr(message) }
                .to_string_lossy()
                .into_owned()
        };
        // SAFETY: `user_ptr` is the `ErrorSlot` owned by an `Arc` inside the `DeviceHandle`, which
        // outlives the device (it is released before the Arc is dropped).
        let slot = unsafe { &*(user_ptr as *const ErrorSlot) };
        if let Ok(mut guard) = slot.lock() {
            guard.get_or_insert(EmbreeError::Embree {
                code: code.0,
                message: text,
            });
        }
    });
}

/// Bytes Embree holds now and at most, as its memory monitor reports them.
#[derive(Default)]
struct MemoryCounter {
    current: AtomicI64,
    peak: AtomicI64,
}

/// Called by Embree on any thread before it allocates (`bytes > 0`) and after it frees
/// (`bytes < 0`). Returning true lets the allocation proceed; it must not unwind into C.
extern "C" fn memory_monitor(user_ptr: *mut c_void, bytes: isize, _post: bool) -> bool {
    // SAFETY: `user_ptr` is the `MemoryCounter` owned by an `Arc` inside the `DeviceHandle`,
    // which outlives the device (it is released before the Arc is dropped).
    let counter = unsafe { &*(user_ptr as *const MemoryCounter) };
    let now = counter.current.fetch_add(bytes as i64, Ordering::Relaxed) + bytes as i64;
    counter.peak.fetch_max(now, Ordering::Relaxed);
    true
}

/// What Embree's allocations amount to on one device (BVHs and any buffers Embree owns; the
/// mesh buffers photondiff shares with it are not included).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EmbreeMemory {
    /// Bytes held now.
    pub current: u64,
    /// Most bytes held at once since the device was made (BVH builds need temporary memory).
    pub peak: u64,
}

pub(super) struct DeviceHandle {
    pub(super) raw: ffi::RTCDevice,
    errors: Arc<ErrorSlot>,
    memory: Arc<MemoryCounter>,
}

// SAFETY: Embree devices are thread-safe; the error slot is behind a mutex.
unsafe impl Send for DeviceHandle {}
// SAFETY: as above.
unsafe impl Sync for DeviceHandle {}

impl DeviceHandle {
    /// Returns and clears the first error reported since the last call.
    pub(super) fn take_error(&self) -> Result<(), EmbreeError> {
        match self.errors.lock() {
            Ok(mut guard) => guard.take().map_or(Ok(()), Err),
            Err(_) => Ok(()),
        }
    }
}

impl Drop for DeviceHandle {
    fn drop(&mut self) {
        // SAFETY: `raw` came from rtcNewDevice and is released exactly once; scenes hold an Arc to
        // this handle, so no scene outlives it.
        unsafe { ffi::rtcReleaseDevice(self.raw) };
    }
}

/// An Embree device. Cheap to clone; scenes keep their device alive.
#[derive(Clone)]
pub struct Device {
    pub(super) handle: Arc<DeviceHandle>,
}

/// What a failed `rtcNewDevice` says, from Embree's error `code` and the memory this process
/// may use (`limit`). Under an address-space limit (`ulimit -v`) device creation runs out of
/// memory (`RTC_ERROR_OUT_OF_MEMORY`, 4), which is not a CPU Embree cannot run on
/// (`RTC_ERROR_UNSUPPORTED_CPU`, 5): "is the CPU supported?" sent a user under a 150 MB limit
/// the wrong way.
fn creation_failure(code: u32, limit: Option<u64>) -> String {
    match code {
        4 => {
            let within = limit.map_or(String::new(), |t| {
                format!(
                    " within the {} this process may use",
                    crate::util::memory::gigabytes(t)
                )
            });
            // What to do about it, too: a user read "Embree error 4: rtcNewDevice ran out of
            // memory within the 0.31 GB ..." as naming nothing (the scene's 75 MB were held).
            format!(
                "rtcNewDevice ran out of memory{within} (Embree's device reserves memory for \
                 its threads before any BVH is built, with the scene's meshes held): give the \
                 process more memory"
            )
        }
        5 => "rtcNewDevice failed: this CPU is not supported by this Embree build".into(),
        _ => "rtcNewDevice failed".into(),
    }
}

impl Device {
    /// The version of the Embree library in use as Embree reports it, e.g. "4.3.3"; always the
    /// version of the headers in [`BACKEND`](super::BACKEND) (the device refuses any other).
    pub fn library_version(&self) -> String {
        // SAFETY: the device is valid while `self` holds it.
        let v = unsafe {
            ffi::rtcGetDeviceProperty(
                self.handle.raw,
                ffi::RTCDeviceProperty::RTC_DEVICE_PROPERTY_VERSION,
            )
        };
        format!("{}.{}.{}", v / 10000, v / 100 % 100, v % 100)
    }

    /// What Embree has allocated on this device, now and at most.
    pub fn memory(&self) -> EmbreeMemory {
        let m = &self.handle.memory;
        EmbreeMemory {
            current: m.current.load(Ordering::Relaxed).max(0) as u64,
            peak: m.peak.load(Ordering::Relaxed).max(0) as u64,
        }
    }

    /// Creates a device with Embree's default configuration (its builds use every core).
    pub fn new() -> Result<Self, EmbreeError> {
        Self::with_threads(0)
    }

    /// Creates a device whose BVH builds use at most `threads` threads (0: every core, Embree's
    /// default). Embree starts its own build threads, apart from photondiff's worker threads:
    /// without this a run asked for one thread (a cluster job given one core) built its BVH
    /// on all of them.
    pub fn with_threads(threads: usize) -> Result<Self, EmbreeError> {
        let config = std::ffi::CString::new(match threads {
            0 => String::new(),
            n => format!("threads={n}"),
        })
        .expect("no NUL in a formatted number");
        // SAFETY: `config` is a NUL-terminated string that outlives the call; an empty one
        // asks for the defaults.
        let raw = unsafe { ffi::rtcNewDevice(config.as_ptr()) };
        if raw.is_null() {
            // SAFETY: a null device asks for the error of the last failed device creation.
            let code = unsafe { ffi::rtcGetDeviceError(std::ptr::null_mut()) };
            let message = creation_failure(code.0, crate::util::memory::total_bytes());
            return Err(EmbreeError::Embree {
                code: code.0,
                message,
            });
        }
        // Headers of one version and a library of another disagree on struct layouts: refuse.
        // SAFETY: `raw` is a valid device; the version property takes no other argument.
        let library = unsafe {
            ffi::rtcGetDeviceProperty(raw, ffi::RTCDeviceProperty::RTC_DEVICE_PROPERTY_VERSION)
        };
        if library != ffi::RTC_VERSION as isize {
            // SAFETY: `raw` came from rtcNewDevice and is not used again.
            unsafe { ffi::rtcReleaseDevice(raw) };
            return Err(EmbreeError::Embree {
                code: 0,
                message: format!(
                    "the Embree library is version {library}, but photondiff was built with the \
                     headers of version {} (RTC_VERSION): rebuild photondiff against this library",
                    ffi::RTC_VERSION
                ),
            });
        }
        let errors: Arc<ErrorSlot> = Arc::new(Mutex::new(None));
        // SAFETY: `raw` is a valid device; the user pointer is the slot inside `errors`, which the
        // handle keeps alive until after rtcReleaseDevice.
        unsafe {
            ffi::rtcSetDeviceErrorFunction(
                raw,
                Some(error_callback),
                Arc::as_ptr(&errors) as *mut c_void,
            )
        };
        let memory: Arc<MemoryCounter> = Arc::default();
        // SAFETY: `raw` is a valid device; the user pointer is the counter inside `memory`, which
        // the handle keeps alive until after rtcReleaseDevice; the monitor never unwinds.
        unsafe {
            ffi::rtcSetDeviceMemoryMonitorFunction(
                raw,
                Some(memory_monitor),
                Arc::as_ptr(&memory) as *mut c_void,
            )
        };
        Ok(Device {
            handle: Arc::new(DeviceHandle {
                raw,
                errors,
                memory,
            }),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::creation_failure;

    /// Out of memory is said as such, with the limit where one is known (the message a tiny
    /// scene under `ulimit -v 150000` gets); an unsupported CPU as such.
    #[test]
    fn a_device_that_runs_out_of_memory_says_so_not_that_the_cpu_is_unsupported() {
        let advice = " (Embree's device reserves memory for its threads before any BVH is \
                      built, with the scene's meshes held): give the process more memory";
        assert_eq!(
            creation_failure(4, Some(150_000 * 1024)),
            format!(
                "rtcNewDevice ran out of memory within the 0.15 GB this process may use{advice}"
            )
        );
        assert_eq!(
            creation_failure(4, None),
            format!("rtcNewDevice ran out of memory{advice}")
        );
        assert_eq!(
            creation_failure(5, Some(1 << 30)),
            "rtcNewDevice failed: this CPU is not supported by this Embree build"
        );
        assert_eq!(creation_failure(1, None), "rtcNewDevice failed");
    }
}
