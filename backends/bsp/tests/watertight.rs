//! Watertightness of closed meshes (paper section 3's projection test with the edge
//! tolerance of `coherent_accel::EDGE_EPS`): rays from inside a closed mesh, aimed exactly at
//! shared vertices and at points of shared edges, must hit it (a miss is a leak).
//!
//! Origins are inside because from outside the criterion is ill-posed: the rounded ray
//! passes up to an ulp of the origin's magnitude beside the aimed-at point, and near a convex
//! edge that may truly miss the surface.
//!
//! Every hit is checked against brute force too: a ray that slips through a crack and hits
//! the far side of the mesh is as much a leak as one that hits nothing. A hit is wrong when
//! its distance is not brute force's first hit's (relative 10^-5), or when its triangle is
//! another that shares no vertex with brute force's (rays aimed at a shared vertex or edge
//! may take either triangle of the tie).
//!
//! `ci_no_leaks` runs a modest number of rays on every backend and allows no leak and no
//! wrong hit; it is the form every `cargo test` runs, CI's included. `million_rays`
//! (ignored: run with `cargo test --release -p coherent-bsp --test watertight -- --ignored
//! --nocapture`) counts leaks over 10^6 rays per case and asserts the bound below.
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
use coherent_accel::testing::same_t;
use coherent_accel::{Accel, BruteForce, Hit1, Instance, Mesh, Ray1, Rays, Scene};
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
fn leaked(hit: Option<Hit1>) -> bool {
    hit.is_none()
}

/// A hit that is not brute force's first hit `want` (see the module's comment): `None` for a
/// leak or where brute force itself has no hit.
fn wrong(mesh: &Mesh, got: Option<Hit1>, want: Option<Hit1>) -> bool {
    let (Some(g), Some(w)) = (got, want) else {
        return false;
    };
    let shares_vertex = || {
        let (a, b) = (mesh.indices[g.prim as usize], mesh.indices[w.prim as usize]);
        a.iter().any(|v| b.contains(v))
    };
    !same_t(g.t, w.t) || (g.prim != w.prim && !shares_vertex())
}

/// What one backend's queries did with one case's rays.
struct Counts {
    name: &'static str,
    rays: usize,
    /// Single-ray and packet leaks.
    single: usize,
    packet: usize,
    /// Single-ray leaks brute force does not share.
    own: usize,
    /// Single-ray and packet hits that are not brute force's.
    wrong: usize,
}

/// A case's structures and rays, with brute force's answers: built once for every backend.
struct Prepared {
    case: Case,
    bsp: Bsp,
    rays: Vec<Ray1>,
    want: Vec<Option<Hit1>>,
}

fn prepare(n: usize) -> Vec<Prepared> {
    cases()
        .into_iter()
        .map(|case| {
            let bsp = Bsp::build(&case.scene, &BspParams::default()).unwrap();
            let bf = BruteForce::build(&case.scene, &()).unwrap();
            let rays = aimed_rays(&case, n, 42);
            let want = rays.iter().map(|r| bf.intersect1(r)).collect();
            Prepared {
                case,
                bsp,
                rays,
                want,
            }
        })
        .collect()
}

/// Leaks and wrong hits of single-ray and packet queries on one backend.
struct CountLeaks<'a>(&'a [Prepared]);

impl Kernel for CountLeaks<'_> {
    type Output = Vec<Counts>;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Self::Output {
        let all = l.splat_mask(true);
        self.0
            .iter()
            .map(|p| {
                let (bsp, rays, want) = (&p.bsp, &p.rays, &p.want);
                let mesh = &p.case.scene.meshes[0];
                let single: Vec<Option<Hit1>> = rays.iter().map(|r| bsp.intersect1(r)).collect();
                let mut c = Counts {
                    name: p.case.name,
                    rays: rays.len(),
                    single: single.iter().filter(|h| leaked(**h)).count(),
                    packet: 0,
                    own: (single.iter().zip(want))
                        .filter(|(h, w)| leaked(**h) && !leaked(**w))
                        .count(),
                    wrong: (single.iter().zip(want))
                        .filter(|(h, w)| wrong(mesh, **h, **w))
                        .count(),
                };
                for (k, chunk) in rays.chunks(L::N).enumerate() {
                    let p = Rays::from_fn(l, |i| chunk[i % chunk.len()]);
                    let hits = bsp.intersect(l, &p, all);
                    for i in 0..chunk.len() {
                        c.packet += usize::from(leaked(hits.lane(i)));
                        c.wrong += usize::from(wrong(mesh, hits.lane(i), want[k * L::N + i]));
                    }
                }
                c
            })
            .collect()
    }
}

#[test]
fn ci_no_leaks() {
    let prepared = prepare(10_000);
    for b in Backend::usable() {
        for c in b.run(CountLeaks(&prepared)).unwrap() {
            assert_eq!(
                (c.single, c.packet, c.wrong),
                (0, 0, 0),
                "{}: {}: over {} rays: leaks (single, packet), hits not brute force's",
                b.name(),
                c.name,
                c.rays
            );
        }
    }
}

/// The check can fail: a hit at another distance (through a crack to the far side) or on a
/// triangle away from the aimed-at point is wrong; a tie on a neighbouring triangle is not.
#[test]
fn hits_elsewhere_are_wrong_and_ties_are_not() {
    let case = &cases()[0];
    let mesh = &case.scene.meshes[0];
    let bf = BruteForce::build(&case.scene, &()).unwrap();
    let ray = aimed_rays(case, 1, 7)[0];
    let near = bf.intersect1(&ray).unwrap();
    let tri = mesh.indices[near.prim as usize];
    let other = |adjacent: bool| {
        let p = (0..mesh.indices.len() as u32)
            .find(|&p| {
                p != near.prim
                    && mesh.indices[p as usize].iter().any(|v| tri.contains(v)) == adjacent
            })
            .unwrap();
        Some(Hit1 { prim: p, ..near })
    };
    assert!(!wrong(mesh, Some(near), Some(near)));
    assert!(!wrong(mesh, other(true), Some(near)));
    assert!(wrong(mesh, other(false), Some(near)));
    let far = Hit1 {
        t: near.t * 1.5,
        ..near
    };
    assert!(wrong(mesh, Some(far), Some(near)));
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
    let prepared = prepare(1_000_000);
    for b in [Backend::Scalar, Backend::Sse, Backend::Avx512] {
        if !b.is_available() {
            continue;
        }
        let (mut singles, mut packets) = (0, 0);
        for c in b.run(CountLeaks(&prepared)).unwrap() {
            println!(
                "{:>7} {:>22}: {} rays, leaks single {}, packet {} (brute force hits {} of \
                 them), hits not brute force's {}",
                b.name(),
                c.name,
                c.rays,
                c.single,
                c.packet,
                c.own,
                c.wrong
            );
            assert_eq!(
                (c.own, c.wrong),
                (0, 0),
                "{}: {}: leaks brute force does not share, wrong hits",
                b.name(),
                c.name
            );
            singles += c.single;
            packets += c.packet;
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
