//! Stratified points for the surface lights of section 5 ("a number of points is randomly
//! generated on the light source"): stratum `k` of a light's grid holds one point at a
//! fixed offset drawn once from a seed, optionally jittered per shading point by the
//! caller's uniform numbers (Cranley-Patterson rotation: `fract(offset + u)`, still
//! uniform in the stratum).

use coherent_simd::{Lanes, SimdF32, SimdMask};

/// Per-stratum offsets in `[0, 1)^2` from a seed, and whether to jitter them.
#[derive(Debug, Clone, PartialEq)]
pub struct Strata {
    offsets: Vec<[f32; 2]>,
    seed: u64,
    jitter: bool,
}

/// SplitMix64: a well-mixed 64-bit hash for the seeded offsets.
fn splitmix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// A number in `[0, 1)` from the top 24 bits of `h`.
fn unit(h: u64) -> f32 {
    (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

impl Strata {
    /// `count` strata with offsets drawn from `seed`; `jitter` adds the caller's numbers.
    pub fn new(count: u32, seed: u64, jitter: bool) -> Strata {
        let offsets = (0..count as u64)
            .map(|k| {
                let h = splitmix(seed ^ splitmix(k));
                [unit(h), unit(splitmix(h))]
            })
            .collect();
        Strata {
            offsets,
            seed,
            jitter,
        }
    }

    pub fn count(&self) -> u32 {
        self.offsets.len() as u32
    }

    pub fn seed(&self) -> u64 {
        self.seed
    }

    pub fn jitter(&self) -> bool {
        self.jitter
    }

    /// The fixed offset of stratum `k`.
    pub fn offset1(&self, k: u32) -> [f32; 2] {
        self.offsets[k as usize % self.offsets.len()]
    }

    /// The offset of stratum `k` per lane.
    #[inline(always)]
    pub fn offset<L: Lanes>(&self, l: L, k: u32, u: [L::F32s; 2]) -> [L::F32s; 2] {
        let o = self.offset1(k);
        if self.jitter {
            // fract(o + u) for o, u in [0, 1): subtract 1 at or above 1 (cheaper than
            // floor on SSE2), and stay below 1 when rounding reaches it.
            let one = l.splat(1.0);
            let below = l.splat(1.0f32.next_down());
            let x = [l.splat(o[0]) + u[0], l.splat(o[1]) + u[1]];
            [
                x[0].ge(one).select(x[0] - one, x[0]).min(below),
                x[1].ge(one).select(x[1] - one, x[1]).min(below),
            ]
        } else {
            [l.splat(o[0]), l.splat(o[1])]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_are_in_the_unit_square_and_depend_on_the_seed() {
        let a = Strata::new(64, 1, false);
        let b = Strata::new(64, 2, false);
        assert!(a.offsets.iter().flatten().all(|x| (0.0..1.0).contains(x)));
        assert_ne!(a.offsets, b.offsets);
        assert_eq!(a, Strata::new(64, 1, false));
    }
}
