//! What the hand-written x86 backends (`avx2`, `avx512`) share: the run-time proof tokens come
//! from pulp's CPU detection, and a gather whose indices fail the range check panics through
//! [`gather_check`] with the offending index (the range check itself is one vector compare in
//! each backend).

/// Panics with the first index of `idx` outside `0..len` unless `ok` (all lanes in range).
#[cold]
#[inline(never)]
pub(crate) fn gather_check(ok: bool, idx: &[i32], len: usize) {
    if !ok {
        let bad = idx
            .iter()
            .find(|&&i| i < 0 || i as usize >= len)
            .copied()
            .unwrap_or(-1);
        panic!("gather index {bad} outside a table of {len}");
    }
}
