//! Beam traversal of the two-level BSP: many packets of coherent rays (a tile of camera
//! rays, a tile's shadow rays toward one point) walk the trees as groups. Beyond the paper,
//! after Reshetov, Soupikov & Hurley 2005: the group decides each node once for all its
//! packets and shares one stack ([`crate::group`]).
//!
//! - A beam is cut into groups of [`group_size`] packets (16 at 16 lanes, 8 at 8, 4 at 4),
//!   in the caller's packet order (for camera tiles: 4 x 4 sub-tiles in Morton order, so
//!   each group is a compact part of the tile). A beam of one packet is that packet's lane
//!   walk: a group of one has nothing to share (so is every beam of the scalar backend).
//! - Each group of equal direction signs walks as a group of its own (in world space, and
//!   again per group in an instance's object space); lanes with a zero or subnormal
//!   direction component go ray by ray. Both are counted ([`Counters::beam_mixed`]: lanes
//!   outside the largest sign group; [`Counters::beam_fallback`]: the ray-by-ray ones).
//! - The top tree: the group walks it; at a leaf each instance is entered once per packet
//!   (a mailbox of packet slots per instance), only by the packets whose bounds reach the
//!   instance's world box, and only those packets are moved into object space and bounded
//!   again there.
//!
//! The answers are those of the packet walk: every ray visits at least the leaves its own
//! walk would, and hits only ever replace farther ones.

use std::mem::MaybeUninit;
use std::time::Instant;

use coherent_accel::{Aabb, Rays, TriAccel};
use coherent_simd::{Lanes, SimdF32, SimdMask};

use crate::KdTree;
use crate::bsp::{Bsp, MeshTree};
use crate::counters::Counters;
use crate::frustum::{Culler, Frustum, FrustumBuilder};
use crate::group::{Bounds, GROUP, GroupLeaf, Slots, entry_point, group_size, walk_group};
use crate::mailbox::MailboxP;
use crate::query::{LaneTask, Query1, QueryP};
use crate::walk::{RaysX, clip_box, leaf_packet};
use crate::walk1::Ray1x;

/// The packets of a group as one tree's walk sees them (world or object space), and the
/// sign group being walked.
struct Group<L: Lanes> {
    /// Prepared rays per slot, written before a slot is used (never initialised as a whole:
    /// the group is set up once per beam and per instance entered).
    rx: [MaybeUninit<RaysX<L>>; GROUP],
    /// Per slot, the lanes to trace.
    base: [L::Mask; GROUP],
    /// Per slot: the lanes with finite inverse directions, and per axis the lanes whose
    /// direction is negative along it.
    bits: [(u32, [u32; 3]); GROUP],
    /// Per slot, the lanes of the sign group being walked.
    m: [L::Mask; GROUP],
    b: Bounds,
    /// How many lanes have each sign pattern (bit k: negative along axis k).
    counts: [u32; 8],
    /// The sign group's direction sign bits.
    neg: u32,
    /// The sign group's frustum, when leaves cull against it.
    fr: Option<Frustum>,
}

impl<L: Lanes> Group<L> {
    #[inline(always)]
    fn new(l: L) -> Self {
        let none = l.splat_mask(false);
        Self {
            rx: [const { MaybeUninit::uninit() }; GROUP],
            base: [none; GROUP],
            bits: [(0, [0; 3]); GROUP],
            m: [none; GROUP],
            b: Bounds::EMPTY,
            counts: [0; 8],
            neg: 0,
            fr: None,
        }
    }

    /// Slot `j`'s rays (written by [`Group::set_rays`]).
    #[inline(always)]
    fn rx(&self, j: usize) -> &RaysX<L> {
        // SAFETY: every slot a walk, a count or a selection reads was written first: the
        // slots they take are among those the caller set (`set_rays`) for this group.
        unsafe { self.rx[j].assume_init_ref() }
    }

    /// Sets slot `j`'s rays and the lanes to trace.
    #[inline(always)]
    fn set_rays(&mut self, j: usize, r: RaysX<L>, lanes: L::Mask) {
        self.rx[j] = MaybeUninit::new(r);
        self.base[j] = lanes;
    }

    /// Counts the sign patterns of slots `slots` (their `rx` and `base` set). Returns, per
    /// slot, the lanes no sign group can take (a zero or subnormal direction component: an
    /// infinite inverse) in `odd`.
    #[inline(always)]
    fn prepare(&mut self, l: L, slots: u32, odd: &mut [L::Mask; GROUP]) {
        self.counts = [0; 8];
        let inf = l.splat(f32::INFINITY);
        let mut s = slots;
        while s != 0 {
            let j = s.trailing_zeros() as usize;
            s &= s - 1;
            let r = self.rx(j);
            // Finite inverse directions only: the bounds' products must not meet 0 * inf.
            let finite = self.base[j]
                & r.inv[0].abs().lt(inf)
                & r.inv[1].abs().lt(inf)
                & r.inv[2].abs().lt(inf);
            let fb = finite.bitmask();
            let nb = [r.neg[0].bitmask(), r.neg[1].bitmask(), r.neg[2].bitmask()];
            let mut rest = fb;
            while rest != 0 {
                let i = rest.trailing_zeros();
                rest &= rest - 1;
                let p = (nb[0] >> i & 1) | (nb[1] >> i & 1) << 1 | (nb[2] >> i & 1) << 2;
                self.counts[p as usize] += 1;
            }
            odd[j] = self.base[j].and_not(finite);
            self.bits[j] = (fb, nb);
        }
    }

    /// Makes the lanes of sign pattern `g` in slots `slots` the group walked: their masks,
    /// bounds and (`cull`) frustum. Returns the slots with lanes in it.
    #[inline(always)]
    fn select(&mut self, l: L, g: u32, slots: u32, cull: bool) -> u32 {
        let pick = |n: u32, bit: u32| if bit != 0 { n } else { !n };
        self.neg = g;
        self.b = Bounds::EMPTY;
        self.fr = None;
        let mut frb: Option<FrustumBuilder<L>> = None;
        let mut with = 0;
        let mut s = slots;
        while s != 0 {
            let j = s.trailing_zeros() as usize;
            s &= s - 1;
            let (fb, nb) = self.bits[j];
            let keep = fb & pick(nb[0], g & 1) & pick(nb[1], g >> 1 & 1) & pick(nb[2], g >> 2 & 1);
            if keep != 0 {
                self.m[j] = l.mask_from_bits(keep);
                // SAFETY: as in `Group::rx` (a field borrow, apart from `b`'s).
                let r = unsafe { self.rx[j].assume_init_ref() };
                self.b.set(l, j, r, self.m[j]);
                if cull {
                    if frb.is_none() {
                        frb = Some(FrustumBuilder::new(l, r, self.m[j]));
                    }
                    if let Some(f) = frb.as_mut() {
                        f.add(l, r, self.m[j]);
                    }
                }
                with |= 1 << j;
            }
        }
        if let Some(f) = frb {
            self.fr = f.finish(g);
        }
        with
    }

    /// The lanes of the sign group in slots `slots`.
    #[inline(always)]
    fn lanes(&self, slots: u32) -> u32 {
        let mut n = 0;
        let mut s = slots;
        while s != 0 {
            let j = s.trailing_zeros() as usize;
            s &= s - 1;
            n += self.m[j].count();
        }
        n
    }
}

/// The sign pattern most lanes have.
#[inline(always)]
fn largest(counts: &[u32; 8]) -> u32 {
    let mut best = 0;
    for g in 1..8 {
        if counts[g] > counts[best] {
            best = g;
        }
    }
    best as u32
}

/// The queries of a world group's packets and each one's highest limit over the group's
/// lanes, taken again after each leaf where the packet found hits (never per node).
struct Queries<'a, L: Lanes, Q> {
    qs: &'a mut [Q],
    /// Per slot, the world group's lanes (object-space groups may hold fewer: the limit is
    /// always over all of them).
    m: [L::Mask; GROUP],
    lim: Slots,
}

impl<L: Lanes, Q: QueryP<L>> Queries<'_, L, Q> {
    /// Takes slot `j`'s limit again.
    #[inline(always)]
    fn update<C: Counters>(&mut self, l: L, j: usize, c: &mut C) {
        c.limit_reduction();
        self.lim[j] = self.m[j]
            .select(self.qs[j].limit(), l.splat(f32::NEG_INFINITY))
            .reduce_max();
    }
}

/// The most items of a leaf culled against a group's frustum (leaves are small: more is
/// rare and tested whole).
const CULL_MAX: usize = 64;

/// A mesh's leaves for a group: each packet that reaches a leaf tests its triangles.
struct MeshLeaf<'a, 'q, L: Lanes, Q> {
    l: L,
    tris: &'a [TriAccel],
    boxes: &'a [Aabb],
    /// The group's frustum against the mesh's triangle boxes, when culling.
    cull: Option<Culler>,
    g: &'a Group<L>,
    q: &'a mut Queries<'q, L, Q>,
    mb: [MailboxP; GROUP],
    inst: u32,
    mailbox: bool,
}

impl<L: Lanes, Q: QueryP<L>, C: Counters> GroupLeaf<C> for MeshLeaf<'_, '_, L, Q> {
    #[inline(always)]
    fn limits(&self) -> &Slots {
        &self.q.lim
    }

    #[inline(always)]
    fn leaf(&mut self, c: &mut C, items: &[u32], active: u32, vox: &Aabb) {
        let l = self.l;
        // The items no ray of the group can hit are skipped for every packet (a leaf of more
        // than `CULL_MAX` items is tested whole).
        let mut kept = [0u32; CULL_MAX];
        let items = match &self.cull {
            Some(f) if items.len() <= CULL_MAX => {
                let mut n = 0;
                for &i in items {
                    if f.outside(&self.boxes[i as usize]) {
                        c.tri_culled();
                    } else {
                        kept[n] = i;
                        n += 1;
                    }
                }
                if n == 0 {
                    return;
                }
                &kept[..n]
            }
            _ => items,
        };
        let mut s = active;
        while s != 0 {
            let j = s.trailing_zeros() as usize;
            s &= s - 1;
            let (m, r) = (self.g.m[j], self.g.rx(j));
            let q = &mut self.q.qs[j];
            // The packet's lanes that are inside the voxel before their limits: its bounds
            // reached it, its rays may not.
            let (t0, t1) = clip_box(l, vox, &r.o, &r.inv, r.tmin, q.limit());
            let m = m & t0.le(t1);
            if m.none() {
                continue;
            }
            let mb = self.mailbox.then_some(&mut self.mb[j]);
            let found = leaf_packet(l, self.tris, items, r, m, self.inst, mb, q, c);
            if found {
                self.q.update(l, j, c);
            }
        }
    }
}

/// The top tree's leaves for a world group: each instance entered once per packet.
struct TopLeaf<'a, 'q, L: Lanes, Q> {
    l: L,
    bsp: &'a Bsp,
    rays: &'a [Rays<L>],
    world: &'a Group<L>,
    q: Queries<'q, L, Q>,
    /// Per instance, the slots that entered it already.
    seen: MailboxP,
    /// Scratch: the group in an instance's object space.
    obj: &'a mut Group<L>,
    /// The entry points the beam's groups share (beams of more than one group).
    ep: Option<&'a mut Entries>,
}

impl<L: Lanes, Q: QueryP<L>, C: Counters> GroupLeaf<C> for TopLeaf<'_, '_, L, Q> {
    #[inline(always)]
    fn limits(&self) -> &Slots {
        &self.q.lim
    }

    #[inline(always)]
    fn leaf(&mut self, c: &mut C, items: &[u32], active: u32, _vox: &Aabb) {
        for &i in items {
            let new = self.seen.untested(i, active);
            if new != 0 {
                self.enter(c, i, new);
            }
        }
    }
}

impl<L: Lanes, Q: QueryP<L>> TopLeaf<'_, '_, L, Q> {
    /// Instance `i` for the world group's slots `slots`: the slots whose bounds reach its
    /// world box, moved into object space when it has a transform and grouped by signs
    /// there.
    #[inline(always)]
    fn enter<C: Counters>(&mut self, c: &mut C, i: u32, slots: u32) {
        let (l, bsp) = (self.l, self.bsp);
        let inst = &bsp.instances[i as usize];
        let mesh = &bsp.meshes[inst.mesh as usize];
        let w = self.world;
        let box_slabs = w.b.slabs(l, &inst.world_bounds, w.neg);
        let slots = slots & box_slabs.open(l, &w.b.tmin, &self.q.lim);
        if slots == 0 {
            return;
        }
        // Where the mesh walk starts: an untransformed instance's entry point for the beam's
        // main signs, else the root.
        let root = (0, mesh.tree.bounds);
        let start = match self.ep.as_deref_mut() {
            Some(e) if inst.identity && e.neg == w.neg => l.apart(
                #[inline(always)]
                |l| e.mesh(l, &mesh.tree, i, c),
            ),
            _ => Some(root),
        };
        let Some(start) = start else {
            return;
        };
        let o = &mut *self.obj;
        if !inst.identity {
            let mut s = slots;
            while s != 0 {
                let j = s.trailing_zeros() as usize;
                s &= s - 1;
                let r = self.rays[j].transformed(l, &inst.object_from_world);
                o.set_rays(j, RaysX::new(l, &r.origin, &r.dir, r.tmin), w.m[j]);
                c.packets_transformed(1);
            }
            let mut odd = [l.splat_mask(false); GROUP];
            o.prepare(l, slots, &mut odd);
            let mut s = slots;
            while s != 0 {
                let j = s.trailing_zeros() as usize;
                s &= s - 1;
                let mut bits = odd[j].bitmask();
                while bits != 0 {
                    let k = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    c.beam_fallback(1);
                    let mut task = ObjectTask {
                        mesh,
                        r: o.rx(j).lane(k),
                        inst: i,
                        mailbox: bsp.params.mailbox,
                        c: &mut *c,
                    };
                    self.q.qs[j].with_lane(l, k, &mut task);
                    self.q.update(l, j, c);
                }
            }
        }
        let big = largest(&o.counts);
        // One walk per sign group (the world group's as it is for an untransformed
        // instance): one call site, so the walk is compiled once.
        for g in 0..8u32 {
            let (grp, with): (&Group<L>, u32) = if inst.identity {
                if g > 0 {
                    break;
                }
                (w, slots)
            } else {
                if o.counts[g as usize] == 0 {
                    continue;
                }
                if g != big {
                    c.beam_mixed(o.counts[g as usize]);
                }
                let with = o.select(l, g, slots, bsp.params.beam_cull);
                (&*o, with)
            };
            c.instance(grp.lanes(with));
            let (q, mailbox) = (&mut self.q, bsp.params.mailbox);
            l.apart(
                #[inline(always)]
                |l| walk_mesh(l, mesh, start, i, grp, with, q, mailbox, c),
            );
        }
    }
}

/// Group `g`'s slots `slots` through instance `inst`'s mesh.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn walk_mesh<L: Lanes, Q: QueryP<L>, C: Counters>(
    l: L,
    mesh: &MeshTree,
    start: (u32, Aabb),
    inst: u32,
    g: &Group<L>,
    slots: u32,
    q: &mut Queries<'_, L, Q>,
    mailbox: bool,
    c: &mut C,
) {
    let mut leaf = MeshLeaf {
        l,
        tris: &mesh.tris,
        boxes: &mesh.boxes,
        // A match, not `Option::map`: a closure may stay out of the kernel's features.
        #[allow(clippy::manual_map)]
        cull: match &g.fr {
            Some(f) => Some(f.culler(&mesh.tree.bounds)),
            None => None,
        },
        g,
        q,
        mb: [const { MailboxP::EMPTY }; GROUP],
        inst,
        mailbox,
    };
    walk_group(l, &mesh.tree, start, &g.b, g.neg, slots, &mut leaf, c);
}

/// A beam through the whole scene: packets `rays` under `active`, one query each, in groups
/// of [`group_size`] packets (a group of one, and any packet of the scalar backend, is the
/// packet walk).
#[inline(always)]
pub(crate) fn scene_beam<L: Lanes, Q: QueryP<L>, C: Counters>(
    l: L,
    bsp: &Bsp,
    rays: &[Rays<L>],
    active: &[L::Mask],
    qs: &mut [Q],
    c: &mut C,
) {
    let n = rays.len();
    // Entry points the groups share, when there is more than one group.
    // Out of line (`Lanes::apart`), as the group walks: this function is inlined into every
    // caller's kernel.
    let mut ep = if L::N > 1 && n > group_size::<L>() {
        l.apart(
            #[inline(always)]
            |l| Entries::new(l, bsp, rays, active, c),
        )
    } else {
        None
    };
    let mut a = 0;
    while a < n {
        let b = (a + group_size::<L>()).min(n);
        if L::N == 1 || b - a == 1 {
            crate::walk::scene_packet(l, bsp, &rays[a], active[a], &mut qs[a], c);
        } else {
            // A function of its own: the group walks are large, and LLVM optimises a
            // function in time superlinear in its size (the lane walk above stays inline).
            let (rays, active, qs) = (&rays[a..b], &active[a..b], &mut qs[a..b]);
            let ep = ep.as_mut();
            l.apart(
                #[inline(always)]
                |l| group_beam(l, bsp, rays, active, qs, ep, c),
            );
        }
        a = b;
    }
}

/// One group of up to [`group_size`] packets through the whole scene.
#[inline(always)]
fn group_beam<L: Lanes, Q: QueryP<L>, C: Counters>(
    l: L,
    bsp: &Bsp,
    rays: &[Rays<L>],
    active: &[L::Mask],
    qs: &mut [Q],
    mut ep: Option<&mut Entries>,
    c: &mut C,
) {
    let t0 = C::TIMED.then(Instant::now);
    let n = rays.len();
    debug_assert!(n <= group_size::<L>());
    let all = (1u32 << n) - 1;
    let mut world = Group::new(l);
    for j in 0..n {
        let r = &rays[j];
        let rx = RaysX::new(l, &r.origin, &r.dir, r.tmin);
        world.set_rays(j, rx, active[j] & r.valid(l));
    }
    let mut odd = [l.splat_mask(false); GROUP];
    world.prepare(l, all, &mut odd);
    if let Some(t0) = t0 {
        c.beam_setup(t0.elapsed().as_nanos() as u64);
    }
    for j in 0..n {
        let mut bits = odd[j].bitmask();
        while bits != 0 {
            let i = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            c.beam_fallback(1);
            let r = rays[j].lane(i);
            qs[j].with_lane(l, i, &mut SceneTask { bsp, r, c: &mut *c });
        }
    }
    let big = largest(&world.counts);
    let ninf = l.splat(f32::NEG_INFINITY);
    let mut obj = Group::new(l);
    for g in 0..8u32 {
        let count = world.counts[g as usize];
        if count == 0 {
            continue;
        }
        if g != big {
            c.beam_mixed(count);
        }
        let t0 = C::TIMED.then(Instant::now);
        // The beam's entry point into the top tree for its main signs.
        let start = match ep.as_deref() {
            Some(e) if e.neg == g => e.top,
            _ => Some((0, bsp.top.bounds)),
        };
        let Some(start) = start else {
            continue;
        };
        let with = world.select(l, g, all, bsp.params.beam_cull);
        let mut lim = [f32::NEG_INFINITY; GROUP];
        for j in 0..n {
            lim[j] = world.m[j].select(qs[j].limit(), ninf).reduce_max();
        }
        if let Some(t0) = t0 {
            c.beam_setup(t0.elapsed().as_nanos() as u64);
        }
        let mut top = TopLeaf {
            l,
            bsp,
            rays,
            world: &world,
            q: Queries {
                qs: &mut *qs,
                m: world.m,
                lim,
            },
            seen: MailboxP::EMPTY,
            obj: &mut obj,
            ep: ep.as_deref_mut(),
        };
        walk_group(l, &bsp.top, start, &world.b, world.neg, with, &mut top, c);
    }
}

/// Entry points into the trees shared by the groups of a beam of more than one group (each
/// group's walk from the root would repeat the same steps above them): found once per beam
/// with the bounds of all its groups (one slot per group) for the lanes of its main sign
/// pattern (those of its first packet's majority), and taken by those lanes of each group.
/// The top tree's is found at once; those of the meshes of untransformed instances as groups
/// first enter them (up to [`MESH_ENTRIES`] meshes; the others' walks start at their roots).
struct Entries {
    neg: u32,
    b: Bounds,
    slots: u32,
    /// The top tree's (`None`: those lanes reach no instance).
    top: Option<(u32, Aabb)>,
    /// Per instance entered so far, its mesh's (`None`: no leaf reached).
    meshes: [(u32, Option<(u32, Aabb)>); MESH_ENTRIES],
    known: usize,
}

/// The most untransformed instances a beam keeps its entry points into.
const MESH_ENTRIES: usize = 16;

impl Entries {
    /// The bounds and the top tree's entry point of beam `rays` (`None` when it has more
    /// groups than a bound has slots, or no lane of the main signs).
    #[inline(always)]
    fn new<L: Lanes, C: Counters>(
        l: L,
        bsp: &Bsp,
        rays: &[Rays<L>],
        active: &[L::Mask],
        c: &mut C,
    ) -> Option<Self> {
        let gs = group_size::<L>();
        let groups = rays.len().div_ceil(gs);
        if groups > GROUP {
            return None;
        }
        let inf = l.splat(f32::INFINITY);
        let all = l.splat_mask(true);
        let mut b = Bounds::UNION;
        let mut neg = 0;
        for j in 0..rays.len() {
            let r = &rays[j];
            let rx = RaysX::new(l, &r.origin, &r.dir, r.tmin);
            let mut m = active[j]
                & r.valid(l)
                & rx.inv[0].abs().lt(inf)
                & rx.inv[1].abs().lt(inf)
                & rx.inv[2].abs().lt(inf);
            if j == 0 {
                let mut counts = [0u32; 8];
                let nb = [
                    rx.neg[0].bitmask(),
                    rx.neg[1].bitmask(),
                    rx.neg[2].bitmask(),
                ];
                let mut bits = m.bitmask();
                while bits != 0 {
                    let i = bits.trailing_zeros();
                    bits &= bits - 1;
                    let p = (nb[0] >> i & 1) | (nb[1] >> i & 1) << 1 | (nb[2] >> i & 1) << 2;
                    counts[p as usize] += 1;
                }
                neg = largest(&counts);
            }
            for k in 0..3 {
                m &= if neg >> k & 1 != 0 {
                    rx.neg[k]
                } else {
                    all.and_not(rx.neg[k])
                };
            }
            b.grow(l, j / gs, &rx, m);
        }
        let slots = (1u32 << groups) - 1;
        let lim = [f32::INFINITY; GROUP];
        let top = entry_point(l, &bsp.top, &b, neg, slots, &lim, c);
        Some(Self {
            neg,
            b,
            slots,
            top,
            meshes: [(0, None); MESH_ENTRIES],
            known: 0,
        })
    }

    /// Where the beam's groups start in the mesh `tree` of untransformed instance `inst`
    /// (`None`: they reach none of its leaves).
    #[inline(always)]
    fn mesh<L: Lanes, C: Counters>(
        &mut self,
        l: L,
        tree: &KdTree,
        inst: u32,
        c: &mut C,
    ) -> Option<(u32, Aabb)> {
        for k in 0..self.known {
            if self.meshes[k].0 == inst {
                return self.meshes[k].1;
            }
        }
        if self.known == MESH_ENTRIES {
            return Some((0, tree.bounds));
        }
        let lim = [f32::INFINITY; GROUP];
        let e = entry_point(l, tree, &self.b, self.neg, self.slots, &lim, c);
        self.meshes[self.known] = (inst, e);
        self.known += 1;
        e
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
