//! The shared-stack group walk of one kd-tree: up to [`GROUP`] packets of rays with equal
//! direction signs walk the tree together. Beyond the paper, after Reshetov, Soupikov &
//! Hurley 2005 (a group of rays decides each node once and shares one stack), with the
//! interval bounds of Wald, Boulos & Shirley 2007 in place of a frustum.
//!
//! Per packet the group keeps interval bounds of its rays ([`Bounds`]: per axis the range of
//! the origins and of the inverse directions) and, for the voxel being visited, per axis the
//! earliest entry into and the latest exit from its slab ([`Slabs`]). `(p - o) * inv` over
//! those ranges bounds where every ray of the packet crosses a plane `p`, with the very
//! arithmetic each ray would use (rounding is monotone, so the bounds hold for the rounded
//! values too). Both are held across the packets, one slot per packet, so one node step
//! decides near, far or both for every packet of the group at once: a few vector operations
//! for up to 16 packets, where each packet walking alone pays one step per node. A packet
//! whose rays cannot reach a child before their current hits drops out of that child; the
//! stack holds (node, packets, their slabs, voxel), so nothing is walked twice and no packet
//! starts from the root.
//!
//! Packets do their own work only at leaves (the leaf's items), and only the packets whose
//! bounds reach the leaf before their limits. After a leaf, the packet's limit (its lanes'
//! highest) is taken once ([`GroupLeaf::limits`]); the walk never reduces limits per node.

use coherent_accel::Aabb;
use coherent_simd::{Lanes, SimdF32, SimdMask};

use crate::counters::Counters;
use crate::stack::Stack;
use crate::walk::{RaysX, widen_hi as widen_hi_s, widen_lo as widen_lo_s};
use crate::{KdTree, Node};

/// Packet slots of a group's bounds (the most packets a group can hold).
pub(crate) const GROUP: usize = 16;

/// Packets per group on backend `L`: one vector of slots, so that a node step is one pass of
/// vector operations (16 packets at 16 lanes, 8 at 8, 4 at 4). The scalar backend's group is
/// one ray, which the beam query traces as its packet walk.
#[inline(always)]
pub(crate) const fn group_size<L: Lanes>() -> usize {
    if L::N < GROUP { L::N } else { GROUP }
}

/// One value per packet slot.
pub(crate) type Slots = [f32; GROUP];

/// The other two axes of axis `k` (0, 1, 2), by table: indexing needs no bounds check.
const OTHER: [(usize, usize); 4] = [(1, 2), (2, 0), (0, 1), (0, 1)];

/// Slots `v .. v + L::N` of `s` (a function, not a closure: it must inline into the
/// backends' target-feature kernels).
#[inline(always)]
fn ld<L: Lanes>(l: L, s: &Slots, v: usize) -> L::F32s {
    l.load(&s[v..])
}

/// Interval bounds of each slot's packet: per axis the range of its rays' origins and
/// inverse directions (all finite), and its lowest `tmin`. An unused slot has `tmin = +inf`:
/// it is never inside a voxel.
#[derive(Clone, Copy)]
pub(crate) struct Bounds {
    o_lo: [Slots; 3],
    o_hi: [Slots; 3],
    inv_lo: [Slots; 3],
    inv_hi: [Slots; 3],
    pub tmin: Slots,
}

impl Bounds {
    pub const EMPTY: Bounds = Bounds {
        o_lo: [[0.0; GROUP]; 3],
        o_hi: [[0.0; GROUP]; 3],
        inv_lo: [[0.0; GROUP]; 3],
        inv_hi: [[0.0; GROUP]; 3],
        tmin: [f32::INFINITY; GROUP],
    };

    /// Bounds of no rays that [`Bounds::grow`] widens (a slot grown by none stays unused).
    pub const UNION: Bounds = Bounds {
        o_lo: [[f32::INFINITY; GROUP]; 3],
        o_hi: [[f32::NEG_INFINITY; GROUP]; 3],
        inv_lo: [[f32::INFINITY; GROUP]; 3],
        inv_hi: [[f32::NEG_INFINITY; GROUP]; 3],
        tmin: [f32::INFINITY; GROUP],
    };

    /// Widens slot `j` by lanes `m` of `r`.
    #[inline(always)]
    pub fn grow<L: Lanes>(&mut self, l: L, j: usize, r: &RaysX<L>, m: L::Mask) {
        if m.none() {
            return;
        }
        let (inf, ninf) = (l.splat(f32::INFINITY), l.splat(f32::NEG_INFINITY));
        for k in 0..3 {
            let o_lo = m.select(r.o[k], inf).reduce_min();
            let o_hi = m.select(r.o[k], ninf).reduce_max();
            let inv_lo = m.select(r.inv[k], inf).reduce_min();
            let inv_hi = m.select(r.inv[k], ninf).reduce_max();
            self.o_lo[k][j] = self.o_lo[k][j].min(o_lo);
            self.o_hi[k][j] = self.o_hi[k][j].max(o_hi);
            self.inv_lo[k][j] = self.inv_lo[k][j].min(inv_lo);
            self.inv_hi[k][j] = self.inv_hi[k][j].max(inv_hi);
        }
        self.tmin[j] = self.tmin[j].min(m.select(r.tmin, inf).reduce_min());
    }

    /// Slot `j` from lanes `m` of `r` (none: the slot is unused).
    #[inline(always)]
    pub fn set<L: Lanes>(&mut self, l: L, j: usize, r: &RaysX<L>, m: L::Mask) {
        if m.none() {
            self.tmin[j] = f32::INFINITY;
            return;
        }
        let (inf, ninf) = (l.splat(f32::INFINITY), l.splat(f32::NEG_INFINITY));
        for k in 0..3 {
            self.o_lo[k][j] = m.select(r.o[k], inf).reduce_min();
            self.o_hi[k][j] = m.select(r.o[k], ninf).reduce_max();
            self.inv_lo[k][j] = m.select(r.inv[k], inf).reduce_min();
            self.inv_hi[k][j] = m.select(r.inv[k], ninf).reduce_max();
        }
        self.tmin[j] = m.select(r.tmin, inf).reduce_min();
    }

    /// For slots `v .. v + L::N`, the lowest and highest `(p - o) * inv` along axis `k`:
    /// where their rays cross the plane at `p`. The product is bilinear, so its extremes
    /// lie at the corners.
    #[inline(always)]
    fn plane<L: Lanes>(&self, l: L, k: usize, p: f32, v: usize) -> (L::F32s, L::F32s) {
        let ps = l.splat(p);
        let a = ps - l.load(&self.o_hi[k][v..]);
        let b = ps - l.load(&self.o_lo[k][v..]);
        let (i0, i1) = (l.load(&self.inv_lo[k][v..]), l.load(&self.inv_hi[k][v..]));
        let (w, x, y, z) = (a * i0, a * i1, b * i0, b * i1);
        (w.min(x).min(y.min(z)), w.max(x).max(y.max(z)))
    }

    /// Every slot's slabs of box `b` (`neg`: the group's direction sign bits).
    #[inline(always)]
    pub fn slabs<L: Lanes>(&self, l: L, b: &Aabb, neg: u32) -> Slabs {
        let mut s = Slabs::EMPTY;
        for k in 0..3 {
            let (p_in, p_out) = if neg >> k & 1 != 0 {
                (b.max[k], b.min[k])
            } else {
                (b.min[k], b.max[k])
            };
            let mut v = 0;
            while v < group_size::<L>() {
                self.plane(l, k, p_in, v).0.store(&mut s.enter[k][v..]);
                self.plane(l, k, p_out, v).1.store(&mut s.exit[k][v..]);
                v += L::N;
            }
        }
        s
    }
}

/// Per slot and axis, bounds of the packet's entries into and exits from a voxel's slabs.
#[derive(Clone, Copy)]
pub(crate) struct Slabs {
    enter: [Slots; 3],
    exit: [Slots; 3],
}

impl Slabs {
    const EMPTY: Slabs = Slabs {
        enter: [[0.0; GROUP]; 3],
        exit: [[0.0; GROUP]; 3],
    };

    /// The slots whose rays may be inside the voxel in `[tmin, limit]` (widened by the
    /// walks' slack, so a ray through a corner is inside).
    #[inline(always)]
    pub fn open<L: Lanes>(&self, l: L, tmin: &Slots, limit: &Slots) -> u32 {
        let mut bits = 0;
        let mut v = 0;
        while v < group_size::<L>() {
            let t0 = ld(l, &self.enter[0], v)
                .max(ld(l, &self.enter[1], v))
                .max(ld(l, &self.enter[2], v))
                .max(ld(l, tmin, v));
            let t1 = ld(l, &self.exit[0], v)
                .min(ld(l, &self.exit[1], v))
                .min(ld(l, &self.exit[2], v))
                .min(ld(l, limit, v));
            bits |= widen_lo_s(l, t0).le(widen_hi_s(l, t1)).bitmask() << v;
            v += L::N;
        }
        bits
    }
}

/// What a group finds at the leaves of the tree it walks.
pub(crate) trait GroupLeaf<C: Counters> {
    /// Per slot, the highest limit of the packet's lanes: new hits must be nearer (`-inf`
    /// once the packet is finished).
    fn limits(&self) -> &Slots;
    /// A non-empty leaf's items, reached by the packets of slots `active`; `vox` is its
    /// voxel.
    fn leaf(&mut self, c: &mut C, items: &[u32], active: u32, vox: &Aabb);
}

/// For a split on axis `k` at `split` of the voxel whose slabs are `sl`: the slots whose
/// rays reach the near child and those that reach the far one before `lim` (the near and
/// far sides by the group's signs `neg`), with each slot's crossings of the split plane
/// (lowest in `lo_s`, highest in `hi_s`).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn split_bits<L: Lanes>(
    l: L,
    b: &Bounds,
    sl: &Slabs,
    lim: &Slots,
    k: usize,
    split: f32,
    lo_s: &mut Slots,
    hi_s: &mut Slots,
) -> (u32, u32) {
    let (ka, kb) = OTHER[k];
    let (mut near, mut far) = (0u32, 0u32);
    let mut v = 0;
    while v < group_size::<L>() {
        let (lo, hi) = b.plane(l, k, split, v);
        lo.store(&mut lo_s[v..]);
        hi.store(&mut hi_s[v..]);
        let t0o = ld(l, &sl.enter[ka], v)
            .max(ld(l, &sl.enter[kb], v))
            .max(ld(l, &b.tmin, v));
        let t1o = ld(l, &sl.exit[ka], v)
            .min(ld(l, &sl.exit[kb], v))
            .min(ld(l, lim, v));
        let t0 = t0o.max(ld(l, &sl.enter[k], v));
        let t1 = t1o.min(ld(l, &sl.exit[k], v));
        // Near child: the rays leave it through the split; far: they enter it there.
        near |= widen_lo_s(l, t0).le(widen_hi_s(l, t1o.min(hi))).bitmask() << v;
        far |= widen_lo_s(l, t0o.max(lo)).le(widen_hi_s(l, t1)).bitmask() << v;
        v += L::N;
    }
    (near, far)
}

/// Where a walk of `tree` by the slots `active` of `b` (sign bits `neg`, limits `lim`) can
/// start: Reshetov et al.'s entry point, the deepest node whose subtree holds every
/// non-empty leaf they reach. The search goes down while they reach one child; at a node
/// where they reach both it keeps the far child as a candidate and goes on near, and when a
/// subtree turns out to hold no non-empty leaf for them and one candidate is left, the
/// entry moves down to it. It stops at the first non-empty leaf. Returns the node and its
/// voxel, or `None` when they reach no non-empty leaf at all.
///
/// Every group whose bounds lie within `b`'s slots can start its own walk there: the
/// leaves it reaches are among these.
#[inline(always)]
pub(crate) fn entry_point<L: Lanes, C: Counters>(
    l: L,
    tree: &KdTree,
    b: &Bounds,
    neg: u32,
    active: u32,
    lim: &Slots,
    c: &mut C,
) -> Option<(u32, Aabb)> {
    let nodes: &[Node] = &tree.nodes;
    let mut sl = b.slabs(l, &tree.bounds, neg);
    let mut act = active & sl.open(l, &b.tmin, lim);
    if act == 0 {
        return None;
    }
    let mut cands: Stack<Entry> = Stack::new();
    let mut depth = 0usize;
    let (mut node, mut vox) = (0usize, tree.bounds);
    let mut entry = (0u32, vox);
    let (mut lo_s, mut hi_s): (Slots, Slots) = ([0.0; GROUP], [0.0; GROUP]);
    loop {
        let n = nodes[node];
        if n.is_leaf() {
            if !n.items().is_empty() {
                return Some(entry);
            }
        } else {
            c.beam_step();
            let k = (n.axis() & 3).min(2);
            let sb = (neg >> k & 1) as usize;
            let empty = n.empty_children();
            let split = n.split();
            let (near, far) = split_bits(l, b, &sl, lim, k, split, &mut lo_s, &mut hi_s);
            let near = near & act & 0u32.wrapping_sub(!empty >> sb & 1);
            let far = far & act & 0u32.wrapping_sub(!empty >> (sb ^ 1) & 1);
            let (near_node, far_node) = (n.left() + sb, n.left() + 1 - sb);
            let (mut left, mut right) = (vox, vox);
            left.max[k] = split;
            right.min[k] = split;
            let (near_vox, far_vox) = if sb == 0 {
                (left, right)
            } else {
                (right, left)
            };
            if near != 0 && far != 0 {
                let mut f = sl;
                f.enter[k] = lo_s;
                cands.push(Entry {
                    node: far_node as u32,
                    active: far,
                    vox: far_vox,
                    slabs: f,
                });
                depth += 1;
                sl.exit[k] = hi_s;
                (node, act, vox) = (near_node, near, near_vox);
                continue;
            }
            if near != 0 || far != 0 {
                if near != 0 {
                    sl.exit[k] = hi_s;
                    (node, act, vox) = (near_node, near, near_vox);
                } else {
                    sl.enter[k] = lo_s;
                    (node, act, vox) = (far_node, far, far_vox);
                }
                if depth == 0 {
                    entry = (node as u32, vox);
                }
                continue;
            }
        }
        // Nothing here for them: the next candidate, which becomes the entry when it is
        // the last.
        let e = cands.pop()?;
        depth -= 1;
        (node, act, sl, vox) = (e.node as usize, e.active, e.slabs, e.vox);
        if depth == 0 {
            entry = (e.node, e.vox);
        }
    }
}

/// A subtree still to visit: node, slots, their slabs.
#[derive(Clone, Copy)]
struct Entry {
    node: u32,
    active: u32,
    vox: Aabb,
    slabs: Slabs,
}

/// Walks `tree` near to far from node `start` (its voxel; the root and the tree's bounds,
/// or an [`entry_point`] of a beam the group belongs to) with the packets of slots `active`
/// (bounds `b`, sign bits `neg`, the same for every packet), calling `s.leaf` at each
/// non-empty leaf some of them reach before their limits.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn walk_group<L: Lanes, C: Counters, S: GroupLeaf<C>>(
    l: L,
    tree: &KdTree,
    start: (u32, Aabb),
    b: &Bounds,
    neg: u32,
    active: u32,
    s: &mut S,
    c: &mut C,
) {
    let nodes: &[Node] = &tree.nodes;
    let mut sl = b.slabs(l, &start.1, neg);
    let mut act = active & sl.open(l, &b.tmin, s.limits());
    if act == 0 {
        return;
    }
    c.beam_entry(act.count_ones());
    let mut stack: Stack<Entry> = Stack::new();
    let mut node = start.0 as usize;
    let mut vox = start.1;
    let (mut lo_s, mut hi_s): (Slots, Slots) = ([0.0; GROUP], [0.0; GROUP]);
    loop {
        let n = nodes[node];
        if n.is_leaf() {
            let items = &tree.items[n.items()];
            if !items.is_empty() {
                c.leaf();
                s.leaf(c, items, act, &vox);
            }
        } else {
            c.beam_step();
            let k = (n.axis() & 3).min(2);
            let sb = (neg >> k & 1) as usize;
            let empty = n.empty_children();
            let split = n.split();
            let (mut near, mut far) =
                split_bits(l, b, &sl, s.limits(), k, split, &mut lo_s, &mut hi_s);
            near &= act & 0u32.wrapping_sub(!empty >> sb & 1);
            far &= act & 0u32.wrapping_sub(!empty >> (sb ^ 1) & 1);
            let (near_node, far_node) = (n.left() + sb, n.left() + 1 - sb);
            let (mut left, mut right) = (vox, vox);
            left.max[k] = split;
            right.min[k] = split;
            let (near_vox, far_vox) = if sb == 0 {
                (left, right)
            } else {
                (right, left)
            };
            match (near != 0, far != 0) {
                (true, false) => {
                    sl.exit[k] = hi_s;
                    (node, act, vox) = (near_node, near, near_vox);
                    continue;
                }
                (false, true) => {
                    sl.enter[k] = lo_s;
                    (node, act, vox) = (far_node, far, far_vox);
                    continue;
                }
                (true, true) => {
                    let mut f = sl;
                    f.enter[k] = lo_s;
                    stack.push(Entry {
                        node: far_node as u32,
                        active: far,
                        vox: far_vox,
                        slabs: f,
                    });
                    sl.exit[k] = hi_s;
                    (node, act, vox) = (near_node, near, near_vox);
                    continue;
                }
                (false, false) => {}
            }
        }
        // The next subtree some packet still needs.
        loop {
            let Some(e) = stack.pop() else {
                return;
            };
            let live = e.active & e.slabs.open(l, &b.tmin, s.limits());
            if live != 0 {
                (node, act, sl, vox) = (e.node as usize, live, e.slabs, e.vox);
                break;
            }
        }
    }
}
