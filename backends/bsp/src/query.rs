//! The three queries of paper section 3 (first hit, all hits, occlusion) as traversal states:
//! what a ray or packet has found so far, and how far it still has to look.

use coherent_accel::{Hit1, Hits};
use coherent_simd::{Lanes, SimdF32, SimdMask};

/// A single ray's query.
pub(crate) trait Query1 {
    /// New hits must be nearer than this (`-inf` once the query is finished).
    fn limit(&self) -> f32;
    /// Takes a hit nearer than [`Query1::limit`]; true when the query is finished.
    fn hit(&mut self, h: Hit1) -> bool;
}

/// Work done for one lane of a packet with that lane's single-ray query (the switch from
/// packet to single-ray traversal).
pub(crate) trait LaneTask {
    fn run<Q: Query1>(&mut self, q: &mut Q);
}

/// A packet's query.
pub(crate) trait QueryP<L: Lanes> {
    /// Per lane, new hits must be nearer than this (`-inf` for finished lanes).
    fn limit(&self) -> L::F32s;
    /// Lanes `m` hit triangle `prim` of instance `inst` at `t` (nearer than the limit).
    #[allow(clippy::too_many_arguments)]
    fn hits(&mut self, l: L, m: L::Mask, t: L::F32s, u: L::F32s, v: L::F32s, prim: u32, inst: u32);
    /// True when every lane of `m` is finished.
    fn finished(&self, m: L::Mask) -> bool;
    /// True when every lane of the query is finished (nothing more to find anywhere).
    #[inline(always)]
    fn done(&self) -> bool {
        false
    }
    /// Runs `task` with lane `i`'s single-ray query and takes back its result.
    fn with_lane(&mut self, l: L, i: usize, task: &mut impl LaneTask);
}

/// First hit of one ray.
pub(crate) struct First1 {
    pub tmax: f32,
    pub best: Option<Hit1>,
}

impl Query1 for First1 {
    #[inline(always)]
    fn limit(&self) -> f32 {
        self.tmax
    }
    #[inline(always)]
    fn hit(&mut self, h: Hit1) -> bool {
        self.tmax = h.t;
        self.best = Some(h);
        false
    }
}

/// Occlusion of one ray.
pub(crate) struct Any1 {
    pub tmax: f32,
    pub occluded: bool,
}

impl Query1 for Any1 {
    #[inline(always)]
    fn limit(&self) -> f32 {
        if self.occluded {
            f32::NEG_INFINITY
        } else {
            self.tmax
        }
    }
    #[inline(always)]
    fn hit(&mut self, _: Hit1) -> bool {
        self.occluded = true;
        true
    }
}

/// All hits of one ray, each (triangle, instance) once.
pub(crate) struct All1<'a, F: FnMut(Hit1)> {
    pub tmax: f32,
    pub seen: Vec<(u32, u32)>,
    pub f: &'a mut F,
}

impl<F: FnMut(Hit1)> Query1 for All1<'_, F> {
    #[inline(always)]
    fn limit(&self) -> f32 {
        self.tmax
    }
    #[inline(always)]
    fn hit(&mut self, h: Hit1) -> bool {
        if !self.seen.contains(&(h.inst, h.prim)) {
            self.seen.push((h.inst, h.prim));
            (self.f)(h);
        }
        false
    }
}

/// First hits of a packet.
#[derive(Clone, Copy)]
pub(crate) struct FirstP<L: Lanes> {
    pub best: L::F32s,
    pub hits: Hits<L>,
}

impl<L: Lanes> FirstP<L> {
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn set(&mut self, l: L, m: L::Mask, t: L::F32s, u: L::F32s, v: L::F32s, prim: u32, inst: u32) {
        self.best = m.select(t, self.best);
        let new = Hits {
            t,
            u,
            v,
            prim: l.splat_i32(prim as i32),
            inst: l.splat_i32(inst as i32),
        };
        self.hits = Hits::select(m, &new, &self.hits);
    }
}

impl<L: Lanes> QueryP<L> for FirstP<L> {
    #[inline(always)]
    fn limit(&self) -> L::F32s {
        self.best
    }
    #[inline(always)]
    fn hits(&mut self, l: L, m: L::Mask, t: L::F32s, u: L::F32s, v: L::F32s, prim: u32, inst: u32) {
        self.set(l, m, t, u, v, prim, inst);
    }
    #[inline(always)]
    fn finished(&self, _: L::Mask) -> bool {
        false
    }
    #[inline(always)]
    fn with_lane(&mut self, l: L, i: usize, task: &mut impl LaneTask) {
        let mut q = First1 {
            tmax: self.best.lane(i),
            best: None,
        };
        task.run(&mut q);
        if let Some(h) = q.best {
            let m = l.mask_from_bits(1 << i);
            let s = |x: f32| l.splat(x);
            self.set(l, m, s(h.t), s(h.u), s(h.v), h.prim, h.inst);
        }
    }
}

/// Occlusion of a packet.
#[derive(Clone, Copy)]
pub(crate) struct AnyP<L: Lanes> {
    pub tmax: L::F32s,
    pub occluded: L::Mask,
    /// The lanes asked about.
    pub active: L::Mask,
    /// `-inf` in every lane.
    pub neg_inf: L::F32s,
}

impl<L: Lanes> QueryP<L> for AnyP<L> {
    #[inline(always)]
    fn limit(&self) -> L::F32s {
        // Finished lanes get -inf: no node and no triangle is nearer.
        self.occluded.select(self.neg_inf, self.tmax)
    }
    #[inline(always)]
    fn hits(&mut self, _: L, m: L::Mask, _: L::F32s, _: L::F32s, _: L::F32s, _: u32, _: u32) {
        self.occluded |= m;
    }
    #[inline(always)]
    fn finished(&self, m: L::Mask) -> bool {
        m.and_not(self.occluded).none()
    }
    #[inline(always)]
    fn done(&self) -> bool {
        self.active.and_not(self.occluded).none()
    }
    #[inline(always)]
    fn with_lane(&mut self, l: L, i: usize, task: &mut impl LaneTask) {
        let mut q = Any1 {
            tmax: self.tmax.lane(i),
            occluded: false,
        };
        task.run(&mut q);
        if q.occluded {
            self.occluded |= l.mask_from_bits(1 << i);
        }
    }
}

/// All hits of a packet, each (lane, triangle, instance) once.
pub(crate) struct AllP<'a, L: Lanes, F: FnMut(usize, Hit1)> {
    pub tmax: L::F32s,
    pub seen: Vec<(u32, u32, u32)>,
    pub f: &'a mut F,
}

impl<L: Lanes, F: FnMut(usize, Hit1)> AllP<'_, L, F> {
    #[inline(always)]
    fn report(&mut self, lane: usize, h: Hit1) {
        let key = (lane as u32, h.inst, h.prim);
        if !self.seen.contains(&key) {
            self.seen.push(key);
            (self.f)(lane, h);
        }
    }
}

impl<L: Lanes, F: FnMut(usize, Hit1)> QueryP<L> for AllP<'_, L, F> {
    #[inline(always)]
    fn limit(&self) -> L::F32s {
        self.tmax
    }
    #[inline(always)]
    fn hits(&mut self, _: L, m: L::Mask, t: L::F32s, u: L::F32s, v: L::F32s, prim: u32, inst: u32) {
        let mut bits = m.bitmask();
        while bits != 0 {
            let i = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let h = Hit1 {
                t: t.lane(i),
                u: u.lane(i),
                v: v.lane(i),
                prim,
                inst,
            };
            self.report(i, h);
        }
    }
    #[inline(always)]
    fn finished(&self, _: L::Mask) -> bool {
        false
    }
    #[inline(always)]
    fn with_lane(&mut self, _: L, i: usize, task: &mut impl LaneTask) {
        let mut q = AllLane {
            tmax: self.tmax.lane(i),
            lane: i,
            parent: self,
        };
        task.run(&mut q);
    }
}

/// One lane of [`AllP`] as a single-ray query.
struct AllLane<'a, 'b, L: Lanes, F: FnMut(usize, Hit1)> {
    tmax: f32,
    lane: usize,
    parent: &'a mut AllP<'b, L, F>,
}

impl<L: Lanes, F: FnMut(usize, Hit1)> Query1 for AllLane<'_, '_, L, F> {
    #[inline(always)]
    fn limit(&self) -> f32 {
        self.tmax
    }
    #[inline(always)]
    fn hit(&mut self, h: Hit1) -> bool {
        self.parent.report(self.lane, h);
        false
    }
}
