//! The object-level build (paper section 3: object trees are "built carefully once"): a
//! surface-area-heuristic kd-tree in O(N log N) with sorted split events, after Wald &
//! Havran 2006, "On building fast kd-trees for ray tracing, and on doing that in O(N log N)".
//!
//! Each node keeps, per axis, its triangles' events (start, end or planar at a position)
//! sorted by position; one sweep per axis finds the SAH-best plane. Children inherit the
//! events of triangles on one side in order; triangles straddling the plane are clipped to
//! each child (perfect splits), and only their new events are sorted and merged in.

use coherent_accel::Aabb;
use glam::Vec3;

use crate::build_binned::PARALLEL_MIN;
use crate::clip::clipped_bounds;
use crate::params::BuildPreset;
use crate::{KdTree, MAX_CHILD, MAX_INDEX, Node, SahParams, TreeStats};

/// Event kinds, in their sort order at equal positions: ends before planars before starts.
const END: u64 = 0;
const PLANAR: u64 = 1;
const START: u64 = 2;
const TRI_BITS: u64 = (1 << 30) - 1;

/// An event as one sortable `u64`: position (order-preserving bits), kind, triangle.
#[inline]
fn key(pos: f32, kind: u64, tri: u32) -> u64 {
    (ordered(pos + 0.0) as u64) << 32 | kind << 30 | tri as u64
}

/// f32 bits mapped so that unsigned order is float order (`-0` is folded into `+0` above).
#[inline]
fn ordered(f: f32) -> u32 {
    let b = f.to_bits();
    if b >> 31 == 1 { !b } else { b | 0x8000_0000 }
}

#[inline]
fn unordered(u: u32) -> f32 {
    f32::from_bits(if u >> 31 == 1 { u & 0x7fff_ffff } else { !u })
}

#[inline]
fn kind(e: u64) -> u64 {
    e >> 30 & 3
}

#[inline]
fn tri(e: u64) -> u32 {
    (e & TRI_BITS) as u32
}

fn push_events(ev: &mut [Vec<u64>; 3], b: &Aabb, t: u32) {
    for (k, list) in ev.iter_mut().enumerate() {
        if b.min[k] == b.max[k] {
            list.push(key(b.min[k], PLANAR, t));
        } else {
            list.push(key(b.min[k], START, t));
            list.push(key(b.max[k], END, t));
        }
    }
}

/// Triangle sides after a split.
const BOTH: u8 = 0;
const LEFT: u8 = 1;
const RIGHT: u8 = 2;

struct Plane {
    axis: usize,
    pos: f32,
    planar_left: bool,
    cost: f32,
}

/// A (sub)tree being built: nodes (the root at 0, padding at 1, children pairs at even
/// indices), leaf item lists and statistics.
#[derive(Debug)]
pub(crate) struct Out {
    pub nodes: Vec<Node>,
    pub items: Vec<u32>,
    pub stats: TreeStats,
}

impl Out {
    /// A tree whose root (node 0) is still to be built.
    pub fn new() -> Self {
        Self {
            nodes: vec![Node::leaf(0, 0); 2],
            items: Vec::new(),
            stats: TreeStats::default(),
        }
    }
}

/// What every node of one tree's build shares.
#[derive(Clone, Copy)]
pub(crate) struct Ctx<'a> {
    pub tris: &'a [[Vec3; 3]],
    pub p: &'a SahParams,
    pub depth_limit: u32,
    /// The root voxel's area: SAH costs are relative to it.
    pub root_area: f64,
}

impl<'a> Ctx<'a> {
    pub fn new(tris: &'a [[Vec3; 3]], p: &'a SahParams, bounds: &Aabb) -> Self {
        Self {
            tris,
            p,
            depth_limit: p.depth_limit(tris.len()),
            root_area: bounds.area().max(f32::MIN_POSITIVE) as f64,
        }
    }
}

struct Builder<'a> {
    c: Ctx<'a>,
    p: &'a SahParams,
    /// The triangle (index into `c.tris`) of each local id the events carry.
    ids: Vec<u32>,
    /// Per local id: the triangle's box (a subtree's: its part in the subtree's voxel).
    boxes: Vec<Aabb>,
    side: Vec<u8>,
    out: &'a mut Out,
    /// Event lists no longer used, for reuse (allocation was a sixth of the build time).
    pool: Vec<Vec<u64>>,
}

/// Builds the kd-tree of triangles `tris` (non-degenerate) with the split search
/// [`SahParams::build`] selects; leaf items are indices into `tris`. At most 2^30 - 1
/// triangles (checked by mesh validation).
pub fn build_sah(tris: &[[Vec3; 3]], p: &SahParams) -> KdTree {
    match p.build {
        BuildPreset::Exact => build_exact(tris, p),
        BuildPreset::Fast => crate::build_binned::build_binned(tris, p),
        BuildPreset::Binned => crate::build_flat::build_flat(tris, p),
    }
}

/// The exact sweep at every node ([`BuildPreset::Exact`]), whatever `p.build` says.
fn build_exact(tris: &[[Vec3; 3]], p: &SahParams) -> KdTree {
    let t0 = std::time::Instant::now();
    let n = tris.len();
    assert!(n <= MAX_INDEX, "{n} triangles: more than a tree can index");
    if n == 0 {
        return KdTree::empty();
    }
    let boxes: Vec<Aabb> = tris.iter().map(|t| Aabb::from_points(*t)).collect();
    let bounds = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(*b));
    let c = Ctx::new(tris, p, &bounds);
    let mut out = Out::new();
    let mut spare = p.ref_budget(n) - n;
    sweep(
        c,
        &mut out,
        0,
        bounds,
        (0..n as u32).collect(),
        boxes,
        0,
        &mut spare,
    );
    let mut stats = out.stats;
    stats.build_seconds = t0.elapsed().as_secs_f64();
    let mut tree = KdTree {
        nodes: out.nodes,
        items: out.items,
        bounds,
        stats,
    };
    tree.mark_empty_children();
    tree
}

/// Builds node `node` of `out` (already allocated) over voxel `v` by the exact sweep, down
/// to its leaves: triangles `ids` (into `c.tris`) with `boxes`, their parts in `v`. Splits
/// may add at most `spare` references (clipped copies); what they add is taken from it.
#[allow(clippy::too_many_arguments)]
pub(crate) fn sweep(
    c: Ctx,
    out: &mut Out,
    node: usize,
    v: Aabb,
    ids: Vec<u32>,
    boxes: Vec<Aabb>,
    depth: u32,
    spare: &mut usize,
) {
    let n = ids.len();
    let mut ev: [Vec<u64>; 3] = core::array::from_fn(|_| Vec::with_capacity(2 * n));
    for (i, b) in boxes.iter().enumerate() {
        push_events(&mut ev, b, i as u32);
    }
    for list in &mut ev {
        list.sort_unstable();
    }
    let mut b = Builder {
        c,
        p: c.p,
        ids,
        boxes,
        side: vec![BOTH; n],
        out,
        pool: Vec::new(),
    };
    b.build(node, v, ev, n, depth, spare);
}

impl Builder<'_> {
    fn build(
        &mut self,
        node: usize,
        v: Aabb,
        ev: [Vec<u64>; 3],
        n: usize,
        depth: u32,
        spare: &mut usize,
    ) {
        let g = self.p.leaf_group.max(1) as usize;
        let leaf_cost = self.p.intersection_cost * n.div_ceil(g) as f32;
        let plane = if n as u32 <= self.p.leaf_size || depth >= self.c.depth_limit {
            None
        } else {
            self.find_plane(&v, &ev, n)
        };
        let plane = plane.filter(|pl| pl.cost < leaf_cost).filter(|pl| {
            // Each straddling triangle adds at most one reference: past the budget, a leaf.
            self.classify(&ev, pl);
            let both = ev[0]
                .iter()
                .filter(|&&e| kind(e) != END && self.side[tri(e) as usize] == BOTH)
                .count();
            both <= *spare
        });
        let Some(plane) = plane else {
            self.leaf(node, &v, &ev[0], depth);
            self.give(ev);
            return;
        };
        let area = v.area() as f64 / self.c.root_area;
        self.out.stats.nodes += 1;
        self.out.stats.sah_cost += area * self.p.traversal_cost as f64;

        let (k, pos) = (plane.axis, plane.pos);
        let mut vl = v;
        vl.max[k] = pos;
        let mut vr = v;
        vr.min[k] = pos;

        // Events of one-sided triangles keep their order; count the triangles on axis 0.
        let mut left: [Vec<u64>; 3] = core::array::from_fn(|j| self.take(ev[j].len()));
        let mut right: [Vec<u64>; 3] = core::array::from_fn(|j| self.take(ev[j].len()));
        let mut both = Vec::new();
        let (mut nl, mut nr) = (0, 0);
        for j in 0..3 {
            let (l, r) = (&mut left[j], &mut right[j]);
            for &e in &ev[j] {
                let t = tri(e) as usize;
                let first = j == 0 && kind(e) != END;
                match self.side[t] {
                    LEFT => {
                        l.push(e);
                        nl += first as usize;
                    }
                    RIGHT => {
                        r.push(e);
                        nr += first as usize;
                    }
                    _ if first => both.push(t as u32),
                    _ => {}
                }
            }
        }
        self.give(ev);
        // Straddling triangles: new events from their parts in each child, sorted, merged.
        let mut new_l: [Vec<u64>; 3] = core::array::from_fn(|_| self.take(2 * both.len()));
        let mut new_r: [Vec<u64>; 3] = core::array::from_fn(|_| self.take(2 * both.len()));
        for &t in &both {
            if let Some(b) = self.child_box(t, &vl) {
                push_events(&mut new_l, &b, t);
                nl += 1;
            }
            if let Some(b) = self.child_box(t, &vr) {
                push_events(&mut new_r, &b, t);
                nr += 1;
            }
        }
        for j in 0..3 {
            let mut out = self.take(left[j].len() + new_l[j].len());
            merge_into(&mut left[j], &mut new_l[j], &mut out);
            self.pool.push(out);
            let mut out = self.take(right[j].len() + new_r[j].len());
            merge_into(&mut right[j], &mut new_r[j], &mut out);
            self.pool.push(out);
        }
        self.give(new_l);
        self.give(new_r);
        let children = self.out.nodes.len();
        assert!(children < MAX_CHILD, "kd-tree too large");
        self.out.nodes.push(Node::leaf(0, 0));
        self.out.nodes.push(Node::leaf(0, 0));
        self.out.nodes[node] = Node::inner(k, pos, children);
        // At most `both` more: `nl + nr <= n + both`.
        *spare = *spare + n - (nl + nr);
        if n < PARALLEL_MIN {
            self.build(children, vl, left, nl, depth + 1, spare);
            self.build(children + 1, vr, right, nr, depth + 1, spare);
        } else {
            // As the fast build does at these sizes (there in parallel): the left subtree may
            // spend only its share of what is left, so that a budget run out does not turn
            // the whole right side into leaves; the right one gets the rest and what the
            // left leaves.
            let mut sl = share(*spare, nl, nr);
            let rest = *spare - sl;
            self.build(children, vl, left, nl, depth + 1, &mut sl);
            *spare = rest + sl;
            self.build(children + 1, vr, right, nr, depth + 1, spare);
        }
    }

    /// An empty list with room for `n` events, from the pool when it has one.
    fn take(&mut self, n: usize) -> Vec<u64> {
        let mut v = self.pool.pop().unwrap_or_default();
        v.clear();
        v.reserve(n);
        v
    }

    /// Returns lists to the pool.
    fn give(&mut self, lists: [Vec<u64>; 3]) {
        self.pool.extend(lists);
    }

    fn leaf(&mut self, node: usize, v: &Aabb, ev0: &[u64], depth: u32) {
        let out = &mut *self.out;
        let first = out.items.len();
        out.items.extend(
            ev0.iter()
                .filter(|&&e| kind(e) != END)
                .map(|&e| self.ids[tri(e) as usize]),
        );
        let count = out.items.len() - first;
        assert!(first <= MAX_INDEX, "kd-tree leaf lists too large");
        out.nodes[node] = Node::leaf(first, count);
        let cost =
            v.area() as f64 / self.c.root_area * (self.p.intersection_cost as f64 * count as f64);
        KdTree::count_leaf(&mut out.stats, count, depth as usize, cost);
    }

    /// The part of triangle `t` (a local id) in voxel `v` (perfect split), or its box cut by
    /// `v`.
    fn child_box(&self, t: u32, v: &Aabb) -> Option<Aabb> {
        child_box(&self.c, self.ids[t as usize], &self.boxes[t as usize], v)
    }

    /// The SAH-best plane: one sweep over each axis's sorted events.
    fn find_plane(&self, v: &Aabb, ev: &[Vec<u64>; 3], n: usize) -> Option<Plane> {
        let area = v.area();
        // Also false for NaN.
        let has_area = area > 0.0;
        if !has_area {
            return None;
        }
        let inv_area = 1.0 / area;
        let (kt, ki) = (self.p.traversal_cost, self.p.intersection_cost);
        let bonus = 1.0 - self.p.empty_bonus;
        let g = self.p.leaf_group.max(1) as usize;
        let sah = |pl: f32, pr: f32, nl: usize, nr: usize| {
            let lambda = if nl == 0 || nr == 0 { bonus } else { 1.0 };
            lambda * (kt + ki * (pl * nl.div_ceil(g) as f32 + pr * nr.div_ceil(g) as f32))
        };
        let ext = v.extent();
        let mut best: Option<Plane> = None;
        for k in 0..3 {
            let (vmin, vmax) = (v.min[k], v.max[k]);
            let has_extent = vmax > vmin;
            if !has_extent {
                continue;
            }
            let (a, b) = (ext[(k + 1) % 3], ext[(k + 2) % 3]);
            let (ab, a_b) = (a * b, a + b);
            let e = &ev[k];
            let (mut nl, mut nr) = (0usize, n);
            let mut i = 0;
            while i < e.len() {
                let pk = e[i] >> 32;
                let count = |i: &mut usize, kd: u64| {
                    let mut c = 0;
                    while *i < e.len() && e[*i] >> 32 == pk && kind(e[*i]) == kd {
                        c += 1;
                        *i += 1;
                    }
                    c
                };
                let pe = count(&mut i, END);
                let pp = count(&mut i, PLANAR);
                let ps = count(&mut i, START);
                nr -= pp + pe;
                let pos = unordered(pk as u32);
                let inside = pos > vmin && pos < vmax;
                // A plane on the voxel's boundary is useful only to cut off the planar
                // triangles lying in it into a flat child (the faces of a box: without
                // this, a box's 12 triangles stay in one leaf, tested by every ray).
                let on_min = pp > 0 && pos == vmin;
                let on_max = pp > 0 && pos == vmax;
                if inside || on_min || on_max {
                    let pl = 2.0 * (ab + a_b * (pos - vmin)) * inv_area;
                    let pr = 2.0 * (ab + a_b * (vmax - pos)) * inv_area;
                    let cl = sah(pl, pr, nl + pp, nr);
                    let cr = sah(pl, pr, nl, nr + pp);
                    let (cost, planar_left) = if on_min || (inside && cl <= cr) {
                        (cl, true)
                    } else {
                        (cr, false)
                    };
                    if best.as_ref().is_none_or(|b| cost < b.cost) {
                        best = Some(Plane {
                            axis: k,
                            pos,
                            planar_left,
                            cost,
                        });
                    }
                }
                nl += ps + pp;
            }
        }
        best
    }

    /// Marks each triangle of the node LEFT, RIGHT or BOTH for `plane`.
    fn classify(&mut self, ev: &[Vec<u64>; 3], plane: &Plane) {
        for &e in &ev[0] {
            if kind(e) != END {
                self.side[tri(e) as usize] = BOTH;
            }
        }
        let p = plane.pos;
        for &e in &ev[plane.axis] {
            let pos = unordered((e >> 32) as u32);
            let t = tri(e) as usize;
            match kind(e) {
                END if pos <= p => self.side[t] = LEFT,
                START if pos >= p => self.side[t] = RIGHT,
                PLANAR => {
                    self.side[t] = if pos < p || (pos == p && plane.planar_left) {
                        LEFT
                    } else {
                        RIGHT
                    }
                }
                _ => {}
            }
        }
    }
}

/// The left child's share of `spare` references, of children holding `nl` and `nr`: in
/// proportion to its references.
pub(crate) fn share(spare: usize, nl: usize, nr: usize) -> usize {
    (spare as u128 * nl as u128 / (nl + nr).max(1) as u128) as usize
}

/// The part of triangle `tri` (into `c.tris`) in voxel `v` (perfect split), or `b` (its box,
/// or its part in a voxel holding `v`) cut by `v`; `None` when nothing of it is in `v`.
#[inline]
pub(crate) fn child_box(c: &Ctx, tri: u32, b: &Aabb, v: &Aabb) -> Option<Aabb> {
    if c.p.perfect_splits {
        clipped_bounds(&c.tris[tri as usize], v)
    } else {
        let b = b.intersection(*v);
        (!b.is_empty()).then_some(b)
    }
}

/// Sorts `new` and merges it into the sorted `list`, through `out` (an empty list that
/// swaps places with `list`: the old list comes back in `out`).
fn merge_into(list: &mut Vec<u64>, new: &mut [u64], out: &mut Vec<u64>) {
    if new.is_empty() {
        return;
    }
    new.sort_unstable();
    let old = &list[..];
    let (mut i, mut j) = (0, 0);
    while i < old.len() && j < new.len() {
        if old[i] <= new[j] {
            out.push(old[i]);
            i += 1;
        } else {
            out.push(new[j]);
            j += 1;
        }
    }
    out.extend_from_slice(&old[i..]);
    out.extend_from_slice(&new[j..]);
    core::mem::swap(list, out);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn event_keys_sort_by_position_then_kind() {
        let mut v = [
            key(1.0, START, 3),
            key(-2.0, END, 1),
            key(1.0, END, 2),
            key(-0.0, PLANAR, 9),
            key(0.0, START, 4),
            key(1.0, PLANAR, 5),
        ];
        v.sort_unstable();
        let got: Vec<(f32, u64, u32)> = v
            .iter()
            .map(|&e| (unordered((e >> 32) as u32), kind(e), tri(e)))
            .collect();
        assert_eq!(
            got,
            vec![
                (-2.0, END, 1),
                (0.0, PLANAR, 9),
                (0.0, START, 4),
                (1.0, END, 2),
                (1.0, PLANAR, 5),
                (1.0, START, 3)
            ]
        );
    }

    /// Every triangle whose part in a leaf's voxel is non-empty is in that leaf, and every
    /// inner node marks exactly its children that are empty leaves.
    #[test]
    fn leaves_hold_every_triangle_that_reaches_them() {
        let mut s = 7u64;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 40) as f32 / (1u64 << 24) as f32
        };
        let tris: Vec<[Vec3; 3]> = (0..400)
            .map(|_| {
                let c = Vec3::new(rnd(), rnd(), rnd()) * 10.0;
                [0; 3].map(|_| c + Vec3::new(rnd(), rnd(), rnd()) - 0.5)
            })
            .collect();
        let binned = |p: SahParams| SahParams {
            sweep_below: 16,
            bins: 8,
            ..p.with_build(BuildPreset::Fast)
        };
        for p in [
            SahParams::fast(),
            SahParams::default(),
            SahParams::slow(),
            binned(SahParams::fast()),
            binned(SahParams::default()),
            SahParams::default().with_build(BuildPreset::Binned),
            SahParams::fast().with_build(BuildPreset::Binned),
            SahParams {
                bins: 4,
                flat_sweep_below: 0,
                ..SahParams::slow().with_build(BuildPreset::Binned)
            },
        ] {
            let t = build_sah(&tris, &p);
            assert!(
                t.stats.leaves > 10 && t.stats.empty_leaves > 0,
                "{:?}",
                t.stats
            );
            // Walk the tree, keeping voxels.
            let mut todo = vec![(0usize, t.bounds)];
            while let Some((i, v)) = todo.pop() {
                let n = t.nodes[i];
                if n.is_leaf() {
                    let items = &t.items[n.items()];
                    for (j, tri) in tris.iter().enumerate() {
                        if clipped_bounds(tri, &v).is_some_and(|b| {
                            // Strictly inside in every axis where the voxel has extent.
                            (0..3).all(|k| b.max[k] > b.min[k] || v.max[k] == v.min[k])
                        }) {
                            assert!(items.contains(&(j as u32)), "triangle {j} missing");
                        }
                    }
                } else {
                    let empty = |c: usize| {
                        let c = t.nodes[c];
                        c.is_leaf() && c.items().is_empty()
                    };
                    let bits = empty(n.left()) as u32 | (empty(n.left() + 1) as u32) << 1;
                    assert_eq!(n.empty_children(), bits, "node {i}");
                    let (k, s) = (n.axis(), n.split());
                    let (mut l, mut r) = (v, v);
                    l.max[k] = s;
                    r.min[k] = s;
                    todo.push((n.left(), l));
                    todo.push((n.left() + 1, r));
                }
            }
        }
    }
}

#[cfg(test)]
mod box_tests {
    use super::*;

    /// A box's faces are cut off into flat leaves, not left in one 12-triangle leaf.
    #[test]
    fn box_faces_are_separated() {
        let m = coherent_accel::shapes::cuboid("box", Vec3::ZERO, Vec3::new(10.0, 8.0, 3.0));
        let t = crate::MeshTree::build(&m.positions, &m.indices, &SahParams::default()).tree;
        let biggest = t
            .nodes
            .iter()
            .filter(|n| n.is_leaf())
            .map(|n| n.items().len())
            .max()
            .unwrap();
        assert!(biggest <= 4, "{:?} {:?}", t.stats, t.nodes);
    }
}
