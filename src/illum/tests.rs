//! The particle pass and its map against what must hold: the furnace (a closed diffuse
//! sphere lit from its centre), energy bounds, bit-identical maps whatever the mode, thread
//! count or file round trip, and errors for bad input.

use std::path::Path;

use coherent_accel::shapes::icosphere;
use coherent_simd::Backend;
use glam::Vec3;

use super::cells::CellLayout;
use super::trace::build_map_on;
use super::*;
use crate::accel_any::AnyAccel;
use crate::light::Light;
use crate::light::omni::Omni;
use crate::material::Material;
use crate::scene::{Camera, RenderScene, ShadedMesh};

/// The backends these tests run on, the only ones their traversal is compiled for: scalar
/// and whatever [`Backend::widest`] may be (avx512, avx2 or sse on x86-64; wide16, or pulp4
/// in builds without `wide`, elsewhere).
#[cfg(target_arch = "x86_64")]
const TESTED: u32 =
    Backend::Scalar.bit() | Backend::Avx512.bit() | Backend::Avx2.bit() | Backend::Sse.bit();
#[cfg(not(target_arch = "x86_64"))]
const TESTED: u32 = Backend::Scalar.bit() | Backend::Wide16.bit() | Backend::Pulp4.bit();

/// The widest backend here, if the tests are compiled for it.
fn widest() -> Option<Backend> {
    let b = Backend::widest();
    if TESTED & b.bit() != 0 {
        Some(b)
    } else {
        eprintln!("skipping backend {b}: not compiled into these tests");
        None
    }
}

/// A closed sphere of radius `r` (icosphere of `subdivisions`) with diffuse albedo `rho`
/// around an omni light of intensity `intensity` at its centre.
fn furnace(rho: f32, subdivisions: u32, r: f32, intensity: f32) -> RenderScene {
    let mesh = icosphere("wall", Vec3::ZERO, r, subdivisions);
    RenderScene {
        name: format!("furnace {rho}"),
        meshes: vec![ShadedMesh::flat(mesh, 0)],
        instances: vec![coherent_accel::Instance::identity(0)],
        materials: vec![Material::phong("wall", [rho; 3], [0.0; 3], 0.0)],
        lights: vec![Light::Omni(Omni::new(Vec3::ZERO, [intensity; 3]).unwrap())],
        camera: Camera::framing(Vec3::splat(-r), Vec3::splat(r)),
        width: 64,
        height: 64,
        depth: 1,
        spp: None,
        accuracy: None,
        tonemap: Default::default(),
        background: [0.0; 3],
        motion: Vec::new(),
        light_spectra: Vec::new(),
    }
}

/// The built-in Cornell-like room (mirror box, glass sphere) with an omni light where its
/// area light hangs; `grey`: every colour made grey (its channels' mean).
fn cornell(grey: bool) -> RenderScene {
    let mut s = crate::scene::load("cornell").unwrap();
    s.lights = vec![Light::Omni(
        Omni::new(Vec3::new(0.0, 1.9, 0.0), [3.0, 2.0, 1.0]).unwrap(),
    )];
    if grey {
        let g = |c: [f32; 3]| [(c[0] + c[1] + c[2]) / 3.0; 3];
        for m in &mut s.materials {
            m.phong.diffuse = g(m.phong.diffuse);
            m.optics.reflectance = g(m.optics.reflectance);
            m.optics.transmittance = g(m.optics.transmittance);
        }
    }
    s
}

fn accel(scene: &RenderScene) -> AnyAccel {
    AnyAccel::build_named(&scene.accel_scene(), "bsp").unwrap()
}

fn build(
    backend: Backend,
    scene: &RenderScene,
    accel: &AnyAccel,
    opts: &MapOptions,
) -> Result<(IllumMap, TraceStats), IllumError> {
    build_map_on::<TESTED>(backend, scene, accel, opts, &|_| {})
}

/// Every value of the map as bits (cells, then lattice points).
fn bits(m: &IllumMap) -> Vec<u32> {
    let mut v: Vec<u32> = m
        .cell_irradiance()
        .iter()
        .flat_map(|e| e.map(f32::to_bits))
        .collect();
    for c in m.lattice() {
        v.extend(c.iter().map(|x| x.to_bits()));
    }
    v
}

#[test]
fn a_diffuse_sphere_around_a_point_light_holds_rho_over_one_minus_rho_of_the_direct_light() {
    let (r, intensity) = (2.0f32, 5.0f32);
    let particles = 6000u64;
    for rho in [0.3f32, 0.5, 0.8] {
        let scene = furnace(rho, 3, r, intensity);
        let a = accel(&scene);
        let opts = MapOptions {
            particles,
            cells: 2048,
            chunk: 1024,
            ..MapOptions::default()
        };
        let (map, stats) = build(Backend::Scalar, &scene, &a, &opts).unwrap();
        let area: f64 = map.cell_area().iter().map(|&a| f64::from(a)).sum();
        // Every particle lands on the closed wall, so the mean direct irradiance is the
        // power over the wall's area (I / R^2 for a true sphere; the facets lie a little
        // inside it).
        let power = 4.0 * std::f64::consts::PI * f64::from(intensity);
        let direct = power / area;
        let ideal = f64::from(intensity) / f64::from(r * r);
        assert!((direct / ideal - 1.0).abs() < 0.02, "{direct} {ideal}");
        assert!(
            (stats.emitted[0] / power - 1.0).abs() < 1e-5,
            "{:?}",
            stats.emitted
        );
        let mean: f64 = map
            .cell_irradiance()
            .iter()
            .zip(map.cell_area())
            .map(|(e, &a)| f64::from(e[0]) * f64::from(a))
            .sum::<f64>()
            / area;
        let rho = f64::from(rho);
        let want = direct * rho / (1.0 - rho);
        // Each particle deposits its whole power once per bounce past the first, a
        // geometric number of times with mean rho / (1 - rho) and variance
        // rho / (1 - rho)^2: the mean's relative deviation is 1 / sqrt(N rho).
        let sigma = 1.0 / (particles as f64 * rho).sqrt();
        let dev = (mean / want - 1.0).abs();
        assert!(
            dev < 4.0 * sigma,
            "rho {rho}: {mean} against {want} ({dev} > 4 x {sigma})"
        );
        // The deposits the statistics count are the map's.
        assert!((stats.deposited[0] / (mean * area) - 1.0).abs() < 1e-5);
        assert_eq!(stats.deposited_by_generation[0], [0.0; 3]);
        // The filtered lookup averages to the same level over random points.
        let tris = scene.meshes[0].mesh.indices.len() as u32;
        let mut sum = 0.0f64;
        let n = 4000;
        for k in 0..n {
            let h = |x: u32| crate::render::rng::hash1(x) as f32 / 4_294_967_296.0;
            let (u, v) = (h(3 * k), h(3 * k + 1));
            let (u, v) = if u + v > 1.0 {
                (1.0 - u, 1.0 - v)
            } else {
                (u, v)
            };
            sum += f64::from(map.irradiance1(0, k % tris, u, v)[0]);
        }
        let filtered = sum / f64::from(n);
        assert!(
            (filtered / want - 1.0).abs() < 0.1,
            "rho {rho}: {filtered} against {want}"
        );
    }
}

#[test]
fn no_generation_deposits_more_than_was_emitted() {
    let opts = MapOptions {
        particles: 3000,
        cells: 4096,
        chunk: 1000,
        ..MapOptions::default()
    };
    for grey in [true, false] {
        let scene = cornell(grey);
        let a = accel(&scene);
        let (_, stats) = build(Backend::Scalar, &scene, &a, &opts).unwrap();
        // Rounding to quanta moves each deposit by at most 2^-25 of a mean particle.
        let slack = 1.0 + 1e-6;
        for (g, d) in stats.deposited_by_generation.iter().enumerate() {
            for (c, (&dc, &ec)) in d.iter().zip(&stats.emitted).enumerate() {
                // Generation 1 deposits each particle's emitted power at most once, whatever
                // the colours; with grey materials roulette keeps a particle's power as it
                // is, so every generation does.
                if grey || g <= 1 {
                    assert!(
                        dc <= ec * slack,
                        "grey {grey}, generation {g}, channel {c}: {dc} > {ec}"
                    );
                }
            }
        }
        assert!(stats.deposited.iter().all(|&d| d > 0.0), "{stats:?}");
        assert!(stats.generations.len() > 3);
    }
}

#[test]
fn every_mode_and_thread_count_gives_the_same_map_bit_for_bit() {
    let scene = cornell(false);
    let a = accel(&scene);
    let base = MapOptions {
        particles: 1500,
        cells: 2048,
        chunk: 400,
        seed: 7,
        ..MapOptions::default()
    };
    for backend in std::iter::once(Backend::Scalar).chain(widest()) {
        let mut first: Option<Vec<u32>> = None;
        for mode in Mode::ALL {
            let opts = MapOptions { mode, ..base };
            let (map, stats) = build(backend, &scene, &a, &opts).unwrap();
            assert_eq!(stats.lanes, backend.lanes());
            let g0 = &stats.generations[0];
            let full = g0.rays.div_ceil(backend.lanes() as u64);
            if mode == Mode::Single {
                assert_eq!(g0.packets, g0.rays);
            } else {
                // Each chunk's last packet may be partial.
                assert!(g0.packets >= full && g0.packets <= full + 4, "{g0:?}");
            }
            let b = bits(&map);
            match &first {
                None => first = Some(b),
                Some(f) => assert!(*f == b, "{backend} {mode}: another map"),
            }
        }
        // Threads: one against two.
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let two = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let opts = MapOptions {
            mode: Mode::Sorted,
            ..base
        };
        let m1 = one.install(|| build(backend, &scene, &a, &opts).unwrap().0);
        let m2 = two.install(|| build(backend, &scene, &a, &opts).unwrap().0);
        assert!(bits(&m1) == bits(&m2), "{backend}: threads change the map");
        assert!(
            Some(bits(&m1)) == first,
            "{backend}: threads change the map"
        );
    }
}

#[test]
fn work_is_counted_when_asked() {
    let scene = furnace(0.5, 2, 1.0, 1.0);
    let a = accel(&scene);
    let opts = MapOptions {
        particles: 200,
        cells: 256,
        count_work: true,
        ..MapOptions::default()
    };
    let seen = std::sync::atomic::AtomicU64::new(0);
    let progress = |n: u64| {
        seen.fetch_max(n, std::sync::atomic::Ordering::Relaxed);
    };
    let (_, stats) = build_map_on::<TESTED>(Backend::Scalar, &scene, &a, &opts, &progress).unwrap();
    assert_eq!(seen.into_inner(), 200);
    assert_eq!(stats.particles, 200);
    assert_eq!(stats.generations[0].rays, 200);
    let t = stats.total();
    assert!(
        t.work.tri_tests >= t.rays && t.work.inner_nodes > 0,
        "{t:?}"
    );
    assert!(t.rays_per_second() > 0.0 && t.lanes_per_packet() == 1.0);
}

/// Writes `map` to `dir/name`.
fn saved(map: &IllumMap, dir: &Path, name: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    map.save(&p).unwrap();
    p
}

#[test]
fn a_saved_map_loads_bit_for_bit_and_only_for_its_scene_and_cells() {
    let dir = tempfile::tempdir().unwrap();
    let scene = cornell(false);
    let a = accel(&scene);
    let opts = MapOptions {
        particles: 500,
        cells: 3000,
        ..MapOptions::default()
    };
    let (map, _) = build(Backend::Scalar, &scene, &a, &opts).unwrap();
    let p = saved(&map, dir.path(), "cornell.exr");
    let back = IllumMap::load(&p, &scene, opts.cells).unwrap();
    assert!(bits(&back) == bits(&map));
    assert_eq!(back.particles(), 500);
    assert_eq!(back.cells(), map.cells());
    assert_eq!(back.fingerprint(), map.fingerprint());

    // Another scene: the light moved.
    let mut other = scene.clone();
    other.lights = vec![Light::Omni(
        Omni::new(Vec3::new(0.0, 1.5, 0.0), [3.0, 2.0, 1.0]).unwrap(),
    )];
    let e = IllumMap::load(&p, &other, opts.cells)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("cornell.exr") && e.contains("another scene"),
        "{e}"
    );
    // Another cells target.
    let e = IllumMap::load(&p, &scene, 4000).unwrap_err().to_string();
    assert!(e.contains("cells target of 3000, not 4000"), "{e}");
    // Truncated.
    let bytes = std::fs::read(&p).unwrap();
    let cut = dir.path().join("cut.exr");
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let e = IllumMap::load(&cut, &scene, opts.cells)
        .unwrap_err()
        .to_string();
    assert!(e.contains("cut.exr"), "{e}");
    // Not a map: an image without the attributes.
    let plain = dir.path().join("plain.exr");
    exr::prelude::write_rgb_file(&plain, 4, 4, |_, _| (0.0f32, 0.0f32, 0.0f32)).unwrap();
    let e = IllumMap::load(&plain, &scene, opts.cells)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("plain.exr") && e.contains("not an illumination map"),
        "{e}"
    );
    // Missing.
    let e = IllumMap::load(&dir.path().join("none.exr"), &scene, opts.cells)
        .unwrap_err()
        .to_string();
    assert!(e.contains("none.exr") && e.contains("cannot read"), "{e}");
}

#[test]
fn bad_options_are_errors_before_any_work() {
    let scene = furnace(0.5, 1, 1.0, 1.0);
    let a = accel(&scene);
    let run = |opts: MapOptions| {
        build(Backend::Scalar, &scene, &a, &opts)
            .unwrap_err()
            .to_string()
    };
    let d = MapOptions::default();
    let e = run(MapOptions { particles: 0, ..d });
    assert!(e.contains("0 particles"), "{e}");
    let e = run(MapOptions { cells: 0, ..d });
    assert!(e.contains("cells target of 0"), "{e}");
    let e = run(MapOptions { chunk: 0, ..d });
    assert!(e.contains("0 rays per chunk"), "{e}");
    let e = run(MapOptions {
        max_generations: 0,
        ..d
    });
    assert!(e.contains("0 generations"), "{e}");
    // 20,480 triangles of 64 x 64 cells each: over the default budget, refused before the
    // cells are allocated.
    let big = furnace(0.5, 5, 1.0, 1.0);
    let e = build(
        Backend::Scalar,
        &big,
        &accel(&big),
        &MapOptions {
            cells: u64::MAX,
            ..d
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("83886080 cells") && e.contains("budget"), "{e}");
    let e = CellLayout::new(&scene, 1000, 1000).unwrap_err().to_string();
    assert!(e.contains("over the budget of 1000 bytes"), "{e}");
    // A scene without lights.
    let mut dark = scene.clone();
    dark.lights.clear();
    let e = build(Backend::Scalar, &dark, &a, &d)
        .unwrap_err()
        .to_string();
    assert!(e.contains("no light"), "{e}");
}

#[test]
fn cells_cover_each_triangle_with_equal_areas_and_lookups_stay_in_range() {
    let scene = cornell(false);
    let layout = CellLayout::new(&scene, 5000, MAP_BUDGET).unwrap();
    let total: f64 = layout.cell_area().iter().map(|&a| f64::from(a)).sum();
    // The room's five quads (20 m^2), the box, the sphere.
    assert!(total > 20.0 && total < 30.0, "{total}");
    assert!(
        layout.cells() > 2500 && layout.cells() < 10_000,
        "{}",
        layout.cells()
    );
    // Barycentrics anywhere (outside the triangle, NaN) find a cell of the triangle.
    for (u, v) in [
        (0.0, 0.0),
        (1.0, 0.0),
        (0.0, 1.0),
        (0.5, 0.5),
        (-0.1, 1.2),
        (f32::NAN, 0.3),
    ] {
        for prim in 0..10 {
            let c = layout.cell(0, prim, u, v).unwrap();
            let s = layout.slot(0, prim).unwrap();
            assert!(layout.slot_cells(s).contains(&c), "{u} {v}");
        }
    }
    assert!(layout.cell(0, 1_000_000, 0.1, 0.1).is_none());
    assert!(layout.cell(99, 0, 0.1, 0.1).is_none());
}

#[test]
fn the_filtered_lookup_interpolates_the_lattice_and_is_smooth_across_a_sphere() {
    let scene = furnace(0.5, 3, 1.0, 1.0);
    let layout = CellLayout::new(&scene, 20_000, MAP_BUDGET).unwrap();
    // Irradiance that varies linearly with height: the lookup follows it closely.
    let mut irr = vec![[0.0f32; 3]; layout.cells()];
    for s in 0..layout.slots() {
        let n = layout.per_edge(s);
        let [a, b, c] = super::cells::world_triangle(&scene, 0, s);
        for j in 0..n {
            for i in 0..n - j {
                for upper in [false, true] {
                    if upper && i + j + 1 >= n {
                        continue;
                    }
                    let (x, y) = if upper {
                        (
                            (i as f32 + 2.0 / 3.0) / n as f32,
                            (j as f32 + 2.0 / 3.0) / n as f32,
                        )
                    } else {
                        (
                            (i as f32 + 1.0 / 3.0) / n as f32,
                            (j as f32 + 1.0 / 3.0) / n as f32,
                        )
                    };
                    let p = a + (b - a) * x + (c - a) * y;
                    let k = layout.slot_cells(s).start + super::cells::local_cell(n, i, j, upper);
                    irr[k] = [p.y + 2.0, 1.0, 0.0];
                }
            }
        }
    }
    let map = IllumMap::from_cells(&scene, layout, irr, 1).unwrap();
    for s in 0..map.layout().slots() as u32 {
        let [a, b, c] = super::cells::world_triangle(&scene, 0, s as usize);
        for (u, v) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.3, 0.3), (0.1, 0.8)] {
            let p = a + (b - a) * u + (c - a) * v;
            let e = map.irradiance1(0, s, u, v);
            // Exact inside (linear data); at corners, the mean over the neighbours' corner
            // cells, within a cell's height.
            assert!(
                (e[0] - (p.y + 2.0)).abs() < 0.05,
                "{s} ({u}, {v}): {e:?} {p}"
            );
            assert!((e[1] - 1.0).abs() < 1e-5 && e[2] == 0.0, "{e:?}");
        }
    }
    assert_eq!(map.irradiance1(3, 0, 0.1, 0.1), [0.0; 3]);
    // Lanes: the same values as one at a time, zero where inactive.
    for backend in std::iter::once(Backend::Scalar).chain(widest()) {
        let n = 64usize;
        let h = |x: u32| crate::render::rng::hash1(x) as f32 / 4_294_967_296.0;
        let prim: Vec<i32> = (0..n as u32).map(|k| (k * 37 % 1280) as i32).collect();
        let u: Vec<f32> = (0..n as u32).map(|k| h(2 * k) * 0.6).collect();
        let v: Vec<f32> = (0..n as u32).map(|k| h(2 * k + 1) * 0.4).collect();
        let out = backend
            .run(Lookup {
                map: &map,
                prim: &prim,
                u: &u,
                v: &v,
            })
            .unwrap();
        for k in 0..n {
            let want = if k % 3 == 0 {
                [0.0; 3]
            } else {
                map.irradiance1(0, prim[k] as u32, u[k], v[k])
            };
            let close = (0..3).all(|c| (out[k][c] - want[c]).abs() <= 1e-5 * want[c].abs());
            assert!(close, "{backend} lane {k}: {:?} against {want:?}", out[k]);
        }
    }
    assert!(map.bytes() > map.cells() * 16);
}

/// [`IllumMap::irradiance`] over packets of the backend's width, every third point inactive.
struct Lookup<'a> {
    map: &'a IllumMap,
    prim: &'a [i32],
    u: &'a [f32],
    v: &'a [f32],
}

impl coherent_simd::Kernel for Lookup<'_> {
    type Output = Vec<[f32; 3]>;
    const BACKENDS: u32 = TESTED;

    #[inline(always)]
    fn run<L: coherent_simd::Lanes>(self, l: L) -> Vec<[f32; 3]> {
        use coherent_simd::SimdF32;
        let mut out = Vec::new();
        for b in (0..self.prim.len()).step_by(L::N) {
            let active = l.mask_from_fn(|m| (b + m) % 3 != 0 && b + m < self.prim.len());
            let e = self.map.irradiance(
                l,
                l.splat_i32(0),
                l.load_i32(&self.prim[b..]),
                l.load(&self.u[b..]),
                l.load(&self.v[b..]),
                active,
            );
            let mut c = [[0.0f32; coherent_simd::MAX_LANES]; 3];
            e.r.store(&mut c[0]);
            e.g.store(&mut c[1]);
            e.b.store(&mut c[2]);
            let lanes = L::N.min(self.prim.len() - b);
            out.extend((0..lanes).map(|m| [c[0][m], c[1][m], c[2][m]]));
        }
        out
    }
}
