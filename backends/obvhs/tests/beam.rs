//! The obvhs accelerator's beams (the large-packet walk over BVH2s, `src/packet.rs`) against
//! brute force: camera and shadow tiles of several sizes on random scenes with instance
//! transforms and degenerate triangles, for both tree kinds, on the scalar backend and the
//! widest one this CPU has; and against the packet query it must answer as.

use coherent_accel::testing::*;
use coherent_accel::{Accel, Hit1, Hits, Ray1, Rays, Scene};
use coherent_obvhs::{Kind, Obvhs, ObvhsParams};
use coherent_simd::{Backend, Kernel, Lanes, Only, SimdMask};
use glam::Vec3;
use proptest::prelude::*;

fn params(kind: Kind) -> ObvhsParams {
    ObvhsParams {
        kind,
        beam_bvh2: true,
        ..Default::default()
    }
}

/// Packs `rays` into packets of `L` (the last padded by repeating its rays), with the lanes
/// holding a ray active.
fn pack<L: Lanes>(l: L, rays: &[Ray1]) -> (Vec<Rays<L>>, Vec<L::Mask>) {
    rays.chunks(L::N)
        .map(|c| {
            (
                Rays::from_fn(l, |i| c[i % c.len()]),
                l.mask_from_fn(|i| i < c.len()),
            )
        })
        .unzip()
}

/// The masks `check_beam_queries` draws for `rays` from `mask_seed` (its code).
fn check_masks<L: Lanes>(l: L, rays: &[Ray1], mask_seed: u64) -> Vec<L::Mask> {
    let mut rng = coherent_accel::shapes::Rng::new(mask_seed);
    rays.chunks(L::N)
        .map(|c| {
            let bits = if !rng.next_u64().is_multiple_of(4) {
                u32::MAX
            } else {
                rng.next_u64() as u32
            };
            l.mask_from_fn(|i| i < c.len() && bits >> i & 1 == 1)
        })
        .collect()
}

fn bits(h: Option<Hit1>) -> Option<(u32, u32, u32, u32, u32)> {
    h.map(|h| (h.t.to_bits(), h.u.to_bits(), h.v.to_bits(), h.prim, h.inst))
}

/// The obvhs accelerator with the interface's default beams (packet after packet): its
/// single-ray path, which the beams must answer as.
struct Packets(Obvhs);

impl Accel for Packets {
    type Params = ObvhsParams;
    fn build(scene: &Scene, params: &ObvhsParams) -> Result<Self, coherent_accel::AccelError> {
        Obvhs::build(scene, params).map(Self)
    }
    fn set_instances(
        &mut self,
        instances: &[coherent_accel::Instance],
    ) -> Result<(), coherent_accel::AccelError> {
        self.0.set_instances(instances)
    }
    fn name(&self) -> &'static str {
        "obvhs packets"
    }
    fn memory_bytes(&self) -> usize {
        self.0.memory_bytes()
    }
    fn stats(&self) -> coherent_accel::BuildStats {
        self.0.stats()
    }
    fn intersect1(&self, ray: &Ray1) -> Option<Hit1> {
        self.0.intersect1(ray)
    }
    fn occluded1(&self, ray: &Ray1) -> bool {
        self.0.occluded1(ray)
    }
    fn intersect_all1(&self, ray: &Ray1, f: &mut impl FnMut(Hit1)) {
        self.0.intersect_all1(ray, f)
    }
}

/// The beam of `rays` against the packet queries of `acc`: the same bits wherever the same
/// triangle is reported, ties ([`same_t`]) otherwise, the same occlusion.
fn beam_is_packets<L: Lanes>(
    l: L,
    acc: &Obvhs,
    p: &[Rays<L>],
    m: &[L::Mask],
) -> Result<(), String> {
    let mut hits = vec![Hits::miss(l); p.len()];
    let mut occ = vec![l.splat_mask(false); p.len()];
    acc.intersect_beam(l, p, m, &mut hits);
    acc.occluded_beam(l, p, m, &mut occ);
    for j in 0..p.len() {
        let want = acc.intersect(l, &p[j], m[j]);
        let want_o = acc.occluded(l, &p[j], m[j]);
        if occ[j].bitmask() != want_o.bitmask() {
            return Err(format!(
                "packet {j}: occluded {:b}, packets say {:b}",
                occ[j].bitmask(),
                want_o.bitmask()
            ));
        }
        for i in 0..L::N {
            let (got, want) = (hits[j].lane(i), want.lane(i));
            let ok = match (got, want) {
                (Some(g), Some(w)) if (g.prim, g.inst) == (w.prim, w.inst) => {
                    bits(Some(g)) == bits(Some(w))
                }
                (Some(g), Some(w)) => same_t(g.t, w.t),
                _ => got == want,
            };
            if !ok {
                return Err(format!(
                    "packet {j} lane {i} ({:?}): {got:?}, packets say {want:?}",
                    p[j].lane(i)
                ));
            }
        }
    }
    Ok(())
}

/// One random scene, beams of both kinds checked against the packet queries and against
/// brute force, for both trees. Brute force's check is the shared one, whose `t` precision
/// obvhs' own triangle test does not always meet (thin, far triangles under scaling
/// instances: `tests/accel_equivalence.rs` holds obvhs to its own tolerance); a beam may fail
/// it only where the packet queries fail it the same way.
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
        for tree in Kind::ALL {
            let (bf, acc) = build_both::<Obvhs>(&scene, &params(tree));
            let lanewise = Packets::build(&scene, &params(tree)).unwrap();
            for (k, kind) in [BeamKind::Camera, BeamKind::Shadow].into_iter().enumerate() {
                let rays = beam_rays(self.seed ^ k as u64, &scene, self.side, kind);
                let (p, m) = pack(l, &rays);
                beam_is_packets(l, &acc, &p, &m)
                    .map_err(|e| format!("{tree:?}: {kind:?} beam of {}: {e}", rays.len()))?;
                if let Err(e) = check_beam_queries(l, &bf, &acc, &rays, self.seed) {
                    // Tolerated only where the beam answers as the packets do under the
                    // check's masks (ties aside): then the failure is obvhs' own triangle
                    // test's (its precision on thin triangles, shared by the packets, or a
                    // duplicate instance at the same `t` that brute force checks more
                    // strictly when it names that one).
                    let same = check_beam_queries(l, &bf, &lanewise, &rays, self.seed);
                    let masks = check_masks(l, &rays, self.seed);
                    if let Err(d) = beam_is_packets(l, &acc, &p, &masks) {
                        return Err(format!(
                            "{tree:?}: {kind:?} beam of {}: {e}; against the packets: {d} \
                             (their check: {same:?})",
                            rays.len()
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}

/// Beams against the packet query of the same accelerator: a beam of one packet is it bit
/// for bit; a beam of many gives the same bits wherever it reports the same triangle, and
/// only ties otherwise; odd rays (zero and NaN directions, against the beam's signs,
/// `tmin < 0`, finite `tmax`, inactive lanes) answer as the packets do.
struct AgainstPackets;

impl Kernel for AgainstPackets {
    type Output = ();
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) {
        for (seed, meshes, instances) in [(7, 2, 4), (8, 1, 1), (9, 3, 6)] {
            let scene = random_scene(seed, 300, meshes, instances);
            for tree in Kind::ALL {
                let acc = Obvhs::build(&scene, &params(tree)).unwrap();
                // One packet: the packet query itself.
                for (k, kind) in [BeamKind::Camera, BeamKind::Shadow].into_iter().enumerate() {
                    let rays = beam_rays(seed + 11 + k as u64, &scene, 4, kind);
                    let (p, m) = pack(l, &rays);
                    for (p, &m) in p.iter().zip(&m) {
                        let mut h = [Hits::miss(l)];
                        let mut o = [l.splat_mask(false)];
                        acc.intersect_beam(l, std::slice::from_ref(p), &[m], &mut h);
                        acc.occluded_beam(l, std::slice::from_ref(p), &[m], &mut o);
                        let want = acc.intersect(l, p, m);
                        for i in 0..L::N {
                            assert_eq!(bits(h[0].lane(i)), bits(want.lane(i)));
                        }
                        assert_eq!(o[0].bitmask(), acc.occluded(l, p, m).bitmask());
                    }
                }
                // Many packets, with odd rays among them.
                for (k, kind) in [BeamKind::Camera, BeamKind::Shadow].into_iter().enumerate() {
                    let mut rays = beam_rays(seed + 21 + k as u64, &scene, 16, kind);
                    let o = rays[0].origin;
                    rays[1] = Ray1::infinite(o, Vec3::new(0.0, 0.3, 1.0));
                    rays[2] = Ray1::infinite(o, -rays[2].dir);
                    rays[3] = Ray1::infinite(o, Vec3::new(f32::NAN, 0.0, 1.0));
                    rays[4] = Ray1::infinite(o, Vec3::ZERO);
                    rays[5] = Ray1::new(rays[5].at(30.0), rays[5].dir, -40.0, f32::INFINITY);
                    rays[6].tmax = 3.0;
                    rays[7].dir.x = -0.0;
                    rays[9] = Ray1::new(o, rays[9].dir, 0.5, 0.25);
                    let (p, mut m) = pack(l, &rays);
                    m[2] = l.mask_from_bits(0b1010_0110_1001_0101);
                    let mut hits = vec![Hits::miss(l); p.len()];
                    let mut occ = vec![l.splat_mask(false); p.len()];
                    acc.intersect_beam(l, &p, &m, &mut hits);
                    acc.occluded_beam(l, &p, &m, &mut occ);
                    for j in 0..p.len() {
                        let want = acc.intersect(l, &p[j], m[j]);
                        let want_o = acc.occluded(l, &p[j], m[j]);
                        assert_eq!(occ[j].bitmask(), want_o.bitmask(), "{tree:?} packet {j}");
                        for i in 0..L::N {
                            let (got, want) = (hits[j].lane(i), want.lane(i));
                            match (got, want) {
                                (Some(g), Some(w)) if (g.prim, g.inst) == (w.prim, w.inst) => {
                                    assert_eq!(bits(Some(g)), bits(Some(w)));
                                }
                                (Some(g), Some(w)) => {
                                    assert!(same_t(g.t, w.t), "{tree:?}: {g:?} against {w:?}")
                                }
                                _ => assert_eq!(got, want, "{tree:?} packet {j} lane {i}"),
                            }
                        }
                    }
                }
                // An empty beam.
                acc.intersect_beam(l, &[], &[], &mut []);
                acc.occluded_beam(l, &[], &[], &mut []);
            }
        }
        // An empty scene.
        let empty = Obvhs::build(&Scene::default(), &ObvhsParams::default()).unwrap();
        let (bf, _) = build_both::<Obvhs>(&Scene::default(), &ObvhsParams::default());
        let rays = beam_rays(3, &random_scene(3, 50, 1, 2), 8, BeamKind::Camera);
        check_beam_queries(l, &bf, &empty, &rays, 2).unwrap();
    }
}

#[test]
fn cwbvh_keeps_a_bvh2_for_the_beams_and_counts_it() {
    let scene = random_scene(5, 200, 2, 3);
    let c = Obvhs::build(&scene, &params(Kind::Cwbvh)).unwrap();
    let b = Obvhs::build(&scene, &params(Kind::Bvh2)).unwrap();
    assert!(c.beam_memory() > 0);
    assert_eq!(b.beam_memory(), 0);
    assert!(c.memory_bytes() > c.beam_memory());
    let extra = c.stats().extra;
    assert!(
        extra
            .iter()
            .any(|(k, v)| k == "beam_bvh2_bytes" && *v == c.beam_memory() as f64),
        "{extra:?}"
    );
}

fn cases() -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(24)
}

/// Runs `k` on backend `b`, or says why it is skipped (`None`). `k` is compiled only for the
/// backends of the set `BITS` (`Only`): a stamped backend's test compiles one copy of it.
fn on<const BITS: u32, K: Kernel>(b: Backend, k: K) -> Option<K::Output> {
    match b.unavailable_reason() {
        Some(why) => {
            eprintln!("skipping backend {}: {why}", b.name());
            None
        }
        None => Some(b.run(Only::<K, BITS>(k)).unwrap()),
    }
}

/// Stamps the tests out for one lane backend: the scalar one and the widest this CPU has.
macro_rules! beam_tests {
    ($name:ident, $backend:expr, $bits:expr) => {
        mod $name {
            use super::*;

            #[test]
            fn against_packets() {
                on::<{ $bits }, _>($backend, AgainstPackets);
            }

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
                    let k = RandomBeams { seed, tris, meshes, instances, side };
                    if let Some(r) = on::<{ $bits }, _>($backend, k) {
                        r.map_err(TestCaseError::fail)?;
                    }
                }
            }
        }
    };
}

/// The backends [`Backend::widest`] can be in this build (its test compiles its kernels for
/// these alone).
#[cfg(target_arch = "x86_64")]
const WIDEST: u32 = Backend::bits(&[
    Backend::Scalar,
    Backend::Sse,
    Backend::Avx2,
    Backend::Avx512,
]);
#[cfg(not(target_arch = "x86_64"))]
const WIDEST: u32 = Backend::bits(&Backend::ALL);

beam_tests!(scalar, Backend::Scalar, Backend::Scalar.bit());
beam_tests!(widest, Backend::widest(), WIDEST);

/// The widest backend is a SIMD one on x86-64 when this crate's tests build every backend
/// (its `backends` feature; a `--no-default-features` build has scalar alone).
#[cfg(all(target_arch = "x86_64", feature = "backends"))]
#[test]
fn the_widest_backend_has_simd_lanes() {
    eprintln!("widest backend: {}", Backend::widest().name());
    assert_ne!(Backend::widest(), Backend::Scalar);
}
