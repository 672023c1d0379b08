//! Ray queries on the Embree scene (the paper's two queries of section 3, plus occlusion):
//! first hit, all hits (through a filter callback that records and rejects every hit), and
//! occlusion, for single rays (`rtcIntersect1`) and for packets of 4, 8 and 16 rays
//! (`rtcIntersect4/8/16`, with the COHERENT flag as the parameters' [`Coherence`] says).
//!
//! Segments: Embree accepts hits in `(tnear, tfar]`, the interface asks for `[tmin, tmax)`;
//! the two differ only for a hit exactly at a bound.

use core::ffi::c_int;

use coherent_accel::{Hit1, Hits, Ray1, Rays};
use coherent_simd::{Lanes, SimdMask};

use crate::ffi::{self, RTCRayHitK, RTCRayQueryContext, ValidK};
use crate::packet::PacketK;
use crate::scene::{Coherence, Embree};

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

impl Embree {
    /// The query flags of a packet whose rays are coherent or not
    /// ([`PacketK`]'s cone test), as the parameters' [`Coherence`] says.
    #[inline(always)]
    fn packet_flags(&self, coherent: bool) -> c_int {
        flags(match self.params.coherence {
            Coherence::Coherent => true,
            Coherence::Incoherent => false,
            Coherence::PerPacket => coherent,
        })
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

/// A valid mask with the first `n` lanes on.
pub fn valid_lanes<const K: usize>(n: usize) -> ValidK<K> {
    let mut v = ValidK([0; K]);
    for (i, w) in v.0.iter_mut().enumerate() {
        *w = if i < n { -1 } else { 0 };
    }
    v
}

/// Lanes `active` of `rays` as a packed K-wide packet.
#[inline(always)]
fn packet<L: Lanes, const K: usize>(e: &Embree, rays: &Rays<L>, active: L::Mask) -> PacketK<K> {
    debug_assert_eq!(L::N, K);
    let bits = active.bitmask();
    let mut buf = [Ray1::infinite(glam::Vec3::ZERO, glam::Vec3::X); K];
    for (i, r) in buf.iter_mut().enumerate() {
        if bits >> i & 1 == 1 {
            *r = rays.lane(i);
        } else {
            r.tmin = f32::NAN; // invalid: off
        }
    }
    PacketK::new(e, &buf)
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
            // One untransformed instance is the mesh itself: no instance id is written.
            inst: if rh.hit.instID[0] == ffi::INVALID_ID {
                0
            } else {
                rh.hit.instID[0]
            },
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
        let Some(scene) = self.all_hits_scene() else {
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
        // SAFETY: as in `first_hit1`, on a scene with filter functions in arguments; the
        // context outlives the call.
        unsafe { (scene.device.api.intersect1)(scene.top, &mut rh, &mut args) };
        hits.into_iter().for_each(|(_, h)| {
            f(Hit1 {
                t: h.t + seg.shift,
                inst: if scene.direct { 0 } else { h.inst },
                ..h
            })
        });
    }

    /// First hits of a packed K-wide packet (K = 4, 8, 16); read them back with
    /// [`PacketK::hit`]. Safe: a [`PacketK`] holds only rays Embree's contract accepts.
    #[inline]
    pub fn intersect_k<const K: usize>(&self, p: &mut PacketK<K>) {
        let mut args = ffi::RTCIntersectArguments::new(self.packet_flags(p.coherent));
        // SAFETY: `PacketK::new` switched on only lanes with valid rays and `tnear >= 0`.
        unsafe { self.call_intersect(&mut p.rh, &p.valid, &mut args) };
    }

    /// Occlusion of a packed K-wide packet; read it back with [`PacketK::occluded`].
    #[inline]
    pub fn occluded_k<const K: usize>(&self, p: &mut PacketK<K>) {
        let mut args = ffi::RTCOccludedArguments::new(self.packet_flags(p.coherent));
        // SAFETY: as in `intersect_k`.
        unsafe { self.call_occluded(&mut p.rh, &p.valid, &mut args) };
    }

    /// Every hit of every valid lane of a packed K-wide packet, as (lane, hit) pairs appended
    /// to `hits`, each (lane, triangle, instance) once, `t` in the ray's own units.
    pub fn all_hits_k<const K: usize>(&self, p: &mut PacketK<K>, hits: &mut Vec<(u32, Hit1)>) {
        let from = hits.len();
        let Some(scene) = self.all_hits_scene() else {
            return;
        };
        // SAFETY: as in `intersect_k`.
        unsafe { scene.all_hits_k_raw(&mut p.rh, &p.valid, p.coherent, hits) };
        for (lane, h) in &mut hits[from..] {
            h.t += p.shift[*lane as usize];
            if scene.direct {
                h.inst = 0;
            }
        }
    }

    /// `rtcIntersectK` on a raw packet (the layout tests use it with guard words); with
    /// [`Coherence::PerPacket`] it goes without the COHERENT flag (Embree's default).
    ///
    /// # Safety
    /// Every lane on in `valid` must hold a valid ray ([`Ray1::is_valid`]) with
    /// `0 <= tnear <= tfar`, and its hit's `geomID` must be [`ffi::INVALID_ID`]: Embree's
    /// answer on other rays is undefined.
    pub unsafe fn intersect_k_raw<const K: usize>(&self, p: &mut RTCRayHitK<K>, valid: &ValidK<K>) {
        let mut args = ffi::RTCIntersectArguments::new(self.packet_flags(false));
        // SAFETY: the caller's contract.
        unsafe { self.call_intersect(p, valid, &mut args) };
    }

    /// # Safety
    /// As [`Self::intersect_k_raw`]; this scene must have been built with filter functions
    /// in arguments (`EmbreeParams::all_hits`).
    unsafe fn all_hits_k_raw<const K: usize>(
        &self,
        p: &mut RTCRayHitK<K>,
        valid: &ValidK<K>,
        coherent: bool,
        hits: &mut Vec<(u32, Hit1)>,
    ) {
        let mut ctx = AllHitsContext {
            base: RTCRayQueryContext::default(),
            hits,
        };
        let mut args = ffi::RTCIntersectArguments::new(
            self.packet_flags(coherent) | ffi::RAY_QUERY_FLAG_INVOKE_ARGUMENT_FILTER,
        );
        args.context = (&mut ctx as *mut AllHitsContext).cast();
        args.filter = Some(record_and_reject);
        // SAFETY: the caller's contract; the context outlives the call.
        unsafe { self.call_intersect(p, valid, &mut args) };
    }

    /// # Safety
    /// As [`Self::intersect_k_raw`].
    #[inline(always)]
    unsafe fn call_occluded<const K: usize>(
        &self,
        p: &mut RTCRayHitK<K>,
        valid: &ValidK<K>,
        args: &mut ffi::RTCOccludedArguments,
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
        // SAFETY: the K-wide call matching K; `p` (whose ray part is an RTCRayK) and `valid`
        // have the library's layout and alignment for K; arguments set as
        // `rtcInitOccludedArguments` does; rays as the caller promised.
        unsafe {
            match K {
                4 => (api.occluded4)(v, self.top, p, args),
                8 => (api.occluded8)(v, self.top, p.cast(), args),
                _ => (api.occluded16)(v, self.top, p.cast(), args),
            }
        }
    }

    /// # Safety
    /// As [`Self::intersect_k_raw`].
    #[inline(always)]
    unsafe fn call_intersect<const K: usize>(
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
        // SAFETY: as in `call_occluded`.
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
        let mut p = packet::<L, K>(self, rays, active);
        if p.lanes() == 0 {
            return Hits::miss(l);
        }
        self.intersect_k(&mut p);
        Hits::from_fn(l, |i| p.hit(i))
    }

    /// [`coherent_accel::Accel::occluded`] for `L::N == K`.
    #[inline(always)]
    pub(crate) fn occluded_packet<L: Lanes, const K: usize>(
        &self,
        l: L,
        rays: &Rays<L>,
        active: L::Mask,
    ) -> L::Mask {
        let mut p = packet::<L, K>(self, rays, active);
        if p.lanes() == 0 {
            return l.splat_mask(false);
        }
        self.occluded_k(&mut p);
        l.mask_from_bits(p.occluded_bits())
    }

    /// [`coherent_accel::Accel::intersect_all`] for `L::N == K`.
    #[inline(always)]
    pub(crate) fn intersect_all_packet<L: Lanes, const K: usize>(
        &self,
        rays: &Rays<L>,
        active: L::Mask,
        f: &mut impl FnMut(usize, Hit1),
    ) {
        let mut p = packet::<L, K>(self, rays, active);
        if p.lanes() == 0 {
            return;
        }
        let mut hits = Vec::new();
        self.all_hits_k(&mut p, &mut hits);
        hits.into_iter().for_each(|(lane, h)| f(lane as usize, h));
    }
}

impl Embree {
    /// The plainest use of the C API, to measure what any wrapper costs: for each packed
    /// packet, restore its far bounds and hit ids ([`PacketK::reset`]) and call
    /// `rtcIntersectK` (or `rtcOccludedK` when `occlusion`), with the query arguments made
    /// once (only their flags set per packet). Nothing is read back.
    pub fn trace_plain<const K: usize>(&self, packets: &mut [PacketK<K>], occlusion: bool) {
        if occlusion {
            let mut args = ffi::RTCOccludedArguments::new(0);
            for p in packets {
                p.reset();
                args.flags = self.packet_flags(p.coherent);
                // SAFETY: a `PacketK` holds only rays inside Embree's contract.
                unsafe { self.call_occluded(&mut p.rh, &p.valid, &mut args) };
            }
        } else {
            let mut args = ffi::RTCIntersectArguments::new(0);
            for p in packets {
                p.reset();
                args.flags = self.packet_flags(p.coherent);
                // SAFETY: as above.
                unsafe { self.call_intersect(&mut p.rh, &p.valid, &mut args) };
            }
        }
    }

    /// [`Self::trace_plain`] reading each packet's answers back: the occluded lanes
    /// ([`PacketK::occluded_bits`]), or the lanes that hit, whose `t` are added per lane
    /// ([`PacketK::accumulate_hits`]). Returns the count and the per-lane sums (zero for
    /// occlusion).
    ///
    /// A packet is read back after the next one's query, not right after its own. Read at
    /// once, the 8-wide first-hit loop ran at 0.91 of the plain loop's rate (blob, primary
    /// rays, one thread, Zen 4; 0.75-0.84 on the real meshes in `accel_embree.csv`); read one
    /// packet later, at 0.97-0.98. Likely cause: Embree writes the answers with masked vector
    /// stores, which loads right after them cannot take from the store buffer.
    pub fn trace_read<const K: usize>(
        &self,
        packets: &mut [PacketK<K>],
        occlusion: bool,
    ) -> (u64, [f32; K]) {
        let (mut hits, mut t_acc) = (0u64, [0.0f32; K]);
        if occlusion {
            let mut args = ffi::RTCOccludedArguments::new(0);
            for j in 0..packets.len() {
                let p = &mut packets[j];
                p.reset();
                args.flags = self.packet_flags(p.coherent);
                // SAFETY: as in `trace_plain`.
                unsafe { self.call_occluded(&mut p.rh, &p.valid, &mut args) };
                if j > 0 {
                    hits += u64::from(packets[j - 1].occluded_bits().count_ones());
                }
            }
            if let Some(p) = packets.last() {
                hits += u64::from(p.occluded_bits().count_ones());
            }
        } else {
            let mut args = ffi::RTCIntersectArguments::new(0);
            for j in 0..packets.len() {
                let p = &mut packets[j];
                p.reset();
                args.flags = self.packet_flags(p.coherent);
                // SAFETY: as in `trace_plain`.
                unsafe { self.call_intersect(&mut p.rh, &p.valid, &mut args) };
                if j > 0 {
                    hits += u64::from(packets[j - 1].accumulate_hits(&mut t_acc));
                }
            }
            if let Some(p) = packets.last() {
                hits += u64::from(p.accumulate_hits(&mut t_acc));
            }
        }
        (hits, t_acc)
    }
}
