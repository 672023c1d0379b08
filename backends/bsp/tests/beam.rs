//! Beams through the two-level BSP against brute force: camera tiles (one origin) and shadow
//! tiles (one end point) of several sizes, on random scenes with instance transforms, for
//! every lane backend, plus the cases that must fall back to lane packets.

use coherent_accel::testing::*;
use coherent_accel::{Accel, Hits, Ray1, Rays, Scene};
use coherent_bsp::{Bsp, BspParams, TraversalStats};
use coherent_simd::{Kernel, Lanes, SimdMask};
use glam::Vec3;
use proptest::prelude::*;

/// [`Bsp::intersect_beam_counted`] out of line, shared by every call as `Apart`'s queries are.
#[inline(always)]
fn beam_counted<L: Lanes>(
    l: L,
    bsp: &Bsp,
    rays: &[Rays<L>],
    active: &[L::Mask],
    hits: &mut [Hits<L>],
    c: &mut TraversalStats,
) {
    l.apart(
        #[inline(always)]
        |l| bsp.intersect_beam_counted(l, rays, active, hits, c),
    )
}

/// One random scene, beams of both kinds and several sizes checked against brute force.
struct RandomBeams {
    seed: u64,
    tris: usize,
    meshes: usize,
    instances: usize,
    side: usize,
}

impl Kernel for RandomBeams {
    type Output = Result<(), String>;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Result<(), String> {
        let scene = random_scene(self.seed, self.tris, self.meshes, self.instances);
        let (bf, bsp) = build_both::<Bsp>(&scene, &BspParams::default());
        // Also without leaf culling and without walking shadow beams from their end point
        // (the same query code: checking it costs this crate no second copy of the walks).
        let mut plain = bsp.clone();
        plain.set_beam_params(false, false);
        for (k, kind) in [BeamKind::Camera, BeamKind::Shadow].into_iter().enumerate() {
            let rays = beam_rays(self.seed ^ k as u64, &scene, self.side, kind);
            for (tree, name) in [(&bsp, ""), (&plain, " (no culling, no reversal)")] {
                check_beam_queries(l, &bf, tree, &rays, self.seed)
                    .map_err(|e| format!("{kind:?} beam of {}{name}: {e}", rays.len()))?;
            }
        }
        Ok(())
    }
}

/// A beam of one ray answers as the single-ray query; a beam of coherent rays answers as
/// its packets one by one; rays against the majority's signs and zero directions are
/// answered all the same, and counted.
struct Basics;

impl Kernel for Basics {
    type Output = ();
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) {
        let scene = random_scene(7, 300, 2, 4);
        let bsp = Bsp::build(&scene, &BspParams::default()).unwrap();
        let one = l.mask_from_bits(1);
        for r in random_rays(8, &scene, 64) {
            let p = [Rays::from_fn(l, |_| r)];
            let mut h = [Hits::miss(l)];
            let mut o = [l.splat_mask(false)];
            Apart(&bsp).intersect_beam(l, &p, &[one], &mut h);
            Apart(&bsp).occluded_beam(l, &p, &[one], &mut o);
            assert_eq!(h[0].lane(0), bsp.intersect1(&r), "{r:?}");
            assert_eq!(o[0].lane(0), bsp.occluded1(&r), "{r:?}");
        }

        // A beam of one packet is the lane query, bit for bit.
        for (k, kind) in [BeamKind::Camera, BeamKind::Shadow].into_iter().enumerate() {
            let rays = beam_rays(11 + k as u64, &scene, 4, kind);
            for c in rays.chunks(L::N) {
                let p = [Rays::from_fn(l, |i| c[i % c.len()])];
                let m = l.mask_from_fn(|i| i < c.len());
                let mut h = [Hits::miss(l)];
                let mut o = [l.splat_mask(false)];
                Apart(&bsp).intersect_beam(l, &p, &[m], &mut h);
                Apart(&bsp).occluded_beam(l, &p, &[m], &mut o);
                let want = Apart(&bsp).intersect(l, &p[0], m);
                for i in 0..L::N {
                    let bits = |h: Option<coherent_accel::Hit1>| {
                        h.map(|h| (h.t.to_bits(), h.u.to_bits(), h.v.to_bits(), h.prim, h.inst))
                    };
                    assert_eq!(bits(h[0].lane(i)), bits(want.lane(i)));
                }
                assert_eq!(o[0].bitmask(), Apart(&bsp).occluded(l, &p[0], m).bitmask());
            }
        }

        // A camera tile of 16 x 16: the same hits as its packets traced one by one.
        let rays = beam_rays(9, &scene, 16, BeamKind::Camera);
        let packets: Vec<Rays<L>> = rays
            .chunks(L::N)
            .map(|c| Rays::from_fn(l, |i| c[i % c.len()]))
            .collect();
        let all = vec![l.splat_mask(true); packets.len()];
        let mut hits = vec![Hits::miss(l); packets.len()];
        let mut stats = TraversalStats::default();
        beam_counted(l, &bsp, &packets, &all, &mut hits, &mut stats);
        for (p, h) in packets.iter().zip(&hits) {
            let want = Apart(&bsp).intersect(l, p, l.splat_mask(true));
            for i in 0..L::N {
                assert_eq!(
                    h.lane(i).map(|h| (h.prim, h.inst)),
                    want.lane(i).map(|h| (h.prim, h.inst))
                );
            }
        }
        // The scalar backend's beams are its ray-by-ray walk (a group would be one ray).
        if L::N > 1 {
            assert!(stats.beam_steps > 0 && stats.beam_entries > 0, "{stats:?}");
        }

        // Rays against the beam's signs, zero and NaN directions: answered as packets would,
        // and counted.
        let o = Vec3::new(0.5, 0.5, -20.0);
        let mut odd = beam_rays(10, &scene, 4, BeamKind::Camera);
        odd[1] = Ray1::infinite(o, Vec3::new(0.0, 0.3, 1.0));
        odd[2] = Ray1::infinite(o, -odd[2].dir);
        odd[3] = Ray1::infinite(o, Vec3::new(f32::NAN, 0.0, 1.0));
        odd[4] = Ray1::infinite(o, Vec3::ZERO);
        let (bf, _) = build_both::<Bsp>(&scene, &BspParams::default());
        check_beam_queries(l, &bf, &bsp, &odd, 1).unwrap();
        let packets: Vec<Rays<L>> = odd
            .chunks(L::N)
            .map(|c| Rays::from_fn(l, |i| c[i % c.len()]))
            .collect();
        let valid: Vec<_> = packets
            .iter()
            .zip(odd.chunks(L::N))
            .map(|(_, c)| l.mask_from_fn(|i| i < c.len()))
            .collect();
        let mut hits = vec![Hits::miss(l); packets.len()];
        let mut stats = TraversalStats::default();
        beam_counted(l, &bsp, &packets, &valid, &mut hits, &mut stats);
        // Lane 1 (a zero component: ray by ray) and lane 2 (against the signs: a group of its
        // own) when they are in a beam of more than one packet; NaN and zero directions are
        // invalid rays, misses, not counted.
        if packets.len() > 1 && L::N > 1 {
            assert!(stats.beam_fallback_lanes >= 1, "{stats:?}");
            assert!(stats.beam_mixed_lanes >= 1, "{stats:?}");
        }

        // An empty beam and an empty scene.
        Apart(&bsp).intersect_beam(l, &[], &[], &mut []);
        let empty = Bsp::build(&Scene::default(), &BspParams::default()).unwrap();
        let (bf, _) = build_both::<Bsp>(&Scene::default(), &BspParams::default());
        check_beam_queries(l, &bf, &empty, &rays, 2).unwrap();
    }
}

/// The counters of a scene counted by hand: a unit quad (one leaf of two triangles) at
/// z = 0, the same quad moved 10 along x, and a beam of two packets from above looking
/// straight down at the first quad's centre.
struct HandCounted;

impl Kernel for HandCounted {
    type Output = ();
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) {
        use coherent_accel::{Instance, Mesh};
        use glam::Affine3A;
        let quad = Mesh::new(
            "quad",
            vec![
                Vec3::new(-1.0, -1.0, 0.0),
                Vec3::new(1.0, -1.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(-1.0, 1.0, 0.0),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        );
        let scene = Scene {
            meshes: vec![quad],
            instances: vec![
                Instance::new(0, Affine3A::IDENTITY),
                Instance::new(0, Affine3A::from_translation(Vec3::new(10.0, 0.0, 0.0))),
            ],
        };
        let bsp = Bsp::build(&scene, &BspParams::default()).unwrap();
        assert!(bsp.mesh_trees()[0].tree.nodes[0].is_leaf(), "one leaf");

        // Shadow beams toward a light on the first quad's surface and toward one behind it,
        // shortened as the renderer's shadow rays are: walked from the light, and answered as
        // brute force does (the first reach the light, the second are blocked by the quad).
        let (bf, _) = build_both::<Bsp>(&scene, &BspParams::default());
        for light in [Vec3::new(0.2, 0.3, 0.0), Vec3::new(0.2, 0.3, -1.0)] {
            let shadow: Vec<Ray1> = (0..4 * L::N)
                .map(|k| {
                    let k = k as f32 / (4 * L::N) as f32;
                    let o = Vec3::new(-0.5 + k, 0.4 - 0.5 * k, 2.0);
                    Ray1::new(o, light - o, 1e-4, 1.0 - 1e-4)
                })
                .collect();
            let packets: Vec<Rays<L>> = shadow
                .chunks(L::N)
                .map(|c| Rays::from_fn(l, |i| c[i]))
                .collect();
            let all = vec![l.splat_mask(true); packets.len()];
            assert!(bsp.reverses_beam(l, &packets, &all), "light at {light}");
            check_beam_queries(l, &bf, &bsp, &shadow, 3).unwrap();
        }

        // Two packets of rays from (0, 0, 5) down through points of [-0.5, 0.5]^2: every
        // direction has -z and, per lane, x and y of one sign pattern (+, +).
        let ray = |j: usize, i: usize| {
            let k = (j * L::N + i) as f32 / (2 * L::N) as f32;
            let target = Vec3::new(0.1 + 0.4 * k, 0.1 + 0.3 * k, 0.0);
            Ray1::infinite(Vec3::new(0.0, 0.0, 5.0), target - Vec3::new(0.0, 0.0, 5.0))
        };
        let packets = [0, 1].map(|j| Rays::from_fn(l, |i| ray(j, i)));
        let all = [l.splat_mask(true); 2];
        let mut hits = [Hits::miss(l); 2];
        let mut c = TraversalStats::default();
        beam_counted(l, &bsp, &packets, &all, &mut hits, &mut c);
        for h in &hits {
            assert!(h.hit_mask(l).all(), "every ray hits the quad");
        }
        let lanes = 2 * L::N as u64;
        if L::N == 1 {
            // The scalar backend's beams are its ray-by-ray walk: the same tests, no group.
            assert_eq!(
                (c.beam_steps, c.beam_entries, c.limit_reductions),
                (0, 0, 0)
            );
            assert_eq!(c.instance_lanes, lanes, "{c:?}");
            assert_eq!(c.tri_tests, 4, "{c:?}");
            return;
        }
        // The moved quad's box is beyond every packet's bounds: entered by no packet, and no
        // packet moved into its space. The first quad: both packets, every lane, one leaf
        // where each packet finds hits and takes its limit once.
        assert_eq!(c.packets_transformed, 0, "{c:?}");
        assert_eq!(c.instances, 1, "{c:?}");
        assert_eq!(c.instance_lanes, lanes, "{c:?}");
        assert_eq!(c.limit_reductions, 2, "{c:?}");
        assert_eq!(c.tri_tests, 4, "{c:?}");
        assert_eq!(c.tri_test_lanes, 2 * lanes, "{c:?}");
        assert_eq!(c.inner_nodes, 0, "{c:?}");
        assert_eq!((c.beam_fallback_lanes, c.beam_mixed_lanes), (0, 0), "{c:?}");
        // The mesh walk begins with both packets.
        assert!(c.beam_entries >= 1 && c.beam_entry_packets >= 2, "{c:?}");

        // The same beam with one lane turned to +z (away from the quads): a sign group of
        // its own, one lane, counted; the others as before.
        let mut up = packets;
        up[1] = Rays::from_fn(l, |i| {
            let r = ray(1, i);
            if i == 0 {
                Ray1::infinite(r.origin, Vec3::new(0.1, 0.1, 1.0))
            } else {
                r
            }
        });
        let mut c = TraversalStats::default();
        beam_counted(l, &bsp, &up, &all, &mut hits, &mut c);
        assert_eq!(c.beam_mixed_lanes, 1, "{c:?}");
        assert_eq!(hits[1].lane(0), None);
        assert_eq!(c.instance_lanes, lanes - 1, "{c:?}");
    }
}

fn cases() -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(24)
}

/// Every beam check on every backend the traversal tests cover.
mod on_backends {
    use super::*;

    #[test]
    fn basics() {
        on_tested_backends(|| Basics).unwrap();
    }

    #[test]
    fn hand_counted() {
        on_tested_backends(|| HandCounted).unwrap();
    }

    // The beam code is generic over the width; each backend of the tested list compiles every
    // beam walk again (the lane trait itself is checked on every backend by
    // `backends/simd/tests/lanes.rs`).
    proptest! {
        #![proptest_config(ProptestConfig { cases: cases(), ..ProptestConfig::default() })]

        #[test]
        fn random_beams_match_brute_force(
            seed in any::<u64>(),
            tris in 1usize..400,
            meshes in 1usize..4,
            instances in 0usize..7,
            side in prop::sample::select(vec![1usize, 3, 8, 16, 24]),
        ) {
            on_tested_backends(|| RandomBeams { seed, tris, meshes, instances, side })
                .map_err(TestCaseError::fail)?;
        }
    }
}
