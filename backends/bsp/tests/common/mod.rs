//! Shared helpers of the BSP tests: random scenes and rays, and the comparison of every
//! query (single-ray and packet) against `BruteForce` (paper section 3's queries).

#![allow(dead_code)]

use coherent_accel::shapes::{Rng, soup};
use coherent_accel::{Accel, BruteForce, Hit1, Instance, Mesh, Ray1, Rays, Scene};
use coherent_bsp::{Bsp, BspParams};
use coherent_simd::{Lanes, SimdMask};
use glam::{Affine3A, Quat, Vec3};

/// A random scene: `meshes` soups of about `tris` triangles in total (with some planar,
/// axis-aligned and degenerate triangles), placed by `instances` instances (identity or
/// random rotation, non-uniform scale and translation).
pub fn random_scene(seed: u64, tris: usize, meshes: usize, instances: usize) -> Scene {
    let mut rng = Rng::new(seed);
    let mut scene = Scene::default();
    for m in 0..meshes.max(1) {
        let n = (tris / meshes.max(1)).max(1);
        let size = [0.3, 2.0, 8.0][rng.next_u64() as usize % 3];
        let mut mesh = soup(&format!("soup{m}"), n, 5.0, size, rng.next_u64());
        // Triangles lying in axis planes (planar split events), and shared positions.
        for t in 0..n {
            let [a, b, c] = mesh.indices[t];
            match rng.next_u64() % 16 {
                0 => {
                    let k = (rng.next_u64() % 3) as usize;
                    let v = mesh.positions[a as usize][k];
                    mesh.positions[b as usize][k] = v;
                    mesh.positions[c as usize][k] = v;
                }
                1 if t > 0 => {
                    // Share an edge with the previous triangle.
                    let [p, q, _] = mesh.indices[t - 1];
                    mesh.indices[t] = [p, q, c];
                }
                2 => {
                    // Degenerate: collapsed onto a line.
                    let p = mesh.positions[a as usize];
                    mesh.positions[c as usize] = p + (mesh.positions[b as usize] - p) * 0.5;
                }
                _ => {}
            }
        }
        scene.add_mesh(mesh);
    }
    for _ in 0..instances {
        let mesh = rng.next_u64() as usize % scene.meshes.len();
        let m = if rng.next_u64().is_multiple_of(3) {
            Affine3A::IDENTITY
        } else {
            let q = Quat::from_axis_angle(rng.unit_vector(), rng.range(0.0, 6.3));
            let s = Vec3::new(
                rng.range(0.2, 3.0),
                rng.range(0.2, 3.0),
                rng.range(0.2, 3.0),
            );
            let t = rng.vec3(Vec3::splat(-8.0), Vec3::splat(8.0));
            Affine3A::from_scale_rotation_translation(s, q, t)
        };
        scene.instances.push(Instance::new(mesh, m));
    }
    scene
}

/// Random rays at a scene: from a box around it, random or axis-parallel directions, some
/// aimed at triangle vertices, edges and interiors, some with finite `tmax` or `tmin > 0`.
pub fn random_rays(seed: u64, scene: &Scene, n: usize) -> Vec<Ray1> {
    let mut rng = Rng::new(seed ^ 0x5eed);
    (0..n)
        .map(|_| {
            let o = rng.vec3(Vec3::splat(-15.0), Vec3::splat(15.0));
            let mut d = match rng.next_u64() % 8 {
                0 => {
                    // Axis-parallel.
                    let mut d = Vec3::ZERO;
                    d[(rng.next_u64() % 3) as usize] = if rng.f32() < 0.5 { -1.0 } else { 1.0 };
                    d
                }
                1 => {
                    let mut d = rng.unit_vector();
                    d[(rng.next_u64() % 3) as usize] = 0.0;
                    d
                }
                2..=4 if !scene.instances.is_empty() => {
                    // At a point of a triangle: a vertex, an edge or inside.
                    let inst = &scene.instances[rng.next_u64() as usize % scene.instances.len()];
                    let mesh = &scene.meshes[inst.mesh];
                    let [a, b, c] = mesh.triangle(rng.next_u64() as usize % mesh.indices.len());
                    let p = match rng.next_u64() % 3 {
                        0 => a,
                        1 => a.lerp(b, rng.f32()),
                        _ => {
                            let (u, v) = (rng.f32(), rng.f32());
                            let (u, v) = if u + v > 1.0 {
                                (1.0 - u, 1.0 - v)
                            } else {
                                (u, v)
                            };
                            a + (b - a) * u + (c - a) * v
                        }
                    };
                    inst.world_from_object.transform_point3(p) - o
                }
                _ => rng.unit_vector(),
            };
            if rng.next_u64().is_multiple_of(4) {
                d *= rng.range(0.01, 10.0);
            }
            let tmin = if rng.next_u64().is_multiple_of(5) {
                rng.range(0.0, 2.0)
            } else {
                0.0
            };
            let tmax = if rng.next_u64().is_multiple_of(4) {
                rng.range(tmin, 30.0)
            } else {
                f32::INFINITY
            };
            Ray1::new(o, d, tmin, tmax)
        })
        .collect()
}

/// `a` and `b` are the same distance, within 1e-5 relative (absolute near 0).
pub fn same_t(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-5 * a.abs().max(b.abs()).max(1.0)
}

/// Checks a first hit against the brute-force answer: the same triangle and instance with
/// the same `t`, or a tie (another triangle the ray really hits at the same `t`).
pub fn check_first(bf: &BruteForce, ray: &Ray1, got: Option<Hit1>) -> Result<(), String> {
    let want = bf.intersect1(ray);
    match (want, got) {
        (None, None) => Ok(()),
        (Some(w), Some(g)) if (w.prim, w.inst) == (g.prim, g.inst) => {
            if same_t(w.t, g.t) && (w.u - g.u).abs() < 1e-4 && (w.v - g.v).abs() < 1e-4 {
                Ok(())
            } else {
                Err(format!("{ray:?}: same triangle, want {w:?}, got {g:?}"))
            }
        }
        (Some(w), Some(g)) if same_t(w.t, g.t) => {
            // A tie: the reported triangle must really be hit there.
            let mut real = false;
            bf.intersect_all1(ray, &mut |h| {
                real |= (h.prim, h.inst) == (g.prim, g.inst) && same_t(h.t, g.t)
            });
            if real {
                Ok(())
            } else {
                Err(format!("{ray:?}: want {w:?}, got {g:?}, which is no hit"))
            }
        }
        (w, g) => Err(format!("{ray:?}: want {w:?}, got {g:?}")),
    }
}

/// All hits as a sorted list of (instance, triangle, t).
pub fn sorted(mut v: Vec<Hit1>) -> Vec<(u32, u32, f32)> {
    v.sort_by_key(|h| (h.inst, h.prim));
    v.into_iter().map(|h| (h.inst, h.prim, h.t)).collect()
}

pub fn check_all(bf: &BruteForce, ray: &Ray1, got: Vec<Hit1>) -> Result<(), String> {
    let mut want = vec![];
    bf.intersect_all1(ray, &mut |h| want.push(h));
    let (w, g) = (sorted(want), sorted(got));
    let same = w.len() == g.len()
        && w.iter()
            .zip(&g)
            .all(|(a, b)| a.0 == b.0 && a.1 == b.1 && same_t(a.2, b.2));
    if same {
        Ok(())
    } else {
        Err(format!("{ray:?}: all hits, want {w:?}, got {g:?}"))
    }
}

/// Every query of `bsp`, single-ray and in packets of `L`, against brute force over `rays`.
/// Packets use the active lanes of `mask_seed`'s pattern (inactive lanes must stay misses).
pub fn check_all_queries<L: Lanes>(
    l: L,
    bf: &BruteForce,
    bsp: &Bsp,
    rays: &[Ray1],
    mask_seed: u64,
) -> Result<(), String> {
    for r in rays {
        check_first(bf, r, bsp.intersect1(r))?;
        if bf.occluded1(r) != bsp.occluded1(r) {
            return Err(format!("{r:?}: occluded1 want {}", bf.occluded1(r)));
        }
        let mut all = vec![];
        bsp.intersect_all1(r, &mut |h| all.push(h));
        check_all(bf, r, all)?;
    }
    let mut rng = Rng::new(mask_seed);
    for chunk in rays.chunks(L::N) {
        let p = Rays::from_fn(l, |i| chunk[i % chunk.len()]);
        let bits = if rng.next_u64().is_multiple_of(2) {
            u32::MAX
        } else {
            rng.next_u64() as u32
        };
        let active = l.mask_from_fn(|i| i < chunk.len() && bits >> i & 1 == 1);
        let hits = bsp.intersect(l, &p, active);
        let occ = bsp.occluded(l, &p, active);
        let mut all = vec![vec![]; L::N];
        bsp.intersect_all(l, &p, active, &mut |i, h| all[i].push(h));
        for (i, hits_i) in all.into_iter().enumerate() {
            let r = p.lane(i);
            if active.lane(i) {
                check_first(bf, &r, hits.lane(i)).map_err(|e| format!("lane {i}: {e}"))?;
                if occ.lane(i) != bf.occluded1(&r) {
                    return Err(format!(
                        "lane {i}: {r:?}: occluded want {}",
                        bf.occluded1(&r)
                    ));
                }
                check_all(bf, &r, hits_i).map_err(|e| format!("lane {i}: {e}"))?;
            } else if hits.lane(i).is_some() || occ.lane(i) || !hits_i.is_empty() {
                return Err(format!("inactive lane {i} reported a hit"));
            }
        }
    }
    Ok(())
}

/// Builds both accelerators.
pub fn build_both(scene: &Scene, params: &BspParams) -> (BruteForce, Bsp) {
    (
        BruteForce::build(scene, &()).unwrap(),
        Bsp::build(scene, params).unwrap(),
    )
}

/// A single mesh scene.
pub fn one(mesh: Mesh) -> Scene {
    Scene::single(mesh)
}
