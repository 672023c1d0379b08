//! The rays every structure traces: per kind, ordered in screen tiles of each packet's or
//! beam's shape, and the scenes they are traced in.

use coherent::accel::{Ray1, Scene};
use coherent::bsp::Bsp;
use coherent::mesh_file::{MeshFileError, REAL_MESHES, RealMesh};
use coherent::simd::Backend;
use coherent_accel::scenes::{self, BuiltinScene, SceneSize, View};
use coherent_accel::workload::{self, RayKind};
use glam::Vec3;

use crate::ctx::Ctx;

/// Width 1 (single rays, `None`) and each packet width with its backend.
pub(super) fn widths(ctx: &mut Ctx) -> Vec<(usize, Option<Backend>)> {
    let mut v = vec![(1, None)];
    for w in [4, 8, 16] {
        match Backend::preferred_for_lanes(w) {
            Some(b) => v.push((w, Some(b))),
            None => ctx.note(format!("accel: no backend gives width {w} here")),
        }
    }
    v
}

/// The beams timed: (rays per beam, backend). Square tiles from 4x4 to 32x32 on the widest
/// backend; 8x8 and 16x16 on the scalar one.
pub(super) fn beams() -> Vec<(usize, Backend)> {
    let widest = Backend::widest();
    let mut v: Vec<(usize, Backend)> = [16, 64, 256, 1024].map(|n| (n, widest)).to_vec();
    if widest != Backend::Scalar {
        v.extend([(64, Backend::Scalar), (256, Backend::Scalar)]);
    }
    v
}

/// Lane packets of other shapes than the square tile: rows of 8 x 2 and 16 x 1 rays on the
/// backend of width 16, if there is one (what the packets' shape alone costs, beside its 4 x 4
/// row in `accel.csv`).
pub(super) fn shapes(widths: &[(usize, Option<Backend>)]) -> Vec<((u32, u32), Backend)> {
    widths
        .iter()
        .filter_map(|&(w, b)| b.filter(|_| w == 16))
        .flat_map(|b| [((8, 2), b), ((16, 1), b)])
        .collect()
}

/// The side of a square beam of `n` rays.
pub(super) fn beam_side(n: usize) -> u32 {
    (n as f64).sqrt().round() as u32
}

/// The rays of one kind, ordered in screen tiles for packets of `width` lanes. Every width
/// gets the same rays (diffuse rays are seeded per pixel), in its own order.
pub(crate) fn rays(
    s: &BuiltinScene,
    bsp: &Bsp,
    kind: RayKind,
    w: u32,
    h: u32,
    width: usize,
) -> Vec<Ray1> {
    rays_in_tiles(
        s,
        bsp,
        kind,
        w,
        h,
        workload::tile_shape(if width == 1 { 16 } else { width }),
    )
}

/// The rays of one kind, ordered tile by tile (`tile`: width and height in pixels).
pub(super) fn rays_in_tiles(
    s: &BuiltinScene,
    bsp: &Bsp,
    kind: RayKind,
    w: u32,
    h: u32,
    tile: (u32, u32),
) -> Vec<Ray1> {
    from_primary(s, bsp, kind, workload::primary_rays(&s.view, w, h, tile))
}

/// The rays of one kind from primary rays `primary`, in their order.
pub(super) fn from_primary(
    s: &BuiltinScene,
    bsp: &Bsp,
    kind: RayKind,
    primary: Vec<Ray1>,
) -> Vec<Ray1> {
    match kind {
        RayKind::Primary => primary,
        RayKind::Shadow => workload::shadow_rays(bsp, &s.scene, &primary, s.light),
        RayKind::Diffuse => workload::diffuse_rays(bsp, &s.scene, &primary, 7),
    }
}

/// The scenes: the built-in ones, then the real meshes (quick: the bunny only); a mesh that
/// is not fetched is noted and left out.
pub(crate) fn scene_list(ctx: &mut Ctx, size: SceneSize) -> Vec<BuiltinScene> {
    let mut list = scenes::all(size);
    let real = match size {
        SceneSize::Quick => &REAL_MESHES[..1],
        SceneSize::Full => &REAL_MESHES[..],
    };
    for m in real {
        match real_scene(m) {
            Ok(s) => list.push(s),
            Err(e) => ctx.note(format!("accel: scene {} left out: {e}", m.name)),
        }
    }
    list
}

/// A real mesh as a scene for the comparisons: placed once, seen from the front-right and a
/// little above (+y up) so that it fills most of the view, lit from above the eye.
pub(crate) fn real_scene(m: &RealMesh) -> Result<BuiltinScene, MeshFileError> {
    let mesh = m.load()?;
    let b = mesh.bounds();
    let (center, radius) = (b.center(), 0.5 * b.extent().length());
    let eye = center + Vec3::new(0.35, 0.25, 1.0).normalize() * (2.6 * radius);
    Ok(BuiltinScene {
        name: m.name,
        scene: Scene::single(mesh),
        view: View {
            eye,
            target: center,
            up: Vec3::Y,
            fov_y_degrees: 45.0,
        },
        light: center + Vec3::new(-0.5, 2.0, 1.5) * radius,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fetched_meshes_load_as_scenes() {
        for m in &REAL_MESHES {
            match real_scene(m) {
                Ok(s) => {
                    s.scene.validate().unwrap();
                    assert!(s.scene.meshes[0].indices.len() > 10_000, "{}", m.name);
                    // The view looks at the mesh: the central primary ray hits its box.
                    let r = s.view.ray_at(0.5, 0.5, 4.0 / 3.0);
                    let b = s.scene.meshes[0].bounds();
                    assert!(
                        b.clip1(r.origin, r.dir.recip(), 0.0, f32::INFINITY)
                            .is_some()
                    );
                }
                Err(e @ MeshFileError::NotFetched { .. })
                    if !coherent::require::required("COHERENT_REQUIRE_MESHES") =>
                {
                    eprintln!("skipping {}: {e}", m.name)
                }
                Err(e) => panic!("{e}"),
            }
        }
    }
}
