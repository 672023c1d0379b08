//! The fuzz test's global allocator: the system's, counting the bytes live, with a cap that a
//! child process sets before it runs cases. Stable Rust cannot turn a refused allocation into
//! a panic (`handle_alloc_error` aborts), so an allocation past the cap writes `fuzz-oom` on
//! stderr and aborts the child: its supervisor sees the case die and reports it as memory.

use std::alloc::{GlobalAlloc, Layout, System};
use std::io::Write;
use std::sync::atomic::{AtomicUsize, Ordering};

pub struct Capped;

static LIVE: AtomicUsize = AtomicUsize::new(0);
/// Bytes live that no allocation may pass; 0: no cap.
static CAP: AtomicUsize = AtomicUsize::new(0);

/// Caps the bytes live at `bytes` more than are live now.
pub fn set_cap(bytes: usize) {
    CAP.store(
        LIVE.load(Ordering::Relaxed).saturating_add(bytes),
        Ordering::Relaxed,
    );
}

/// Counts `size` more bytes, or aborts when that passes the cap.
fn admit(size: usize) {
    let live = LIVE.fetch_add(size, Ordering::Relaxed).saturating_add(size);
    let cap = CAP.load(Ordering::Relaxed);
    if cap != 0 && live > cap {
        // Formatted on the stack: allocating here would recurse.
        let mut buf = [0u8; 200];
        let mut w = &mut buf[..];
        let _ = writeln!(
            w,
            "fuzz-oom: an allocation of {size} bytes would leave {live} bytes live, past the \
             cap of {cap}"
        );
        let n = 200 - w.len();
        let _ = std::io::stderr().write_all(&buf[..n]);
        std::process::abort();
    }
}

// SAFETY: every call is passed to `System` unchanged; the counters only observe.
unsafe impl GlobalAlloc for Capped {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        admit(layout.size());
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        admit(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > layout.size() {
            admit(new_size - layout.size());
        } else {
            LIVE.fetch_sub(layout.size() - new_size, Ordering::Relaxed);
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}
