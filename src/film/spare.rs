//! The screen matrices of the last film dropped, kept for the next film of the same size.
//!
//! A film's matrices are its largest allocation (25 MB at 1024 x 768), and fresh memory costs
//! a page fault per 4 KiB page on its first write: zeroing fresh matrices took 10-60 ms, run to
//! run, of a single-thread 1024 x 768 `cornell_pov` frame whose tracing took 64 ms (avx512).
//! A program that renders frame after frame (an animation, the
//! timed frames of `reproduce`) now zeroes the pages it already has, about 1 ms. At most one
//! set is kept: the memory of the last film, held until the next film takes it (or one of
//! another size replaces it).

use std::sync::Mutex;

use super::matrix::ScreenMatrix;

static SPARE: Mutex<Option<[ScreenMatrix; 2]>> = Mutex::new(None);

/// The kept matrices if they have `pixels` pixels (not yet zeroed); a set of another size is
/// freed.
pub(super) fn take(pixels: usize) -> Option<[ScreenMatrix; 2]> {
    let mut spare = SPARE.lock().unwrap_or_else(|e| e.into_inner());
    match spare.take() {
        Some(m) if m.iter().all(|m| m.pixels() == pixels) => Some(m),
        _ => None,
    }
}

/// Keeps `matrices` for the next film (in place of any kept before).
pub(super) fn keep(matrices: [ScreenMatrix; 2]) {
    if matrices.iter().any(|m| m.pixels() == 0) {
        return;
    }
    let old = SPARE
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .replace(matrices);
    // Freed outside the lock.
    drop(old);
}
