//! Large packets on the BVH (Wald, Boulos & Shirley 2007): the beam queries
//! ([`coherent_accel::Accel::intersect_beam`], [`coherent_accel::Accel::occluded_beam`]) walk
//! obvhs' BVH2 nodes with all the beam's packets at once.
//!
//! The whole beam walks one stack of (node, first active packet). At a node the first active
//! packet is tested against the box (any lane hitting it in `[tmin, its current limit]`); if
//! it misses, an interval test of all the rays from that packet on (per axis the range of
//! their origins and inverse directions, Wald et al.'s interval arithmetic) may reject the
//! node for all of them; otherwise the next packet that hits the box becomes the first active
//! one and the walk descends from there. At a leaf every packet from the first active one on
//! tests the leaf's primitives on its lanes that reach the leaf's box. Children are visited
//! near to far by the first active packet's direction along the axis that separates their
//! centres most (a BVH2 node stores no split axis).
//!
//! The two-level scene: the top tree over the instances is walked the same way; at an
//! instance leaf the packets that reach it are moved into the instance's space
//! ([`coherent_accel::Rays::transformed`], the single-ray path's arithmetic) and the mesh's
//! tree is walked with the same algorithm.
//!
//! **The beams walk BVH2s.** With [`crate::Kind::Bvh2`] those are the trees themselves; with
//! [`crate::Kind::Cwbvh`] (the default) each tree's BVH2 is built besides its CWBVH and kept
//! ([`BeamTree`]) when [`crate::ObvhsParams::beam_bvh2`] asks for it (else the beams trace
//! packet after packet): its bytes are counted in `memory_bytes` (and reported alone as the
//! build statistic `beam_bvh2_bytes`, [`crate::Obvhs::beam_memory`]), its build time in the
//! build time.
//!
//! The answers are those of the single-ray path lane by lane: the same ray set-up
//! ([`coherent_accel::Ray1::forward`], `-0.0` directions made `+0.0`), the same object-space
//! arithmetic and obvhs' Möller-Trumbore test written out lane-wise in its order of
//! operations (no FMA), so a triangle gives the same `t`, `u`, `v` bits. Lanes whose world
//! direction has a zero or non-finite inverse component take the single-ray path; invalid
//! rays and inactive lanes are misses. Which of two triangles at the same `t` is reported
//! may differ (the contract leaves it open). A beam of one packet is the packet query
//! itself. Nothing is allocated: a call holds up to [`BEAM`] packets on the stack and takes
//! longer beams in chunks of that size.

use coherent_accel::{Hits, Rays};
use coherent_simd::{Lanes, SimdF32, SimdI32, SimdMask, Vec3s};
use glam::Vec3A;
use obvhs::Boundable;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::triangle::Triangle;

use crate::scene::Obvhs;
use crate::tree::{Preset, Tree};

/// Packets traced together per chunk of a beam.
pub const BEAM: usize = 64;

/// Entries of the walk's stack: a tree deeper than this has no beams (its beam queries
/// trace packet after packet).
const STACK: usize = 192;

/// Relative slack of the box tests' `t` limits: a hit the triangle test puts just inside
/// `[tmin, limit)` is not lost to the box test's own rounding.
const SLACK: f32 = 1e-6;

/// The BVH2 the beams walk for one tree: none kept when the tree is a BVH2 (the beams walk
/// it), the tree's BVH2 otherwise.
pub(crate) struct BeamTree {
    /// `Tree::Bvh2` built with the tree's preset when the tree is not one, else empty.
    own: Tree,
    /// Whether the walked tree fits [`STACK`].
    fits: bool,
}

impl Default for BeamTree {
    fn default() -> Self {
        Self {
            own: Tree::Empty,
            fits: true,
        }
    }
}

impl BeamTree {
    /// For a tree over triangles.
    pub(crate) fn over_triangles(tree: &Tree, tris: &[Triangle], preset: Preset) -> Self {
        let own = match tree {
            Tree::Cwbvh(_) => Tree::over_triangles(crate::Kind::Bvh2, tris, preset),
            _ => Tree::Empty,
        };
        Self::new(tree, own)
    }

    /// For a tree over boxes.
    pub(crate) fn over_boxes<T: Boundable>(tree: &Tree, boxes: &[T], preset: Preset) -> Self {
        let own = match tree {
            Tree::Cwbvh(_) => Tree::over_boxes(crate::Kind::Bvh2, boxes, preset),
            _ => Tree::Empty,
        };
        Self::new(tree, own)
    }

    fn new(tree: &Tree, own: Tree) -> Self {
        let mut b = Self { own, fits: true };
        b.fits = b.get_any(tree).is_none_or(|t| depth(t) < STACK);
        b
    }

    fn get_any<'a>(&'a self, tree: &'a Tree) -> Option<&'a Bvh2> {
        match (&self.own, tree) {
            (Tree::Bvh2(b), _) | (_, Tree::Bvh2(b)) => Some(b),
            _ => None,
        }
    }

    /// The BVH2 to walk for `tree` (the one this was made for), if it fits the stack.
    #[inline(always)]
    pub(crate) fn get<'a>(&'a self, tree: &'a Tree) -> Option<&'a Bvh2> {
        if self.fits { self.get_any(tree) } else { None }
    }

    /// Bytes kept besides the tree.
    pub(crate) fn memory_bytes(&self) -> usize {
        self.own.memory_bytes()
    }
}

/// Deepest level of `b` (the root is level 0).
fn depth(b: &Bvh2) -> usize {
    let mut deepest = 0;
    let mut stack = vec![(0usize, 0usize)];
    while let Some((n, d)) = stack.pop() {
        deepest = deepest.max(d);
        let node = &b.nodes[n];
        if node.prim_count == 0 {
            let c = node.first_index as usize;
            stack.push((c, d + 1));
            stack.push((c + 1, d + 1));
        }
    }
    deepest
}

/// One packet's rays in one space: origins, directions, inverse directions.
#[derive(Clone, Copy)]
struct Geo<L: Lanes> {
    o: Vec3s<L>,
    d: Vec3s<L>,
    inv: Vec3s<L>,
    /// Whether some lane's inverse direction is not finite (object space: its slabs take the
    /// NaN rule of the box test).
    odd: bool,
    /// Per axis: the packet's directions point down that axis (by their sum).
    neg: [bool; 3],
}

impl<L: Lanes> Geo<L> {
    #[inline(always)]
    fn new(l: L, o: Vec3s<L>, d: Vec3s<L>, m: L::Mask) -> Self {
        let one = l.splat(1.0);
        let inv: Vec3s<L> = Vec3s::new(one / d.x, one / d.y, one / d.z);
        let inf = l.splat(f32::INFINITY);
        let fine = inv.x.abs().lt(inf) & inv.y.abs().lt(inf) & inv.z.abs().lt(inf);
        let zero = l.splat(0.0);
        Self {
            o,
            d,
            inv,
            odd: m.and_not(fine).any(),
            neg: [
                spread::<L>(m, d.x, zero) < 0.0,
                spread::<L>(m, d.y, zero) < 0.0,
                spread::<L>(m, d.z, zero) < 0.0,
            ],
        }
    }
}

/// One packet's state, shared by the spaces it is walked in.
#[derive(Clone, Copy)]
struct State<L: Lanes> {
    tmin: L::F32s,
    /// The segment's end, then the nearest hit so far (first hits).
    limit: L::F32s,
    /// Lanes still searched.
    active: L::Mask,
    /// First hits so far (`t` before the shift of [`coherent_accel::Ray1::forward`]).
    hit: Hits<L>,
    /// Lanes found occluded (occlusion).
    occluded: L::Mask,
}

/// Conservative bounds of some packets' rays in one space (Wald et al.'s intervals).
#[derive(Clone, Copy)]
struct Bounds {
    o_lo: [f32; 3],
    o_hi: [f32; 3],
    r_lo: [f32; 3],
    r_hi: [f32; 3],
    tmin_lo: f32,
    tmax_hi: f32,
    /// False when some lane's inverse direction is not finite: no interval test.
    usable: bool,
}

impl Bounds {
    const EMPTY: Self = Self {
        o_lo: [f32::INFINITY; 3],
        o_hi: [f32::NEG_INFINITY; 3],
        r_lo: [f32::INFINITY; 3],
        r_hi: [f32::NEG_INFINITY; 3],
        tmin_lo: f32::INFINITY,
        tmax_hi: f32::NEG_INFINITY,
        usable: true,
    };

    /// The bounds of lanes `m` of one packet.
    #[inline(always)]
    fn of<L: Lanes>(l: L, g: &Geo<L>, s: &State<L>, m: L::Mask) -> Self {
        if m.none() {
            return Self::EMPTY;
        }
        let (inf, ninf) = (l.splat(f32::INFINITY), l.splat(f32::NEG_INFINITY));
        Self {
            o_lo: [
                m.select(g.o.x, inf).reduce_min(),
                m.select(g.o.y, inf).reduce_min(),
                m.select(g.o.z, inf).reduce_min(),
            ],
            o_hi: [
                m.select(g.o.x, ninf).reduce_max(),
                m.select(g.o.y, ninf).reduce_max(),
                m.select(g.o.z, ninf).reduce_max(),
            ],
            r_lo: [
                m.select(g.inv.x, inf).reduce_min(),
                m.select(g.inv.y, inf).reduce_min(),
                m.select(g.inv.z, inf).reduce_min(),
            ],
            r_hi: [
                m.select(g.inv.x, ninf).reduce_max(),
                m.select(g.inv.y, ninf).reduce_max(),
                m.select(g.inv.z, ninf).reduce_max(),
            ],
            tmin_lo: m.select(s.tmin, inf).reduce_min(),
            tmax_hi: m.select(s.limit, ninf).reduce_max(),
            usable: !g.odd,
        }
    }

    #[inline(always)]
    fn union(&self, b: &Self) -> Self {
        let mut u = *self;
        for k in 0..3 {
            u.o_lo[k] = u.o_lo[k].min(b.o_lo[k]);
            u.o_hi[k] = u.o_hi[k].max(b.o_hi[k]);
            u.r_lo[k] = u.r_lo[k].min(b.r_lo[k]);
            u.r_hi[k] = u.r_hi[k].max(b.r_hi[k]);
        }
        u.tmin_lo = u.tmin_lo.min(b.tmin_lo);
        u.tmax_hi = u.tmax_hi.max(b.tmax_hi);
        u.usable &= b.usable;
        u
    }

    /// Whether every ray these bounds hold misses the box `[lo, hi]` (as the lane box test
    /// decides it: its rounded slabs lie inside these intervals, the operations being
    /// monotonic).
    #[inline(always)]
    fn misses(&self, lo: Vec3A, hi: Vec3A) -> bool {
        if !self.usable {
            return false;
        }
        let mut near = f32::NEG_INFINITY;
        let mut far = f32::INFINITY;
        for k in 0..3 {
            let (a, b) = range_mul(lo[k] - self.o_hi[k], lo[k] - self.o_lo[k], self, k);
            let (c, d) = range_mul(hi[k] - self.o_hi[k], hi[k] - self.o_lo[k], self, k);
            // Each ray's slab is [min(p, q), max(p, q)] with p in [a, b], q in [c, d].
            near = near.max(a.min(c));
            far = far.min(b.max(d));
        }
        // NaN (an empty set of rays) rejects nothing.
        near > far || far < self.tmin_lo * (1.0 - SLACK) || near > self.tmax_hi * (1.0 + SLACK)
    }
}

/// The range of `x * r` for `x` in `[x0, x1]` and `r` in the bounds' axis `k` range.
#[inline(always)]
fn range_mul(x0: f32, x1: f32, b: &Bounds, k: usize) -> (f32, f32) {
    let p = [
        x0 * b.r_lo[k],
        x0 * b.r_hi[k],
        x1 * b.r_lo[k],
        x1 * b.r_hi[k],
    ];
    (
        p[0].min(p[1]).min(p[2].min(p[3])),
        p[0].max(p[1]).max(p[2].max(p[3])),
    )
}

/// Suffix bounds: `out[j]` bounds the rays `m[j..n]` (`out[n]` empty).
#[inline(always)]
fn suffix_bounds<L: Lanes>(
    l: L,
    g: &[Geo<L>],
    s: &[State<L>],
    m: &[L::Mask],
    from: usize,
    out: &mut [Bounds; BEAM + 1],
) {
    let n = g.len();
    out[n] = Bounds::EMPTY;
    for j in (from..n).rev() {
        out[j] = Bounds::of(l, &g[j], &s[j], m[j]).union(&out[j + 1]);
    }
}

/// Largest plus smallest of lanes `m` of `v` (its sign: where most of them point).
#[inline(always)]
fn spread<L: Lanes>(m: L::Mask, v: L::F32s, zero: L::F32s) -> f32 {
    m.select(v, zero).reduce_max() + m.select(v, zero).reduce_min()
}

/// One axis' slab `[min, max]` of the planes `lo` and `hi`.
#[inline(always)]
fn slab<L: Lanes>(l: L, lo: f32, hi: f32, o: L::F32s, inv: L::F32s) -> (L::F32s, L::F32s) {
    let a = (l.splat(lo) - o) * inv;
    let c = (l.splat(hi) - o) * inv;
    (a.min(c), a.max(c))
}

/// A slab with a NaN end (a ray in a face plane with a zero direction component) made
/// unbounded.
#[inline(always)]
fn unbounded_nan<L: Lanes>(
    a: L::F32s,
    b: L::F32s,
    ninf: L::F32s,
    inf: L::F32s,
) -> (L::F32s, L::F32s) {
    let nan = a.is_nan() | b.is_nan();
    (nan.select(ninf, a), nan.select(inf, b))
}

/// `v` in every lane, per component.
#[inline(always)]
fn splat3<L: Lanes>(l: L, v: Vec3A) -> (L::F32s, L::F32s, L::F32s) {
    (l.splat(v.x), l.splat(v.y), l.splat(v.z))
}

/// The lanes of a packet whose rays meet the box `[lo, hi]` within `[tmin, limit]` (with
/// [`SLACK`]), among its active ones.
#[inline(always)]
fn box_hit<L: Lanes>(l: L, g: &Geo<L>, s: &State<L>, lo: Vec3A, hi: Vec3A) -> L::Mask {
    let (x0, x1) = slab(l, lo.x, hi.x, g.o.x, g.inv.x);
    let (y0, y1) = slab(l, lo.y, hi.y, g.o.y, g.inv.y);
    let (z0, z1) = slab(l, lo.z, hi.z, g.o.z, g.inv.z);
    let (near, far) = if g.odd {
        // A zero direction component (object space): the slab is NaN for a ray in a face
        // plane and does not limit it; infinite for one off the plane, as it should.
        let (ninf, inf) = (l.splat(f32::NEG_INFINITY), l.splat(f32::INFINITY));
        let ((x0, x1), (y0, y1), (z0, z1)) = (
            unbounded_nan::<L>(x0, x1, ninf, inf),
            unbounded_nan::<L>(y0, y1, ninf, inf),
            unbounded_nan::<L>(z0, z1, ninf, inf),
        );
        (x0.max(y0).max(z0), x1.min(y1).min(z1))
    } else {
        (x0.max(y0).max(z0), x1.min(y1).min(z1))
    };
    let lo_t = s.tmin - s.tmin * l.splat(SLACK);
    let hi_t = s.limit + s.limit * l.splat(SLACK);
    near.le(far) & far.ge(lo_t) & near.le(hi_t) & s.active
}

/// The walk: `f(states, node, first, masks)` at each leaf reached, with `masks[j]` the lanes
/// of packet `j >= first` that reach the leaf's box; it returns `true` when nothing is left
/// to search (every lane occluded), which ends the walk.
#[inline(always)]
fn walk<L: Lanes>(
    l: L,
    bvh: &Bvh2,
    g: &[Geo<L>],
    s: &mut [State<L>],
    bounds: &[Bounds; BEAM + 1],
    first: usize,
    mut f: impl FnMut(&mut [State<L>], &Bvh2Node, usize, &[L::Mask; BEAM]) -> bool,
) -> bool {
    let n = g.len();
    let mut stack = [(0u32, 0u32); STACK];
    stack[0] = (0, first as u32);
    let mut sp = 1;
    let mut masks = [l.splat_mask(false); BEAM];
    while sp > 0 {
        sp -= 1;
        let (mut node_id, first) = stack[sp];
        let mut first = first as usize;
        'descend: loop {
            while first < n && s[first].active.none() {
                first += 1;
            }
            if first == n {
                break;
            }
            let node = &bvh.nodes[node_id as usize];
            let (lo, hi) = (node.aabb.min, node.aabb.max);
            if box_hit(l, &g[first], &s[first], lo, hi).none() {
                if bounds[first + 1].misses(lo, hi) {
                    break;
                }
                first += 1;
                loop {
                    if first == n {
                        break 'descend;
                    }
                    if box_hit(l, &g[first], &s[first], lo, hi).any() {
                        break;
                    }
                    first += 1;
                }
            }
            if node.prim_count > 0 {
                let mut any = false;
                for j in first..n {
                    masks[j] = box_hit(l, &g[j], &s[j], lo, hi);
                    any |= masks[j].any();
                }
                if any && f(s, node, first, &masks) {
                    return true;
                }
                break;
            }
            let c = node.first_index;
            let (a, b) = (&bvh.nodes[c as usize].aabb, &bvh.nodes[c as usize + 1].aabb);
            let gap = (b.min + b.max - a.min - a.max).abs();
            let k = if gap.x >= gap.y && gap.x >= gap.z {
                0
            } else if gap.y >= gap.z {
                1
            } else {
                2
            };
            // Near child first: the one with the smaller centre when the packet goes up.
            let b_below = b.min[k] + b.max[k] < a.min[k] + a.max[k];
            let (near, far) = if b_below != g[first].neg[k] {
                (c + 1, c)
            } else {
                (c, c + 1)
            };
            stack[sp] = (far, first as u32);
            sp += 1;
            node_id = near;
        }
    }
    false
}

/// obvhs' Möller-Trumbore ([`Triangle::intersect`]) on lanes `m` of a packet, in its order
/// of operations: `(t, u, v)` and the lanes hit in `[tmin, limit)`.
#[inline(always)]
fn triangle<L: Lanes>(
    l: L,
    tri: &Triangle,
    g: &Geo<L>,
    tmin: L::F32s,
    limit: L::F32s,
    m: L::Mask,
) -> (L::F32s, L::F32s, L::F32s, L::Mask) {
    let e1 = tri.v0 - tri.v1;
    let e2 = tri.v2 - tri.v0;
    let n = e1.cross(e2);
    let (e1x, e1y, e1z) = splat3(l, e1);
    let (e2x, e2y, e2z) = splat3(l, e2);
    let (nx, ny, nz) = splat3(l, n);
    let d = &g.d;
    let cx = l.splat(tri.v0.x) - g.o.x;
    let cy = l.splat(tri.v0.y) - g.o.y;
    let cz = l.splat(tri.v0.z) - g.o.z;
    // r = d x c, as glam computes a cross product.
    let rx = d.y * cz - cy * d.z;
    let ry = d.z * cx - cz * d.x;
    let rz = d.x * cy - cx * d.y;
    // Dot products as glam's: (x + y) + z.
    let inv_det = l.splat(1.0) / (nx * d.x + ny * d.y + nz * d.z);
    let u = (rx * e2x + ry * e2y + rz * e2z) * inv_det;
    let v = (rx * e1x + ry * e1y + rz * e1z) * inv_det;
    let w = l.splat(1.0) - u - v;
    let signs = u.to_bits() | v.to_bits() | w.to_bits();
    let valid = inv_det.ne(l.splat(0.0)) & signs.gt(l.splat_i32(-1));
    let t = (nx * cx + ny * cy + nz * cz) * inv_det;
    (t, u, v, valid & t.ge(tmin) & t.lt(limit) & m)
}

/// Whether no lane is left to search.
#[inline(always)]
fn all_done<L: Lanes>(s: &[State<L>]) -> bool {
    for st in s {
        if st.active.any() {
            return false;
        }
    }
    true
}

/// A mesh leaf: its triangles against the lanes `masks[j]` of packets `j >= first`; first
/// hits keep the nearest, occlusion retires the lanes hit. Returns whether nothing is left.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn mesh_leaf<L: Lanes, const OCCLUSION: bool>(
    l: L,
    bvh: &Bvh2,
    tris: &[Triangle],
    prims: &[u32],
    inst: i32,
    g: &[Geo<L>],
    s: &mut [State<L>],
    node: &Bvh2Node,
    first: usize,
    masks: &[L::Mask; BEAM],
) -> bool {
    let ids = &bvh.primitive_indices;
    let mut retired = false;
    for p in node.first_index..node.first_index + node.prim_count {
        let k = ids[p as usize] as usize;
        let tri = &tris[k];
        for j in first..g.len() {
            let m = masks[j] & s[j].active;
            if m.none() {
                continue;
            }
            let st = &mut s[j];
            let (t, u, v, hit) = triangle(l, tri, &g[j], st.tmin, st.limit, m);
            if hit.none() {
                continue;
            }
            if OCCLUSION {
                st.occluded |= hit;
                st.active = st.active.and_not(hit);
                retired = true;
            } else {
                st.limit = hit.select(t, st.limit);
                let h = &mut st.hit;
                h.t = hit.select(t, h.t);
                h.u = hit.select(u, h.u);
                h.v = hit.select(v, h.v);
                h.prim = hit.select_i32(l.splat_i32(prims[k] as i32), h.prim);
                h.inst = hit.select_i32(l.splat_i32(inst), h.inst);
            }
        }
    }
    retired && all_done(s)
}

impl Obvhs {
    /// Whether the beams have trees to walk (else they trace packet after packet).
    fn beams_walk(&self) -> bool {
        match self.direct {
            Some(m) => self.meshes[m].beam.get(&self.meshes[m].tree).is_some(),
            None => {
                self.top_beam.get(&self.top).is_some()
                    && self
                        .meshes
                        .iter()
                        .all(|m| m.tris.is_empty() || m.beam.get(&m.tree).is_some())
            }
        }
    }

    /// [`coherent_accel::Accel::intersect_beam`] by the large-packet walk, out of line
    /// (`Lanes::apart`): one copy per lane type, which every caller shares, not two lane
    /// walks and the large-packet walk inlined at each call site.
    #[inline(always)]
    pub(crate) fn beam_first_hits<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        hits: &mut [Hits<L>],
    ) {
        // A beam of one packet is the packet query, inline as that query is.
        if let ([r], [m], [h]) = (rays, active, &mut *hits) {
            *h = coherent_accel::Accel::intersect(self, l, r, *m);
            return;
        }
        l.apart(
            #[inline(always)]
            |l| self.beam_first_hits_apart(l, rays, active, hits),
        )
    }

    #[inline(always)]
    fn beam_first_hits_apart<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        hits: &mut [Hits<L>],
    ) {
        debug_assert!(rays.len() == active.len() && rays.len() == hits.len());
        if rays.len() == 1 || !self.beams_walk() {
            for ((r, &m), h) in rays.iter().zip(active).zip(hits.iter_mut()) {
                *h = coherent_accel::Accel::intersect(self, l, r, m);
            }
            return;
        }
        for ((r, m), h) in rays
            .chunks(BEAM)
            .zip(active.chunks(BEAM))
            .zip(hits.chunks_mut(BEAM))
        {
            if r.len() == 1 {
                h[0] = coherent_accel::Accel::intersect(self, l, &r[0], m[0]);
                continue;
            }
            self.chunk::<L, false>(
                l,
                r,
                m,
                #[inline(always)]
                |j, st, shift, fallback| {
                    let mut out = st.hit;
                    out.t = st.hit.t + shift;
                    if fallback.any() {
                        let rays = r[j].unpack();
                        let one = Hits::from_fn(
                            l,
                            #[inline(always)]
                            |i| {
                                if fallback.lane(i) {
                                    self.first_hit1(&rays[i])
                                } else {
                                    None
                                }
                            },
                        );
                        out = Hits::select(fallback, &one, &out);
                    }
                    h[j] = out;
                },
            );
        }
    }

    /// [`coherent_accel::Accel::occluded_beam`] by the large-packet walk, out of line as
    /// [`Obvhs::beam_first_hits`].
    #[inline(always)]
    pub(crate) fn beam_occluded<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        occluded: &mut [L::Mask],
    ) {
        if let ([r], [m], [o]) = (rays, active, &mut *occluded) {
            *o = coherent_accel::Accel::occluded(self, l, r, *m);
            return;
        }
        l.apart(
            #[inline(always)]
            |l| self.beam_occluded_apart(l, rays, active, occluded),
        )
    }

    #[inline(always)]
    fn beam_occluded_apart<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        occluded: &mut [L::Mask],
    ) {
        debug_assert!(rays.len() == active.len() && rays.len() == occluded.len());
        if rays.len() == 1 || !self.beams_walk() {
            for ((r, &m), o) in rays.iter().zip(active).zip(occluded.iter_mut()) {
                *o = coherent_accel::Accel::occluded(self, l, r, m);
            }
            return;
        }
        for ((r, m), o) in rays
            .chunks(BEAM)
            .zip(active.chunks(BEAM))
            .zip(occluded.chunks_mut(BEAM))
        {
            if r.len() == 1 {
                o[0] = coherent_accel::Accel::occluded(self, l, &r[0], m[0]);
                continue;
            }
            self.chunk::<L, true>(
                l,
                r,
                m,
                #[inline(always)]
                |j, st, _, fallback| {
                    let mut out = st.occluded;
                    if fallback.any() {
                        let rays = r[j].unpack();
                        let bits = fallback.bitmask();
                        out |= l.mask_from_fn(
                            #[inline(always)]
                            |i| bits >> i & 1 != 0 && self.any_hit1(&rays[i]),
                        );
                    }
                    o[j] = out;
                },
            );
        }
    }

    /// One chunk of at most [`BEAM`] packets: sets the rays up as the single-ray path does,
    /// walks, and calls `out(j, state, shift, fallback)` per packet with the lanes left to
    /// the single-ray path.
    #[inline(always)]
    fn chunk<L: Lanes, const OCCLUSION: bool>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        mut out: impl FnMut(usize, &State<L>, L::F32s, L::Mask),
    ) {
        let n = rays.len();
        let zero = l.splat(0.0);
        let none = l.splat_mask(false);
        let zv = Vec3s::new(zero, zero, zero);
        let blank = Geo {
            o: zv,
            d: zv,
            inv: zv,
            odd: false,
            neg: [false; 3],
        };
        let mut g = [blank; BEAM];
        let mut s = [State {
            tmin: zero,
            limit: zero,
            active: none,
            hit: Hits::miss(l),
            occluded: none,
        }; BEAM];
        let mut shift = [zero; BEAM];
        let mut fallback = [none; BEAM];
        for j in 0..n {
            let mut r = rays[j];
            let mut valid = r.valid(l) & active[j];
            if (valid & r.tmin.lt(zero)).any() {
                // `Ray1::forward` lane by lane: clipped to the scene's box, moved when the
                // clipped start lies behind the origin.
                let lanes = r.unpack();
                let mut moved = lanes;
                let mut sh = [0.0f32; coherent_simd::MAX_LANES];
                let bits = valid.bitmask();
                let mut keep = 0u32;
                for i in 0..L::N {
                    if bits >> i & 1 == 0 {
                        continue;
                    }
                    if let Some((f, t)) = lanes[i].forward(&self.bounds) {
                        moved[i] = f;
                        sh[i] = t;
                        keep |= 1 << i;
                    }
                }
                r = Rays::from_fn(l, |i| moved[i]);
                shift[j] = l.load(&sh);
                valid &= l.mask_from_bits(keep);
            }
            // `-0.0` made `+0.0`, as the single-ray path gives obvhs its rays.
            let d = Vec3s::new(r.dir.x + zero, r.dir.y + zero, r.dir.z + zero);
            let geo = Geo::new(l, r.origin, d, valid);
            let inf = l.splat(f32::INFINITY);
            let fine = geo.inv.x.abs().lt(inf) & geo.inv.y.abs().lt(inf) & geo.inv.z.abs().lt(inf);
            fallback[j] = valid.and_not(fine);
            let live = valid & fine;
            // The lanes left to the single-ray path are out of the walk (and of `odd`).
            g[j] = Geo { odd: false, ..geo };
            s[j].tmin = r.tmin;
            s[j].limit = r.tmax;
            s[j].active = live;
        }
        let (g, s_n) = (&g[..n], &mut s[..n]);
        let mut bounds = [Bounds::EMPTY; BEAM + 1];
        let mut act = [none; BEAM];
        for j in 0..n {
            act[j] = s_n[j].active;
        }
        suffix_bounds(l, g, s_n, &act[..n], 0, &mut bounds);
        if let Some(m) = self.direct {
            let mesh = &self.meshes[m];
            let bvh = mesh.beam.get(&mesh.tree).expect("checked by beams_walk");
            walk(
                l,
                bvh,
                g,
                s_n,
                &bounds,
                0,
                #[inline(always)]
                |s, node, first, masks| {
                    mesh_leaf::<L, OCCLUSION>(
                        l,
                        bvh,
                        &mesh.tris,
                        &mesh.prims,
                        0,
                        g,
                        s,
                        node,
                        first,
                        masks,
                    )
                },
            );
        } else if let Some(top) = self.top_beam.get(&self.top) {
            let mut og = [blank; BEAM];
            let mut ob = [Bounds::EMPTY; BEAM + 1];
            let mut saved = [none; BEAM];
            walk(
                l,
                top,
                g,
                s_n,
                &bounds,
                0,
                #[inline(always)]
                |s, node, first, masks| {
                    self.instance_leaf::<L, OCCLUSION>(
                        l, top, g, s, node, first, masks, &mut og, &mut ob, &mut saved,
                    )
                },
            );
        }
        for j in 0..n {
            out(j, &s[j], shift[j], fallback[j]);
        }
    }

    /// A top-tree leaf: each instance's mesh walked by the packets that reach the leaf, in
    /// the instance's space. Returns whether nothing is left (occlusion).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn instance_leaf<L: Lanes, const OCCLUSION: bool>(
        &self,
        l: L,
        top: &Bvh2,
        g: &[Geo<L>],
        s: &mut [State<L>],
        node: &Bvh2Node,
        first: usize,
        masks: &[L::Mask; BEAM],
        og: &mut [Geo<L>; BEAM],
        ob: &mut [Bounds; BEAM + 1],
        saved: &mut [L::Mask; BEAM],
    ) -> bool {
        let n = g.len();
        let none = l.splat_mask(false);
        let zero = l.splat(0.0);
        for p in node.first_index..node.first_index + node.prim_count {
            let i = self.top_ids[top.primitive_indices[p as usize] as usize];
            let inst = &self.instances[i as usize];
            let mesh = &self.meshes[inst.mesh];
            let Some(bvh) = mesh.beam.get(&mesh.tree) else {
                continue;
            };
            let mut any = false;
            for j in 0..n {
                saved[j] = s[j].active;
                let m = if j >= first {
                    masks[j] & s[j].active
                } else {
                    none
                };
                s[j].active = m;
                if m.any() {
                    any = true;
                    let w = Rays {
                        origin: g[j].o,
                        dir: g[j].d,
                        tmin: zero,
                        tmax: zero,
                    }
                    .transformed(l, &inst.object_from_world);
                    let d = Vec3s::new(w.dir.x + zero, w.dir.y + zero, w.dir.z + zero);
                    og[j] = Geo::new(l, w.origin, d, m);
                }
            }
            let mut done = false;
            if any {
                let mut act = [none; BEAM];
                for j in 0..n {
                    act[j] = s[j].active;
                }
                suffix_bounds(l, &og[..n], s, &act[..n], first, ob);
                done = walk(
                    l,
                    bvh,
                    &og[..n],
                    s,
                    ob,
                    first,
                    #[inline(always)]
                    |s, node, f, masks| {
                        mesh_leaf::<L, OCCLUSION>(
                            l,
                            bvh,
                            &mesh.tris,
                            &mesh.prims,
                            i as i32,
                            &og[..n],
                            s,
                            node,
                            f,
                            masks,
                        )
                    },
                );
            }
            for j in 0..n {
                if OCCLUSION {
                    // Lanes retired in the mesh stay retired.
                    let tried = if j >= first {
                        masks[j] & saved[j]
                    } else {
                        none
                    };
                    s[j].active = saved[j].and_not(tried.and_not(s[j].active));
                } else {
                    s[j].active = saved[j];
                }
            }
            if OCCLUSION && done && all_done(s) {
                return true;
            }
        }
        OCCLUSION && all_done(s)
    }
}
