//! Embree's K-wide ray packets (`RTCRayHitK`, K = 4, 8, 16) packed from the interface's rays
//! (paper section 3's packets, in Embree's layout): built once, before any timing, holding
//! only rays Embree's contract accepts, and reset between queries with the least work a
//! query needs (the far bound and the hit id of each lane).

use coherent_accel::{Hit1, Ray1};

use crate::ffi::{self, RTCRayHitK, ValidK};
use crate::scene::Embree;

/// A packed K-wide packet: lanes `0..n` of the rays it was made from, with the ones
/// Embree must not see (invalid rays, rays with `tmin < 0` that miss the scene's box) switched
/// off in its valid mask. Lane `i`'s ray id is `i` (the all-hits filter reads it).
///
/// Only [`PacketK::new`] makes one, so every lane Embree sees holds a valid ray with
/// `0 <= tnear <= tfar` and an empty hit: the safe packet queries
/// ([`Embree::intersect_k`], [`Embree::occluded_k`], [`Embree::all_hits_k`]) cannot hand the
/// library rays outside its contract.
#[derive(Clone, Debug)]
pub struct PacketK<const K: usize> {
    pub(crate) rh: RTCRayHitK<K>,
    pub(crate) valid: ValidK<K>,
    /// The far bound each lane was packed with ([`Self::reset`] restores it).
    tfar: [f32; K],
    /// Added to Embree's `t` to give the ray's `t` (non-zero for rays with `tmin < 0`,
    /// whose origin moved to where they enter the scene's box).
    pub(crate) shift: [f32; K],
    /// Lanes on in `valid`, as bits.
    bits: u32,
    /// Every lane's direction within [`COHERENT_CONE_DEGREES`] of the first lane's
    /// ([`crate::Coherence::PerPacket`]).
    pub(crate) coherent: bool,
}

/// The widest angle, in degrees, between the first active lane's direction and any other
/// lane's for which [`crate::Coherence::PerPacket`] sets Embree's COHERENT flag.
pub const COHERENT_CONE_DEGREES: f32 = 10.0;

/// Whether directions lie within [`COHERENT_CONE_DEGREES`] of the first one: fed one
/// direction at a time as a packet is packed. Measured on whole frames (1024 x 768, one
/// thread, Zen 4, AVX-512, `--accel embree --stages`): with the flag on every packet, the
/// bunny scene's shadow packets (environment samples, scattered) took 0.82-0.84 s, without
/// it 0.42-0.43 s, and with it per packet at this cone 0.44-0.47 s; `room2`'s camera packets
/// took 0.040 s with the flag, 0.063-0.066 s without and 0.039-0.040 s per packet. A 25-degree
/// cone timed the same as 10 within noise on `room2` and `spdemo`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cone {
    /// The first direction and its squared length.
    first: Option<(glam::Vec3, f32)>,
    /// Every direction so far within the cone.
    pub(crate) coherent: bool,
}

impl Cone {
    /// `cos^2` of the cone's angle: the test compares squares, sparing a square root per lane.
    const COS2: f32 = {
        // cos(10 degrees), to f32 precision.
        let c = 0.984_807_7_f32;
        c * c
    };

    pub(crate) fn new() -> Self {
        Self {
            first: None,
            coherent: true,
        }
    }

    /// Adds direction `d` (not necessarily of unit length, non-zero).
    #[inline(always)]
    pub(crate) fn add(&mut self, d: glam::Vec3) {
        let (d0, n0) = *self.first.get_or_insert((d, d.length_squared()));
        let dot = d.dot(d0);
        // cos >= c, as squares, with the sign kept.
        self.coherent &= dot >= 0.0 && dot * dot >= Self::COS2 * d.length_squared() * n0;
    }
}

impl<const K: usize> PacketK<K> {
    /// Packs up to K rays for `e` (lanes past `rays.len()` are off). Panics when `rays` holds
    /// more than K rays.
    pub fn new(e: &Embree, rays: &[Ray1]) -> Self {
        const {
            assert!(
                K == 4 || K == 8 || K == 16,
                "Embree has 4, 8 and 16-wide packets"
            )
        };
        assert!(
            rays.len() <= K,
            "{} rays do not fit a {K}-wide packet",
            rays.len()
        );
        let mut rh = RTCRayHitK::<K>::default();
        let mut valid = ValidK([0; K]);
        let mut shift = [0.0; K];
        let mut bits = 0;
        let mut cone = Cone::new();
        for (i, r) in rays.iter().enumerate() {
            rh.id[i] = i as u32;
            if !r.is_valid() {
                continue;
            }
            let Some((f, s)) = r.forward(&e.bounds) else {
                continue;
            };
            [rh.org_x[i], rh.org_y[i], rh.org_z[i]] = f.origin.to_array();
            [rh.dir_x[i], rh.dir_y[i], rh.dir_z[i]] = f.dir.to_array();
            (rh.tnear[i], rh.tfar[i], shift[i]) = (f.tmin, f.tmax, s);
            valid.0[i] = -1;
            bits |= 1 << i;
            cone.add(f.dir);
        }
        Self {
            tfar: rh.tfar,
            rh,
            valid,
            shift,
            bits,
            coherent: cone.coherent,
        }
    }

    /// Packs `rays` into packets of K, in order (the last one padded with inactive lanes).
    pub fn pack_all(e: &Embree, rays: &[Ray1]) -> Vec<Self> {
        rays.chunks(K).map(|c| Self::new(e, c)).collect()
    }

    /// Makes the packet ready for the next query: each lane's far bound as packed, and no
    /// hit. This is all a query changes that a later one reads.
    #[inline(always)]
    pub fn reset(&mut self) {
        self.rh.tfar = self.tfar;
        self.rh.geomID = [ffi::INVALID_ID; K];
    }

    /// The lanes Embree is asked about, as bits.
    #[inline(always)]
    pub fn lanes(&self) -> u32 {
        self.bits
    }

    /// Lane `i`'s first hit after [`Embree::intersect_k`] (`t` in the ray's own units).
    #[inline(always)]
    pub fn hit(&self, i: usize) -> Option<Hit1> {
        let p = &self.rh;
        (p.geomID[i] != ffi::INVALID_ID).then(|| Hit1 {
            t: p.tfar[i] + self.shift[i],
            u: p.u[i],
            v: p.v[i],
            prim: p.primID[i],
            // A scene of one untransformed instance is the mesh itself (no instance level):
            // Embree then leaves the instance id unset.
            inst: if p.instID[0][i] == ffi::INVALID_ID {
                0
            } else {
                p.instID[0][i]
            },
        })
    }

    /// Whether lane `i` is occluded after [`Embree::occluded_k`].
    #[inline(always)]
    pub fn occluded(&self, i: usize) -> bool {
        self.bits >> i & 1 == 1 && self.rh.tfar[i] == f32::NEG_INFINITY
    }

    /// The raw packet (read-only).
    pub fn raw(&self) -> &RTCRayHitK<K> {
        &self.rh
    }

    /// Its valid mask.
    pub fn valid(&self) -> &ValidK<K> {
        &self.valid
    }
}

impl<const K: usize> PacketK<K> {
    /// The occluded lanes as bits, after [`Embree::occluded_k`].
    #[inline(always)]
    pub fn occluded_bits(&self) -> u32 {
        let mut b = 0;
        for i in 0..K {
            if self.rh.tfar[i] == f32::NEG_INFINITY {
                b |= 1 << i;
            }
        }
        b & self.bits
    }

    /// After [`Embree::intersect_k`]: adds each hit lane's `t` (in the ray's own units) to
    /// lane `i` of `acc`, and returns how many lanes hit. One pass over the lanes with a
    /// select, not a branch, per lane, so the compiler makes vector code of it: the read-back
    /// the BSP's packet rows do (a hit mask, its count and a masked add into per-lane sums).
    #[inline(always)]
    // One index over four arrays in lockstep (hit ids, far bounds, shifts and the sums).
    #[allow(clippy::needless_range_loop)]
    pub fn accumulate_hits(&self, acc: &mut [f32; K]) -> u32 {
        let p = &self.rh;
        let mut n = 0;
        for i in 0..K {
            let hit = p.geomID[i] != ffi::INVALID_ID;
            n += u32::from(hit);
            acc[i] += if hit { p.tfar[i] + self.shift[i] } else { 0.0 };
        }
        n
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::{COHERENT_CONE_DEGREES, Cone};

    fn cone(dirs: &[Vec3]) -> bool {
        let mut c = Cone::new();
        dirs.iter().for_each(|&d| c.add(d));
        c.coherent
    }

    #[test]
    fn the_cone_holds_directions_within_its_angle_of_the_first() {
        let want = COHERENT_CONE_DEGREES.to_radians().cos().powi(2);
        assert!(
            (Cone::COS2 - want).abs() < 1e-6,
            "the constant is the cone's"
        );
        let at = |deg: f32| Vec3::new(deg.to_radians().cos(), deg.to_radians().sin(), 0.0);
        // Empty and one-lane packets are coherent; lengths do not matter.
        assert!(cone(&[]));
        assert!(cone(&[Vec3::new(0.0, 0.0, -3.0)]));
        assert!(cone(&[at(0.0), at(9.9) * 5.0, at(-9.9) * 0.01]));
        assert!(!cone(&[at(0.0), at(10.1)]));
        assert!(!cone(&[at(0.0), at(5.0), at(-10.1)]));
        // The opposite direction is not within the cone (the squares would say so).
        assert!(!cone(&[at(0.0), at(180.0)]));
        // The first lane is the axis: two lanes 19 degrees apart, each within 10 of the
        // axis, are not taken when the first is one of them.
        assert!(!cone(&[at(-9.5), at(9.5)]));
    }
}
