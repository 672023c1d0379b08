//! The renderer's batch driver: a film tile's packets through their ray trees, each
//! packet's tree depth-first (the paper's way), or regrouped.
//!
//! The paper's packets keep their four lanes from the camera to the film: a reflection or
//! refraction packet holds the lanes of its parent that hit a mirror or glass, and the rest
//! of its lanes idle through traversal and shading. Regrouping (the compaction of active
//! lanes across packets that stream tracers do) traces the camera packets of the whole batch
//! first, then the ray tree generation by generation: per node of the tree (the same depth,
//! kind and random-number stream), the full packets as they are and the lanes of the partial
//! ones from every packet of the batch compacted into full packets, in sample order (the
//! batch's packets, lane by lane) so that neighbouring samples stay together.
//!
//! Each lane keeps its random numbers (they derive from its sample id and its node of the
//! ray tree, both carried along), so a lane's radiance is what it is without regrouping, up
//! to the order in which its contributions are summed (breadth-first here, depth-first per
//! packet otherwise) and to which of two triangles sharing an edge it hits when its
//! packet-mates change.
//!
//! Both ways share one loop with one call of [`Renderer::segment`]: the whole pipeline is
//! inlined into each backend's kernel, and a second call site would be a second copy of it
//! per backend (build time and code size).

use coherent_accel::{Accel, Hits, Rays, Work};
use coherent_simd::{Lanes, MAX_LANES, Rgbs, SimdF32, SimdI32, SimdMask, Vec3s};

use super::colour::Colour;
use super::stats::StageClock;
use super::{AovBuffer, Differentials, Packets, RenderStats, Renderer, Segment, Stage};
use crate::film::{PacketIn, PacketOut};

/// The `f32` values a lane of a segment carries: origin, direction, `tmin`, `tmax`, the four
/// differential vectors and the throughput.
const FIELDS: usize = 23;

/// One lane of a segment, lifted out of its packet.
#[derive(Clone, Copy)]
struct Lane {
    f: [f32; FIELDS],
    light_id: i32,
    id: i32,
    slot: i32,
}

impl<A: Accel> Renderer<'_, A> {
    /// [`crate::film::SampleTracer::trace_batch`]: the radiance of each lane of `packets`,
    /// depth-first per packet, or regrouped when `self.regroup` is on. NaN lanes are counted
    /// in `stats.nan` and zeroed.
    #[inline(always)]
    pub(super) fn trace_batch_in<L: Lanes, C: Colour<L>>(
        &self,
        l: L,
        t: &C::Tables,
        packets: &[PacketIn],
        stats: &mut RenderStats,
    ) -> Vec<PacketOut> {
        let n = L::N;
        stats.width = n as u32;
        // Each sample's radiance (lane `m` of packet `i` at `i * n + m`).
        let mut acc = vec![[0.0f32; 3]; packets.len() * n];
        // Segments ready to trace (the top first): depth-first, a packet's children; with
        // regrouping, the packed segments of the current generation.
        let mut ready: Vec<Segment<L, C>> = Vec::new();
        // The children of the segment just traced.
        let mut children: Vec<Segment<L, C>> = Vec::new();
        // With regrouping, the next generation's segments as they come.
        let mut generation: Vec<Segment<L, C>> = Vec::new();
        let mut lanes: Vec<Lane> = Vec::new();
        let mut next_packet = 0;
        // With per-pixel maps, each sample's pixel (by slot) and one sample more there.
        let aov = self.aov.as_deref();
        let mut pixels: Vec<u32> = Vec::new();
        if let Some(a) = aov {
            pixels = vec![0; packets.len() * n];
            for (i, p) in packets.iter().enumerate() {
                for m in 0..n {
                    if p.bits >> m & 1 != 0 {
                        let px = a.pixel(p.xs[m], p.ys[m]);
                        pixels[i * n + m] = px;
                        a.sample(px);
                    }
                }
            }
        }
        // With beams, the camera packets' hits all at once, before anything else.
        let camera_hits = if self.packets == Packets::Beam && !packets.is_empty() {
            self.beam_hits(l, packets, &pixels, stats)
        } else {
            Vec::new()
        };
        // The hits of the camera packet about to be traced, when the beam found them.
        let mut traced: Option<Hits<L>> = None;
        let mut radiance = C::zero(l, t);
        // The camera packet whose tree is being traced depth-first (its lanes, slots and
        // sample ids).
        let mut root = (l.splat_mask(false), l.lane_ids(), l.splat_i32(0));
        loop {
            let seg = if let Some(s) = ready.pop() {
                s
            } else if let Some(p) = packets.get(next_packet) {
                let mut clock = StageClock::start(self.time_stages);
                let active = l.mask_from_bits(p.bits);
                let mut s = self.camera_segment(
                    l,
                    t,
                    l.load(&p.xs),
                    l.load(&p.ys),
                    l.load_i32(&p.ids),
                    active,
                );
                s.slot = l.lane_ids() + l.splat_i32((next_packet * n) as i32);
                traced = camera_hits.get(next_packet).copied();
                root = (active, s.slot, s.ids);
                next_packet += 1;
                clock.lap(stats, Stage::Other);
                s
            } else if !generation.is_empty() {
                let mut clock = StageClock::start(self.time_stages);
                regroup(l, &mut generation, &mut ready, &mut lanes);
                clock.lap(stats, Stage::Other);
                continue;
            } else {
                break;
            };
            let before = stats.work;
            let t0 = aov.map(|_| std::time::Instant::now());
            self.segment(
                l,
                t,
                &seg,
                traced.take().as_ref(),
                &mut radiance,
                &mut children,
                stats,
            );
            if let (Some(a), Some(t0)) = (aov, t0) {
                let ns = t0.elapsed().as_nanos() as f64;
                let work = Work {
                    inner_nodes: stats.work.inner_nodes - before.inner_nodes,
                    tri_tests: stats.work.tri_tests - before.tri_tests,
                };
                charge(a, &pixels, seg.active, seg.slot, work, ns);
            }
            if self.regroup {
                let rgb = radiance.to_rgb(l, t, &C::waves(l, t, seg.ids));
                file(&mut acc, seg.active, seg.slot, &rgb);
                radiance = C::zero(l, t);
                generation.append(&mut children);
            } else {
                // Depth-first: the last child pushed is traced next.
                ready.append(&mut children);
                if ready.is_empty() {
                    let rgb = radiance.to_rgb(l, t, &C::waves(l, t, root.2));
                    file(&mut acc, root.0, root.1, &rgb);
                    radiance = C::zero(l, t);
                }
            }
        }
        let mut out = Vec::with_capacity(packets.len());
        for (pi, p) in packets.iter().enumerate() {
            let mut colours = [[0.0f32; 3]; MAX_LANES];
            for (m, c) in colours.iter_mut().enumerate().take(n) {
                if p.bits >> m & 1 == 0 {
                    continue;
                }
                let rgb = acc[pi * n + m];
                if rgb.iter().any(|v| v.is_nan()) {
                    stats.nan += 1;
                } else {
                    *c = rgb;
                }
            }
            out.push(colours);
        }
        out
    }

    /// The hits of every camera packet of `packets`, traced together as one beam; with
    /// per-pixel maps on, what the beam did is charged to its samples' `pixels`.
    #[inline(always)]
    fn beam_hits<L: Lanes>(
        &self,
        l: L,
        packets: &[PacketIn],
        pixels: &[u32],
        stats: &mut RenderStats,
    ) -> Vec<Hits<L>> {
        let n = L::N;
        let aov = self.aov.as_deref();
        let mut clock = StageClock::start(self.time_stages);
        // A loop, not iterator adaptors: those stay out of line, outside the kernel.
        let mut rays: Vec<Rays<L>> = Vec::with_capacity(packets.len());
        let mut active: Vec<L::Mask> = Vec::with_capacity(packets.len());
        for p in packets {
            rays.push(self.camera.rays(l, l.load(&p.xs), l.load(&p.ys)).rays);
            active.push(l.mask_from_bits(p.bits));
        }
        let mut camera_hits = vec![Hits::miss(l); packets.len()];
        if let Some(a) = aov {
            let t0 = std::time::Instant::now();
            let mut work = Work::default();
            l.apart(
                #[inline(always)]
                |l| {
                    self.accel
                        .intersect_beam_work(l, &rays, &active, &mut camera_hits, &mut work)
                },
            );
            charge_beam(a, pixels, packets, n, work, t0.elapsed().as_nanos() as f64);
            stats.work += work;
        } else {
            // Out of the kernel, as the renderer's other queries (`Lanes::apart`).
            l.apart(
                #[inline(always)]
                |l| {
                    self.accel
                        .intersect_beam(l, &rays, &active, &mut camera_hits)
                },
            );
        }
        clock.lap(stats, Stage::Traversal);
        camera_hits
    }
}

/// Moves the segments of `generation` into `ready` as full packets: per node of the ray tree
/// (in path order), its full segments as they are, then the active lanes of the others in
/// sample order, `L::N` at a time; `ready` is popped from the end, so the first packet goes
/// last.
///
/// Sample order, not the order the segments came in: from depth 2 on a generation holds the
/// children of full parents first and of compacted ones after, so lanes of one node would
/// come in two interleaved runs and samples from opposite ends of a tile share a packet.
///
/// Full segments pass unchanged: compacting them too shifts every later packet's lanes
/// across two parent packets, which costs coherence for no lane gained (measured over 7
/// interleaved rounds, frames 3-6% slower at 8 and 16 lanes on spdemo, glass1 and cornell
/// when every segment was compacted than when full ones passed: within this machine's
/// run-to-run noise, but in the same direction on each).
#[inline(always)]
fn regroup<L: Lanes, C: Colour<L>>(
    l: L,
    generation: &mut Vec<Segment<L, C>>,
    ready: &mut Vec<Segment<L, C>>,
    lanes: &mut Vec<Lane>,
) {
    let mut order: Vec<usize> = (0..generation.len()).collect();
    // Stable: within a node, the batch's order. The node's id decides; its other labels
    // only keep two nodes apart if diffuse bounces' hashed ids ever met another's.
    let node_of = |i: usize| {
        let s = &generation[i];
        (s.path, s.bounces, s.depth, s.kind as u8)
    };
    order.sort_by_key(|&i| node_of(i));
    let mut packed = Vec::new();
    for node in order.chunk_by(|&a, &b| node_of(a) == node_of(b)) {
        lanes.clear();
        for &i in node {
            if generation[i].active.all() {
                packed.push(generation[i].clone());
            } else {
                lift(&generation[i], lanes);
            }
        }
        if lanes.is_empty() {
            continue;
        }
        // A sample has at most one lane per node: the slots are distinct.
        lanes.sort_unstable_by_key(|lane| lane.slot);
        let like = &generation[node[0]];
        for chunk in lanes.chunks(L::N) {
            packed.push(pack(l, chunk, like));
        }
    }
    generation.clear();
    packed.reverse();
    ready.append(&mut packed);
}

/// Charges one segment's `work` and time `ns` to the pixels of its `active` lanes.
#[inline(always)]
fn charge<M: SimdMask, I: SimdI32>(
    aov: &AovBuffer,
    pixels: &[u32],
    active: M,
    slot: I,
    work: Work,
    ns: f64,
) {
    let mut slots = [0i32; MAX_LANES];
    slot.store(&mut slots);
    let mut px = [0u32; MAX_LANES];
    let mut k = 0;
    let mut bits = active.bitmask();
    while bits != 0 {
        let m = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        px[k] = pixels[slots[m] as usize];
        k += 1;
    }
    aov.charge_packet(&px[..k], work, ns);
}

/// Charges a camera beam's `work` to its packets in equal shares and its time `ns` to its
/// rays in equal shares (the packets' lanes count when they are shaded, as segments).
fn charge_beam(
    aov: &AovBuffer,
    pixels: &[u32],
    packets: &[PacketIn],
    n: usize,
    work: Work,
    ns: f64,
) {
    let rays: u32 = packets.iter().map(|p| p.bits.count_ones()).sum();
    let share = 1.0 / packets.len().max(1) as f64;
    for (i, p) in packets.iter().enumerate() {
        for m in 0..n {
            if p.bits >> m & 1 != 0 {
                aov.charge_work(
                    pixels[i * n + m],
                    work.inner_nodes as f64 * share,
                    work.tri_tests as f64 * share,
                    ns / f64::from(rays.max(1)),
                );
            }
        }
    }
}

/// Adds the `active` lanes of `radiance` to their samples (`slot`) in `acc`.
#[inline(always)]
fn file<L: Lanes>(acc: &mut [[f32; 3]], active: L::Mask, slot: L::I32s, radiance: &Rgbs<L>) {
    let mut rgb = [[0.0f32; MAX_LANES]; 3];
    radiance.r.store(&mut rgb[0]);
    radiance.g.store(&mut rgb[1]);
    radiance.b.store(&mut rgb[2]);
    let mut slots = [0i32; MAX_LANES];
    slot.store(&mut slots);
    let mut bits = active.bitmask();
    while bits != 0 {
        let m = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let a = &mut acc[slots[m] as usize];
        for (c, v) in a.iter_mut().zip(&rgb) {
            *c += v[m];
        }
    }
}

/// The per-lane values of `seg`, in [`FIELDS`] order.
#[inline(always)]
fn fields<L: Lanes, C: Colour<L>>(seg: &Segment<L, C>) -> [L::F32s; FIELDS] {
    let (r, d, t) = (&seg.rays, &seg.diff, seg.throughput.rgb_fields());
    [
        r.origin.x,
        r.origin.y,
        r.origin.z,
        r.dir.x,
        r.dir.y,
        r.dir.z,
        r.tmin,
        r.tmax,
        d.dorigin_dx.x,
        d.dorigin_dx.y,
        d.dorigin_dx.z,
        d.dorigin_dy.x,
        d.dorigin_dy.y,
        d.dorigin_dy.z,
        d.ddir_dx.x,
        d.ddir_dx.y,
        d.ddir_dx.z,
        d.ddir_dy.x,
        d.ddir_dy.y,
        d.ddir_dy.z,
        t[0],
        t[1],
        t[2],
    ]
}

/// Appends the active lanes of `seg` to `out`, in lane order.
#[inline(always)]
fn lift<L: Lanes, C: Colour<L>>(seg: &Segment<L, C>, out: &mut Vec<Lane>) {
    let mut f = [[0.0f32; MAX_LANES]; FIELDS];
    for (a, v) in f.iter_mut().zip(fields(seg)) {
        v.store(a);
    }
    let mut light = [0i32; MAX_LANES];
    let mut id = [0i32; MAX_LANES];
    let mut slot = [0i32; MAX_LANES];
    seg.light_ids.store(&mut light);
    seg.ids.store(&mut id);
    seg.slot.store(&mut slot);
    let mut bits = seg.active.bitmask();
    while bits != 0 {
        let m = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let mut lane = Lane {
            f: [0.0; FIELDS],
            light_id: light[m],
            id: id[m],
            slot: slot[m],
        };
        for (x, a) in lane.f.iter_mut().zip(&f) {
            *x = a[m];
        }
        out.push(lane);
    }
}

/// A packet of `lanes` (1 to `L::N` of them) at the node of the ray tree of `like`. Lanes
/// past the last copy it and are inactive, so they compute on valid numbers.
#[inline(always)]
fn pack<L: Lanes, C: Colour<L>>(l: L, lanes: &[Lane], like: &Segment<L, C>) -> Segment<L, C> {
    let mut f = [[0.0f32; MAX_LANES]; FIELDS];
    let mut light = [0i32; MAX_LANES];
    let mut id = [0i32; MAX_LANES];
    let mut slot = [0i32; MAX_LANES];
    let last = lanes.len() - 1;
    for m in 0..L::N {
        let lane = &lanes[m.min(last)];
        for (a, x) in f.iter_mut().zip(&lane.f) {
            a[m] = *x;
        }
        light[m] = lane.light_id;
        id[m] = lane.id;
        slot[m] = lane.slot;
    }
    let mut v = [l.splat(0.0); FIELDS];
    for (x, a) in v.iter_mut().zip(&f) {
        *x = l.load(a);
    }
    // (No closure to build the vectors: one called several times may stay out of line, and
    // outside the kernel's `#[target_feature]` function every vector move becomes a copy
    // through memory.)
    Segment {
        rays: Rays {
            origin: Vec3s {
                x: v[0],
                y: v[1],
                z: v[2],
            },
            dir: Vec3s {
                x: v[3],
                y: v[4],
                z: v[5],
            },
            tmin: v[6],
            tmax: v[7],
        },
        diff: Differentials {
            dorigin_dx: Vec3s {
                x: v[8],
                y: v[9],
                z: v[10],
            },
            dorigin_dy: Vec3s {
                x: v[11],
                y: v[12],
                z: v[13],
            },
            ddir_dx: Vec3s {
                x: v[14],
                y: v[15],
                z: v[16],
            },
            ddir_dy: Vec3s {
                x: v[17],
                y: v[18],
                z: v[19],
            },
        },
        active: l.mask_from_bits((1u32 << lanes.len()) - 1),
        throughput: C::from_rgb_fields([v[20], v[21], v[22]]),
        wave: like.wave,
        depth: like.depth,
        bounces: like.bounces,
        kind: like.kind,
        path: like.path,
        light_ids: l.load_i32(&light),
        ids: l.load_i32(&id),
        slot: l.load_i32(&slot),
    }
}
