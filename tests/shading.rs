//! Shading equivalence (paper section 4): tabulated BDFs, the non-uniform table search,
//! texture sampling, mip level choice and multi-material packets give on every backend what
//! the scalar backend gives one ray at a time. Backends this CPU cannot run are skipped
//! with their reason printed.
//!
//! Every backend runs the same approximations, so results differ only where `mul_add` is
//! fused (FMA backends) or not: table searches and mip levels are compared bit for bit;
//! BDF values, which go through dot products and the inverse trigonometry polynomials, to
//! [`REL_TOL`] of the value (a few ulps of angle times the steepest table slope).

use std::sync::Arc;

use coherent::bdf::{
    Analytic, Bdf, Frames, PAPER_ANISOTROPIC_SHAPE, Symmetry, tabulate_anisotropic,
    tabulate_isotropic,
};
use coherent::material::{Material, Optics, ShadeHits, SplitCount, shade};
use coherent::simd::{Backend, Kernel, Lanes, MAX_LANES, SimdF32, SimdI32, Vec3s};
use coherent::tabulated::Axis;
use coherent::texture::{Texture, Wrap, lod_by_halving};
use glam::Vec3;
use proptest::prelude::*;
use rand::{Rng, SeedableRng, rngs::StdRng};

/// Relative tolerance of BDF and shading values between backends (see the module doc).
const REL_TOL: f32 = 1e-4;

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= REL_TOL * b.abs().max(1.0) || (a.is_nan() && b.is_nan())
}

/// Runs `k` on every usable backend, printing the skipped ones.
fn on_every_backend<K: Kernel + Clone>(k: K) -> Vec<(Backend, K::Output)> {
    Backend::usable()
        .into_iter()
        .map(|b| (b, b.run(k.clone()).expect("usable backend")))
        .collect()
}

/// A unit vector from two numbers in [0, 1) (uniform on the sphere).
fn sphere(u: f32, v: f32) -> Vec3 {
    let z = 1.0 - 2.0 * u;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * v;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Local direction pairs, most above the surface, some below, some grazing.
#[derive(Clone, Debug)]
struct Dirs {
    wi: Vec<Vec3>,
    wo: Vec<Vec3>,
}

fn dirs(seed: u64, n: usize) -> Dirs {
    let mut rng = StdRng::seed_from_u64(seed);
    let pick = |rng: &mut StdRng| {
        let w = sphere(rng.random(), rng.random());
        match rng.random_range(0..10) {
            0 => w,                                              // anywhere, also below
            1 => Vec3::new(w.x, w.y, 0.0).normalize_or(Vec3::Z), // grazing
            _ => Vec3::new(w.x, w.y, w.z.abs()),
        }
    };
    Dirs {
        wi: (0..n).map(|_| pick(&mut rng)).collect(),
        wo: (0..n).map(|_| pick(&mut rng)).collect(),
    }
}

#[derive(Clone)]
struct EvalBdf<'a> {
    bdf: &'a Bdf,
    dirs: &'a Dirs,
}

impl Kernel for EvalBdf<'_> {
    type Output = Vec<[f32; 3]>;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Vec<[f32; 3]> {
        let n = self.dirs.wi.len();
        let mut out = Vec::with_capacity(n);
        for p in (0..n).step_by(L::N) {
            let wi = Vec3s::from_fn(l, |i| self.dirs.wi[p + i]);
            let wo = Vec3s::from_fn(l, |i| self.dirs.wo[p + i]);
            let v = self.bdf.eval(l, &wi, &wo);
            out.extend((0..L::N).map(|i| v.lane(i)));
        }
        out
    }
}

fn check_bdf(bdf: &Bdf, d: &Dirs) {
    let runs = on_every_backend(EvalBdf { bdf, dirs: d });
    let (_, scalar) = &runs[0];
    for (b, got) in &runs[1..] {
        for (i, (g, s)) in got.iter().zip(scalar).enumerate() {
            for c in 0..3 {
                assert!(
                    close(g[c], s[c]),
                    "{b}: lane {i} ({:?}, {:?}) channel {c}: {} vs scalar {}",
                    d.wi[i],
                    d.wo[i],
                    g[c],
                    s[c]
                );
            }
        }
    }
}

#[test]
fn bdf_tables_equal_scalar_on_every_backend() {
    let d = dirs(1, 4096);
    let tables: Vec<Bdf> = vec![
        tabulate_anisotropic(
            &Analytic::brushed_ward(),
            PAPER_ANISOTROPIC_SHAPE,
            Symmetry::Quadrant,
        )
        .unwrap()
        .into(),
        tabulate_anisotropic(&Analytic::rough_ggx(), [9, 13, 9, 13], Symmetry::None)
            .unwrap()
            .into(),
        tabulate_isotropic(&Analytic::rough_ggx(), [17, 17, 13])
            .unwrap()
            .into(),
    ];
    for bdf in &tables {
        check_bdf(bdf, &d);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn bdf_equals_scalar_for_any_directions(
        u in prop::collection::vec((0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0), MAX_LANES)
    ) {
        let bdf: Bdf = tabulate_anisotropic(&Analytic::brushed_ward(), [9, 5, 9, 7], Symmetry::Quadrant)
            .unwrap()
            .into();
        let d = Dirs {
            wi: u.iter().map(|q| sphere(q.0, q.1)).collect(),
            wo: u.iter().map(|q| sphere(q.2, q.3)).collect(),
        };
        check_bdf(&bdf, &d);
    }
}

#[derive(Clone)]
struct Locate<'a> {
    axis: &'a Axis,
    x: &'a [f32],
}

impl Kernel for Locate<'_> {
    type Output = Vec<(i32, u32)>;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Vec<(i32, u32)> {
        let mut out = Vec::new();
        for p in (0..self.x.len()).step_by(L::N) {
            let c = self.axis.locate(l, l.load(&self.x[p..]));
            out.extend((0..L::N).map(|i| (c.index.lane(i), c.t.lane(i).to_bits())));
        }
        out
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn table_search_is_bit_exact_on_every_backend(
        steps in prop::collection::vec(0.01f32..2.0, 2..40),
        x in prop::collection::vec(prop_oneof![-5.0f32..60.0, Just(f32::NAN), Just(f32::INFINITY)], MAX_LANES * 4),
    ) {
        let mut nodes = vec![-1.0f32];
        for s in steps {
            nodes.push(nodes.last().unwrap() + s);
        }
        let axis = Axis::new(0, nodes).unwrap();
        let runs = on_every_backend(Locate { axis: &axis, x: &x });
        for (b, got) in &runs[1..] {
            prop_assert_eq!(got, &runs[0].1, "{}", b);
        }
        // And the scalar search is the plain binary search.
        for (i, &xi) in x.iter().enumerate() {
            let (idx, t) = axis.locate1(xi);
            prop_assert_eq!((runs[0].1[i].0 as usize, f32::from_bits(runs[0].1[i].1)), (idx, t));
        }
    }
}

#[derive(Clone)]
struct SampleTexture<'a> {
    tex: &'a Texture,
    st: &'a [(f32, f32, f32, f32)], // s, t, hit distance, spread
}

impl Kernel for SampleTexture<'_> {
    type Output = Vec<([f32; 3], f32)>;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Vec<([f32; 3], f32)> {
        let mut out = Vec::new();
        let top = self.tex.levels().len() - 1;
        for p in (0..self.st.len()).step_by(L::N) {
            let s = l.from_fn(|i| self.st[p + i].0);
            let t = l.from_fn(|i| self.st[p + i].1);
            let dist = l.from_fn(|i| self.st[p + i].2);
            let lod = lod_by_halving(l, dist, self.st[p].3, top);
            let v = self.tex.sample(l, s, t, lod);
            out.extend((0..L::N).map(|i| (v.lane(i), lod.lane(i))));
        }
        out
    }
}

#[test]
fn texture_sampling_equals_scalar_on_every_backend() {
    let (w, h) = (37, 23);
    let texels: Vec<[f32; 3]> = (0..w * h)
        .map(|i| {
            [
                (i % 7) as f32 * 0.3,
                (i % 11) as f32 * 0.1,
                ((i * 31) % 13) as f32,
            ]
        })
        .collect();
    let mut rng = StdRng::seed_from_u64(5);
    for wrap in [Wrap::Repeat, Wrap::Clamp] {
        let tex = Texture::from_linear("pattern", w, h, &texels, wrap).unwrap();
        let st: Vec<_> = (0..2048)
            .map(|_| {
                (
                    rng.random_range(-2.0..3.0),
                    rng.random_range(-2.0..3.0),
                    rng.random_range(0.1..500.0),
                    0.07,
                )
            })
            .collect();
        let runs = on_every_backend(SampleTexture { tex: &tex, st: &st });
        for (b, got) in &runs[1..] {
            for (i, (g, s)) in got.iter().zip(&runs[0].1).enumerate() {
                assert_eq!(g.1, s.1, "{b}: lane {i}: mip level");
                for c in 0..3 {
                    assert!(
                        close(g.0[c], s.0[c]),
                        "{b}: lane {i}: {:?} vs {:?}",
                        g.0,
                        s.0
                    );
                }
            }
        }
    }
}

fn materials() -> Vec<Material> {
    let checker: Vec<[f32; 3]> = (0..64)
        .map(|i| {
            if (i % 8 + i / 8) % 2 == 0 {
                [0.9, 0.8, 0.7]
            } else {
                [0.1, 0.2, 0.3]
            }
        })
        .collect();
    let tex = Arc::new(Texture::from_linear("checker", 8, 8, &checker, Wrap::Repeat).unwrap());
    let ward: Arc<Bdf> = Arc::new(
        tabulate_anisotropic(
            &Analytic::brushed_ward(),
            PAPER_ANISOTROPIC_SHAPE,
            Symmetry::Quadrant,
        )
        .unwrap()
        .into(),
    );
    let ggx: Arc<Bdf> = Arc::new(
        tabulate_isotropic(&Analytic::rough_ggx(), [9, 9, 9])
            .unwrap()
            .into(),
    );
    let mut plastic = Material::phong("plastic", [0.5, 0.1, 0.1], [0.3, 0.3, 0.3], 20.0);
    plastic.phong.ambient = [0.05, 0.05, 0.05];
    let mut floor = Material::phong("floor", [0.8, 0.8, 0.8], [0.0; 3], 1.0);
    floor.texture = Some(tex.clone());
    let mut metal = Material::phong("brushed", [0.0; 3], [0.0; 3], 0.0);
    metal.bdf = Some(ward);
    metal.texture = Some(tex);
    let mut glass = Material::phong("glass", [0.0; 3], [0.1; 3], 200.0);
    glass.optics = Optics {
        reflectance: [1.0; 3],
        transmittance: [0.9, 0.95, 0.9],
        ior: 1.5,
        fresnel: true,
        dispersion: None,
    };
    let mut gold = Material::phong("gold", [0.0; 3], [0.0; 3], 0.0);
    gold.bdf = Some(ggx);
    gold.optics.reflectance = [0.3, 0.2, 0.1];
    for m in [&plastic, &floor, &metal, &glass, &gold] {
        m.validate().unwrap();
    }
    vec![plastic, floor, metal, glass, gold]
}

/// One hit: material, active, normal, tangent, wo, wi, s, t, lod.
#[derive(Clone, Copy, Debug)]
struct Hit {
    material: i32,
    active: bool,
    n: Vec3,
    tangent: Vec3,
    wo: Vec3,
    wi: Vec3,
    st: [f32; 3],
}

fn hits(seed: u64, count: usize, materials: usize) -> Vec<Hit> {
    let mut rng = StdRng::seed_from_u64(seed);
    (0..count)
        .map(|_| {
            let n = sphere(rng.random(), rng.random());
            let any = sphere(rng.random(), rng.random());
            let tangent = any.cross(n).normalize_or(n.any_orthonormal_vector());
            let toward = |w: Vec3| if w.dot(n) < 0.0 && rng_flip(w) { -w } else { w };
            let wo = toward(sphere(rng.random(), rng.random()));
            let wi = toward(sphere(rng.random(), rng.random()));
            Hit {
                // Runs of the same material, as neighbouring pixels have, and mixes.
                material: if rng.random_bool(0.5) {
                    0
                } else {
                    rng.random_range(0..materials as i32)
                },
                active: rng.random_bool(0.85),
                n,
                tangent,
                wo,
                wi,
                st: [
                    rng.random_range(-1.0..2.0),
                    rng.random_range(-1.0..2.0),
                    rng.random_range(0.0..4.0),
                ],
            }
        })
        .collect()
}

/// Mostly flip directions below the surface above it (keeps some below).
fn rng_flip(w: Vec3) -> bool {
    (w.x * 1000.0).fract().abs() > 0.2
}

#[derive(Clone)]
struct ShadePackets<'a> {
    materials: &'a [Material],
    hits: &'a [Hit],
    /// Shade each hit alone in a packet of its own (lane 0 only).
    alone: bool,
}

impl Kernel for ShadePackets<'_> {
    type Output = (Vec<[[f32; 3]; 4]>, SplitCount);
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Self::Output {
        let mut out = Vec::new();
        let mut count = SplitCount::default();
        let step = if self.alone { 1 } else { L::N };
        for p in (0..self.hits.len()).step_by(step) {
            let h = |i: usize| self.hits[(p + i).min(self.hits.len() - 1)];
            let live = |i: usize| (!self.alone || i == 0) && h(i).active;
            let n = Vec3s::from_fn(l, |i| h(i).n);
            let tangent = Vec3s::from_fn(l, |i| h(i).tangent);
            let hits = ShadeHits {
                active: l.mask_from_fn(live),
                material: l.from_fn_i32(|i| if live(i) { h(i).material } else { 99 }),
                frames: Frames {
                    tangent,
                    bitangent: n.cross(tangent),
                    normal: n,
                },
                wo: Vec3s::from_fn(l, |i| h(i).wo),
                s: l.from_fn(|i| h(i).st[0]),
                t: l.from_fn(|i| h(i).st[1]),
                lod: l.from_fn(|i| h(i).st[2]),
            };
            let wi = Vec3s::from_fn(l, |i| h(i).wi);
            let s = shade(l, self.materials, &hits, &wi, &mut count).unwrap();
            for i in 0..step {
                out.push([
                    s.reflected.lane(i),
                    s.ambient.lane(i),
                    s.reflection.lane(i),
                    s.refraction.lane(i),
                ]);
            }
        }
        (out, count)
    }
}

#[test]
fn masked_multi_material_packets_equal_shading_each_ray_alone() {
    let mats = materials();
    let hs = hits(9, 16 * 64, mats.len());
    let (alone, alone_count) = Backend::Scalar
        .run(ShadePackets {
            materials: &mats,
            hits: &hs,
            alone: true,
        })
        .unwrap();
    let active = hs.iter().filter(|h| h.active).count() as u64;
    assert_eq!(alone_count.passes, active);
    for (b, (got, count)) in on_every_backend(ShadePackets {
        materials: &mats,
        hits: &hs,
        alone: false,
    }) {
        for (i, h) in hs.iter().enumerate() {
            for (k, part) in ["reflected", "ambient", "reflection", "refraction"]
                .iter()
                .enumerate()
            {
                for c in 0..3 {
                    let (g, s) = (got[i][k][c], alone[i][k][c]);
                    if h.active {
                        assert!(
                            close(g, s),
                            "{b}: hit {i} ({h:?}) {part}: {:?} vs alone {:?}",
                            got[i][k],
                            alone[i][k]
                        );
                    } else {
                        assert_eq!(g, 0.0, "{b}: inactive hit {i} {part}");
                    }
                }
            }
        }
        // One pass per distinct material among each packet's active lanes.
        let n = b.lanes();
        let mut want = SplitCount::default();
        for chunk in hs.chunks(n) {
            let mut ids: Vec<i32> = chunk
                .iter()
                .filter(|h| h.active)
                .map(|h| h.material)
                .collect();
            ids.sort();
            ids.dedup();
            want.packets += !ids.is_empty() as u64;
            want.passes += ids.len() as u64;
        }
        assert_eq!(count, want, "{b}");
        eprintln!(
            "{b}: {:.2} material passes per packet",
            count.passes_per_packet()
        );
    }
}

#[test]
fn unknown_material_is_an_error_naming_it() {
    let mats = materials();
    let mut hs = hits(3, 16, mats.len());
    hs[5].material = 17;
    hs[5].active = true;
    let l = coherent::simd::scalar::Scalar;
    let h = hs[5];
    let n = Vec3s::splat(l, h.n);
    let hits = ShadeHits {
        active: true,
        material: l.splat_i32(17),
        frames: Frames {
            tangent: Vec3s::splat(l, h.tangent),
            bitangent: n.cross(Vec3s::splat(l, h.tangent)),
            normal: n,
        },
        wo: Vec3s::splat(l, h.wo),
        s: 0.0,
        t: 0.0,
        lod: 0.0,
    };
    let e = shade(
        l,
        &mats,
        &hits,
        &Vec3s::splat(l, h.wi),
        &mut SplitCount::default(),
    )
    .unwrap_err();
    assert!(
        e.to_string().contains("material 17") && e.to_string().contains("5 material"),
        "{e}"
    );
    let mut bad = mats[0].clone();
    bad.optics.ior = -1.0;
    assert!(bad.validate().unwrap_err().to_string().contains("plastic"));
}
