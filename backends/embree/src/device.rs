//! An Embree device: the library's handle for everything built, with its version, its error
//! state and a count of the bytes it holds (section 3's comparison reports memory).

use core::ffi::{CStr, c_void};
use std::ffi::CString;
use std::sync::atomic::{AtomicIsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};

use crate::EmbreeError;
use crate::ffi::{self, Api, RTCDevice};
use crate::library::api;

/// An Embree device (`rtcNewDevice`), released on drop.
pub struct Device {
    pub(crate) api: &'static Api,
    pub(crate) raw: RTCDevice,
    /// Bytes the device holds, counted by its memory monitor callback. Boxed so the address
    /// handed to the library stays put when the device moves.
    memory: Box<AtomicIsize>,
    /// Held around everything that allocates or frees on the device (building, changing and
    /// releasing scenes), so that a scene's share of [`Self::memory_bytes`] is the change
    /// during its own build even when other threads build or drop scenes.
    alloc: Mutex<()>,
}

// SAFETY: an Embree device may be used from any thread (the library's documented contract);
// the memory counter is atomic.
unsafe impl Send for Device {}
unsafe impl Sync for Device {}

unsafe extern "C" fn count_memory(ptr: *mut c_void, bytes: isize, _post: bool) -> bool {
    // SAFETY: `ptr` is the `AtomicIsize` registered in `Device::new`, alive while the device is.
    let counter = unsafe { &*(ptr as *const AtomicIsize) };
    counter.fetch_add(bytes, Ordering::Relaxed);
    true
}

impl Device {
    /// A device with Embree's default settings, or with `threads` build threads (1 makes
    /// builds single-threaded, like the other structures' builders).
    pub fn new(threads: Option<usize>) -> Result<Self, EmbreeError> {
        let api = api()?;
        let config = match threads {
            Some(n) => format!("threads={n},verbose=0"),
            None => "verbose=0".to_string(),
        };
        let config = CString::new(config).expect("no NUL in the config");
        // SAFETY: `config` is a NUL-terminated string that outlives the call.
        let raw = unsafe { (api.new_device)(config.as_ptr()) };
        if raw.is_null() {
            // SAFETY: a null device asks for the error of the last device creation.
            let code = unsafe { (api.get_device_error)(core::ptr::null_mut()) };
            return Err(EmbreeError::Call {
                what: "create a device",
                code: error_name(api, code),
            });
        }
        let memory = Box::new(AtomicIsize::new(0));
        let device = Self {
            api,
            raw,
            memory,
            alloc: Mutex::new(()),
        };
        // SAFETY: the counter outlives the device (dropped after `rtcReleaseDevice`).
        unsafe {
            (api.set_device_memory_monitor_function)(
                raw,
                Some(count_memory),
                &*device.memory as *const AtomicIsize as *mut c_void,
            )
        };
        check_abi(device.version())?;
        device.check("set up the device")?;
        Ok(device)
    }

    /// The process's device for `threads` build threads: created on first use and kept until
    /// the process ends, shared by every scene built with that setting.
    ///
    /// One device per scene made Embree's TBB tasking leave a worker thread spinning at 100%
    /// of a core (`sched_yield` in a loop) for as long as any device was alive, once two
    /// devices had been alive at the same time (measured: process CPU time over a 1 s sleep
    /// with one scene alive, 0% before any overlap, 100% after; `reproduce --only accel`
    /// rebuilt each scene while the previous build was still alive). That spinning thread
    /// took the second core during every single-thread timing of every accelerator, and the
    /// main thread lost a quarter of its samples while profiled. Embree's tasking (the
    /// `threads` setting) is global to the process anyway, so one device per setting loses
    /// nothing.
    pub fn shared(threads: Option<usize>) -> Result<Arc<Device>, EmbreeError> {
        static DEVICES: Mutex<Vec<(Option<usize>, Arc<Device>)>> = Mutex::new(Vec::new());
        let mut devices = DEVICES.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, d)) = devices.iter().find(|(t, _)| *t == threads) {
            return Ok(Arc::clone(d));
        }
        let d = Arc::new(Device::new(threads)?);
        devices.push((threads, Arc::clone(&d)));
        Ok(d)
    }

    /// The lock to hold while allocating or freeing on the device (see [`Self::alloc`]).
    pub(crate) fn alloc_lock(&self) -> MutexGuard<'_, ()> {
        self.alloc.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// `rtcGetDeviceProperty(VERSION)`, e.g. 40400 for 4.4.0.
    pub fn version(&self) -> u32 {
        self.property(ffi::DEVICE_PROPERTY_VERSION) as u32
    }

    /// The instruction set Embree's kernels use here. Embree has no property for it; it
    /// dispatches to its widest kernels this CPU runs, and native 16-wide packets exist only
    /// in its AVX-512 kernels, native 8-wide in its AVX/AVX2 ones: so `avx512` with native
    /// 16-wide packets, else `avx2` (8-wide and the CPU has AVX2), `avx` (8-wide), else
    /// `sse4.2` or `sse2` by the CPU.
    pub fn isa(&self) -> &'static str {
        #[cfg(target_arch = "x86_64")]
        {
            if self.native_packets(16) {
                "avx512"
            } else if self.native_packets(8) {
                if std::arch::is_x86_feature_detected!("avx2") {
                    "avx2"
                } else {
                    "avx"
                }
            } else if std::arch::is_x86_feature_detected!("sse4.2") {
                "sse4.2"
            } else {
                "sse2"
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            if self.native_packets(8) {
                "neon2x"
            } else {
                "neon"
            }
        }
    }

    /// Whether the library has native (not emulated) packets of `width` rays on this CPU.
    pub fn native_packets(&self, width: usize) -> bool {
        let prop = match width {
            4 => ffi::DEVICE_PROPERTY_NATIVE_RAY4_SUPPORTED,
            8 => ffi::DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED,
            16 => ffi::DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED,
            _ => return false,
        };
        self.property(prop) != 0
    }

    /// Whether the library culls back faces (it must not: the other structures do not).
    pub fn backface_culling(&self) -> bool {
        self.property(ffi::DEVICE_PROPERTY_BACKFACE_CULLING_ENABLED) != 0
    }

    /// Whether the library calls filter functions (all-hits queries need them).
    pub fn filter_functions(&self) -> bool {
        self.property(ffi::DEVICE_PROPERTY_FILTER_FUNCTION_SUPPORTED) != 0
    }

    /// Bytes the device holds now (scenes, geometry buffers, acceleration structures).
    pub fn memory_bytes(&self) -> usize {
        self.memory.load(Ordering::Relaxed).max(0) as usize
    }

    fn property(&self, prop: core::ffi::c_int) -> isize {
        // SAFETY: a live device and a property the header defines.
        unsafe { (self.api.get_device_property)(self.raw, prop) }
    }

    /// `Ok` when the device has no pending error, else the error of `what`.
    pub(crate) fn check(&self, what: &'static str) -> Result<(), EmbreeError> {
        // SAFETY: a live device; reading its error also clears it.
        let code = unsafe { (self.api.get_device_error)(self.raw) };
        if code == ffi::ERROR_NONE {
            Ok(())
        } else {
            Err(EmbreeError::Call {
                what,
                code: error_name(self.api, code),
            })
        }
    }
}

/// The ABI this backend declares (`ffi.rs`: the 4.4 hit structs with `instPrimID`, one
/// instance level). Another version's structs may differ in size, and the library would
/// write past ours: refused, naming the version found.
pub(crate) fn check_abi(version: u32) -> Result<(), EmbreeError> {
    if version / 100 == 404 {
        Ok(())
    } else {
        Err(EmbreeError::Unusable {
            path: "(loaded library)".into(),
            why: format!(
                "it is Embree {}, and this backend is written for the Embree 4.4 ABI \
                 (its hit structs differ in other versions)",
                crate::version_string(version)
            ),
        })
    }
}

fn error_name(api: &Api, code: core::ffi::c_int) -> String {
    // SAFETY: the library returns a static string for any code.
    let name = unsafe { (api.get_error_string)(code) };
    if name.is_null() {
        format!("error {code}")
    } else {
        // SAFETY: non-null static NUL-terminated string from the library.
        unsafe { CStr::from_ptr(name) }
            .to_string_lossy()
            .into_owned()
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: the device is live and released once. The memory monitor is unset first:
        // objects made on the device may outlive this handle (they hold references), and the
        // counter does not.
        unsafe {
            (self.api.set_device_memory_monitor_function)(self.raw, None, core::ptr::null_mut());
            (self.api.release_device)(self.raw)
        }
    }
}
