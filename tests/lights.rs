//! Light equivalence (paper section 5): every kind of light gives on every backend what the
//! scalar backend gives one shading point at a time, masks included; shadow packets too.
//! Backends this CPU cannot run are skipped with their reason printed.
//!
//! Every backend runs the same arithmetic, so values differ only where `mul_add` is fused
//! or not: radiance to [`REL_TOL`] of the value, directions and distances to [`ABS_TOL`].
//! Lanes within [`EDGE`] of a mask's edge (grazing, a cone's border) may differ in the
//! mask and are skipped.

use coherent::light::photometry::{PhotometricTable, PhotometricType};
use coherent::light::{
    Circular, Direct, Environment, GonioLookup, Goniodiagram, Light, Linear, Omni, Parallel,
    Rectangular, Spot, SpotFalloff, shadow_rays,
};
use coherent::simd::{Backend, Kernel, Lanes, SimdF32, SimdMask, Vec3s};
use glam::Vec3;
use rand::{Rng, SeedableRng, rngs::StdRng};

const REL_TOL: f32 = 2e-4;
const ABS_TOL: f32 = 1e-5;

/// Test lights of every kind.
pub fn lights() -> Vec<Light> {
    vec![
        Light::Omni(Omni::new(Vec3::new(0.3, 0.2, 2.0), [1.0, 2.0, 3.0]).unwrap()),
        Light::Spot(
            Spot::new(
                Vec3::new(0.0, 0.0, 2.0),
                Vec3::new(0.1, 0.0, -1.0),
                [5.0; 3],
                0.5,
                1.0,
                SpotFalloff::Approx,
            )
            .unwrap(),
        ),
        Light::Spot(
            Spot::new(
                Vec3::new(0.0, 0.0, 2.0),
                Vec3::new(0.1, 0.0, -1.0),
                [5.0; 3],
                0.5,
                1.0,
                SpotFalloff::Exact,
            )
            .unwrap(),
        ),
        Light::Parallel(Parallel::new(Vec3::new(0.2, 0.3, -1.0), [1.0; 3]).unwrap()),
        Light::Direct(
            Direct::new(
                Vec3::new(0.0, 1.0, 2.0),
                Vec3::new(0.0, -0.3, -1.0),
                [2.0; 3],
            )
            .unwrap(),
        ),
        Light::Linear(
            Linear::new(
                Vec3::new(-1.0, 0.0, 1.5),
                Vec3::new(1.0, 0.5, 1.5),
                [1.0; 3],
                7,
                1,
                true,
            )
            .unwrap(),
        ),
        Light::Circular(
            Circular::new(
                Vec3::new(0.0, 0.0, 1.5),
                Vec3::new(0.0, 0.2, -1.0),
                0.5,
                [1.0; 3],
                (3, 7),
                2,
                true,
            )
            .unwrap(),
        ),
        Light::Rectangular(
            Rectangular::new(
                Vec3::new(-0.5, -0.5, 1.5),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(0.0, -1.0, 0.0),
                [1.0; 3],
                (7, 3),
                3,
                false,
            )
            .unwrap(),
        ),
        gonio(PhotometricType::C, GonioLookup::Search),
        gonio(PhotometricType::C, GonioLookup::Uniform),
        gonio(PhotometricType::B, GonioLookup::Search),
        Light::Environment(environment()),
    ]
}

/// A small sky with a sun, up +z.
fn environment() -> Environment {
    let (w, h) = (24, 12);
    let mut t = Vec::new();
    for j in 0..h {
        for i in 0..w {
            let sun = if i == 5 && j == 3 { 200.0 } else { 0.0 };
            t.push([
                0.2 + sun,
                0.3 + 0.01 * i as f32 + sun,
                0.5 - 0.02 * j as f32 + sun,
            ]);
        }
    }
    Environment::new("sky", w, h, &t, 1.0, Vec3::Z, Vec3::X, 8).unwrap()
}

/// A goniodiagram light from a smooth made-up table with quadrant symmetry (type C) or
/// floodlight planes (type B), aimed down from above the points.
fn gonio(kind: PhotometricType, lookup: GonioLookup) -> Light {
    let planes: Vec<f32> = vec![0.0, 10.0, 25.0, 45.0, 70.0, 90.0];
    let angles: Vec<f32> = match kind {
        PhotometricType::C => vec![0.0, 5.0, 15.0, 30.0, 50.0, 70.0, 90.0, 135.0, 180.0],
        _ => vec![-90.0, -45.0, -20.0, 0.0, 20.0, 45.0, 90.0],
    };
    let mut candela = Vec::new();
    for &c in &planes {
        for &g in &angles {
            candela.push(500.0 + 300.0 * g.to_radians().cos() + 40.0 * (c / 30.0).sin());
        }
    }
    let table = PhotometricTable {
        kind,
        planes,
        angles,
        candela,
    };
    Light::Goniodiagram(
        Goniodiagram::new(
            Vec3::new(0.2, 0.1, 1.8),
            Vec3::Z,
            Vec3::X,
            &table,
            [1.0, 0.8, 0.6],
            lookup,
            std::path::Path::new("made-up"),
        )
        .unwrap(),
    )
}

/// Shading points on a bumpy surface, normals mostly up, some down or grazing.
#[derive(Clone)]
struct Inputs {
    p: Vec<Vec3>,
    n: Vec<Vec3>,
    u: Vec<[f32; 2]>,
}

fn inputs(seed: u64, count: usize) -> Inputs {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut v = Inputs {
        p: vec![],
        n: vec![],
        u: vec![],
    };
    for _ in 0..count {
        v.p.push(Vec3::new(
            rng.random_range(-2.0..2.0),
            rng.random_range(-2.0..2.0),
            rng.random_range(-0.2..0.2),
        ));
        let n = Vec3::new(
            rng.random_range(-0.6..0.6),
            rng.random_range(-0.6..0.6),
            if rng.random_range(0..8) == 0 {
                -1.0
            } else {
                1.0
            },
        );
        v.n.push(n.normalize());
        v.u.push([rng.random(), rng.random()]);
    }
    v
}

/// Per shading point and sample: active, wi, dist, li, and the shadow ray's origin and tmax.
type Out = Vec<(bool, Vec3, f32, [f32; 3], Vec3, f32)>;

#[derive(Clone)]
struct Eval<'a> {
    light: &'a Light,
    inputs: &'a Inputs,
}

impl Kernel for Eval<'_> {
    type Output = Out;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Out {
        let inp = self.inputs;
        let mut out = Vec::new();
        for base in (0..inp.p.len()).step_by(L::N) {
            let at = |i: usize| (base + i).min(inp.p.len() - 1);
            let p = Vec3s::from_fn(l, |i| inp.p[at(i)]);
            let n = Vec3s::from_fn(l, |i| inp.n[at(i)]);
            let u = [
                l.from_fn(|i| inp.u[at(i)][0]),
                l.from_fn(|i| inp.u[at(i)][1]),
            ];
            // Every third lane starts inactive.
            let active = l.mask_from_fn(|i| (base + i) % 3 != 2);
            for k in 0..self.light.samples() {
                let s = self.light.sample(l, &p, &n, active, k, u);
                let r = shadow_rays(l, &p, &n, &s);
                for i in 0..L::N.min(inp.p.len() - base) {
                    out.push((
                        s.active.lane(i),
                        s.wi.lane(i),
                        s.dist.lane(i),
                        s.li.lane(i),
                        r.origin.lane(i),
                        r.tmax.lane(i),
                    ));
                }
            }
        }
        // Reorder to (point, sample) so every width lists the same things in the same order.
        let samples = self.light.samples() as usize;
        let mut sorted = vec![out[0]; out.len()];
        let mut idx = 0;
        for base in (0..inp.p.len()).step_by(L::N) {
            let lanes = L::N.min(inp.p.len() - base);
            for k in 0..samples {
                for i in 0..lanes {
                    sorted[(base + i) * samples + k] = out[idx];
                    idx += 1;
                }
            }
        }
        sorted
    }
}

fn close(a: f32, b: f32, rel: f32) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()) + ABS_TOL || (a.is_infinite() && a == b)
}

#[test]
fn every_light_on_every_backend_equals_scalar() {
    let inp = inputs(7, 203);
    for light in lights() {
        let want = Backend::Scalar
            .run(Eval {
                light: &light,
                inputs: &inp,
            })
            .unwrap();
        let lit = want.iter().filter(|o| o.0).count();
        assert!(
            lit > want.len() / 6,
            "{}: only {lit} of {} lit",
            light.kind(),
            want.len()
        );
        for b in Backend::usable() {
            let got = b
                .run(Eval {
                    light: &light,
                    inputs: &inp,
                })
                .unwrap();
            assert_eq!(got.len(), want.len());
            let mut mask_diffs = 0;
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                let what = format!(
                    "{} on {}, item {i}: {g:?} vs scalar {w:?}",
                    light.kind(),
                    b.name()
                );
                if g.0 != w.0 {
                    // Only at a mask's edge (FMA changes the last bit of a dot product).
                    mask_diffs += 1;
                    continue;
                }
                if !w.0 {
                    assert_eq!(g.3, [0.0; 3], "{what}: inactive lanes carry no radiance");
                    continue;
                }
                assert!((g.1 - w.1).abs().max_element() <= ABS_TOL, "{what}: wi");
                assert!(close(g.2, w.2, REL_TOL), "{what}: dist");
                for c in 0..3 {
                    assert!(close(g.3[c], w.3[c], REL_TOL), "{what}: li");
                }
                assert!(
                    (g.4 - w.4).abs().max_element() <= ABS_TOL,
                    "{what}: shadow origin"
                );
                assert!(close(g.5, w.5, REL_TOL), "{what}: shadow tmax");
            }
            assert!(
                mask_diffs <= 2,
                "{} on {}: {mask_diffs} mask differences",
                light.kind(),
                b.name()
            );
        }
    }
}

#[derive(Clone)]
struct Seen<'a> {
    light: &'a Light,
    dirs: &'a [Vec3],
}

impl Kernel for Seen<'_> {
    type Output = Vec<[f32; 3]>;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Vec<[f32; 3]> {
        let mut out = Vec::new();
        for base in (0..self.dirs.len()).step_by(L::N) {
            let d = Vec3s::from_fn(l, |i| self.dirs[(base + i).min(self.dirs.len() - 1)]);
            let r = self.light.radiance_seen(l, &d);
            for i in 0..L::N.min(self.dirs.len() - base) {
                out.push(r.lane(i));
            }
        }
        out
    }
}

#[test]
fn what_rays_see_of_the_lights_is_the_same_on_every_backend() {
    let inp = inputs(11, 301);
    let dirs: Vec<Vec3> = inp
        .n
        .iter()
        .zip(&inp.p)
        .map(|(n, p)| (*n + *p * 0.3).normalize())
        .collect();
    for light in lights() {
        let want = Backend::Scalar
            .run(Seen {
                light: &light,
                dirs: &dirs,
            })
            .unwrap();
        if light.kind() != coherent::light::LightKind::Environment {
            assert!(want.iter().all(|c| *c == [0.0; 3]), "{}", light.kind());
        }
        for b in Backend::usable() {
            let got = b
                .run(Seen {
                    light: &light,
                    dirs: &dirs,
                })
                .unwrap();
            // Nearest texel: directions on a texel border may pick the neighbour when
            // the approximate angles round differently; at most a few.
            let differ = got.iter().zip(&want).filter(|(g, w)| g != w).count();
            assert!(
                differ <= 2,
                "{} on {}: {differ} directions differ",
                light.kind(),
                b.name()
            );
        }
    }
}
