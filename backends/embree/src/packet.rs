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
        }
        Self {
            tfar: rh.tfar,
            rh,
            valid,
            shift,
            bits,
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
