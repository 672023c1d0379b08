//! How exact the BSP's hit distances are: the relative error of `t` against the ray's
//! intersection with the hit triangle's plane computed in f64, for the BSP's projection test
//! and for a textbook f32 Möller-Trumbore test (the family of Embree's and obvhs' tests) on
//! the same triangles.
//!
//! ```text
//! cargo run --release -p coherent-bsp --example t_error -- [quick|full]
//! ```
//!
//! Primary and diffuse rays of a 1024 x 768 image (the `accel` experiment's workload) on each
//! built-in scene. Both tests see the ray as the traversal does: moved into the instance's
//! object space in f32. The reference moves it in f64, from the same f32 ray, and intersects
//! the f32 triangle's plane in f64. `docs/findings/traversal.md` cites it for the image
//! differences between accelerators.

use coherent_accel::scenes::{self, SceneSize};
use coherent_accel::workload::{self, RayKind};
use coherent_accel::{Accel, Ray1, Scene};
use coherent_bsp::{Bsp, BspParams};
use glam::{DAffine3, DVec3, Vec3};

fn main() {
    let size = match std::env::args().nth(1).as_deref() {
        Some("quick") => SceneSize::Quick,
        _ => SceneSize::Full,
    };
    for s in scenes::all(size) {
        let bsp = Bsp::build(&s.scene, &BspParams::default()).expect("the scene builds");
        let primary = workload::primary_rays(&s.view, 1024, 768, workload::tile_shape(16));
        let diffuse = workload::diffuse_rays(&bsp, &s.scene, &primary, 7);
        for (kind, rays) in [(RayKind::Primary, &primary), (RayKind::Diffuse, &diffuse)] {
            let mut bsp_err = Vec::new();
            let mut mt_err = Vec::new();
            for r in rays.iter() {
                let Some(h) = bsp.intersect1(r) else { continue };
                let (a, b, c, m) = triangle(&s.scene, h.inst, h.prim);
                let Some(exact) = plane_t(r, a, b, c, m) else {
                    continue;
                };
                bsp_err.push((f64::from(h.t) - exact).abs() / exact);
                let inv = m.inverse();
                let o = inv.transform_point3(r.origin);
                let d = inv.transform_vector3(r.dir);
                if let Some(t) = moller_trumbore(o, d, a, b, c) {
                    mt_err.push((f64::from(t) - exact).abs() / exact);
                }
            }
            println!(
                "{:>8} {:>8}: {:>7} hits; relative t error, median / 99th percentile: BSP {}, Möller-Trumbore {}",
                s.name,
                kind.name(),
                bsp_err.len(),
                quantiles(&mut bsp_err),
                quantiles(&mut mt_err),
            );
        }
    }
}

/// The hit triangle's corners in object space and the instance's `world_from_object`.
fn triangle(scene: &Scene, inst: u32, prim: u32) -> (Vec3, Vec3, Vec3, glam::Affine3A) {
    let instance = &scene.instances[inst as usize];
    let mesh = &scene.meshes[instance.mesh];
    let [i, j, k] = mesh.indices[prim as usize];
    let p = |i: u32| mesh.positions[i as usize];
    (p(i), p(j), p(k), instance.world_from_object)
}

/// `t` where the f32 ray meets the plane of the f32 triangle, all in f64.
fn plane_t(r: &Ray1, a: Vec3, b: Vec3, c: Vec3, m: glam::Affine3A) -> Option<f64> {
    let inv = DAffine3::from_mat4(glam::Mat4::from(m).as_dmat4().inverse());
    let o = inv.transform_point3(r.origin.as_dvec3());
    let d = inv.transform_vector3(r.dir.as_dvec3());
    let (a, b, c): (DVec3, DVec3, DVec3) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    let n = (b - a).cross(c - a);
    let t = (a - o).dot(n) / d.dot(n);
    (t.is_finite() && t > 0.0).then_some(t)
}

/// Möller & Trumbore 1997, in f32, without culling.
fn moller_trumbore(o: Vec3, d: Vec3, a: Vec3, b: Vec3, c: Vec3) -> Option<f32> {
    let e1 = b - a;
    let e2 = c - a;
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - a;
    let u = s.dot(p) * inv;
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if !(0.0..=1.0).contains(&u) || v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some(e2.dot(q) * inv)
}

/// "median / 99th percentile" of `e`.
fn quantiles(e: &mut [f64]) -> String {
    if e.is_empty() {
        return "-".to_owned();
    }
    e.sort_by(f64::total_cmp);
    let at = |q: f64| e[((e.len() - 1) as f64 * q) as usize];
    format!("{:.1e} / {:.1e}", at(0.5), at(0.99))
}
