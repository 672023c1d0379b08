//! A leaf's triangles four at a time for one ray (Embree's triangle4 idea on the paper's
//! projection-test records): each leaf's records are copied, in the leaf's order, into blocks
//! of four in SoA form, and a single ray tests a block with 4-wide SSE arithmetic (glam's
//! `Vec4`, SSE2 on x86-64) instead of one record after the other.
//!
//! The arithmetic per lane is [`TriAccel::intersect1x`]'s, operation for operation, so a
//! block answers bit for bit what the records would (the equivalence tests check it against
//! brute force). Each record's projection axis `k` differs, so the ray's components are
//! picked per lane by two selects. Padding lanes have a NaN `a_k`: their `t` is NaN and
//! never in range.
//!
//! Off by default ([`crate::BspParams::simd_leaves`]): the scalar renderer's single rays stay
//! one triangle at a time, as the paper's non-SSE code was.

use coherent_accel::TriAccel;
use glam::{BVec4A, Vec4};

use crate::KdTree;

/// Four triangle records in SoA form (padding lanes never hit).
#[derive(Debug, Clone, Copy)]
#[repr(C, align(16))]
pub struct Tri4 {
    /// Lanes whose projection axis is x (`k0`) or y (`k1`); neither: z.
    k0: BVec4A,
    k1: BVec4A,
    n_u: Vec4,
    n_v: Vec4,
    a_k: Vec4,
    a_u: Vec4,
    a_v: Vec4,
    b_nu: Vec4,
    b_nv: Vec4,
    c_nu: Vec4,
    c_nv: Vec4,
    /// Per lane the barycentric bounds ([`TriAccel::bounds`]): lowest `u`, lowest `v`,
    /// highest `u + v`.
    lo_u: Vec4,
    lo_v: Vec4,
    hi: Vec4,
    /// Triangle index in the mesh per lane.
    pub prim: [u32; 4],
    /// Record index per lane (into the mesh's records; `u32::MAX` for padding).
    pub rec: [u32; 4],
}

impl Tri4 {
    fn new(recs: &[(u32, TriAccel)]) -> Self {
        debug_assert!(!recs.is_empty() && recs.len() <= 4);
        let get = |f: &dyn Fn(&TriAccel) -> f32, pad: f32| {
            Vec4::from_array(core::array::from_fn(|j| {
                recs.get(j).map_or(pad, |(_, r)| f(r))
            }))
        };
        let k = |want: u32| {
            let b: [bool; 4] =
                core::array::from_fn(|j| recs.get(j).is_some_and(|(_, r)| r.k == want));
            BVec4A::from_array(b)
        };
        Self {
            k0: k(0),
            k1: k(1),
            n_u: get(&|r| r.n_u, 0.0),
            n_v: get(&|r| r.n_v, 0.0),
            a_k: get(&|r| r.a_k, f32::NAN),
            a_u: get(&|r| r.a_u, 0.0),
            a_v: get(&|r| r.a_v, 0.0),
            b_nu: get(&|r| r.b_nu, 0.0),
            b_nv: get(&|r| r.b_nv, 0.0),
            c_nu: get(&|r| r.c_nu, 0.0),
            c_nv: get(&|r| r.c_nv, 0.0),
            lo_u: get(&|r| r.bounds().0, 0.0),
            lo_v: get(&|r| r.bounds().1, 0.0),
            hi: get(&|r| r.bounds().2, 1.0),
            prim: core::array::from_fn(|j| recs.get(j).map_or(u32::MAX, |(_, r)| r.prim)),
            rec: core::array::from_fn(|j| recs.get(j).map_or(u32::MAX, |(i, _)| *i)),
        }
    }

    /// Lanes (bits 0-3) where the ray meets the triangle with `tmin <= t < tmax`, and per lane
    /// `t`, `u`, `v` (undefined where the bit is clear).
    #[inline(always)]
    pub(crate) fn intersect(
        &self,
        r: &Ray4,
        tmin: f32,
        tmax: f32,
    ) -> (u32, [f32; 4], [f32; 4], [f32; 4]) {
        // The ray's components on each lane's axes k, u = k + 1, v = k + 2 (mod 3).
        let pick =
            |x: Vec4, y: Vec4, z: Vec4| Vec4::select(self.k0, x, Vec4::select(self.k1, y, z));
        let [ox, oy, oz] = r.o;
        let [dx, dy, dz] = r.d;
        let wk = pick(ox, oy, oz) - self.a_k;
        let wu = pick(oy, oz, ox) - self.a_u;
        let wv = pick(oz, ox, oy) - self.a_v;
        let (dk, du, dv) = (pick(dx, dy, dz), pick(dy, dz, dx), pick(dz, dx, dy));
        let denom = dk + self.n_u * du + self.n_v * dv;
        let t = -(wk + self.n_u * wu + self.n_v * wv) / denom;
        let mut m = t.cmpge(Vec4::splat(tmin)) & t.cmplt(Vec4::splat(tmax));
        if !m.any() {
            return (0, [0.0; 4], [0.0; 4], [0.0; 4]);
        }
        let hu = wu + t * du;
        let hv = wv + t * dv;
        let beta = self.b_nu * hu + self.b_nv * hv;
        let gamma = self.c_nu * hu + self.c_nv * hv;
        m &= beta.cmpge(self.lo_u) & gamma.cmpge(self.lo_v) & (beta + gamma).cmple(self.hi);
        (m.bitmask(), t.to_array(), beta.to_array(), gamma.to_array())
    }
}

/// A ray's origin and direction components, each splatted over four lanes.
#[derive(Clone, Copy)]
pub(crate) struct Ray4 {
    o: [Vec4; 3],
    d: [Vec4; 3],
}

impl Ray4 {
    #[inline(always)]
    pub fn new(o: &[f32; 4], d: &[f32; 4]) -> Self {
        Self {
            o: [0, 1, 2].map(|k| Vec4::splat(o[k])),
            d: [0, 1, 2].map(|k| Vec4::splat(d[k])),
        }
    }
}

/// Every leaf's records in blocks of four; `first[node]` is a leaf's first block, and it has
/// `items.div_ceil(4)` of them.
#[derive(Debug, Clone, Default)]
pub struct Leaves4 {
    pub blocks: Vec<Tri4>,
    pub first: Vec<u32>,
}

impl Leaves4 {
    /// The blocks of `tree`'s leaves over the records `tris`.
    pub fn new(tree: &KdTree, tris: &[TriAccel]) -> Self {
        let mut blocks = Vec::new();
        let mut first = vec![0; tree.nodes.len()];
        for (i, n) in tree.nodes.iter().enumerate() {
            if !n.is_leaf() {
                continue;
            }
            first[i] = blocks.len() as u32;
            let recs: Vec<(u32, TriAccel)> = tree.items[n.items()]
                .iter()
                .map(|&j| (j, tris[j as usize]))
                .collect();
            blocks.extend(recs.chunks(4).map(Tri4::new));
        }
        Self { blocks, first }
    }

    /// The blocks of leaf node `node` (with `n` items).
    #[inline(always)]
    pub(crate) fn of(&self, node: usize, n: usize) -> &[Tri4] {
        let f = self.first[node] as usize;
        &self.blocks[f..f + n.div_ceil(4)]
    }

    pub fn memory_bytes(&self) -> usize {
        self.blocks.len() * size_of::<Tri4>() + self.first.len() * 4
    }
}
