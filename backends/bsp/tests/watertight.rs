//! Watertightness of closed meshes (paper section 3's projection test with the edge
//! tolerance of `coherent_accel::EDGE_EPS`): rays from inside a closed mesh, aimed exactly at
//! shared vertices and at points of shared edges, must hit it (a miss is a leak).
//!
//! Origins are inside because from outside the criterion is ill-posed: the rounded ray
//! passes up to an ulp of the origin's magnitude beside the aimed-at point, and near a convex
//! edge that may truly miss the surface.
//!
//! `ci_no_leaks` runs a modest number of rays on every backend and allows no leak; it is the
//! form every `cargo test` runs. `million_rays` (ignored: run with `cargo test --release -p
//! coherent-bsp --test watertight -- --ignored --nocapture`) counts leaks over 10^6 rays per
//! case and asserts the bound below.
//!
//! The bound: at most [`MILLION_RAY_LEAKS`] leak in 7 * 10^6 rays per backend (scalar, sse,
//! avx512) and query form (single-ray, packet), with `EDGE_EPS = 2^-13` (without the
//! tolerance 557,830), and none that brute force does not share: the BSP adds no leaks of its
//! own. The one leak is the same ray on every backend, a grazing one in the torus. It comes
//! from the projection test itself: for a ray meeting a triangle's plane at a grazing angle,
//! the rounding of the hit distance moves the projected point by more than the tolerance. A
//! watertight test (shared edge functions, Woop et al. 2013) would remove it at about twice
//! the arithmetic per test; the paper's test is kept.

use coherent_accel::shapes::{Rng, cuboid, icosphere, torus, uv_sphere};
use coherent_accel::{Accel, BruteForce, Instance, Mesh, Ray1, Rays, Scene};
use coherent_bsp::{Bsp, BspParams};
use coherent_simd::{Backend, Kernel, Lanes};
use glam::{Affine3A, Quat, Vec3};

/// A closed test object and where ray origins lie: inside it, so every ray must hit.
struct Case {
    name: &'static str,
    scene: Scene,
    /// An origin strictly inside the (single instance's) mesh, in object space.
    inside: fn(&mut Rng) -> Vec3,
}

fn in_ball(rng: &mut Rng, r: f32) -> Vec3 {
    rng.unit_vector() * r * rng.f32().cbrt()
}

fn cases() -> Vec<Case> {
    let single = |name, mesh: Mesh, inside| Case {
        name,
        scene: Scene::single(mesh),
        inside,
    };
    let skewed = Affine3A::from_scale_rotation_translation(
        Vec3::new(1.0, 2.5, 0.7),
        Quat::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.9),
        Vec3::new(3.0, -1.0, 2.0),
    );
    let far = Vec3::new(1000.0, -500.0, 250.0);
    vec![
        single("icosphere", icosphere("ico", Vec3::ZERO, 1.0, 4), |r| {
            in_ball(r, 0.95)
        }),
        single(
            "big icosphere",
            icosphere("ico", Vec3::ZERO, 100.0, 6),
            |r| in_ball(r, 95.0),
        ),
        single(
            "uv sphere",
            uv_sphere("uv", Vec3::ZERO, 1.0, 64, 128),
            |r| in_ball(r, 0.95),
        ),
        single("torus", torus("torus", Vec3::ZERO, 2.0, 0.6, 96, 48), |r| {
            let a = r.range(0.0, core::f32::consts::TAU);
            Vec3::new(2.0 * a.cos(), 2.0 * a.sin(), 0.0) + in_ball(r, 0.55)
        }),
        single("cube", cuboid("cube", Vec3::splat(-1.0), Vec3::ONE), |r| {
            r.vec3(Vec3::splat(-0.95), Vec3::splat(0.95))
        }),
        single("off-centre icosphere", icosphere("ico", far, 1.0, 3), |r| {
            Vec3::new(1000.0, -500.0, 250.0) + in_ball(r, 0.95)
        }),
        Case {
            name: "instanced icosphere",
            scene: Scene::new(
                vec![icosphere("ico", Vec3::ZERO, 1.0, 4)],
                vec![Instance::new(0, skewed)],
            ),
            inside: |r| in_ball(r, 0.95),
        },
    ]
}

/// `n` rays from inside aimed exactly at shared vertices (a third) and at points of shared
/// edges (the rest), in world space. Each must hit (a miss is a leak).
fn aimed_rays(case: &Case, n: usize, seed: u64) -> Vec<Ray1> {
    let mut rng = Rng::new(seed);
    let inst = &case.scene.instances[0];
    let mesh = &case.scene.meshes[inst.mesh];
    let m = &inst.world_from_object;
    (0..n)
        .map(|_| {
            let [a, b, c] = mesh.triangle(rng.next_u64() as usize % mesh.indices.len());
            let target = match rng.next_u64() % 6 {
                0 => a,
                1 => b,
                2 => c,
                3 => a.lerp(b, rng.f32()),
                4 => b.lerp(c, rng.f32()),
                _ => c.lerp(a, rng.f32()),
            };
            let o = m.transform_point3((case.inside)(&mut rng));
            Ray1::infinite(o, m.transform_point3(target) - o)
        })
        .collect()
}

/// A leak: a ray from inside a closed mesh that hits nothing.
fn leaked(hit: Option<coherent_accel::Hit1>) -> bool {
    hit.is_none()
}

/// Leaks of single-ray and packet queries on one backend, over `n` rays per case.
struct CountLeaks {
    n: usize,
}

impl Kernel for CountLeaks {
    /// Per case: name, rays, single-ray leaks, packet leaks, leaks brute force does not have.
    type Output = Vec<(&'static str, usize, usize, usize, usize)>;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Self::Output {
        let all = l.splat_mask(true);
        cases()
            .iter()
            .map(|case| {
                let bsp = Bsp::build(&case.scene, &BspParams::default()).unwrap();
                let bf = BruteForce::build(&case.scene, &()).unwrap();
                let rays = aimed_rays(case, self.n, 42);
                let leaks: Vec<&Ray1> = rays.iter().filter(|r| leaked(bsp.intersect1(r))).collect();
                let single = leaks.len();
                let own = leaks.iter().filter(|r| !leaked(bf.intersect1(r))).count();
                let mut packet = 0;
                for c in rays.chunks(L::N) {
                    let p = Rays::from_fn(l, |i| c[i % c.len()]);
                    let hits = bsp.intersect(l, &p, all);
                    packet += (0..c.len()).filter(|&i| leaked(hits.lane(i))).count();
                }
                (case.name, rays.len(), single, packet, own)
            })
            .collect()
    }
}

#[test]
fn ci_no_leaks() {
    for b in Backend::usable() {
        let n = if b == Backend::Scalar { 20_000 } else { 4_000 };
        for (name, rays, single, packet, _) in b.run(CountLeaks { n }).unwrap() {
            assert_eq!(
                (single, packet),
                (0, 0),
                "{}: {name}: leaks over {rays} rays (single, packet)",
                b.name()
            );
        }
    }
}

/// Single rays testing leaves four triangles at a time leak no more than one at a time.
#[test]
fn ci_no_leaks_with_simd_leaves() {
    let mut p = BspParams {
        simd_leaves: true,
        ..BspParams::default()
    };
    p.object.leaf_group = 4;
    for case in cases() {
        let bsp = Bsp::build(&case.scene, &p).unwrap();
        let rays = aimed_rays(&case, 20_000, 42);
        let leaks = rays.iter().filter(|r| leaked(bsp.intersect1(r))).count();
        assert_eq!(
            leaks,
            0,
            "{}: leaks over {} single rays",
            case.name,
            rays.len()
        );
    }
}

/// Leaks allowed over the 7 * 10^6 rays of `million_rays`, per backend and query form.
const MILLION_RAY_LEAKS: usize = 1;

#[test]
#[ignore = "10^6 rays per case: run in release with --ignored --nocapture"]
fn million_rays() {
    let mut total = 0;
    for b in [Backend::Scalar, Backend::Sse, Backend::Avx512] {
        if !b.is_available() {
            continue;
        }
        let (mut singles, mut packets) = (0, 0);
        for (name, rays, single, packet, own) in b.run(CountLeaks { n: 1_000_000 }).unwrap() {
            println!(
                "{:>7} {name:>22}: {rays} rays, leaks single {single}, packet {packet} \
                 (brute force hits {own} of them)",
                b.name()
            );
            assert_eq!(
                own,
                0,
                "{}: {name}: the BSP leaks {own} rays that brute force hits",
                b.name()
            );
            singles += single;
            packets += packet;
        }
        assert!(
            singles <= MILLION_RAY_LEAKS && packets <= MILLION_RAY_LEAKS,
            "{}: leaks over 7 * 10^6 rays: single {singles}, packet {packets} \
             (at most {MILLION_RAY_LEAKS})",
            b.name()
        );
        total += singles + packets;
    }
    println!(
        "edge tolerance {:e}: total leaks {total}",
        coherent_accel::EDGE_EPS
    );
}
