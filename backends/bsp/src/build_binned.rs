//! The fast object-level build ([`crate::BuildPreset::Fast`]): a binned-SAH kd-tree after
//! Hunt, Mark & Stoll 2006 ("Fast kd-tree construction with an adaptive error-bounded
//! heuristic") and Shevtsov, Soupikov & Kapustin 2007 ("Highly parallel fast kd-tree
//! construction for interactive ray tracing of dynamic scenes"), finished by the exact sweep
//! of Wald & Havran 2006 (`build_sah.rs`) below a node size; for the paper's object trees
//! (section 3), same costs, leaves and node format as the exact build.
//!
//! A node above [`SahParams::sweep_below`] references counts its references' starts and ends
//! in [`SahParams::bins`] bins per axis (from their boxes clipped to the node's voxel), prices
//! the bin boundaries by the SAH and splits at the best one; triangles straddling it are
//! clipped to each child as in the exact build. Smaller nodes, and nodes whose best boundary
//! does not beat a leaf, go to the exact sweep, which searches every plane (and may still make
//! a leaf). The two children of a node of at least [`PARALLEL_MIN`] references are built in
//! parallel (rayon) into separate node arrays, then appended with their indices moved.
//!
//! Deterministic: whether a node's children are built in parallel depends on its size only,
//! and the two subtrees built in parallel each spend their own share of the reference budget
//! ([`SahParams::max_refs_per_tri`]), so the nodes, items and statistics are the same on any
//! number of threads (tested on 1 and 2).

use coherent_accel::Aabb;
use glam::Vec3;

use crate::build_sah::{Ctx, Out, child_box, share, sweep};
use crate::params::MAX_BINS;
use crate::{KdTree, MAX_CHILD, MAX_INDEX, Node, SahParams};

/// Nodes of at least this many references build their children in parallel (below it a
/// subtree takes about a millisecond or less, not worth handing to another thread), and, in
/// both builds, give each child its own share of the reference budget.
pub const PARALLEL_MIN: usize = 4096;

/// A reference: a triangle and the bounds of its part in the node's voxel.
#[derive(Clone, Copy)]
struct Ref {
    tri: u32,
    b: Aabb,
}

/// Builds the kd-tree of triangles `tris` (non-degenerate) by binning above
/// [`SahParams::sweep_below`] references and the exact sweep below; leaf items are indices
/// into `tris`. The same tree whatever the number of rayon threads.
pub fn build_binned(tris: &[[Vec3; 3]], p: &SahParams) -> KdTree {
    let t0 = std::time::Instant::now();
    let n = tris.len();
    assert!(n <= MAX_INDEX, "{n} triangles: more than a tree can index");
    if n == 0 {
        return KdTree::empty();
    }
    let refs: Vec<Ref> = tris
        .iter()
        .enumerate()
        .map(|(i, t)| Ref {
            tri: i as u32,
            b: Aabb::from_points(*t),
        })
        .collect();
    let bounds = refs.iter().fold(Aabb::EMPTY, |a, r| a.union(r.b));
    let c = Ctx::new(tris, p, &bounds);
    let mut out = Out::new();
    let mut spare = p.ref_budget(n) - n;
    node(&c, &mut out, 0, bounds, refs, 0, &mut spare);
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

/// Builds node `at` of `out` (already allocated) over voxel `v` and `refs`, down to its leaves.
/// Splits may add at most `spare` references (clipped copies); what they add is taken from it.
fn node(c: &Ctx, out: &mut Out, at: usize, v: Aabb, refs: Vec<Ref>, depth: u32, spare: &mut usize) {
    let p = c.p;
    let n = refs.len();
    let split =
        if n <= p.sweep_below as usize || n <= p.leaf_size as usize || depth >= c.depth_limit {
            None
        } else {
            find_plane(c, &v, &refs).and_then(|(k, pos)| partition(c, &v, &refs, k, pos, *spare))
        };
    let Some(s) = split else {
        let (ids, boxes) = refs.into_iter().map(|r| (r.tri, r.b)).unzip();
        sweep(*c, out, at, v, ids, boxes, depth, spare);
        return;
    };
    drop(refs);
    out.stats.nodes += 1;
    out.stats.sah_cost += v.area() as f64 / c.root_area * p.traversal_cost as f64;
    let (nl, nr) = (s.left.len(), s.right.len());
    *spare = *spare + n - (nl + nr);
    let (mut vl, mut vr) = (v, v);
    vl.max[s.axis] = s.pos;
    vr.min[s.axis] = s.pos;
    let children = out.nodes.len();
    assert!(children < MAX_CHILD, "kd-tree too large");
    if n < PARALLEL_MIN {
        out.nodes.push(Node::leaf(0, 0));
        out.nodes.push(Node::leaf(0, 0));
        out.nodes[at] = Node::inner(s.axis, s.pos, children);
        node(c, out, children, vl, s.left, depth + 1, spare);
        node(c, out, children + 1, vr, s.right, depth + 1, spare);
        return;
    }
    // Each side gets a share of the spare references in proportion to its own (so that
    // neither depends on how far the other has got), and gives back what it leaves.
    let sl = share(*spare, nl, nr);
    let (mut sl, mut sr) = (sl, *spare - sl);
    let (left, right) = (s.left, s.right);
    let (l, r) = rayon::join(
        || {
            let mut o = Out::new();
            node(c, &mut o, 0, vl, left, depth + 1, &mut sl);
            (o, sl)
        },
        || {
            let mut o = Out::new();
            node(c, &mut o, 0, vr, right, depth + 1, &mut sr);
            (o, sr)
        },
    );
    *spare = l.1 + r.1;
    out.nodes[at] = Node::inner(s.axis, s.pos, children);
    append(out, l.0, r.0);
}

/// Appends subtrees `l` and `r` (each a fresh [`Out`]: root at 0, padding at 1) to `out`, their
/// roots as the children pair at `out.nodes.len()`, their other nodes after it, moving every
/// child and item index by where it lands.
pub(crate) fn append(out: &mut Out, l: Out, r: Out) {
    let c = out.nodes.len();
    let items = out.items.len();
    // Node i >= 2 of `l` lands at c + i, of `r` at c + l.nodes.len() + i - 2: both lengths are
    // even, so children pairs stay at even indices.
    let (dl, dr) = (c, c + l.nodes.len() - 2);
    let (il, ir) = (items, items + l.items.len());
    assert!(
        dr + r.nodes.len() <= MAX_CHILD,
        "kd-tree too large: {} nodes",
        dr + r.nodes.len()
    );
    assert!(
        ir + r.items.len() <= MAX_INDEX,
        "kd-tree leaf lists too large"
    );
    let moved = |n: Node, d: usize, i: usize| {
        if n.is_leaf() {
            let it = n.items();
            Node::leaf(it.start + i, it.len())
        } else {
            Node::inner(n.axis(), n.split(), n.left() + d)
        }
    };
    out.nodes.push(moved(l.nodes[0], dl, il));
    out.nodes.push(moved(r.nodes[0], dr, ir));
    out.nodes
        .extend(l.nodes[2..].iter().map(|&n| moved(n, dl, il)));
    out.nodes
        .extend(r.nodes[2..].iter().map(|&n| moved(n, dr, ir)));
    out.items.extend_from_slice(&l.items);
    out.items.extend_from_slice(&r.items);
    let s = &mut out.stats;
    for t in [l.stats, r.stats] {
        s.nodes += t.nodes;
        s.leaves += t.leaves;
        s.empty_leaves += t.empty_leaves;
        s.leaf_refs += t.leaf_refs;
        s.max_depth = s.max_depth.max(t.max_depth);
        s.sah_cost += t.sah_cost;
    }
}

/// The SAH-best bin boundary `(axis, position)` of voxel `v` over `refs`, when it beats a
/// leaf (by the binned counts).
fn find_plane(c: &Ctx, v: &Aabb, refs: &[Ref]) -> Option<(usize, f32)> {
    let p = c.p;
    let area = v.area();
    // Also false for NaN.
    let has_area = area > 0.0;
    if !has_area {
        return None;
    }
    let inv_area = 1.0 / area;
    let n = refs.len();
    let nb = p.bins.clamp(2, MAX_BINS) as usize;
    let ext = v.extent();
    // Starts and ends per bin, per axis: one pass over the references for all three.
    let mut starts = [[0u32; MAX_BINS as usize]; 3];
    let mut ends = [[0u32; MAX_BINS as usize]; 3];
    let scale: [f32; 3] = core::array::from_fn(|k| {
        if ext[k] > 0.0 {
            nb as f32 / ext[k]
        } else {
            0.0
        }
    });
    // Negative offsets (rounding) saturate to bin 0 in `as usize`.
    let bin = |x: f32, k: usize| (((x - v.min[k]) * scale[k]) as usize).min(nb - 1);
    for r in refs {
        for k in 0..3 {
            starts[k][bin(r.b.min[k], k)] += 1;
            ends[k][bin(r.b.max[k], k)] += 1;
        }
    }
    let g = p.leaf_group.max(1) as usize;
    let mut best: Option<(usize, f32, f32)> = None;
    for k in 0..3 {
        let (vmin, vmax, w) = (v.min[k], v.max[k], ext[k]);
        let has_extent = w > 0.0;
        if !has_extent {
            continue;
        }
        let (a, b) = (ext[(k + 1) % 3], ext[(k + 2) % 3]);
        let (mut nl, mut nr) = (0usize, n);
        for j in 1..nb {
            nl += starts[k][j - 1] as usize;
            nr -= ends[k][j - 1] as usize;
            let pos = vmin + w * (j as f32 / nb as f32);
            if !(pos > vmin && pos < vmax) {
                continue;
            }
            let pl = 2.0 * (a * b + (a + b) * (pos - vmin)) * inv_area;
            let pr = 2.0 * (a * b + (a + b) * (vmax - pos)) * inv_area;
            let cost = sah(p, pl, pr, nl, nr, g);
            if best.is_none_or(|b| cost < b.2) {
                best = Some((k, pos, cost));
            }
        }
    }
    let leaf_cost = p.intersection_cost * n.div_ceil(g) as f32;
    best.filter(|b| b.2 < leaf_cost).map(|b| (b.0, b.1))
}

/// The SAH cost of a split with relative child areas `pl`, `pr` and `nl`, `nr` references, as
/// the exact build prices it.
#[inline]
fn sah(p: &SahParams, pl: f32, pr: f32, nl: usize, nr: usize, g: usize) -> f32 {
    let lambda = if nl == 0 || nr == 0 {
        1.0 - p.empty_bonus
    } else {
        1.0
    };
    lambda
        * (p.traversal_cost
            + p.intersection_cost * (pl * nl.div_ceil(g) as f32 + pr * nr.div_ceil(g) as f32))
}

/// A split's children.
struct Split {
    axis: usize,
    pos: f32,
    left: Vec<Ref>,
    right: Vec<Ref>,
}

/// The references of each side of the plane at `pos` on axis `k`, straddling ones clipped to
/// each child; `None` (no split) when, with the exact counts, it does not beat a leaf or would
/// add more than `spare` references.
fn partition(c: &Ctx, v: &Aabb, refs: &[Ref], k: usize, pos: f32, spare: usize) -> Option<Split> {
    let (mut vl, mut vr) = (*v, *v);
    vl.max[k] = pos;
    vr.min[k] = pos;
    let mut left = Vec::with_capacity(refs.len());
    let mut right = Vec::with_capacity(refs.len());
    for r in refs {
        let (lo, hi) = (r.b.min[k], r.b.max[k]);
        // As the exact build sides them: ends at or before the plane go left, starts at or
        // after it right, triangles lying in it left.
        if hi <= pos {
            left.push(*r);
        } else if lo >= pos {
            right.push(*r);
        } else {
            if let Some(b) = child_box(c, r.tri, &r.b, &vl) {
                left.push(Ref { tri: r.tri, b });
            }
            if let Some(b) = child_box(c, r.tri, &r.b, &vr) {
                right.push(Ref { tri: r.tri, b });
            }
        }
        if left.len() + right.len() > refs.len() + spare {
            return None;
        }
    }
    let p = c.p;
    let g = p.leaf_group.max(1) as usize;
    let inv_area = 1.0 / v.area();
    let ext = v.extent();
    let (a, b) = (ext[(k + 1) % 3], ext[(k + 2) % 3]);
    let pl = 2.0 * (a * b + (a + b) * (pos - v.min[k])) * inv_area;
    let pr = 2.0 * (a * b + (a + b) * (v.max[k] - pos)) * inv_area;
    let cost = sah(p, pl, pr, left.len(), right.len(), g);
    let leaf_cost = p.intersection_cost * refs.len().div_ceil(g) as f32;
    (cost < leaf_cost).then_some(Split {
        axis: k,
        pos,
        left,
        right,
    })
}
