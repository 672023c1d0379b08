//! Ray queries on an Embree scene (the paper's two queries of section 3, plus occlusion):
//! first hit, all hits (through a filter callback that records and rejects every hit), and
//! occlusion, for single rays (`rtcIntersect1`) and for packets of 4, 8 and 16 rays
//! (`rtcIntersect4/8/16` with the COHERENT flag).

use core::ffi::c_int;

use crate::ffi::{self, RTCRayHitK, RTCRayQueryContext, ValidK};
use crate::scene::EmbreeScene;

/// One ray: origin, direction, and the segment `[tmin, tmax]` searched.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray1 {
    pub org: [f32; 3],
    pub dir: [f32; 3],
    pub tmin: f32,
    pub tmax: f32,
}

/// One hit: distance along the ray, barycentrics, triangle and instance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit1 {
    pub t: f32,
    pub u: f32,
    pub v: f32,
    pub prim: u32,
    pub inst: u32,
}

impl Ray1 {
    /// Rays Embree must not see: non-finite origins or directions, a zero direction, or an
    /// empty or NaN segment. They miss (Embree's behaviour on them is undefined).
    #[inline(always)]
    pub fn is_valid(&self) -> bool {
        let finite = self.org.iter().chain(&self.dir).all(|x| x.is_finite());
        let nonzero = self.dir.iter().any(|&x| x != 0.0);
        finite && nonzero && self.tmin >= 0.0 && self.tmin <= self.tmax
    }
}

/// Writes ray `r` into lane `i` of a K-wide packet (id = lane, for the filter callback).
#[inline(always)]
pub fn set_lane<const K: usize>(p: &mut RTCRayHitK<K>, i: usize, r: &Ray1) {
    p.org_x[i] = r.org[0];
    p.org_y[i] = r.org[1];
    p.org_z[i] = r.org[2];
    p.dir_x[i] = r.dir[0];
    p.dir_y[i] = r.dir[1];
    p.dir_z[i] = r.dir[2];
    p.tnear[i] = r.tmin;
    p.tfar[i] = r.tmax;
    p.time[i] = 0.0;
    p.mask[i] = u32::MAX;
    p.id[i] = i as u32;
    p.flags[i] = 0;
    p.geomID[i] = ffi::INVALID_ID;
    p.instID[0][i] = ffi::INVALID_ID;
}

/// The hit in lane `i` after an intersect call, if any.
#[inline(always)]
pub fn lane_hit<const K: usize>(p: &RTCRayHitK<K>, i: usize) -> Option<Hit1> {
    (p.geomID[i] != ffi::INVALID_ID).then(|| Hit1 {
        t: p.tfar[i],
        u: p.u[i],
        v: p.v[i],
        prim: p.primID[i],
        inst: p.instID[0][i],
    })
}

/// Whether lane `i` was found occluded after an occluded call (Embree sets `tfar` to -inf).
#[inline(always)]
pub fn lane_occluded<const K: usize>(p: &RTCRayHitK<K>, i: usize) -> bool {
    p.tfar[i] == f32::NEG_INFINITY
}

/// The context of an all-hits query: Embree's context first (the library sees only that),
/// then where the filter callback records the hits.
#[repr(C)]
struct AllHitsContext {
    base: RTCRayQueryContext,
    /// (lane, hit), deduplicated per lane (a triangle split into several BVH leaves is
    /// reported once per leaf).
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
        let ray = args.ray;
        let hit = args.hit;
        for i in 0..n {
            let valid = args.valid.add(i);
            if *valid == 0 {
                continue;
            }
            let word = |base: *mut f32, row: usize| base.add(row * n + i);
            let lane = *(word(ray, 10) as *const u32);
            let h = Hit1 {
                t: *word(ray, 8),
                u: *word(hit, 3),
                v: *word(hit, 4),
                prim: *(word(hit, 5) as *const u32),
                inst: *(word(hit, 7) as *const u32),
            };
            if !hits.iter().any(|&(l, o)| l == lane && o.prim == h.prim && o.inst == h.inst) {
                hits.push((lane, h));
            }
            *valid = 0;
        }
    }
}

/// Ray `r` with an empty hit, as `rtcIntersect1` takes it.
#[inline(always)]
fn ray_hit1(r: &Ray1) -> ffi::RTCRayHit {
    ffi::RTCRayHit {
        ray: ffi::RTCRay {
            org_x: r.org[0],
            org_y: r.org[1],
            org_z: r.org[2],
            tnear: r.tmin,
            dir_x: r.dir[0],
            dir_y: r.dir[1],
            dir_z: r.dir[2],
            time: 0.0,
            tfar: r.tmax,
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

fn flags(coherent: bool) -> c_int {
    if coherent { ffi::RAY_QUERY_FLAG_COHERENT } else { ffi::RAY_QUERY_FLAG_INCOHERENT }
}

impl EmbreeScene {
    /// First hit of one ray (`rtcIntersect1`).
    pub fn intersect1(&self, r: &Ray1) -> Option<Hit1> {
        if !r.is_valid() {
            return None;
        }
        let mut rh = ray_hit1(r);
        let mut args = ffi::RTCIntersectArguments::new(ffi::RAY_QUERY_FLAG_INCOHERENT);
        // SAFETY: a committed scene, a ray/hit of the library's layout, arguments set as
        // `rtcInitIntersectArguments` does.
        unsafe { (self.device.api.intersect1)(self.top, &mut rh, &mut args) };
        (rh.hit.geomID != ffi::INVALID_ID).then(|| Hit1 {
            t: rh.ray.tfar,
            u: rh.hit.u,
            v: rh.hit.v,
            prim: rh.hit.primID,
            inst: rh.hit.instID[0],
        })
    }

    /// Whether anything lies on the ray's segment (`rtcOccluded1`).
    pub fn occluded1(&self, r: &Ray1) -> bool {
        if !r.is_valid() {
            return false;
        }
        let mut ray = ray_hit1(r).ray;
        let mut args = ffi::RTCOccludedArguments::new(ffi::RAY_QUERY_FLAG_INCOHERENT);
        // SAFETY: as in `intersect1`.
        unsafe { (self.device.api.occluded1)(self.top, &mut ray, &mut args) };
        ray.tfar == f32::NEG_INFINITY
    }

    /// Every hit on the ray's segment, in no particular order, each (triangle, instance)
    /// once, appended to `out` (`rtcIntersect1` with a filter that records and rejects).
    pub fn all_hits1(&self, r: &Ray1, out: &mut Vec<Hit1>) {
        if !r.is_valid() {
            return;
        }
        let mut hits = Vec::new();
        let mut ctx = AllHitsContext { base: RTCRayQueryContext::default(), hits: &mut hits };
        let mut args = ffi::RTCIntersectArguments::new(
            ffi::RAY_QUERY_FLAG_INCOHERENT | ffi::RAY_QUERY_FLAG_INVOKE_ARGUMENT_FILTER,
        );
        args.context = (&mut ctx as *mut AllHitsContext).cast();
        args.filter = Some(record_and_reject);
        let mut rh = ray_hit1(r);
        // SAFETY: as in `intersect1`; the context outlives the call.
        unsafe { (self.device.api.intersect1)(self.top, &mut rh, &mut args) };
        out.extend(hits.into_iter().map(|(_, h)| h));
    }

    /// First hits of a K-wide packet (K = 4, 8, 16) for the lanes on in `valid`; results
    /// are read back with [`lane_hit`]. `coherent` sets Embree's COHERENT query flag.
    pub fn intersect_k<const K: usize>(
        &self,
        p: &mut RTCRayHitK<K>,
        valid: &ValidK<K>,
        coherent: bool,
    ) {
        let mut args = ffi::RTCIntersectArguments::new(flags(coherent));
        self.call_intersect(p, valid, &mut args);
    }

    /// Occlusion of a K-wide packet; results are read back with [`lane_occluded`].
    pub fn occluded_k<const K: usize>(
        &self,
        p: &mut RTCRayHitK<K>,
        valid: &ValidK<K>,
        coherent: bool,
    ) {
        let mut args = ffi::RTCOccludedArguments::new(flags(coherent));
        const { assert!(K == 4 || K == 8 || K == 16, "Embree has 4, 8 and 16-wide packets") };
        let api = self.device.api;
        let v = valid.0.as_ptr();
        // SAFETY: the K-wide call matching K; `p` and `valid` have the library's layout and
        // alignment for K; arguments set as `rtcInitOccludedArguments` does.
        unsafe {
            match K {
                4 => (api.occluded4)(v, self.top, (p as *mut RTCRayHitK<K>).cast(), &mut args),
                8 => (api.occluded8)(v, self.top, (p as *mut RTCRayHitK<K>).cast(), &mut args),
                16 => (api.occluded16)(v, self.top, (p as *mut RTCRayHitK<K>).cast(), &mut args),
                _ => unreachable!("Embree has no {K}-wide packets"),
            }
        }
    }

    /// Every hit of every valid lane of a K-wide packet, as (lane, hit) pairs appended to
    /// `hits`, each (lane, triangle, instance) once.
    pub fn all_hits_k<const K: usize>(
        &self,
        p: &mut RTCRayHitK<K>,
        valid: &ValidK<K>,
        coherent: bool,
        hits: &mut Vec<(u32, Hit1)>,
    ) {
        let mut ctx = AllHitsContext { base: RTCRayQueryContext::default(), hits };
        let mut args = ffi::RTCIntersectArguments::new(
            flags(coherent) | ffi::RAY_QUERY_FLAG_INVOKE_ARGUMENT_FILTER,
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
        const { assert!(K == 4 || K == 8 || K == 16, "Embree has 4, 8 and 16-wide packets") };
        let api = self.device.api;
        let v = valid.0.as_ptr();
        // SAFETY: as in `occluded_k`.
        unsafe {
            match K {
                4 => (api.intersect4)(v, self.top, (p as *mut RTCRayHitK<K>).cast(), args),
                8 => (api.intersect8)(v, self.top, (p as *mut RTCRayHitK<K>).cast(), args),
                16 => (api.intersect16)(v, self.top, (p as *mut RTCRayHitK<K>).cast(), args),
                _ => unreachable!("Embree has no {K}-wide packets"),
            }
        }
    }
}

/// A valid mask with the first `n` lanes on.
pub fn valid_lanes<const K: usize>(n: usize) -> ValidK<K> {
    ValidK(core::array::from_fn(|i| if i < n { -1 } else { 0 }))
}
