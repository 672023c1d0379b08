//! Beam traversal of the two-level BSP: many packets of coherent rays (a tile of camera
//! rays, a tile's shadow rays toward one point) walk the trees as one group. Beyond the
//! paper, after Reshetov, Soupikov & Hurley 2005 ("Multi-level ray tracing algorithm": an
//! entry point shared by the group, found once, below which the group splits) with the
//! interval bounds of Wald, Boulos & Shirley 2007 in place of a frustum.
//!
//! A beam's rays share direction signs. Per axis it keeps the range of its rays' origins and
//! inverse directions ([`Span`]); `(p - o) * inv` over those ranges bounds, from below and
//! above, where every ray of the beam crosses a plane `p`, with the very arithmetic each ray
//! would use (rounding is monotone, so the bounds hold for the rounded values too). With
//! those bounds one test decides a node for every ray at once: a child no ray can enter before
//! its current hit is skipped for all of them.
//!
//! - Object trees, multi-level: from the mesh root the beam descends while its rays enter one
//!   child only (the entry point search). Where they may enter both, the beam halves (its
//!   packets are ordered along the tile, so each half is a smaller tile) and each half
//!   searches on from that node with its own, tighter bounds; a single packet, or a beam at a
//!   leaf, continues as the ordinary packet walk from its entry point, its rays clipped to
//!   the entry point's voxel.
//! - The top tree: the whole beam walks it near to far with a stack, entering each instance
//!   it reaches once; an instance's beam is moved into object space and regrouped by signs.
//! - Each group of equal direction signs walks as a beam of its own (in world space, and
//!   again per group in an instance's object space); lanes with a zero or subnormal direction
//!   component go ray by ray. Both are counted ([`Counters::beam_fallback`]: lanes outside
//!   the largest group, and the ray-by-ray ones).
//!
//! The answers are those of the packet walk: every ray visits at least the leaves its own
//! walk would, and hits only ever replace farther ones.

use coherent_accel::{Aabb, Rays};
use coherent_simd::{Lanes, SimdF32, SimdMask};

use crate::bsp::{Bsp, MeshTree};
use crate::counters::Counters;
use crate::mailbox::Mailbox1;
use crate::query::{LaneTask, Query1, QueryP};
use crate::stack::Stack;
use crate::walk::{RaysX, clip_box, mesh_packet};
use crate::walk1::{Ray1x, widen_hi, widen_lo};
use crate::{KdTree, Node};

/// Interval bounds of a set of rays with equal direction signs: per axis the range of the
/// origins and of the inverse directions (all finite), and the lowest `tmin`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Span {
    o_lo: [f32; 3],
    o_hi: [f32; 3],
    inv_lo: [f32; 3],
    inv_hi: [f32; 3],
    tmin: f32,
}

impl Span {
    const EMPTY: Span = Span {
        o_lo: [f32::INFINITY; 3],
        o_hi: [f32::NEG_INFINITY; 3],
        inv_lo: [f32::INFINITY; 3],
        inv_hi: [f32::NEG_INFINITY; 3],
        tmin: f32::INFINITY,
    };

    /// True when the span bounds no ray.
    #[inline(always)]
    fn is_empty(&self) -> bool {
        self.o_lo[0]
            .partial_cmp(&self.o_hi[0])
            .is_none_or(|o| o.is_gt())
    }

    #[inline(always)]
    fn union(&self, o: &Span) -> Span {
        let mut s = *self;
        for k in 0..3 {
            s.o_lo[k] = s.o_lo[k].min(o.o_lo[k]);
            s.o_hi[k] = s.o_hi[k].max(o.o_hi[k]);
            s.inv_lo[k] = s.inv_lo[k].min(o.inv_lo[k]);
            s.inv_hi[k] = s.inv_hi[k].max(o.inv_hi[k]);
        }
        s.tmin = s.tmin.min(o.tmin);
        s
    }

    /// The bounds of lanes `m` of `r` (empty when `m` is).
    #[inline(always)]
    fn of_packet<L: Lanes>(l: L, r: &RaysX<L>, m: L::Mask) -> Span {
        if m.none() {
            return Span::EMPTY;
        }
        let (inf, ninf) = (l.splat(f32::INFINITY), l.splat(f32::NEG_INFINITY));
        Span {
            o_lo: [
                lanes_min(m, r.o[0], inf),
                lanes_min(m, r.o[1], inf),
                lanes_min(m, r.o[2], inf),
            ],
            o_hi: [
                lanes_max(m, r.o[0], ninf),
                lanes_max(m, r.o[1], ninf),
                lanes_max(m, r.o[2], ninf),
            ],
            inv_lo: [
                lanes_min(m, r.inv[0], inf),
                lanes_min(m, r.inv[1], inf),
                lanes_min(m, r.inv[2], inf),
            ],
            inv_hi: [
                lanes_max(m, r.inv[0], ninf),
                lanes_max(m, r.inv[1], ninf),
                lanes_max(m, r.inv[2], ninf),
            ],
            tmin: lanes_min(m, r.tmin, inf),
        }
    }

    /// The lowest and highest `(p - o) * inv` along axis `k` over the set: where its rays
    /// cross the plane at `p`. The product is bilinear, so its extremes lie at the corners.
    #[inline(always)]
    fn plane(&self, k: usize, p: f32) -> (f32, f32) {
        let a = p - self.o_hi[k];
        let b = p - self.o_lo[k];
        let (i0, i1) = (self.inv_lo[k], self.inv_hi[k]);
        let (w, x, y, z) = (a * i0, a * i1, b * i0, b * i1);
        (w.min(x).min(y.min(z)), w.max(x).max(y.max(z)))
    }

    /// Per axis, the earliest entry into and the latest exit from box `b`'s slab over the
    /// set (`neg`: the set's direction sign bits).
    #[inline(always)]
    fn slabs(&self, b: &Aabb, neg: u32) -> Slabs {
        let mut s = Slabs {
            enter: [0.0; 3],
            exit: [0.0; 3],
        };
        for k in 0..3 {
            let (p_in, p_out) = if neg >> k & 1 != 0 {
                (b.max[k], b.min[k])
            } else {
                (b.min[k], b.max[k])
            };
            s.enter[k] = self.plane(k, p_in).0;
            s.exit[k] = self.plane(k, p_out).1;
        }
        s
    }
}

/// The lowest of lanes `m` of `x` (`inf`: `+inf` in every lane). A function, not a closure
/// called seven times: it must inline into the backends' target-feature kernels.
#[inline(always)]
fn lanes_min<M: SimdMask>(m: M, x: M::F32s, inf: M::F32s) -> f32 {
    m.select(x, inf).reduce_min()
}

/// The highest of lanes `m` of `x` (`ninf`: `-inf` in every lane).
#[inline(always)]
fn lanes_max<M: SimdMask>(m: M, x: M::F32s, ninf: M::F32s) -> f32 {
    m.select(x, ninf).reduce_max()
}

/// Per axis, the bounds of a span's entries into and exits from a voxel's slabs.
#[derive(Debug, Clone, Copy)]
struct Slabs {
    enter: [f32; 3],
    exit: [f32; 3],
}

impl Slabs {
    /// Whether some ray of the span may be inside the voxel in `[tmin, limit]` (widened by
    /// the walks' slack, so a ray through a corner is inside).
    #[inline(always)]
    fn open(&self, tmin: f32, limit: f32) -> bool {
        let t0 = self.enter[0]
            .max(self.enter[1])
            .max(self.enter[2])
            .max(tmin);
        let t1 = self.exit[0].min(self.exit[1]).min(self.exit[2]).min(limit);
        widen_lo(t0) <= widen_hi(t1)
    }
}

/// The child voxels of `vox` split on axis `k` at `p`: (left, right).
#[inline(always)]
fn halves(vox: &Aabb, k: usize, p: f32) -> (Aabb, Aabb) {
    let (mut left, mut right) = (*vox, *vox);
    left.max[k] = p;
    right.min[k] = p;
    (left, right)
}

/// The packets of a beam as one tree's walk sees them (world or object space), and the
/// group of equal direction signs being walked.
pub(crate) struct BeamX<L: Lanes> {
    /// Prepared rays per packet, `signs` set to the group's.
    rx: Vec<RaysX<L>>,
    /// Per packet: the lanes with finite inverse directions, and per axis the lanes whose
    /// direction is negative along it.
    bits: Vec<(u32, [u32; 3])>,
    /// Per packet, the lanes of the group being walked.
    m: Vec<L::Mask>,
    /// Bounds over packet ranges, a complete binary tree over `width` (the packet count
    /// rounded up to a power of two) leaves: entry 1 holds every packet, entry `h` has
    /// children `2h` and `2h + 1`, and leaf `width + j` is packet `j` (empty past the last).
    spans: Vec<Span>,
    width: usize,
    /// How many lanes have each sign pattern (bit k: negative along axis k).
    counts: [u32; 8],
    /// The group's direction sign bits (x, y, z, and z again in bit 3).
    neg: u32,
}

impl<L: Lanes> BeamX<L> {
    fn empty() -> Self {
        Self {
            rx: Vec::new(),
            bits: Vec::new(),
            m: Vec::new(),
            spans: Vec::new(),
            width: 1,
            counts: [0; 8],
            neg: 0,
        }
    }

    /// The packets under span entry `h`.
    #[inline(always)]
    fn range(&self, h: usize) -> (usize, usize) {
        let level = h.ilog2();
        let size = self.width >> level;
        let a = (h - (1 << level)) * size;
        (a.min(self.rx.len()), (a + size).min(self.rx.len()))
    }

    /// Takes the prepared packets `rays`, each with the lanes to trace, and counts their sign
    /// patterns. `odd` receives, per packet, the lanes no group can take (a zero or subnormal
    /// direction component: an infinite inverse).
    #[inline(always)]
    fn prepare(
        &mut self,
        l: L,
        rays: impl Iterator<Item = (RaysX<L>, L::Mask)>,
        odd: &mut Vec<L::Mask>,
    ) {
        self.rx.clear();
        self.bits.clear();
        odd.clear();
        self.counts = [0; 8];
        let inf = l.splat(f32::INFINITY);
        for (r, lanes) in rays {
            // Finite inverse directions only: the bounds' products must not meet 0 * inf.
            let finite =
                lanes & r.inv[0].abs().lt(inf) & r.inv[1].abs().lt(inf) & r.inv[2].abs().lt(inf);
            let fb = finite.bitmask();
            let nb = [r.neg[0].bitmask(), r.neg[1].bitmask(), r.neg[2].bitmask()];
            let mut rest = fb;
            while rest != 0 {
                let i = rest.trailing_zeros();
                rest &= rest - 1;
                let p = (nb[0] >> i & 1) | (nb[1] >> i & 1) << 1 | (nb[2] >> i & 1) << 2;
                self.counts[p as usize] += 1;
            }
            odd.push(lanes.and_not(finite));
            self.bits.push((fb, nb));
            self.rx.push(r);
        }
    }

    /// Makes the lanes of sign pattern `g` the group walked: their masks, signs and bounds.
    #[inline(always)]
    fn select(&mut self, l: L, g: u32) {
        let pick = |n: u32, bit: u32| if bit != 0 { n } else { !n };
        self.neg = g | (g >> 2 & 1) << 3;
        self.m.clear();
        for (r, &(fb, nb)) in self.rx.iter_mut().zip(&self.bits) {
            let keep = fb & pick(nb[0], g & 1) & pick(nb[1], g >> 1 & 1) & pick(nb[2], g >> 2 & 1);
            self.m.push(l.mask_from_bits(keep));
            r.signs = self.neg;
            r.mixed = 0;
        }
        let n = self.rx.len();
        self.width = n.max(1).next_power_of_two();
        let w = self.width;
        self.spans.clear();
        self.spans.resize(2 * w, Span::EMPTY);
        for j in 0..n {
            self.spans[w + j] = Span::of_packet(l, &self.rx[j], self.m[j]);
        }
        for h in (1..w).rev() {
            self.spans[h] = self.spans[2 * h].union(&self.spans[2 * h + 1]);
        }
    }
}

/// The highest limit over the beam lanes of packets `a..b`.
#[inline(always)]
fn limit_of<L: Lanes, Q: QueryP<L>>(l: L, bx: &BeamX<L>, qs: &[Q], a: usize, b: usize) -> f32 {
    let ninf = l.splat(f32::NEG_INFINITY);
    let mut lim = f32::NEG_INFINITY;
    for (m, q) in bx.m[a..b].iter().zip(&qs[a..b]) {
        if m.any() {
            lim = lim.max(m.select(q.limit(), ninf).reduce_max());
        }
    }
    lim
}

/// What every walk of one mesh with a beam shares.
struct MeshBeam<'a, L: Lanes> {
    l: L,
    mesh: &'a MeshTree,
    inst: u32,
    bx: &'a BeamX<L>,
    thr: u32,
    mailbox: bool,
}

impl<L: Lanes> MeshBeam<'_, L> {
    /// The whole beam from the mesh root: per sub-beam the entry point search, then halves
    /// or packets. A work list rather than recursion, so that it all inlines into the
    /// backend's kernel.
    #[inline(always)]
    fn walk<Q: QueryP<L>, C: Counters>(&self, qs: &mut [Q], c: &mut C) {
        let nodes = &self.mesh.tree.nodes[..];
        let neg = self.bx.neg;
        let mut work: Stack<(u32, u32, Aabb)> = Stack::new();
        work.push((1, 0, self.mesh.tree.bounds));
        'beams: while let Some((h, start, vox)) = work.pop() {
            let (h, mut node, mut vox) = (h as usize, start as usize, vox);
            let span = &self.bx.spans[h];
            if span.is_empty() {
                continue;
            }
            let (a, b) = self.bx.range(h);
            let limit = limit_of(self.l, self.bx, qs, a, b);
            let mut s = span.slabs(&vox, neg);
            if !s.open(span.tmin, limit) {
                continue;
            }
            // The entry point: down while the rays may enter one child only.
            loop {
                let n = nodes[node];
                if n.is_leaf() {
                    break;
                }
                c.beam_step();
                let k = n.axis() & 3;
                let (ts_lo, ts_hi) = span.plane(k, n.split());
                let sb = (neg >> k & 1) as usize;
                let empty = n.empty_children();
                // Near child: the rays leave it through the split; far: they enter it there.
                let (mut sn, mut sf) = (s, s);
                sn.exit[k] = ts_hi;
                sf.enter[k] = ts_lo;
                let go_near = empty >> sb & 1 == 0 && sn.open(span.tmin, limit);
                let go_far = empty >> (sb ^ 1) & 1 == 0 && sf.open(span.tmin, limit);
                let (left, right) = halves(&vox, k, n.split());
                let (near_vox, far_vox) = if sb == 0 {
                    (left, right)
                } else {
                    (right, left)
                };
                match (go_near, go_far) {
                    (true, false) => (node, vox, s) = (n.left() + sb, near_vox, sn),
                    (false, true) => (node, vox, s) = (n.left() + 1 - sb, far_vox, sf),
                    (false, false) => continue 'beams,
                    (true, true) => break,
                }
            }
            if b - a > 1 && !nodes[node].is_leaf() {
                // Both halves search on from here, the first half first.
                work.push((2 * h as u32 + 1, node as u32, vox));
                work.push((2 * h as u32, node as u32, vox));
                continue;
            }
            c.beam_entry((b - a) as u32);
            for (j, q) in qs.iter_mut().enumerate().take(b).skip(a) {
                self.packet(j, node, &vox, q, c);
            }
        }
    }

    /// Packet `j`'s beam lanes from node `node`, their segments clipped to its voxel.
    #[inline(always)]
    fn packet<Q: QueryP<L>, C: Counters>(
        &self,
        j: usize,
        node: usize,
        vox: &Aabb,
        q: &mut Q,
        c: &mut C,
    ) {
        let (l, r) = (self.l, &self.bx.rx[j]);
        let m = self.bx.m[j];
        if m.none() || q.finished(m) {
            return;
        }
        let (t0, t1) = clip_box(l, vox, &r.o, &r.inv, r.tmin, q.limit());
        let m = m & t0.le(t1);
        if m.any() {
            mesh_packet(
                l,
                self.mesh,
                self.inst,
                r,
                node,
                t0,
                t1,
                m,
                self.thr,
                self.mailbox,
                q,
                c,
            );
        }
    }
}

/// Walks `tree` near to far with the whole of span `span` (sign bits `neg`), calling
/// `leaf(s, c, items)` at each non-empty leaf some ray may reach before `limit(s)`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn walk_span<S: ?Sized, C: Counters>(
    tree: &KdTree,
    span: &Span,
    neg: u32,
    s: &mut S,
    c: &mut C,
    limit: impl Fn(&S) -> f32,
    done: impl Fn(&S) -> bool,
    mut leaf: impl FnMut(&mut S, &mut C, &[u32]),
) {
    let nodes: &[Node] = &tree.nodes;
    let mut stack: Stack<(u32, Slabs)> = Stack::new();
    let mut node = 0;
    let mut sl = span.slabs(&tree.bounds, neg);
    if !sl.open(span.tmin, limit(s)) {
        return;
    }
    loop {
        let n = nodes[node];
        if n.is_leaf() {
            let items = &tree.items[n.items()];
            if !items.is_empty() {
                c.leaf();
                leaf(s, c, items);
                if done(s) {
                    return;
                }
            }
        } else {
            c.beam_step();
            let k = n.axis() & 3;
            let (ts_lo, ts_hi) = span.plane(k, n.split());
            let sb = (neg >> k & 1) as usize;
            let empty = n.empty_children();
            let lim = limit(s);
            let (mut sn, mut sf) = (sl, sl);
            sn.exit[k] = ts_hi;
            sf.enter[k] = ts_lo;
            let go_near = empty >> sb & 1 == 0 && sn.open(span.tmin, lim);
            let go_far = empty >> (sb ^ 1) & 1 == 0 && sf.open(span.tmin, lim);
            let (near, far) = (n.left() + sb, n.left() + 1 - sb);
            match (go_near, go_far) {
                (true, false) => {
                    (node, sl) = (near, sn);
                    continue;
                }
                (false, true) => {
                    (node, sl) = (far, sf);
                    continue;
                }
                (true, true) => {
                    stack.push((far as u32, sf));
                    (node, sl) = (near, sn);
                    continue;
                }
                (false, false) => {}
            }
        }
        loop {
            let Some((next, e)) = stack.pop() else {
                return;
            };
            if e.open(span.tmin, limit(s)) {
                (node, sl) = (next as usize, e);
                break;
            }
        }
    }
}

/// A beam through the whole scene: packets `rays` under `active`, one query each. Each group
/// of equal direction signs walks as a beam of its own; lanes with a zero direction component
/// go ray by ray.
#[inline(always)]
pub(crate) fn scene_beam<L: Lanes, Q: QueryP<L>, C: Counters>(
    l: L,
    bsp: &Bsp,
    rays: &[Rays<L>],
    active: &[L::Mask],
    qs: &mut [Q],
    c: &mut C,
) {
    let mut world = BeamX::empty();
    let mut odd = Vec::new();
    world.prepare(
        l,
        rays.iter().zip(active).map(
            #[inline(always)]
            |(r, &a)| (RaysX::new(l, &r.origin, &r.dir, r.tmin), a & r.valid(l)),
        ),
        &mut odd,
    );
    for (j, &m) in odd.iter().enumerate() {
        let mut bits = m.bitmask();
        while bits != 0 {
            let i = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            c.beam_fallback(1);
            let r = rays[j].lane(i);
            qs[j].with_lane(l, i, &mut SceneTask { bsp, r, c: &mut *c });
        }
    }
    let mut obj = BeamX::empty();
    let largest = (0..8).max_by_key(|&g| world.counts[g]).unwrap_or(0);
    for g in 0..8u32 {
        let n = world.counts[g as usize];
        if n == 0 {
            continue;
        }
        if g as usize != largest {
            c.beam_fallback(n);
        }
        world.select(l, g);
        let mut seen = Mailbox1::new();
        // A top tree of one leaf (few instances) too: its root box culls first.
        walk_span(
            &bsp.top,
            &world.spans[1],
            world.neg,
            qs,
            c,
            #[inline(always)]
            |qs| limit_of(l, &world, qs, 0, world.rx.len()),
            #[inline(always)]
            |qs| all_done(qs),
            #[inline(always)]
            |qs, c, items| {
                for &i in items {
                    if !seen.seen(i) {
                        enter_beam(l, bsp, i, rays, &world, &mut obj, &mut odd, qs, c);
                    }
                }
            },
        );
    }
}

/// Whether every packet's query is finished.
#[inline(always)]
fn all_done<L: Lanes, Q: QueryP<L>>(qs: &[Q]) -> bool {
    // A loop, not `Iterator::all`: that stays out of line, outside the kernel's features.
    for q in qs {
        if !q.done() {
            return false;
        }
    }
    true
}

/// Instance `i` for the world group `world` (packets `rays`): in object space, per group of
/// equal signs there (a transform may change them), when the instance has a transform. `obj`
/// and `odd` are scratch space.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn enter_beam<L: Lanes, Q: QueryP<L>, C: Counters>(
    l: L,
    bsp: &Bsp,
    i: u32,
    rays: &[Rays<L>],
    world: &BeamX<L>,
    obj: &mut BeamX<L>,
    odd: &mut Vec<L::Mask>,
    qs: &mut [Q],
    c: &mut C,
) {
    let inst = &bsp.instances[i as usize];
    let mesh = &bsp.meshes[inst.mesh as usize];
    let thr = bsp.params.threshold_for(L::N);
    let mailbox = bsp.params.mailbox;
    if !inst.identity {
        let m = &inst.object_from_world;
        obj.prepare(
            l,
            rays.iter().zip(&world.m).map(
                #[inline(always)]
                |(r, &bm)| {
                    let o = r.transformed(l, m);
                    (RaysX::new(l, &o.origin, &o.dir, r.tmin), bm)
                },
            ),
            odd,
        );
        for (j, &m) in odd.iter().enumerate() {
            let mut bits = m.bitmask();
            while bits != 0 {
                let k = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                c.beam_fallback(1);
                let r = obj.rx[j].lane(k);
                qs[j].with_lane(
                    l,
                    k,
                    &mut ObjectTask {
                        mesh,
                        r,
                        inst: i,
                        mailbox,
                        c: &mut *c,
                    },
                );
            }
        }
    }
    // One walk per group (the world's group as it is for an untransformed instance): one
    // call site, so the walk is compiled once.
    for g in 0..8u32 {
        let bx: &BeamX<L> = if inst.identity {
            if g > 0 {
                break;
            }
            world
        } else {
            if obj.counts[g as usize] == 0 {
                continue;
            }
            obj.select(l, g);
            obj
        };
        let mut lanes = 0;
        for m in &bx.m {
            lanes += m.count();
        }
        c.instance(lanes);
        MeshBeam {
            l,
            mesh,
            inst: i,
            bx,
            thr,
            mailbox,
        }
        .walk(qs, c);
    }
}

/// A lane with a zero direction component through the whole scene, ray by ray.
struct SceneTask<'a, C: Counters> {
    bsp: &'a Bsp,
    r: coherent_accel::Ray1,
    c: &'a mut C,
}

impl<C: Counters> LaneTask for SceneTask<'_, C> {
    #[inline(always)]
    fn run<Q1: Query1>(&mut self, q: &mut Q1) {
        crate::walk1::scene1(self.bsp, self.r.origin, self.r.dir, self.r.tmin, q, self.c);
    }
}

/// An object-space lane with a zero direction component through one instance's mesh.
struct ObjectTask<'a, C: Counters> {
    mesh: &'a MeshTree,
    r: Ray1x,
    inst: u32,
    mailbox: bool,
    c: &'a mut C,
}

impl<C: Counters> LaneTask for ObjectTask<'_, C> {
    #[inline(always)]
    fn run<Q1: Query1>(&mut self, q: &mut Q1) {
        crate::walk1::mesh1(self.mesh, &self.r, self.inst, None, self.mailbox, q, self.c);
    }
}
