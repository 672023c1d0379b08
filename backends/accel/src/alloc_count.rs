//! A build's peak working memory: the system allocator, counting the bytes live while a
//! measurement runs. The resident size shows it only coarsely (freed pages stay resident,
//! fresh ones count only once touched). A program that measures declares it its allocator:
//!
//! ```
//! use coherent_accel::alloc_count::{CountingAlloc, peak_bytes};
//!
//! #[global_allocator]
//! static ALLOCATOR: CountingAlloc = CountingAlloc;
//!
//! let (v, peak) = peak_bytes(|| vec![0u8; 1 << 20]);
//! assert!(peak >= v.len());
//! ```
//!
//! Outside a measurement every allocation pays one relaxed load and a branch. Memory that C
//! libraries (Embree) allocate is not seen.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicIsize, Ordering::Relaxed};

/// Whether [`CountingAlloc`] counts (only inside [`peak_bytes`]).
static COUNTING: AtomicBool = AtomicBool::new(false);
/// Bytes allocated less bytes freed since counting started (negative when the measured code
/// frees what was allocated before it).
static LIVE: AtomicIsize = AtomicIsize::new(0);
/// The most [`LIVE`] has been since counting started.
static PEAK: AtomicIsize = AtomicIsize::new(0);

/// The system allocator, counting the bytes live during [`peak_bytes`].
pub struct CountingAlloc;

impl CountingAlloc {
    fn add(delta: isize) {
        if COUNTING.load(Relaxed) {
            let now = LIVE.fetch_add(delta, Relaxed) + delta;
            PEAK.fetch_max(now, Relaxed);
        }
    }
}

// SAFETY: every call is forwarded to the system allocator unchanged; the counters only
// observe.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        // SAFETY: the caller's contract, passed on.
        let p = unsafe { System.alloc(l) };
        if !p.is_null() {
            Self::add(l.size() as isize);
        }
        p
    }

    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        // SAFETY: the caller's contract, passed on.
        let p = unsafe { System.alloc_zeroed(l) };
        if !p.is_null() {
            Self::add(l.size() as isize);
        }
        p
    }

    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        Self::add(-(l.size() as isize));
        // SAFETY: the caller's contract, passed on.
        unsafe { System.dealloc(p, l) }
    }

    unsafe fn realloc(&self, p: *mut u8, l: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: the caller's contract, passed on.
        let q = unsafe { System.realloc(p, l, new_size) };
        if !q.is_null() {
            Self::add(new_size as isize - l.size() as isize);
        }
        q
    }
}

/// What `f` returned, and the most bytes live at once while it ran over those live when it
/// started (every thread's allocations count). One measurement at a time; without
/// [`CountingAlloc`] as the program's allocator the peak is 0.
pub fn peak_bytes<T>(f: impl FnOnce() -> T) -> (T, usize) {
    LIVE.store(0, Relaxed);
    PEAK.store(0, Relaxed);
    COUNTING.store(true, Relaxed);
    let out = f();
    COUNTING.store(false, Relaxed);
    (out, PEAK.load(Relaxed).max(0) as usize)
}
