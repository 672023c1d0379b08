//! The orders a generation's rays are traced in ([`super::Mode`]): sort keys and the
//! permutations they give. Every order is deterministic: ties keep the rays' positions in
//! the buffer.

use coherent_accel::Aabb;
use glam::Vec3;

/// Bits of each origin component in the Morton code of [`sort_key`].
pub const MORTON_BITS: u32 = 16;
/// Bits of each direction component in the coarse direction of [`sort_key`].
pub const DIR_BITS: u32 = 3;

/// The direction octant: bit `k` is set when component `k` is negative.
#[inline]
pub fn octant(d: Vec3) -> u32 {
    u32::from(d.x < 0.0) | u32::from(d.y < 0.0) << 1 | u32::from(d.z < 0.0) << 2
}

/// Spreads the low 21 bits of `x` to every third bit (bit `k` to bit `3k`).
#[inline]
fn spread3(x: u32) -> u64 {
    let mut x = u64::from(x & 0x1f_ffff);
    x = (x | x << 32) & 0x001f_0000_0000_ffff;
    x = (x | x << 16) & 0x001f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    (x | x << 2) & 0x1249_2492_4924_9249
}

/// `v` in `[lo, hi]` quantised to `bits` bits (NaN and values outside clamp to the ends).
#[inline]
fn quantise(v: f32, lo: f32, hi: f32, bits: u32) -> u32 {
    let max = ((1u32 << bits) - 1) as f32;
    let span = hi - lo;
    let t = if span > 0.0 { (v - lo) / span } else { 0.0 };
    // `as` saturates and maps NaN to 0.
    ((t * (max + 1.0)) as u32).min(max as u32)
}

/// The sorted streams' key (after Áfra et al. 2016): the direction octant in the top bits,
/// then a 48-bit Morton code of the origin quantised to `bounds` (16 bits per axis), then a
/// coarse direction (3 bits per component).
#[inline]
pub fn sort_key(origin: Vec3, dir: Vec3, bounds: &Aabb) -> u64 {
    let q = [0, 1, 2].map(|k| quantise(origin[k], bounds.min[k], bounds.max[k], MORTON_BITS));
    let morton = spread3(q[0]) | spread3(q[1]) << 1 | spread3(q[2]) << 2;
    let mut coarse = 0u64;
    for k in 0..3 {
        coarse = coarse << DIR_BITS | u64::from(quantise(dir[k], -1.0, 1.0, DIR_BITS));
    }
    u64::from(octant(dir)) << (3 * MORTON_BITS + 3 * DIR_BITS) | morton << (3 * DIR_BITS) | coarse
}

/// The rays `0..origins.len()` ordered by [`sort_key`], ties by position, into `perm`.
pub fn sorted(origins: &[Vec3], dirs: &[Vec3], bounds: &Aabb, perm: &mut Vec<u32>) {
    let mut keyed: Vec<(u64, u32)> = origins
        .iter()
        .zip(dirs)
        .enumerate()
        .map(|(i, (&o, &d))| (sort_key(o, d, bounds), i as u32))
        .collect();
    // The position makes every pair distinct, so the unstable sort's order is unique.
    keyed.sort_unstable();
    perm.clear();
    perm.extend(keyed.iter().map(|&(_, i)| i));
}

/// The rays `0..dirs.len()` grouped by direction octant (a stable counting sort), into
/// `perm`.
pub fn by_octant(dirs: &[Vec3], perm: &mut Vec<u32>) {
    let mut start = [0usize; 9];
    for &d in dirs {
        start[octant(d) as usize + 1] += 1;
    }
    for k in 1..9 {
        start[k] += start[k - 1];
    }
    perm.clear();
    perm.resize(dirs.len(), 0);
    for (i, &d) in dirs.iter().enumerate() {
        let o = octant(d) as usize;
        perm[start[o]] = i as u32;
        start[o] += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn octant_order_is_stable_and_keys_put_the_octant_first() {
        let dirs = [
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
        ];
        let mut perm = Vec::new();
        by_octant(&dirs, &mut perm);
        assert_eq!(perm, [1, 3, 0, 2]);
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let origins = [Vec3::ONE, Vec3::ZERO, Vec3::ONE, Vec3::ZERO];
        sorted(&origins, &dirs, &b, &mut perm);
        assert_eq!(perm, [1, 3, 0, 2]);
        assert!(sort_key(Vec3::ONE, Vec3::X, &b) < sort_key(Vec3::ZERO, -Vec3::X, &b));
        assert_eq!(spread3(0xffff).count_ones(), 16);
        for k in 0..16 {
            assert_eq!(spread3(1 << k), 1 << (3 * k));
        }
        // NaN does not panic and sorts somewhere.
        let _ = sort_key(Vec3::NAN, Vec3::NAN, &b);
    }
}
