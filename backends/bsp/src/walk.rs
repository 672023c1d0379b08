//! Packet traversal of the two-level BSP, as in paper section 3 (after Wald et al. 2001):
//! the packet is tested against the scene box and walked near/far with an explicit stack;
//! masks block lanes that do not enter a child or have finished. The paper (after Wald)
//! splits a packet into groups of equal direction signs first; by default
//! ([`crate::BspParams::mixed_signs`]) lanes of mixed signs walk together, each lane choosing
//! its own near child; a node is skipped when every active lane's hit is nearer than it. When a
//! subtree's active lanes fall to a threshold, its lanes continue ray by ray.

use coherent_accel::triangle::xyzz_s;
use coherent_accel::{Aabb, Rays, TriAccel, Vec3s};
use coherent_simd::{Lanes, SimdF32, SimdI32, SimdMask};
use glam::Vec3;

use crate::KdTree;
use crate::bsp::{Bsp, MeshTree};
use crate::counters::Counters;
use crate::mailbox::MailboxP;
use crate::query::QueryP;
use crate::stack::Stack;
use crate::walk1::{MeshTask, Ray1x, SLACK};

/// A subtree still to visit: node, per-lane segment, lanes.
#[derive(Clone, Copy)]
struct Entry<L: Lanes> {
    node: u32,
    tn: L::F32s,
    tf: L::F32s,
    m: L::Mask,
}

/// Rays prepared for traversal: vectors as `[x, y, z, z]` (indexed by an axis `& 3`).
#[derive(Clone, Copy)]
pub(crate) struct RaysX<L: Lanes> {
    pub o: [L::F32s; 4],
    pub d: [L::F32s; 4],
    /// `1 / d` per lane and axis (infinite for zero components).
    pub inv: [L::F32s; 4],
    pub tmin: L::F32s,
    /// Per axis (`[x, y, z, z]`), the lanes whose direction is negative along it.
    pub neg: [L::Mask; 4],
    /// Bit `k` set when most lanes of the group walked have a negative direction along axis
    /// `k` (all of them, for a group of equal signs): the group's near child of a split on
    /// `k` is then the right one.
    pub signs: u32,
    /// Bit `k` set when the group's lanes differ in direction sign along axis `k`; `minor[k]`
    /// then holds the lanes against the majority, whose near child is the group's far one.
    pub mixed: u32,
    pub minor: [L::Mask; 4],
}

impl<L: Lanes> RaysX<L> {
    #[inline(always)]
    pub fn new(l: L, o: &Vec3s<L>, d: &Vec3s<L>, tmin: L::F32s) -> Self {
        let one = l.splat(1.0);
        let zero = l.splat_i32(0);
        let nz = d.z.to_bits().lt(zero);
        Self {
            o: xyzz_s(o),
            d: xyzz_s(d),
            inv: [one / d.x, one / d.y, one / d.z, one / d.z],
            tmin,
            neg: [d.x.to_bits().lt(zero), d.y.to_bits().lt(zero), nz, nz],
            signs: 0,
            mixed: 0,
            minor: [l.splat_mask(false); 4],
        }
    }

    /// Lane `i` as a single ray.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Ray1x {
        Ray1x::new(lane3(&self.o, i), lane3(&self.d, i), self.tmin.lane(i))
    }
}

/// Lane `i` of a packet vector as [`Vec3`] (a function, not a closure called twice: it must
/// inline into the target-feature kernels).
#[inline(always)]
fn lane3<F: SimdF32>(a: &[F; 4], i: usize) -> Vec3 {
    Vec3::new(a[0].lane(i), a[1].lane(i), a[2].lane(i))
}

/// The ray segments inside box `b`, cut to `[t0, t1]`, with the arithmetic of
/// [`Aabb::clip1`] per lane (a lane misses when the result has `t0 > t1`).
#[inline(always)]
pub(crate) fn clip_box<L: Lanes>(
    l: L,
    b: &Aabb,
    o: &[L::F32s; 4],
    inv: &[L::F32s; 4],
    mut t0: L::F32s,
    mut t1: L::F32s,
) -> (L::F32s, L::F32s) {
    let (ninf, inf) = (l.splat(f32::NEG_INFINITY), l.splat(f32::INFINITY));
    for k in 0..3 {
        let a = (l.splat(b.min[k]) - o[k]) * inv[k];
        let c = (l.splat(b.max[k]) - o[k]) * inv[k];
        // NaN: a ray in a face plane with a zero direction component; the slab does not
        // limit it.
        let nan = a.is_nan() | c.is_nan();
        let lo = nan.select(ninf, a.min(c));
        let hi = nan.select(inf, a.max(c));
        t0 = lo.max(t0);
        t1 = hi.min(t1);
    }
    (widen_lo(l, t0), widen_hi(l, t1))
}

/// `x` moved down by [`SLACK`] relative, per lane.
#[inline(always)]
pub(crate) fn widen_lo<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    x - x.abs() * l.splat(SLACK)
}

/// `x` moved up by [`SLACK`] relative, per lane.
#[inline(always)]
pub(crate) fn widen_hi<L: Lanes>(l: L, x: L::F32s) -> L::F32s {
    x + x.abs() * l.splat(SLACK)
}

/// Calls `f(group, r)` for each group of the lanes `m` of `r` with equal direction signs, or
/// once with all of `m` when `together` (see [`walk`]), with `r`'s `signs`, `mixed` and
/// `minor` set for the group. `f` has one call site: the walk inlined into it is compiled
/// once.
#[inline(always)]
pub(crate) fn sign_groups<L: Lanes>(
    l: L,
    r: &mut RaysX<L>,
    m: L::Mask,
    together: bool,
    mut f: impl FnMut(L::Mask, &RaysX<L>),
) {
    let all = m.bitmask();
    let neg = [r.neg[0].bitmask(), r.neg[1].bitmask(), r.neg[2].bitmask()];
    let mut rest = all;
    while rest != 0 {
        let group = if together {
            rest
        } else {
            let i = rest.trailing_zeros();
            let mut group = rest;
            for n in neg {
                // Lanes whose sign bit along this axis equals lane i's.
                group &= !(n ^ 0u32.wrapping_sub(n >> i & 1));
            }
            group
        };
        rest &= !group;
        let gm = if group == all {
            m
        } else {
            m & l.mask_from_bits(group)
        };
        // Signs and mixed axes from the bitmasks; the minority masks only where needed (a
        // stale `minor[k]` is never read while bit `k` of `mixed` is clear).
        let lanes = group.count_ones();
        (r.signs, r.mixed) = (0, 0);
        for (k, n) in neg.iter().enumerate() {
            let negs = (n & group).count_ones();
            let majority = 2 * negs > lanes;
            r.signs |= u32::from(majority) << k;
            if negs != 0 && negs != lanes {
                r.mixed |= 1 << k;
                r.minor[k] = if majority {
                    gm.and_not(r.neg[k])
                } else {
                    gm & r.neg[k]
                };
            }
        }
        r.signs |= (r.signs >> 2 & 1) << 3;
        r.mixed |= (r.mixed >> 2 & 1) << 3;
        r.minor[3] = r.minor[2];
        f(gm, r);
    }
}

/// Walks `tree` from `start` with lanes `m` over per-lane segments `[tn, tf]`, front to
/// back, calling `leaf(s, c, items, lanes)` at each leaf. At each split every lane goes to
/// the child or children its own segment reaches. The near child is the group's (`r.signs`);
/// on an axis along which the lanes differ in sign (`r.mixed`), the minority's near child is
/// the group's far one, so those lanes may meet their leaves out of order. The answers stay
/// the same: first hits only ever replace farther ones, and entries beyond a lane's hit are
/// still skipped. Entries are skipped for lanes whose `limit(s)` is before them; the walk
/// ends as soon as `done(s)` (every lane of the query finished: occlusion found for all). A
/// subtree whose active lanes are at most `thr` goes to `single(s, c, node, lanes, tn, tf)`
/// instead (`thr = 0` never switches).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn walk<L: Lanes, S, C: Counters>(
    l: L,
    tree: &KdTree,
    r: &RaysX<L>,
    start: usize,
    mut tn: L::F32s,
    mut tf: L::F32s,
    mut m: L::Mask,
    thr: u32,
    s: &mut S,
    c: &mut C,
    limit: impl Fn(&S) -> L::F32s,
    done: impl Fn(&S) -> bool,
    mut leaf: impl FnMut(&mut S, &mut C, &[u32], L::Mask),
    mut single: impl FnMut(&mut S, &mut C, usize, L::Mask, L::F32s, L::F32s),
) {
    let nodes = &tree.nodes[..];
    let mut stack: Stack<Entry<L>> = Stack::new();
    let mut node = start;
    loop {
        if m.count() <= thr {
            c.handoff(m.count());
            single(s, c, node, m, tn, tf);
            if done(s) {
                return;
            }
        } else {
            loop {
                let n = nodes[node];
                if n.is_leaf() {
                    c.leaf();
                    leaf(s, c, &tree.items[n.items()], m);
                    if done(s) {
                        return;
                    }
                    break;
                }
                c.inner();
                let k = n.axis() & 3;
                let ts = (l.splat(n.split()) - r.o[k]) * r.inv[k];
                let sb = (r.signs >> k & 1) as usize;
                let near = n.left() + sb;
                let far = n.left() + 1 - sb;
                // Lanes that reach the near child (not `ts < tn`) and the far child (not
                // `ts > tf`); NaN lanes reach both.
                let go_near = m.and_not(ts.lt(tn));
                let go_far = m.and_not(ts.gt(tf));
                if r.mixed >> k & 1 != 0 {
                    // Lanes of mixed signs along `k`: for the minority (`minor[k]`), the
                    // group's near child is their far one. A step of its own, apart from the
                    // one below, so that packets of equal signs pay only this test (a bit
                    // that changes with the node's axis: the compiler does not copy the
                    // whole walk for it, as it would for a per-packet flag).
                    let mi = r.minor[k];
                    let flip = (go_near ^ go_far) & mi;
                    let (go_near, go_far) = (go_near ^ flip, go_far ^ flip);
                    if go_far.none() {
                        node = near;
                    } else if go_near.none() {
                        node = far;
                    } else {
                        let near_tf = widen_hi(l, ts.min(tf));
                        let far_tn = widen_lo(l, ts.max(tn));
                        stack.push(Entry {
                            node: far as u32,
                            tn: mi.select(tn, far_tn),
                            tf: mi.select(near_tf, tf),
                            m: go_far,
                        });
                        node = near;
                        (tn, tf) = (mi.select(far_tn, tn), mi.select(tf, near_tf));
                        m = go_near;
                        if m.count() <= thr {
                            c.handoff(m.count());
                            single(s, c, node, m, tn, tf);
                            if done(s) {
                                return;
                            }
                            break;
                        }
                    }
                    continue;
                }
                if go_far.none() {
                    node = near;
                } else if go_near.none() {
                    node = far;
                } else {
                    stack.push(Entry {
                        node: far as u32,
                        tn: widen_lo(l, ts.max(tn)),
                        tf,
                        m: go_far,
                    });
                    node = near;
                    tf = widen_hi(l, ts.min(tf));
                    m = go_near;
                    if m.count() <= thr {
                        c.handoff(m.count());
                        single(s, c, node, m, tn, tf);
                        if done(s) {
                            return;
                        }
                        break;
                    }
                }
            }
        }
        // The next subtree some lane still needs.
        loop {
            let Some(e) = stack.pop() else {
                return;
            };
            let live = e.m & e.tn.le(limit(s));
            if live.any() {
                (node, tn, tf, m) = (e.node as usize, e.tn, e.tf, live);
                break;
            }
        }
    }
}

/// Walks one mesh from node `start` with an object-space packet group (lanes `m`, segments
/// `[tn, tf]` inside the node's voxel).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn mesh_packet<L: Lanes, Q: QueryP<L>, C: Counters>(
    l: L,
    mesh: &MeshTree,
    inst: u32,
    r: &RaysX<L>,
    start: usize,
    tn: L::F32s,
    tf: L::F32s,
    m: L::Mask,
    thr: u32,
    mailbox: bool,
    q: &mut Q,
    c: &mut C,
) {
    let mut mb = MailboxP::new();
    let tris = &mesh.tris[..];
    walk(
        l,
        &mesh.tree,
        r,
        start,
        tn,
        tf,
        m,
        thr,
        q,
        c,
        #[inline(always)]
        |q| q.limit(),
        #[inline(always)]
        |q| q.done(),
        #[inline(always)]
        |q, c, items, m| {
            leaf_packet(l, tris, items, r, m, inst, mailbox.then_some(&mut mb), q, c);
        },
        #[inline(always)]
        |q, c, node, m, tn, tf| {
            let mut bits = m.bitmask();
            while bits != 0 {
                let i = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let mut task = MeshTask {
                    mesh,
                    r: r.lane(i),
                    inst,
                    start: (node, tn.lane(i), tf.lane(i)),
                    mailbox,
                    c,
                };
                q.with_lane(l, i, &mut task);
            }
        },
    );
}

/// Lanes `m` of packet `r` test a leaf's triangles `items` (of `tris`, instance `inst`),
/// skipping those the packet's mailbox `mb` says were tested already; stops once the query
/// has finished `m`. Returns whether any lane found a hit.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn leaf_packet<L: Lanes, Q: QueryP<L>, C: Counters>(
    l: L,
    tris: &[TriAccel],
    items: &[u32],
    r: &RaysX<L>,
    m: L::Mask,
    inst: u32,
    mut mb: Option<&mut MailboxP>,
    q: &mut Q,
    c: &mut C,
) -> bool {
    let bits = m.bitmask();
    let mut found = false;
    for &i in items {
        let mut mm = m;
        if let Some(mb) = mb.as_deref_mut() {
            let new = mb.untested(i, bits);
            if new != bits {
                c.mailbox_skip((bits & !new).count_ones());
                if new == 0 {
                    continue;
                }
                mm = m & l.mask_from_bits(new);
            }
        }
        c.tri_test(mm.count());
        let tri = &tris[i as usize];
        let (hit, t, u, v) = tri.intersectx(l, &r.o, &r.d, r.tmin, q.limit(), mm);
        if hit.any() {
            q.hits(l, hit, t, u, v, tri.prim, inst);
            found = true;
            if q.finished(m) {
                break;
            }
        }
    }
    found
}

/// Enters instance `i` with world-space lanes `m`: moves them into object space, clips them
/// to the mesh box and walks the mesh (per sign group unless [`crate::BspParams::mixed_signs`]:
/// a transform may change signs).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn enter_instance<L: Lanes, Q: QueryP<L>, C: Counters>(
    l: L,
    bsp: &Bsp,
    i: u32,
    world: &Rays<L>,
    wr: &RaysX<L>,
    m: L::Mask,
    thr: u32,
    q: &mut Q,
    c: &mut C,
) {
    let inst = &bsp.instances[i as usize];
    let mesh = &bsp.meshes[inst.mesh as usize];
    if inst.identity {
        let (t0, t1) = clip_box(l, &mesh.tree.bounds, &wr.o, &wr.inv, wr.tmin, q.limit());
        let mm = m & t0.le(t1);
        if mm.any() {
            c.instance(mm.count());
            mesh_packet(l, mesh, i, wr, 0, t0, t1, mm, thr, bsp.params.mailbox, q, c);
        }
        return;
    }
    let obj = world.transformed(l, &inst.object_from_world);
    c.packets_transformed(1);
    let mut r = RaysX::new(l, &obj.origin, &obj.dir, wr.tmin);
    let (t0, t1) = clip_box(l, &mesh.tree.bounds, &r.o, &r.inv, wr.tmin, q.limit());
    let mm = m & t0.le(t1);
    if mm.none() {
        return;
    }
    c.instance(mm.count());
    sign_groups(
        l,
        &mut r,
        mm,
        bsp.params.mixed_signs,
        #[inline(always)]
        |g, r| {
            mesh_packet(l, mesh, i, r, 0, t0, t1, g, thr, bsp.params.mailbox, q, c);
        },
    );
}

/// A packet through the whole scene: lanes `active` of `rays` (invalid lanes dropped).
#[inline(always)]
pub(crate) fn scene_packet<L: Lanes, Q: QueryP<L>, C: Counters>(
    l: L,
    bsp: &Bsp,
    rays: &Rays<L>,
    active: L::Mask,
    q: &mut Q,
    c: &mut C,
) {
    let m = active & rays.valid(l);
    if m.none() {
        return;
    }
    let mut wr = RaysX::new(l, &rays.origin, &rays.dir, rays.tmin);
    // The scene box first (or the object's, with a single top leaf): lanes that miss it are
    // done.
    let thr = bsp.params.threshold_for(L::N);
    let root = bsp.top.nodes[0];
    if root.is_leaf() {
        // Few instances: no top-level walk, each instance's box test culls.
        sign_groups(
            l,
            &mut wr,
            m,
            bsp.params.mixed_signs,
            #[inline(always)]
            |g, wr| {
                for &i in &bsp.top.items[root.items()] {
                    enter_instance(l, bsp, i, rays, wr, g, thr, q, c);
                    if q.done() {
                        return;
                    }
                }
            },
        );
        return;
    }
    let (t0, t1) = clip_box(l, &bsp.top.bounds, &wr.o, &wr.inv, rays.tmin, q.limit());
    let m = m & t0.le(t1);
    if m.none() {
        return;
    }
    sign_groups(
        l,
        &mut wr,
        m,
        bsp.params.mixed_signs,
        #[inline(always)]
        |g, wr| {
            let mut seen = MailboxP::new();
            walk(
                l,
                &bsp.top,
                wr,
                0,
                t0,
                t1,
                g,
                0,
                q,
                c,
                #[inline(always)]
                |q| q.limit(),
                #[inline(always)]
                |q| q.done(),
                #[inline(always)]
                |q, c, items, m| {
                    let bits = m.bitmask();
                    for &i in items {
                        if q.done() {
                            return;
                        }
                        let new = seen.untested(i, bits);
                        if new == 0 {
                            continue;
                        }
                        let mm = if new == bits {
                            m
                        } else {
                            m & l.mask_from_bits(new)
                        };
                        enter_instance(l, bsp, i, rays, wr, mm, thr, q, c);
                    }
                },
                #[inline(always)]
                |_, _, _, _, _, _| {},
            );
        },
    );
}
