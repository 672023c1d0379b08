//! Ray queries on the Embree scene (the paper's two queries of section 3, plus occlusion):
//! first hit, all hits (through a filter callback that records and rejects every hit), and
//! occlusion, for single rays (`rtcIntersect1`) and for packets of 4, 8 and 16 rays
//! (`rtcIntersect4/8/16`, with the COHERENT flag unless the parameters say otherwise).
//!
//! Segments: Embree accepts hits in `(tnear, tfar]`, the interface asks for `[tmin, tmax)`;
//! the two differ only for a hit exactly at a bound.

use core::ffi::c_int;

use coherent_accel::{Hit1, Hits, Ray1, Rays};
use coherent_simd::{Lanes, SimdF32, SimdMask};

use crate::ffi::{self, RTCRayHitK, RTCRayQueryContext, ValidK};
use crate::scene::Embree;

/// The context of an all-hits query: Embree's context first (the library sees only that),
/// then where the filter callback records the hits.
#[repr(C)]
struct AllHitsContext {
    base: RTCRayQueryContext,
    /// (lane, hit), each (lane, triangle, instance) once: a triangle split into several BVH
    /// leaves (spatial splits) is reported once per leaf.
    hits: *mut Vec<(u32, Hit1)>,
}

/// Records every candidate hit and rejects it, so traversal goes on to the next one.
///
/// The callback's packet width N need not be the query's (Embree may split or narrow the
/// packet), so the query's lane comes from the ray id.
unsafe extern "C" fn record_and_reject(args: *const ffi::RTCFilterFunctionNArguments) {
    // SAFETY: Embree passes valid arguments for N rays; the context is the `AllHitsContext`
    // the query made (its first field is the RTCRayQueryContext Embree knows), alive for
    // the duration of the query, and `hits` points at a Vec only the query's thread uses.
    unsafe {
        let args = &*args;
        let n = args.N as usize;
        let ctx = &*(args.context as *const AllHitsContext);
        let hits = &mut *ctx.hits;
        let word = |base: *mut f32, row: usize, i: usize| base.add(row * n + i);
        for i in 0..n {
            let valid = args.valid.add(i);
            if *valid == 0 {
                continue;
            }
            // RTCRayN rows: org 0-2, tnear 3, dir 4-6, time 7, tfar 8, mask 9, id 10.
            // RTCHitN rows: Ng 0-2, u 3, v 4, primID 5, geomID 6, instID 7, instPrimID 8.
            let lane = *(word(args.ray, 10, i) as *const u32);
            let h = Hit1 {
                t: *word(args.ray, 8, i),
                u: *word(args.hit, 3, i),
                v: *word(args.hit, 4, i),
                prim: *(word(args.hit, 5, i) as *const u32),
                inst: *(word(args.hit, 7, i) as *const u32),
            };
            if !hits
                .iter()
                .any(|&(l, o)| l == lane && o.prim == h.prim && o.inst == h.inst)
            {
                hits.push((lane, h));
            }
            *valid = 0;
        }
    }
}

fn flags(coherent: bool) -> c_int {
    if coherent {
        ffi::RAY_QUERY_FLAG_COHERENT
    } else {
        ffi::RAY_QUERY_FLAG_INCOHERENT
    }
}

/// A ray as Embree is asked it: Embree searches `t >= 0` only, so a ray with `tmin < 0` is
/// clipped to the scene's box and its origin moved to the clipped start `s < 0`; Embree's
/// `t` plus `shift` is then the ray's `t`. `None`: the ray misses the scene's box.
#[derive(Clone, Copy, Debug)]
struct Segment {
    origin: glam::Vec3,
    tnear: f32,
    tfar: f32,
    shift: f32,
}

impl Embree {
    #[inline(always)]
    fn segment(&self, r: &Ray1) -> Option<Segment> {
        let (f, shift) = r.forward(&self.bounds)?;
        Some(Segment {
            origin: f.origin,
            tnear: f.tmin,
            tfar: f.tmax,
            shift,
        })
    }
}

/// Ray `r` with an empty hit, as `rtcIntersect1` takes it.
#[inline(always)]
fn ray_hit1(r: &Ray1, s: &Segment) -> ffi::RTCRayHit {
    ffi::RTCRayHit {
        ray: ffi::RTCRay {
            org_x: s.origin.x,
            org_y: s.origin.y,
            org_z: s.origin.z,
            tnear: s.tnear,
            dir_x: r.dir.x,
            dir_y: r.dir.y,
            dir_z: r.dir.z,
            time: 0.0,
            tfar: s.tfar,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        },
        hit: ffi::RTCHit {
            geomID: ffi::INVALID_ID,
            instID: [ffi::INVALID_ID],
            ..Default::default()
        },
    }
}

/// A K-wide packet of `rays` (lane ids for the filter callback), the valid mask of the
/// lanes on in `active` that hold valid rays (Embree's answer on invalid rays is undefined)
/// and meet the scene's box if `tmin < 0`, the lanes' bits, and each lane's `t` shift.
#[inline(always)]
fn packet<L: Lanes, const K: usize>(
    e: &Embree,
    l: L,
    rays: &Rays<L>,
    active: L::Mask,
) -> (RTCRayHitK<K>, ValidK<K>, u32, Option<[f32; K]>) {
    debug_assert_eq!(L::N, K);
    let mut bits = (active & rays.valid(l)).bitmask();
    let mut p = RTCRayHitK::<K>::default();
    rays.origin.x.store(&mut p.org_x);
    rays.origin.y.store(&mut p.org_y);
    rays.origin.z.store(&mut p.org_z);
    rays.dir.x.store(&mut p.dir_x);
    rays.dir.y.store(&mut p.dir_y);
    rays.dir.z.store(&mut p.dir_z);
    rays.tmin.store(&mut p.tnear);
    rays.tmax.store(&mut p.tfar);
    p.id = core::array::from_fn(|i| i as u32);
    let mut shift = None;
    if bits != 0 && rays.tmin.reduce_min() < 0.0 {
        // Rare: lanes searching behind their origin, one at a time.
        let mut s = [0.0f32; K];
        for (i, si) in s.iter_mut().enumerate() {
            if bits >> i & 1 == 0 || p.tnear[i] >= 0.0 {
                continue;
            }
            match e.segment(&rays.lane(i)) {
                Some(seg) => {
                    [p.org_x[i], p.org_y[i], p.org_z[i]] = seg.origin.to_array();
                    (p.tnear[i], p.tfar[i], *si) = (seg.tnear, seg.tfar, seg.shift);
                }
                None => bits &= !(1 << i),
            }
        }
        shift = Some(s);
    }
    let valid = ValidK(core::array::from_fn(|i| {
        if bits >> i & 1 == 1 { -1 } else { 0 }
    }));
    (p, valid, bits, shift)
}

/// A valid mask with the first `n` lanes on.
pub fn valid_lanes<const K: usize>(n: usize) -> ValidK<K> {
    ValidK(core::array::from_fn(|i| if i < n { -1 } else { 0 }))
}

impl Embree {
    /// First hit of one ray (`rtcIntersect1`).
    pub fn first_hit1(&self, r: &Ray1) -> Option<Hit1> {
        if !r.is_valid() {
            return None;
        }
        let seg = self.segment(r)?;
        let mut rh = ray_hit1(r, &seg);
        let mut args = ffi::RTCIntersectArguments::new(ffi::RAY_QUERY_FLAG_INCOHERENT);
        // SAFETY: a committed scene, a ray/hit of the library's layout, arguments set as
        // `rtcInitIntersectArguments` does.
        unsafe { (self.device.api.intersect1)(self.top, &mut rh, &mut args) };
        (rh.hit.geomID != ffi::INVALID_ID).then_some(Hit1 {
            t: rh.ray.tfar + seg.shift,
            u: rh.hit.u,
            v: rh.hit.v,
            prim: rh.hit.primID,
            inst: rh.hit.instID[0],
        })
    }

    /// Whether anything lies on the ray's segment (`rtcOccluded1`).
    pub fn any_hit1(&self, r: &Ray1) -> bool {
        if !r.is_valid() {
            return false;
        }
        let Some(seg) = self.segment(r) else {
            return false;
        };
        let mut ray = ray_hit1(r, &seg).ray;
        let mut args = ffi::RTCOccludedArguments::new(ffi::RAY_QUERY_FLAG_INCOHERENT);
        // SAFETY: as in `first_hit1`.
        unsafe { (self.device.api.occluded1)(self.top, &mut ray, &mut args) };
        ray.tfar == f32::NEG_INFINITY
    }

    /// Every hit on the ray's segment, each (triangle, instance) once, in no particular
    /// order (`rtcIntersect1` with a filter that records and rejects every hit).
    pub fn every_hit1(&self, r: &Ray1, f: &mut impl FnMut(Hit1)) {
        if !r.is_valid() {
            return;
        }
        let Some(seg) = self.segment(r) else {
            return;
        };
        let mut hits = Vec::new();
        let mut ctx = AllHitsContext {
            base: RTCRayQueryContext::default(),
            hits: &mut hits,
        };
        let mut args = ffi::RTCIntersectArguments::new(
            ffi::RAY_QUERY_FLAG_INCOHERENT | ffi::RAY_QUERY_FLAG_INVOKE_ARGUMENT_FILTER,
        );
        args.context = (&mut ctx as *mut AllHitsContext).cast();
        args.filter = Some(record_and_reject);
        let mut rh = ray_hit1(r, &seg);
        // SAFETY: as in `first_hit1`; the context outlives the call.
        unsafe { (self.device.api.intersect1)(self.top, &mut rh, &mut args) };
        hits.into_iter().for_each(|(_, h)| {
            f(Hit1 {
                t: h.t + seg.shift,
                ..h
            })
        });
    }

    /// First hits of a K-wide packet (K = 4, 8, 16) for the lanes on in `valid`; results
    /// are read back from the packet (`geomID` != invalid: `tfar`, `u`, `v`, `primID`,
    /// `instID`).
    pub fn intersect_k<const K: usize>(&self, p: &mut RTCRayHitK<K>, valid: &ValidK<K>) {
        let mut args = ffi::RTCIntersectArguments::new(flags(self.params.coherent));
        self.call_intersect(p, valid, &mut args);
    }

    /// Occlusion of a K-wide packet (occluded lanes get `tfar = -inf`).
    pub fn occluded_k<const K: usize>(&self, p: &mut RTCRayHitK<K>, valid: &ValidK<K>) {
        const {
            assert!(
                K == 4 || K == 8 || K == 16,
                "Embree has 4, 8 and 16-wide packets"
            )
        };
        let mut args = ffi::RTCOccludedArguments::new(flags(self.params.coherent));
        let api = self.device.api;
        let v = valid.0.as_ptr();
        let p = (p as *mut RTCRayHitK<K>).cast();
        // SAFETY: the K-wide call matching K; `p` (whose ray part is an RTCRayK) and `valid`
        // have the library's layout and alignment for K; arguments set as
        // `rtcInitOccludedArguments` does.
        unsafe {
            match K {
                4 => (api.occluded4)(v, self.top, p, &mut args),
                8 => (api.occluded8)(v, self.top, p.cast(), &mut args),
                _ => (api.occluded16)(v, self.top, p.cast(), &mut args),
            }
        }
    }

    /// Every hit of every valid lane of a K-wide packet, as (lane, hit) pairs appended to
    /// `hits`, each (lane, triangle, instance) once.
    pub fn all_hits_k<const K: usize>(
        &self,
        p: &mut RTCRayHitK<K>,
        valid: &ValidK<K>,
        hits: &mut Vec<(u32, Hit1)>,
    ) {
        let mut ctx = AllHitsContext {
            base: RTCRayQueryContext::default(),
            hits,
        };
        let mut args = ffi::RTCIntersectArguments::new(
            flags(self.params.coherent) | ffi::RAY_QUERY_FLAG_INVOKE_ARGUMENT_FILTER,
        );
        args.context = (&mut ctx as *mut AllHitsContext).cast();
        args.filter = Some(record_and_reject);
        self.call_intersect(p, valid, &mut args);
    }

    fn call_intersect<const K: usize>(
        &self,
        p: &mut RTCRayHitK<K>,
        valid: &ValidK<K>,
        args: &mut ffi::RTCIntersectArguments,
    ) {
        const {
            assert!(
                K == 4 || K == 8 || K == 16,
                "Embree has 4, 8 and 16-wide packets"
            )
        };
        let api = self.device.api;
        let v = valid.0.as_ptr();
        let p = (p as *mut RTCRayHitK<K>).cast();
        // SAFETY: as in `occluded_k`.
        unsafe {
            match K {
                4 => (api.intersect4)(v, self.top, p, args),
                8 => (api.intersect8)(v, self.top, p.cast(), args),
                _ => (api.intersect16)(v, self.top, p.cast(), args),
            }
        }
    }

    /// [`coherent_accel::Accel::intersect`] for `L::N == K`.
    #[inline(always)]
    pub(crate) fn intersect_packet<L: Lanes, const K: usize>(
        &self,
        l: L,
        rays: &Rays<L>,
        active: L::Mask,
    ) -> Hits<L> {
        let (mut p, valid, bits, shift) = packet::<L, K>(self, l, rays, active);
        if bits == 0 {
            return Hits::miss(l);
        }
        self.intersect_k(&mut p, &valid);
        if let Some(s) = shift {
            p.tfar = core::array::from_fn(|i| p.tfar[i] + s[i]);
        }
        let hit: [bool; K] = core::array::from_fn(|i| p.geomID[i] != ffi::INVALID_ID);
        let m = l.mask_from_fn(|i| hit[i]);
        let miss = Hits::miss(l);
        let id = |a: &[u32; K]| l.load_i32(&a.map(|x| x as i32));
        let got = Hits {
            t: l.load(&p.tfar),
            u: l.load(&p.u),
            v: l.load(&p.v),
            prim: id(&p.primID),
            inst: id(&p.instID[0]),
        };
        Hits::select(m, &got, &miss)
    }

    /// [`coherent_accel::Accel::occluded`] for `L::N == K`.
    #[inline(always)]
    pub(crate) fn occluded_packet<L: Lanes, const K: usize>(
        &self,
        l: L,
        rays: &Rays<L>,
        active: L::Mask,
    ) -> L::Mask {
        let (mut p, valid, bits, _) = packet::<L, K>(self, l, rays, active);
        if bits == 0 {
            return l.splat_mask(false);
        }
        self.occluded_k(&mut p, &valid);
        l.load(&p.tfar).eq(l.splat(f32::NEG_INFINITY)) & l.mask_from_bits(bits)
    }

    /// [`coherent_accel::Accel::intersect_all`] for `L::N == K`.
    #[inline(always)]
    pub(crate) fn intersect_all_packet<L: Lanes, const K: usize>(
        &self,
        l: L,
        rays: &Rays<L>,
        active: L::Mask,
        f: &mut impl FnMut(usize, Hit1),
    ) {
        let (mut p, valid, bits, shift) = packet::<L, K>(self, l, rays, active);
        if bits == 0 {
            return;
        }
        let mut hits = Vec::new();
        self.all_hits_k(&mut p, &valid, &mut hits);
        let s = shift.unwrap_or([0.0; K]);
        hits.into_iter().for_each(|(lane, h)| {
            f(
                lane as usize,
                Hit1 {
                    t: h.t + s[lane as usize],
                    ..h
                },
            )
        });
    }
}
