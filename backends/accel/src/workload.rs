//! Ray workloads for measuring accelerators (paper section 7 times the coherent tracer on
//! primary, shadow and reflected rays): primary rays in packet-shaped screen tiles, shadow
//! rays to a point light, diffuse rays over the cosine hemisphere, and timing kernels that run
//! a workload through any [`Accel`] one ray at a time or in packets of any lane backend.

use std::time::Instant;

use coherent_simd::{Kernel, Lanes, SimdF32, SimdMask};
use glam::Vec3;

use crate::scenes::View;
use crate::shapes::Rng;
use crate::{Accel, Hit1, Ray1, Rays, Scene};

/// The kind of rays in a workload (the `rays` column of `accel.csv`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RayKind {
    /// From the eye through pixel centres: coherent.
    Primary,
    /// From primary hit points to a point light: coherent (common end point), any-hit.
    Shadow,
    /// From primary hit points over the cosine-weighted hemisphere: incoherent.
    Diffuse,
}

impl RayKind {
    pub const ALL: [RayKind; 3] = [RayKind::Primary, RayKind::Shadow, RayKind::Diffuse];

    pub fn name(self) -> &'static str {
        match self {
            RayKind::Primary => "primary",
            RayKind::Shadow => "shadow",
            RayKind::Diffuse => "diffuse",
        }
    }

    /// Shadow rays ask for occlusion, the others for the first hit.
    pub fn occlusion(self) -> bool {
        self == RayKind::Shadow
    }
}

/// The screen tile a packet of `lanes` rays covers: 1x1, 2x2, 4x2, 4x4 (wider: 8 x lanes/8).
pub fn tile_shape(lanes: usize) -> (u32, u32) {
    match lanes {
        0 | 1 => (1, 1),
        2 => (2, 1),
        4 => (2, 2),
        8 => (4, 2),
        16 => (4, 4),
        n => (8, (n as u32).div_ceil(8)),
    }
}

/// Primary rays of a `width x height` image, ordered tile by tile (`tile_w x tile_h` tiles,
/// rows of tiles top to bottom), so that consecutive groups of `tile_w * tile_h` rays are
/// coherent packets. Width and height must be multiples of the tile size.
pub fn primary_rays(view: &View, width: u32, height: u32, tile: (u32, u32)) -> Vec<Ray1> {
    let (tw, th) = tile;
    assert!(
        width.is_multiple_of(tw) && height.is_multiple_of(th),
        "image not a whole number of tiles"
    );
    let mut rays = Vec::with_capacity((width * height) as usize);
    for ty in (0..height).step_by(th as usize) {
        for tx in (0..width).step_by(tw as usize) {
            for y in ty..ty + th {
                for x in tx..tx + tw {
                    rays.push(view.primary_ray(x, y, width, height));
                }
            }
        }
    }
    rays
}

/// Primary rays of a `width x height` image for beams of `side x side` pixels whose packets
/// are `packet` tiles (see [`tile_shape`]): beam after beam (rows of beams, top to bottom),
/// and inside a beam packet after packet in Morton order, so that consecutive packets, and
/// any run of them a beam traversal groups, are compact sub-tiles. Width and height must be
/// multiples of `side`; a `side` that is not a multiple of the packet's sides takes the
/// packets as rows of the beam's tile.
pub fn beam_rays(view: &View, width: u32, height: u32, side: u32, packet: (u32, u32)) -> Vec<Ray1> {
    assert!(
        width.is_multiple_of(side) && height.is_multiple_of(side),
        "image not a whole number of beams"
    );
    let (pw, ph) = packet;
    let order: Vec<(u32, u32)> = if side.is_multiple_of(pw) && side.is_multiple_of(ph) {
        let mut cells: Vec<(u32, u32)> = (0..side / ph)
            .flat_map(|y| (0..side / pw).map(move |x| (x, y)))
            .collect();
        cells.sort_by_key(|&(x, y)| morton(x, y));
        cells
            .into_iter()
            .flat_map(|(cx, cy)| {
                (0..ph).flat_map(move |y| (0..pw).map(move |x| (cx * pw + x, cy * ph + y)))
            })
            .collect()
    } else {
        (0..side)
            .flat_map(|y| (0..side).map(move |x| (x, y)))
            .collect()
    };
    let mut rays = Vec::with_capacity((width * height) as usize);
    for ty in (0..height).step_by(side as usize) {
        for tx in (0..width).step_by(side as usize) {
            for &(x, y) in &order {
                rays.push(view.primary_ray(tx + x, ty + y, width, height));
            }
        }
    }
    rays
}

/// The Morton code of cell `(x, y)`: their bits interleaved, x in the even bits.
fn morton(x: u32, y: u32) -> u64 {
    let spread = |v: u32| {
        let mut v = u64::from(v) & 0xffff_ffff;
        v = (v | v << 16) & 0x0000_ffff_0000_ffff;
        v = (v | v << 8) & 0x00ff_00ff_00ff_00ff;
        v = (v | v << 4) & 0x0f0f_0f0f_0f0f_0f0f;
        v = (v | v << 2) & 0x3333_3333_3333_3333;
        (v | v << 1) & 0x5555_5555_5555_5555
    };
    spread(x) | spread(y) << 1
}

/// The world-space hit point and geometric normal (facing the ray) of `h` on `ray`.
pub fn hit_frame(scene: &Scene, ray: &Ray1, h: &Hit1) -> (Vec3, Vec3) {
    let inst = &scene.instances[h.inst as usize];
    let m = &inst.world_from_object;
    let [a, b, c] = scene.meshes[inst.mesh]
        .triangle(h.prim as usize)
        .map(|p| m.transform_point3(p));
    let mut n = (b - a).cross(c - a).normalize_or_zero();
    if n.dot(ray.dir) > 0.0 {
        n = -n;
    }
    (ray.at(h.t), n)
}

/// A secondary ray origin: `p` pushed off the surface along `n` by a relative epsilon.
fn offset(p: Vec3, n: Vec3) -> Vec3 {
    p + n * (1e-4 * p.abs().max_element().max(1.0))
}

/// Shadow rays from the primary hits (in order; misses give none) to `light`: `t` in
/// `[0, 1)` reaches the light.
pub fn shadow_rays<A: Accel>(accel: &A, scene: &Scene, primary: &[Ray1], light: Vec3) -> Vec<Ray1> {
    primary
        .iter()
        .filter_map(|r| {
            let h = accel.intersect1(r)?;
            let (p, n) = hit_frame(scene, r, &h);
            let o = offset(p, n);
            Some(Ray1::new(o, light - o, 0.0, 1.0))
        })
        .collect()
}

/// Diffuse rays from the primary hits (in order; misses give none), cosine-distributed over
/// the hemisphere of the geometric normal.
///
/// Each ray's random numbers are seeded by its primary ray (its direction's bits, one per
/// pixel) and `seed`, not drawn from one stream in list order: the same pixel gets the same
/// diffuse ray whatever order the primary rays come in, so workloads ordered for different
/// packet widths hold the same rays.
pub fn diffuse_rays<A: Accel>(accel: &A, scene: &Scene, primary: &[Ray1], seed: u64) -> Vec<Ray1> {
    primary
        .iter()
        .filter_map(|r| {
            let h = accel.intersect1(r)?;
            let (p, n) = hit_frame(scene, r, &h);
            let mut rng = Rng::new(pixel_seed(seed, r));
            // Cosine-weighted: a point on the unit sphere around the normal's tip.
            let d = (n + rng.unit_vector()).normalize_or(n);
            Some(Ray1::infinite(offset(p, n), d))
        })
        .collect()
}

/// A seed from `seed` and the bits of a primary ray's direction (distinct per pixel).
fn pixel_seed(seed: u64, r: &Ray1) -> u64 {
    let mut k = Rng::new(seed ^ u64::from(r.dir.x.to_bits()));
    let mut k = Rng::new(k.next_u64() ^ u64::from(r.dir.y.to_bits()));
    let mut k = Rng::new(k.next_u64() ^ u64::from(r.dir.z.to_bits()));
    k.next_u64()
}

/// What the timers measure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Clock {
    /// Wall-clock time.
    #[default]
    Wall,
    /// CPU time of the calling thread (`clock_gettime(CLOCK_THREAD_CPUTIME_ID)`, nanosecond
    /// resolution; elsewhere wall time): time-slicing by other processes on a shared machine
    /// does not count. (`/proc/thread-self/schedstat`, used before, advanced in scheduler
    /// ticks on the dev machine: passes of a few ms read as 0 or one tick.)
    ThreadCpu,
}

impl Clock {
    /// Seconds since an arbitrary origin.
    pub fn now(self) -> f64 {
        static ORIGIN: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
        let wall = || ORIGIN.get_or_init(Instant::now).elapsed().as_secs_f64();
        match self {
            Clock::Wall => wall(),
            Clock::ThreadCpu => thread_cpu_seconds().unwrap_or_else(wall),
        }
    }
}

/// The calling thread's CPU time, in seconds.
#[cfg(unix)]
fn thread_cpu_seconds() -> Option<f64> {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: a valid clock id and a pointer to a timespec we own.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    (rc == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

#[cfg(not(unix))]
fn thread_cpu_seconds() -> Option<f64> {
    None
}

/// What a timed pass found: rays that hit (or were occluded), and the sum of their `t`
/// (a checksum; 0 for occlusion).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PassResult {
    pub seconds: f64,
    pub hits: u64,
    pub t_sum: f64,
}

/// Times one pass of `rays` one ray at a time (the scalar path): best of `repeats` passes.
pub fn time_single<A: Accel>(
    accel: &A,
    rays: &[Ray1],
    occlusion: bool,
    repeats: usize,
    clock: Clock,
) -> PassResult {
    let mut best = PassResult {
        seconds: f64::INFINITY,
        ..Default::default()
    };
    for _ in 0..repeats.max(1) {
        let t0 = clock.now();
        let (mut hits, mut t_sum) = (0u64, 0.0f64);
        for r in rays {
            if occlusion {
                hits += accel.occluded1(r) as u64;
            } else if let Some(h) = accel.intersect1(r) {
                hits += 1;
                t_sum += h.t as f64;
            }
        }
        let s = clock.now() - t0;
        if s < best.seconds {
            best = PassResult {
                seconds: s,
                hits,
                t_sum,
            };
        }
    }
    best
}

/// Times one pass of `rays` in packets of the backend's width (consecutive rays form a
/// packet; the last is padded with inactive lanes): best of `repeats` passes. Run it with
/// [`coherent_simd::Backend::run`]. Packing happens before the clock starts.
pub struct TimePackets<'a, A: Accel> {
    pub accel: &'a A,
    pub rays: &'a [Ray1],
    pub occlusion: bool,
    pub repeats: usize,
    pub clock: Clock,
}

impl<A: Accel> Kernel for TimePackets<'_, A> {
    type Output = PassResult;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> PassResult {
        let packets: Vec<(Rays<L>, L::Mask)> = self
            .rays
            .chunks(L::N)
            .map(|c| {
                let p = Rays::from_fn(l, |i| c[i.min(c.len() - 1)]);
                (p, l.mask_from_fn(|i| i < c.len()))
            })
            .collect();
        let mut best = PassResult {
            seconds: f64::INFINITY,
            ..Default::default()
        };
        for _ in 0..self.repeats.max(1) {
            let t0 = self.clock.now();
            let mut hits = 0u64;
            let zero = l.splat(0.0);
            let mut t_acc = zero;
            for (p, m) in &packets {
                if self.occlusion {
                    hits += self.accel.occluded(l, p, *m).count() as u64;
                } else {
                    let h = self.accel.intersect(l, p, *m);
                    let hm = h.hit_mask(l) & *m;
                    hits += hm.count() as u64;
                    t_acc += hm.select(h.t, zero);
                }
            }
            let s = self.clock.now() - t0;
            let t_sum = (0..L::N).map(|i| t_acc.lane(i) as f64).sum();
            if s < best.seconds {
                best = PassResult {
                    seconds: s,
                    hits,
                    t_sum,
                };
            }
        }
        best
    }
}

/// Times one pass of `rays` as beams of `beam` rays (consecutive rays; the packets of the
/// backend's width they pack into, traced together by [`Accel::intersect_beam`] or
/// [`Accel::occluded_beam`]): best of `repeats` passes. `beam` is rounded up to whole
/// packets. Packing happens before the clock starts.
pub struct TimeBeams<'a, A: Accel> {
    pub accel: &'a A,
    pub rays: &'a [Ray1],
    pub beam: usize,
    pub occlusion: bool,
    pub repeats: usize,
    pub clock: Clock,
}

impl<A: Accel> Kernel for TimeBeams<'_, A> {
    type Output = PassResult;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> PassResult {
        // Loops, not iterator adaptors: those stay out of line, outside the kernel's features.
        let mut packets: Vec<Rays<L>> = Vec::new();
        let mut masks: Vec<L::Mask> = Vec::new();
        for c in self.rays.chunks(L::N) {
            packets.push(Rays::from_fn(l, |i| c[i.min(c.len() - 1)]));
            masks.push(l.mask_from_fn(|i| i < c.len()));
        }
        let per_beam = self.beam.div_ceil(L::N).max(1);
        let mut hits_buf = vec![crate::Hits::miss(l); per_beam];
        let mut occ_buf = vec![l.splat_mask(false); per_beam];
        let mut best = PassResult {
            seconds: f64::INFINITY,
            ..Default::default()
        };
        for _ in 0..self.repeats.max(1) {
            let t0 = self.clock.now();
            let mut hits = 0u64;
            let zero = l.splat(0.0);
            let mut t_acc = zero;
            for (p, m) in packets.chunks(per_beam).zip(masks.chunks(per_beam)) {
                if self.occlusion {
                    let o = &mut occ_buf[..p.len()];
                    self.accel.occluded_beam(l, p, m, o);
                    for o in o.iter() {
                        hits += o.count() as u64;
                    }
                } else {
                    let hs = &mut hits_buf[..p.len()];
                    self.accel.intersect_beam(l, p, m, hs);
                    for (h, &m) in hs.iter().zip(m) {
                        let hm = h.hit_mask(l) & m;
                        hits += hm.count() as u64;
                        t_acc += hm.select(h.t, zero);
                    }
                }
            }
            let s = self.clock.now() - t0;
            let t_sum = (0..L::N).map(|i| t_acc.lane(i) as f64).sum();
            if s < best.seconds {
                best = PassResult {
                    seconds: s,
                    hits,
                    t_sum,
                };
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::BruteForce;
    use crate::scenes::{SceneSize, room};

    /// Beam order: every pixel once, and each packet a compact tile (16 lanes: 4 x 4).
    #[test]
    fn beam_order_covers_the_image_with_square_packets() {
        let s = room(SceneSize::Quick);
        let (w, h) = (32, 16);
        let rays = beam_rays(&s.view, w, h, 16, tile_shape(16));
        let mut all = primary_rays(&s.view, w, h, (1, 1));
        let key = |r: &Ray1| r.dir.to_array().map(f32::to_bits);
        let mut got: Vec<_> = rays.iter().map(key).collect();
        got.sort_unstable();
        all.sort_by_key(key);
        assert_eq!(got, all.iter().map(key).collect::<Vec<_>>());
        // The first packet is the beam's top-left 4 x 4 pixels, the second the 4 x 4 right of
        // it (Morton order), the third the one below the first.
        let px = |x, y| key(&s.view.primary_ray(x, y, w, h));
        assert_eq!(key(&rays[0]), px(0, 0));
        assert_eq!(key(&rays[5]), px(1, 1));
        assert_eq!(key(&rays[16]), px(4, 0));
        assert_eq!(key(&rays[32]), px(0, 4));
        assert_eq!(morton(3, 0), 0b101);
        assert_eq!(morton(0, 3), 0b1010);
    }

    /// Every packet width's workload holds the same rays, in its own tile order.
    #[test]
    fn every_tile_order_gives_the_same_diffuse_rays() {
        let s = room(SceneSize::Quick);
        let accel = BruteForce::build(&s.scene, &()).unwrap();
        let key = |r: &Ray1| {
            [r.origin, r.dir]
                .map(|v| v.to_array().map(f32::to_bits))
                .concat()
        };
        let sorted = |lanes: usize| {
            let primary = primary_rays(&s.view, 16, 8, tile_shape(lanes));
            let mut v: Vec<_> = diffuse_rays(&accel, &s.scene, &primary, 7)
                .iter()
                .map(key)
                .collect();
            v.sort_unstable();
            v
        };
        let one = sorted(1);
        assert!(!one.is_empty());
        for lanes in [4, 8, 16] {
            assert_eq!(sorted(lanes), one, "width {lanes}");
        }
    }
}
