//! Random numbers derived from sample ids (paper section 6.2: the image must not depend on
//! how samples are grouped): a per-lane integer hash of (sample id, stream), so a lane's
//! numbers are the same whatever the packet width and thread count.

use coherent_simd::{Lanes, SimdI32};

/// The `lowbias32` integer hash (Chris Wellons' hash-prospector), per lane.
#[inline(always)]
pub fn hash<L: Lanes>(l: L, x: L::I32s) -> L::I32s {
    let mut x = x;
    x = x ^ x.shr_logical(16);
    x = x * l.splat_i32(0x7feb_352d);
    x = x ^ x.shr_logical(15);
    x = x * l.splat_i32(0x846c_a68b_u32 as i32);
    x ^ x.shr_logical(16)
}

/// A uniform number in `[0, 1)` per lane for sample `ids` and a stream number (which
/// light, which sample of it, which bounce).
#[inline(always)]
pub fn uniform<L: Lanes>(l: L, ids: L::I32s, stream: u32) -> L::F32s {
    let h = hash(
        l,
        hash(l, ids) ^ l.splat_i32(stream.wrapping_mul(0x9e37_79b9) as i32),
    );
    // The top 24 bits, exactly representable.
    h.shr_logical(8).to_f32() * (1.0 / 16_777_216.0)
}

/// The scalar twin of [`hash`] (tests).
pub fn hash1(x: u32) -> u32 {
    let mut x = x;
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

#[cfg(test)]
mod tests {
    use super::*;
    use coherent_simd::scalar::Scalar;
    use coherent_simd::{SimdF32, SimdI32};

    #[test]
    fn packet_hash_matches_the_scalar_one_and_numbers_are_uniform() {
        let l = Scalar;
        let mut sum = 0.0f64;
        let n = 10_000;
        for i in 0..n {
            assert_eq!(hash(l, l.splat_i32(i)).lane(0) as u32, hash1(i as u32));
            let u = uniform(l, l.splat_i32(i), 3).lane(0);
            assert!((0.0..1.0).contains(&u));
            sum += f64::from(u);
        }
        let mean = sum / f64::from(n);
        assert!((mean - 0.5).abs() < 0.01, "{mean}");
        assert_ne!(
            uniform(l, l.splat_i32(7), 0).lane(0),
            uniform(l, l.splat_i32(7), 1).lane(0)
        );
    }
}
