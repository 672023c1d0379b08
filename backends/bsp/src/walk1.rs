//! Single-ray traversal of the two-level BSP (paper section 3; the scalar path, and the path
//! packets switch to when few lanes stay active): near/far order with an explicit stack,
//! the intersection cache, early exit once the nearest hit is before the next node.

use coherent_accel::aabb::slab1;
use coherent_accel::triangle::xyzz;
use coherent_accel::{Hit1, transform_point1, transform_vector1};
use glam::Vec3;

use crate::KdTree;
use crate::bsp::{Bsp, MeshTree};
use crate::counters::Counters;
use crate::leaf4::Ray4;
use crate::mailbox::Mailbox1;
use crate::query::{LaneTask, Query1};
use crate::stack::Stack;

/// A ray prepared for traversal; vectors as `[x, y, z, z]`, indexed by an axis `& 3`.
#[derive(Clone, Copy)]
pub(crate) struct Ray1x {
    pub o: [f32; 4],
    pub d: [f32; 4],
    /// `1 / d` per axis (infinite for zero components).
    pub inv: [f32; 4],
    pub tmin: f32,
    /// Bit `k` set when the direction's sign bit along axis `k` is set (bit 3 repeats bit
    /// 2): the right child is nearer. Bits in a register, not an array: the next node's
    /// address waits for this choice at every split, and a shift is quicker than a load.
    pub neg: u32,
}

impl Ray1x {
    #[inline(always)]
    pub fn new(o: Vec3, d: Vec3, tmin: f32) -> Self {
        let inv = Vec3::new(1.0 / d.x, 1.0 / d.y, 1.0 / d.z);
        let [x, y, z] = [d.x, d.y, d.z].map(|c| c.is_sign_negative() as u32);
        let neg = x | y << 1 | z << 2 | z << 3;
        Self {
            o: xyzz(o),
            d: xyzz(d),
            inv: xyzz(inv),
            tmin,
            neg,
        }
    }

    /// The part of the ray in `b`, cut to `[tmin, tmax]` and widened by [`SLACK`] (before the
    /// emptiness test: a ray touching the box at a corner is inside).
    #[inline(always)]
    pub fn clip(&self, b: &coherent_accel::Aabb, tmax: f32) -> Option<(f32, f32)> {
        let (mut t0, mut t1) = (self.tmin, tmax);
        for k in 0..3 {
            let (lo, hi) = slab1(self.o[k], self.inv[k], b.min[k], b.max[k]);
            t0 = max1(lo, t0);
            t1 = min1(hi, t1);
        }
        let (t0, t1) = (widen_lo(t0), widen_hi(t1));
        (t0 <= t1).then_some((t0, t1))
    }
}

/// Relative slack added to ray segments where a split or a box cuts them (2^-16): `ts` and
/// the hit `t` are rounded differently, and a ray through a voxel corner must not skip the
/// voxel it touches. Without it the equivalence tests found hits exactly at a vertex lying in
/// two split planes missed; 2^-20 still missed one behind a scaling instance transform.
pub(crate) const SLACK: f32 = 1.0 / (1 << 16) as f32;

/// `x` moved down by [`SLACK`] relative.
#[inline(always)]
pub(crate) fn widen_lo(x: f32) -> f32 {
    x - x.abs() * SLACK
}

/// `x` moved up by [`SLACK`] relative.
#[inline(always)]
pub(crate) fn widen_hi(x: f32) -> f32 {
    x + x.abs() * SLACK
}

/// `max` with the x86 rule: a NaN `a` gives `b`.
#[inline(always)]
pub(crate) fn max1(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// `min` with the x86 rule: a NaN `a` gives `b`.
#[inline(always)]
pub(crate) fn min1(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

/// Walks `tree` from node `start` over the ray segment `[tn, tf]`, calling `leaf` on each
/// leaf (its node index and items) in front-to-back order until it returns true (returns
/// true then). Nodes entirely beyond `limit(s)` are skipped.
///
/// At a split with `ts = (split - o) / d`: the near child alone when `ts > tf`, the far one
/// alone when `ts < tn`, else both. A NaN `ts` (a ray lying in the split plane) visits both
/// with the whole segment. A child that is an empty leaf is neither entered nor stacked
/// ([`crate::Node::empty_children`]), so `leaf` sees empty leaves only as `start`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn walk1<S, C: Counters>(
    tree: &KdTree,
    r: &Ray1x,
    start: usize,
    mut tn: f32,
    mut tf: f32,
    s: &mut S,
    c: &mut C,
    limit: impl Fn(&S) -> f32,
    mut leaf: impl FnMut(&mut S, &mut C, usize, &[u32]) -> bool,
) -> bool {
    let nodes = &tree.nodes[..];
    let mut stack: Stack<(u32, f32, f32)> = Stack::new();
    let mut node = start;
    loop {
        let n = nodes[node];
        if !n.is_leaf() {
            c.inner();
            let k = n.axis() & 3;
            let ts = (n.split() - r.o[k]) * r.inv[k];
            let sb = (r.neg >> k & 1) as usize;
            let near = n.left() + sb;
            let far = n.left() + 1 - sb;
            // Children that are empty leaves are never entered (`Node::empty_children`).
            let empty = n.empty_children();
            let near_empty = empty >> sb & 1 != 0;
            let far_empty = empty >> (sb ^ 1) & 1 != 0;
            if ts > tf {
                if !near_empty {
                    node = near;
                    continue;
                }
            } else if ts < tn {
                if !far_empty {
                    node = far;
                    continue;
                }
            } else if !near_empty {
                if !far_empty {
                    stack.push((far as u32, widen_lo(max1(ts, tn)), tf));
                }
                node = near;
                tf = widen_hi(min1(ts, tf));
                continue;
            } else if !far_empty {
                node = far;
                tn = widen_lo(max1(ts, tn));
                continue;
            }
            // Every child the segment reaches is empty.
        } else {
            c.leaf();
            if leaf(s, c, node, &tree.items[n.items()]) {
                return true;
            }
        }
        loop {
            let Some((next, a, b)) = stack.pop() else {
                return false;
            };
            if a <= limit(s) {
                (node, tn, tf) = (next as usize, a, b);
                break;
            }
        }
    }
}

/// Traverses one mesh's tree with an object-space ray, from node `start` over `[tn, tf]`
/// (or, with `None`, from the root over the ray's part inside the mesh box). Returns true when
/// the query finished.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn mesh1<Q: Query1, C: Counters>(
    mesh: &MeshTree,
    r: &Ray1x,
    inst: u32,
    start: Option<(usize, f32, f32)>,
    mailbox: bool,
    q: &mut Q,
    c: &mut C,
) -> bool {
    let (node, tn, tf) = match start {
        Some(s) => s,
        None => match r.clip(&mesh.tree.bounds, q.limit()) {
            Some((t0, t1)) => (0, t0, t1),
            None => return false,
        },
    };
    let mut mb = Mailbox1::new();
    let tris = &mesh.tris[..];
    walk1(
        &mesh.tree,
        r,
        node,
        tn,
        tf,
        q,
        c,
        #[inline(always)]
        |q| q.limit(),
        #[inline(always)]
        |q, c, _, items| {
            for &i in items {
                if mailbox && mb.seen(i) {
                    c.mailbox_skip(1);
                    continue;
                }
                c.tri_test(1);
                let tri = &tris[i as usize];
                if let Some((t, u, v)) = tri.intersect1x(&r.o, &r.d, r.tmin, q.limit()) {
                    let h = Hit1 {
                        t,
                        u,
                        v,
                        prim: tri.prim,
                        inst,
                    };
                    if q.hit(h) {
                        return true;
                    }
                }
            }
            false
        },
    )
}

/// [`mesh1`] testing the leaves' triangles four at a time (`blocks`, the mesh's
/// [`crate::Leaves4`]), from the root over the ray's part inside the mesh box. Only world rays
/// entering a mesh take it; a packet lane continuing ray by ray keeps [`mesh1`].
#[inline(always)]
fn mesh1_blocks<Q: Query1, C: Counters>(
    mesh: &MeshTree,
    l4: &crate::Leaves4,
    r: &Ray1x,
    inst: u32,
    q: &mut Q,
    c: &mut C,
) -> bool {
    let Some((tn, tf)) = r.clip(&mesh.tree.bounds, q.limit()) else {
        return false;
    };
    let r4 = Ray4::new(&r.o, &r.d);
    walk1(
        &mesh.tree,
        r,
        0,
        tn,
        tf,
        q,
        c,
        #[inline(always)]
        |q| q.limit(),
        #[inline(always)]
        |q, c, node, items| {
            for b in l4.of(node, items.len()) {
                c.tri_test(1);
                let (mut m, t, u, v) = b.intersect(&r4, r.tmin, q.limit());
                // Lane by lane in the leaf's order, as one record after the other.
                while m != 0 {
                    let j = m.trailing_zeros() as usize;
                    m &= m - 1;
                    if t[j] < q.limit() {
                        let h = Hit1 {
                            t: t[j],
                            u: u[j],
                            v: v[j],
                            prim: b.prim[j],
                            inst,
                        };
                        if q.hit(h) {
                            return true;
                        }
                    }
                }
            }
            false
        },
    )
}

/// A world-space ray through the whole scene (the ray must be valid).
#[inline(always)]
pub(crate) fn scene1<Q: Query1, C: Counters>(
    bsp: &Bsp,
    o: Vec3,
    d: Vec3,
    tmin: f32,
    q: &mut Q,
    c: &mut C,
) {
    let r = Ray1x::new(o, d, tmin);
    let enter = |q: &mut Q, c: &mut C, i: u32| enter1(bsp, &r, (o, d), i, q, c);
    let root = bsp.top.nodes[0];
    if root.is_leaf() {
        // Few instances: no top-level walk, each instance's box test culls.
        for &i in &bsp.top.items[root.items()] {
            if enter(q, c, i) {
                return;
            }
        }
        return;
    }
    let Some((t0, t1)) = r.clip(&bsp.top.bounds, q.limit()) else {
        return;
    };
    let mut seen = Mailbox1::new();
    walk1(
        &bsp.top,
        &r,
        0,
        t0,
        t1,
        q,
        c,
        #[inline(always)]
        |q| q.limit(),
        #[inline(always)]
        |q, c, _, items| {
            for &i in items {
                if !seen.seen(i) && enter(q, c, i) {
                    return true;
                }
            }
            false
        },
    );
}

/// Instance `i` for the world-space ray `r` (`od`: its origin and direction).
#[inline(always)]
fn enter1<Q: Query1, C: Counters>(
    bsp: &Bsp,
    r: &Ray1x,
    od: (Vec3, Vec3),
    i: u32,
    q: &mut Q,
    c: &mut C,
) -> bool {
    let inst = &bsp.instances[i as usize];
    let mesh = &bsp.meshes[inst.mesh as usize];
    c.instance(1);
    let moved;
    let r = if inst.identity {
        r
    } else {
        let m = &inst.object_from_world;
        moved = Ray1x::new(
            transform_point1(m, od.0),
            transform_vector1(m, od.1),
            r.tmin,
        );
        &moved
    };
    match &mesh.leaves4 {
        Some(l4) => mesh1_blocks(mesh, l4, r, i, q, c),
        None => mesh1(mesh, r, i, None, bsp.params.mailbox, q, c),
    }
}

/// One lane of a packet continuing ray by ray in a mesh subtree.
pub(crate) struct MeshTask<'a, C: Counters> {
    pub mesh: &'a MeshTree,
    pub r: Ray1x,
    pub inst: u32,
    pub start: (usize, f32, f32),
    pub mailbox: bool,
    pub c: &'a mut C,
}

impl<C: Counters> LaneTask for MeshTask<'_, C> {
    #[inline(always)]
    fn run<Q: Query1>(&mut self, q: &mut Q) {
        mesh1(
            self.mesh,
            &self.r,
            self.inst,
            Some(self.start),
            self.mailbox,
            q,
            self.c,
        );
    }
}
