//! The object-level build binned at every level ([`crate::BuildPreset::Binned`]), after
//! Shevtsov, Soupikov & Kapustin 2007 ("Highly parallel fast kd-tree construction for
//! interactive ray tracing of dynamic scenes") with Wald 2007's bin layout ("On fast
//! construction of SAH-based bounding volume hierarchies"); same costs, leaves and node format
//! as the exact build (paper section 3, the object trees).
//!
//! References (a triangle and the box of its part in the node's voxel) live in one flat array
//! per task. A node counts its references' box minima and maxima in [`SahParams::bins`] bins
//! per axis and splits at the SAH-best bin boundary; nodes of at most
//! [`SahParams::flat_sweep_below`] references instead sort their few box bounds and sweep
//! every plane (as the exact build does, with planar triangles and the voxel's faces), without
//! event lists carried between nodes. The references are partitioned in place into left,
//! straddling and right ones; only the straddling ones are clipped, by the chosen plane alone
//! (the triangle cut by the plane, bounded, and intersected with the reference's box: never
//! smaller than its part in the child), the left parts in place, the right parts appended.
//! The right child is then the top of the array, so it is built first and the array shrinks
//! back before the left one: no allocation per node.
//!
//! Parallel at both scales (rayon): nodes of at least [`PARALLEL_MIN`] references count their
//! bins and partition in chunks across threads, and build their two subtrees as tasks, each
//! into its own arrays, appended afterwards. Whether a node goes parallel depends on its size
//! only, chunks have a fixed size, counts are integers and each subtree spends its own share of
//! the reference budget, so the tree is the same on any number of threads.

use coherent_accel::Aabb;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::build_binned::{PARALLEL_MIN, append};
use crate::build_sah::{Ctx, Out, share};
use crate::params::MAX_BINS;
use crate::{KdTree, MAX_CHILD, MAX_INDEX, Node, SahParams};

/// A reference: a triangle and the bounds of its part in the node's voxel.
#[derive(Clone, Copy, Debug)]
struct Ref {
    b: Aabb,
    tri: u32,
}

/// References per chunk when a large node bins or partitions across threads: fixed, so that
/// the children's order does not depend on the thread count.
const CHUNK: usize = 8192;

/// A chosen split: axis, position, and the side of triangles lying in the plane.
#[derive(Clone, Copy, Debug)]
struct Plane {
    axis: usize,
    pos: f32,
    planar_left: bool,
}

/// Which side of `pl` a reference box lies on: `Some(true)` left, `Some(false)` right, `None`
/// both (as the exact build sides them: ends at or before the plane go left, starts at or
/// after it right, boxes flat in the plane's axis by their position and `planar_left`).
#[inline]
fn side(b: &Aabb, pl: &Plane) -> Option<bool> {
    let (lo, hi, p) = (b.min[pl.axis], b.max[pl.axis], pl.pos);
    if lo == hi {
        Some(lo < p || (lo == p && pl.planar_left))
    } else if hi <= p {
        Some(true)
    } else if lo >= p {
        Some(false)
    } else {
        None
    }
}

/// Builds the kd-tree of triangles `tris` (non-degenerate) binned at every level; leaf items
/// are indices into `tris`. The same tree whatever the number of rayon threads.
pub fn build_flat(tris: &[[Vec3; 3]], p: &SahParams) -> KdTree {
    let t0 = std::time::Instant::now();
    let n = tris.len();
    assert!(n <= MAX_INDEX, "{n} triangles: more than a tree can index");
    if n == 0 {
        return KdTree::empty();
    }
    let refs: Vec<Ref> = if n >= PARALLEL_MIN {
        tris.par_iter()
            .enumerate()
            .map(|(i, t)| Ref {
                b: Aabb::from_points(*t),
                tri: i as u32,
            })
            .collect()
    } else {
        tris.iter()
            .enumerate()
            .map(|(i, t)| Ref {
                b: Aabb::from_points(*t),
                tri: i as u32,
            })
            .collect()
    };
    let bounds = refs.iter().fold(Aabb::EMPTY, |a, r| a.union(r.b));
    let c = Ctx::new(tris, p, &bounds);
    let mut spare = p.ref_budget(n) - n;
    let out = task(&c, bounds, refs, 0, &mut spare);
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

/// Builds a subtree over voxel `v` and `refs` as one task: large nodes split across threads,
/// smaller ones in place in `refs`.
fn task(c: &Ctx, v: Aabb, refs: Vec<Ref>, depth: u32, spare: &mut usize) -> Out {
    let n = refs.len();
    if n < PARALLEL_MIN {
        let mut s = Seq {
            c,
            refs,
            out: Out::new(),
            keys: Vec::new(),
        };
        s.refs.reserve(n / 2);
        s.node(0, v, 0, depth, spare);
        return s.out;
    }
    let mut out = Out::new();
    let plane = if depth >= c.depth_limit {
        None
    } else {
        let bins = refs
            .par_chunks(CHUNK)
            .map(|ch| Bins::count(c, &v, ch))
            .reduce(|| Bins::new(c), Bins::add);
        bins.best(c, &v, n)
    };
    // Partition by chunks in parallel, then join the chunks' sides in chunk order.
    let parts: Option<Vec<Sides>> = plane.map(|pl| {
        refs.par_chunks(CHUNK)
            .map(|ch| split_chunk(c, &pl, ch))
            .collect()
    });
    let split = plane.zip(parts).and_then(|(pl, parts)| {
        let both: usize = parts.iter().map(|p| p.2).sum();
        let nl: usize = parts.iter().map(|p| p.0.len()).sum();
        let nr: usize = parts.iter().map(|p| p.1.len()).sum();
        (both <= *spare && split_cost(c, &v, &pl, nl, nr) < leaf_cost(c, n)).then_some((pl, parts))
    });
    let Some((pl, parts)) = split else {
        // A leaf (or too few planes to bin): the sequential build decides.
        let mut s = Seq {
            c,
            refs,
            out,
            keys: Vec::new(),
        };
        s.leaf(0, &v, 0, depth);
        return s.out;
    };
    drop(refs);
    let mut left = Vec::with_capacity(parts.iter().map(|p| p.0.len()).sum());
    let mut right = Vec::with_capacity(parts.iter().map(|p| p.1.len()).sum());
    for (l, r, _) in parts {
        left.extend_from_slice(&l);
        right.extend_from_slice(&r);
    }
    let (nl, nr) = (left.len(), right.len());
    out.stats.nodes += 1;
    out.stats.sah_cost += v.area() as f64 / c.root_area * c.p.traversal_cost as f64;
    *spare = *spare + n - (nl + nr);
    let (mut vl, mut vr) = (v, v);
    vl.max[pl.axis] = pl.pos;
    vr.min[pl.axis] = pl.pos;
    let sl = share(*spare, nl, nr);
    let (mut sl, mut sr) = (sl, *spare - sl);
    let (l, r) = rayon::join(
        || task(c, vl, left, depth + 1, &mut sl),
        || task(c, vr, right, depth + 1, &mut sr),
    );
    *spare = sl + sr;
    out.nodes[0] = Node::inner(pl.axis, pl.pos, 2);
    append(&mut out, l, r);
    out
}

/// A chunk's left and right references and how many straddled.
type Sides = (Vec<Ref>, Vec<Ref>, usize);

/// One chunk of a large node's references split by `pl`: its left and right references (the
/// straddling ones clipped) and how many straddled.
fn split_chunk(c: &Ctx, pl: &Plane, ch: &[Ref]) -> Sides {
    let (mut l, mut r) = (Vec::with_capacity(ch.len()), Vec::with_capacity(ch.len()));
    let mut both = 0;
    for x in ch {
        match side(&x.b, pl) {
            Some(true) => l.push(*x),
            Some(false) => r.push(*x),
            None => {
                both += 1;
                let (a, b) = clip(c, x, pl);
                l.extend(a);
                r.extend(b);
            }
        }
    }
    (l, r, both)
}

/// The parts of straddling reference `x` on each side of `pl`: with perfect
/// splits, the triangle cut by the plane, bounded (rounded outward) and intersected with the
/// reference's box cut by the plane; without, that box alone. `None` for a side it misses.
fn clip(c: &Ctx, x: &Ref, pl: &Plane) -> (Option<Ref>, Option<Ref>) {
    let (k, p) = (pl.axis, pl.pos);
    let (mut bl, mut br) = (x.b, x.b);
    bl.max[k] = p;
    br.min[k] = p;
    if c.p.perfect_splits {
        let t = c.tris[x.tri as usize].map(|q| q.as_dvec3());
        let pd = p as f64;
        let (mut lmin, mut lmax) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        let (mut rmin, mut rmax) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for i in 0..3 {
            let (a, b) = (t[i], t[(i + 1) % 3]);
            if a[k] <= pd {
                (lmin, lmax) = (lmin.min(a), lmax.max(a));
            }
            if a[k] >= pd {
                (rmin, rmax) = (rmin.min(a), rmax.max(a));
            }
            if (a[k] < pd) != (b[k] < pd) && a[k] != b[k] {
                let s = (pd - a[k]) / (b[k] - a[k]);
                let mut q = a + (b - a) * s;
                q[k] = pd;
                (lmin, lmax) = (lmin.min(q), lmax.max(q));
                (rmin, rmax) = (rmin.min(q), rmax.max(q));
            }
        }
        bl = bl.intersection(Aabb::new(down(lmin), up(lmax)));
        br = br.intersection(Aabb::new(down(rmin), up(rmax)));
    }
    let keep = |b: Aabb| (!b.is_empty()).then_some(Ref { b, tri: x.tri });
    (keep(bl), keep(br))
}

/// The largest f32 at or below each of `x` (NaN and infinities: the empty box's side).
fn down(x: DVec3) -> Vec3 {
    Vec3::from_array(x.to_array().map(|v| {
        let f = v as f32;
        if f as f64 > v { f.next_down() } else { f }
    }))
}

/// The smallest f32 at or above each of `x`.
fn up(x: DVec3) -> Vec3 {
    Vec3::from_array(x.to_array().map(|v| {
        let f = v as f32;
        if (f as f64) < v { f.next_up() } else { f }
    }))
}

/// The cost of a leaf of `n` references.
fn leaf_cost(c: &Ctx, n: usize) -> f32 {
    c.p.intersection_cost * n.div_ceil(c.p.leaf_group.max(1) as usize) as f32
}

/// The relative extents of voxel `v` (largest 1), so that areas and their ratios stay finite
/// however large the coordinates.
fn unit_extent(v: &Aabb) -> Option<[f64; 3]> {
    let e = v.extent().as_dvec3();
    let m = e.max_element();
    // Also false for NaN and infinity.
    let finite = m > 0.0 && m.is_finite();
    finite.then(|| (e / m).to_array())
}

/// The SAH cost of a split of voxel `v` at `pl` into children of `nl` and `nr` references,
/// as the exact build prices it.
fn split_cost(c: &Ctx, v: &Aabb, pl: &Plane, nl: usize, nr: usize) -> f32 {
    let Some(e) = unit_extent(v) else {
        return f32::INFINITY;
    };
    let k = pl.axis;
    let t = (pl.pos as f64 - v.min[k] as f64) / (v.max[k] as f64 - v.min[k] as f64);
    let sah = Sah::new(c, e, k);
    sah.cost(t, nl, nr)
}

/// The SAH of splits along one axis of a voxel: child areas relative to the voxel's.
struct Sah {
    /// Area of the faces across the axis, and of the sides per unit of its extent, both over
    /// the voxel's area.
    cap: f64,
    side: f64,
    kt: f32,
    ki: f32,
    bonus: f32,
    g: usize,
}

impl Sah {
    fn new(c: &Ctx, e: [f64; 3], k: usize) -> Self {
        let (a, b) = (e[(k + 1) % 3], e[(k + 2) % 3]);
        let area = e[0] * e[1] + e[1] * e[2] + e[2] * e[0];
        Self {
            cap: a * b / area,
            side: (a + b) * e[k] / area,
            kt: c.p.traversal_cost,
            ki: c.p.intersection_cost,
            bonus: 1.0 - c.p.empty_bonus,
            g: c.p.leaf_group.max(1) as usize,
        }
    }

    /// The cost of the plane at fraction `t` of the axis with `nl` and `nr` references.
    #[inline]
    fn cost(&self, t: f64, nl: usize, nr: usize) -> f32 {
        let pl = (self.cap + self.side * t) as f32;
        let pr = (self.cap + self.side * (1.0 - t)) as f32;
        let lambda = if nl == 0 || nr == 0 { self.bonus } else { 1.0 };
        // Most trees price each triangle: no division on the sweep's path.
        let (gl, gr) = if self.g == 1 {
            (nl, nr)
        } else {
            (nl.div_ceil(self.g), nr.div_ceil(self.g))
        };
        lambda * (self.kt + self.ki * (pl * gl as f32 + pr * gr as f32))
    }
}

/// Min-max bins: per axis, how many reference boxes start and end in each bin.
struct Bins {
    nb: usize,
    starts: [[u32; MAX_BINS as usize]; 3],
    ends: [[u32; MAX_BINS as usize]; 3],
}

impl Bins {
    fn new(c: &Ctx) -> Self {
        Self {
            nb: c.p.bins.clamp(2, MAX_BINS) as usize,
            starts: [[0; MAX_BINS as usize]; 3],
            ends: [[0; MAX_BINS as usize]; 3],
        }
    }

    fn count(c: &Ctx, v: &Aabb, refs: &[Ref]) -> Self {
        let mut s = Self::new(c);
        let nb = s.nb;
        let scale: [f32; 3] = core::array::from_fn(|k| {
            let w = v.max[k] as f64 - v.min[k] as f64;
            if w > 0.0 { (nb as f64 / w) as f32 } else { 0.0 }
        });
        // Negative offsets (rounding) saturate to bin 0 in `as usize`, huge ones to the last.
        let bin = |x: f32, k: usize| (((x - v.min[k]) * scale[k]) as usize).min(nb - 1);
        for r in refs {
            for k in 0..3 {
                s.starts[k][bin(r.b.min[k], k)] += 1;
                s.ends[k][bin(r.b.max[k], k)] += 1;
            }
        }
        s
    }

    fn add(mut self, o: Self) -> Self {
        for k in 0..3 {
            for j in 0..self.nb {
                self.starts[k][j] += o.starts[k][j];
                self.ends[k][j] += o.ends[k][j];
            }
        }
        self
    }

    /// The SAH-best bin boundary of voxel `v` over `n` references, when it beats a leaf by
    /// the binned counts.
    fn best(&self, c: &Ctx, v: &Aabb, n: usize) -> Option<Plane> {
        let e = unit_extent(v)?;
        let nb = self.nb;
        let mut best: Option<(Plane, f32)> = None;
        for k in 0..3 {
            let (vmin, vmax) = (v.min[k], v.max[k]);
            // Also false for NaN.
            let has_extent = vmax > vmin;
            if !has_extent {
                continue;
            }
            let sah = Sah::new(c, e, k);
            let (mut nl, mut nr) = (0usize, n);
            for j in 1..nb {
                nl += self.starts[k][j - 1] as usize;
                nr -= self.ends[k][j - 1] as usize;
                let t = j as f64 / nb as f64;
                let pos = (vmin as f64 + (vmax as f64 - vmin as f64) * t) as f32;
                if !(pos > vmin && pos < vmax) {
                    continue;
                }
                let cost = sah.cost(t, nl, nr);
                if best.is_none_or(|b| cost < b.1) {
                    let planar_left = true;
                    best = Some((
                        Plane {
                            axis: k,
                            pos,
                            planar_left,
                        },
                        cost,
                    ));
                }
            }
        }
        best.filter(|b| b.1 < leaf_cost(c, n)).map(|b| b.0)
    }
}

/// Event kinds in their sort order at one position: ends, planars, starts.
const END: u64 = 0;
const PLANAR: u64 = 1;
const START: u64 = 2;

/// f32 bits mapped so that unsigned order is float order (`-0` folded into `+0` first).
#[inline]
fn ordered(f: f32) -> u32 {
    let b = (f + 0.0).to_bits();
    if b >> 31 == 1 { !b } else { b | 0x8000_0000 }
}

#[inline]
fn unordered(u: u32) -> f32 {
    f32::from_bits(if u >> 31 == 1 { u & 0x7fff_ffff } else { !u })
}

/// One task's sequential build: its references in one array, nodes into `out`.
struct Seq<'a, 'c> {
    c: &'a Ctx<'c>,
    /// The references of the nodes on the recursion path; a node's are the array's top.
    refs: Vec<Ref>,
    out: Out,
    /// Sorted split events of a small node (reused).
    keys: Vec<u64>,
}

impl Seq<'_, '_> {
    /// Builds node `at` (allocated) over voxel `v` and references `refs[start..]`.
    fn node(&mut self, at: usize, v: Aabb, start: usize, depth: u32, spare: &mut usize) {
        let c = self.c;
        let p = c.p;
        let n = self.refs.len() - start;
        let plane = if n <= p.leaf_size as usize || depth >= c.depth_limit {
            None
        } else if n <= p.flat_sweep_below as usize {
            self.sweep(&v, start)
        } else {
            Bins::count(c, &v, &self.refs[start..]).best(c, &v, n)
        };
        let Some(pl) = plane else {
            self.leaf(at, &v, start, depth);
            return;
        };
        // Three-way partition in place: left | straddling | right.
        let r = &mut self.refs[start..];
        let (mut lo, mut hi) = (0, r.len());
        let mut i = 0;
        while i < hi {
            match side(&r[i].b, &pl) {
                Some(true) => {
                    r.swap(i, lo);
                    lo += 1;
                    i += 1;
                }
                Some(false) => {
                    hi -= 1;
                    r.swap(i, hi);
                }
                None => i += 1,
            }
        }
        let (ln, bn, rn) = (lo, hi - lo, n - hi);
        // Priced as if every straddler reached both children (the exact build's counts):
        // refused, the node's references are only reordered and make the leaf.
        if bn > *spare || split_cost(c, &v, &pl, ln + bn, rn + bn) >= leaf_cost(c, n) {
            self.leaf(at, &v, start, depth);
            return;
        }
        // Straddlers: left parts in place (compacted), right parts appended after the right
        // references.
        let end = self.refs.len();
        let mut w = start + ln;
        for j in start + ln..start + hi {
            let x = self.refs[j];
            let (a, b) = clip(c, &x, &pl);
            if let Some(a) = a {
                self.refs[w] = a;
                w += 1;
            }
            if let Some(b) = b {
                self.refs.push(b);
            }
        }
        let (nl, nr) = (w - start, rn + self.refs.len() - end);
        self.out.stats.nodes += 1;
        self.out.stats.sah_cost += v.area() as f64 / c.root_area * p.traversal_cost as f64;
        *spare = *spare + n - (nl + nr);
        let (mut vl, mut vr) = (v, v);
        vl.max[pl.axis] = pl.pos;
        vr.min[pl.axis] = pl.pos;
        let children = self.out.nodes.len();
        assert!(children < MAX_CHILD, "kd-tree too large");
        self.out.nodes.push(Node::leaf(0, 0));
        self.out.nodes.push(Node::leaf(0, 0));
        self.out.nodes[at] = Node::inner(pl.axis, pl.pos, children);
        // The right child's references are the array's top: [hi, ...).
        self.node(children + 1, vr, start + hi, depth + 1, spare);
        self.refs.truncate(w);
        self.node(children, vl, start, depth + 1, spare);
        self.refs.truncate(start);
    }

    /// A leaf for node `at` over references `refs[start..]`, which it consumes.
    fn leaf(&mut self, at: usize, v: &Aabb, start: usize, depth: u32) {
        let out = &mut self.out;
        let first = out.items.len();
        out.items.extend(self.refs[start..].iter().map(|r| r.tri));
        self.refs.truncate(start);
        let count = out.items.len() - first;
        assert!(first <= MAX_INDEX, "kd-tree leaf lists too large");
        out.nodes[at] = Node::leaf(first, count);
        let cost =
            v.area() as f64 / self.c.root_area * (self.c.p.intersection_cost as f64 * count as f64);
        KdTree::count_leaf(&mut out.stats, count, depth as usize, cost);
    }

    /// The SAH-best plane of a small node by sorting its references' box bounds per axis and
    /// sweeping them, as the exact build does (planar triangles and the voxel's faces too).
    fn sweep(&mut self, v: &Aabb, start: usize) -> Option<Plane> {
        let c = self.c;
        let e = unit_extent(v)?;
        let n = self.refs.len() - start;
        let mut best: Option<(Plane, f32)> = None;
        for k in 0..3 {
            let (vmin, vmax) = (v.min[k], v.max[k]);
            // Also false for NaN.
            let has_extent = vmax > vmin;
            if !has_extent {
                continue;
            }
            let keys = &mut self.keys;
            keys.clear();
            for r in &self.refs[start..] {
                let (lo, hi) = (r.b.min[k], r.b.max[k]);
                if lo == hi {
                    keys.push((ordered(lo) as u64) << 32 | PLANAR);
                } else {
                    keys.push((ordered(lo) as u64) << 32 | START);
                    keys.push((ordered(hi) as u64) << 32 | END);
                }
            }
            keys.sort_unstable();
            let sah = Sah::new(c, e, k);
            let w = vmax as f64 - vmin as f64;
            let (mut nl, mut nr) = (0usize, n);
            let mut i = 0;
            while i < keys.len() {
                let pk = keys[i] >> 32;
                let mut count = |kd: u64| {
                    let mut m = 0;
                    while i < keys.len() && keys[i] >> 32 == pk && keys[i] & 3 == kd {
                        m += 1;
                        i += 1;
                    }
                    m
                };
                let pe = count(END);
                let pp = count(PLANAR);
                let ps = count(START);
                nr -= pp + pe;
                let pos = unordered(pk as u32);
                let inside = pos > vmin && pos < vmax;
                // The voxel's faces are useful only to cut planar triangles off into a flat
                // child (a box's faces).
                let on_min = pp > 0 && pos == vmin;
                let on_max = pp > 0 && pos == vmax;
                if inside || on_min || on_max {
                    let t = ((pos as f64 - vmin as f64) / w).clamp(0.0, 1.0);
                    let cl = sah.cost(t, nl + pp, nr);
                    let cr = sah.cost(t, nl, nr + pp);
                    let (cost, planar_left) = if on_min || (inside && cl <= cr) {
                        (cl, true)
                    } else {
                        (cr, false)
                    };
                    if best.is_none_or(|b| cost < b.1) {
                        best = Some((
                            Plane {
                                axis: k,
                                pos,
                                planar_left,
                            },
                            cost,
                        ));
                    }
                }
                nl += ps + pp;
            }
        }
        best.filter(|b| b.1 < leaf_cost(c, n)).map(|b| b.0)
    }
}
