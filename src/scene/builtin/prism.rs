//! `prism`: a spectrum from white light, for the spectral colour forms. The camera looks
//! through a 60° prism of Schott F2 flint (a strongly dispersive glass, [`GLASS`]) at a
//! narrow white slit on a black wall, at about the minimum deviation of the prism; the slit
//! is seen only through the glass (its direct view is outside the image), displaced by the
//! refraction by a different amount per wavelength. An RGB render (one index,
//! `optics.ior` = the glass's `n_d`) shows one white line; a spectral render shows the
//! slit's image fanned out into a rainbow band, blue to the left (a shorter wavelength is
//! bent more), about 37 pixels from 450 to 650 nm at the default 640 x 360.
//!
//! The renderer traces no caustics (shadow rays do not pass through glass), so the light is
//! not sent through the prism onto a screen: the eye looks through the prism instead, and
//! the slit is lit by a parallel light from high above, whose shadow rays from the slit
//! pass far over the prism. The even light shows the wall and floor as an even grey (a
//! tone-mapping operator adapts to the log average), against which the slit stands out.
//!
//! [`slit_column`] gives, in closed form, the image column at which the slit appears at a
//! wavelength: the test `tests/spectral_prism.rs` checks the renders against it. Layout (+y
//! up; the prism is an extrusion along y, so the deviation is worked out in the xz-plane):
//! the prism stands on a grey floor at y = 0, 0.6 tall, its sides 1 long, around the
//! origin; the camera looks at it horizontally from 3 units away at y = 0.3, along the
//! incident direction of minimum deviation at `n_d`; the exit direction is -z, towards the
//! wall 10 units away (the plane z = -10), whose slit (5 cm wide, white) runs vertically
//! through the point the central camera ray reaches at `n_d`.

use glam::{DVec2, Vec3};

use coherent_accel::Mesh;

use super::Builder;
use super::materials::glass;
use crate::light::{Light, Parallel};
use crate::material::Material;
use crate::scene::{Camera, RenderScene, ShadedMesh};
use crate::spectrum::dispersion::{Dispersion, LAMBDA_D, preset};

/// The prism's glass: a name of [`crate::spectrum::dispersion::PRESETS`].
pub const GLASS: &str = "F2";
/// The image size of the scene (the user's default render).
pub const DEFAULT_SIZE: (u32, u32) = (640, 360);
/// The prism's apex angle (degrees).
const APEX_DEG: f64 = 60.0;
/// The length of the prism's sides (its cross-section is equilateral).
const SIDE: f64 = 1.0;
/// The prism's height (it stands on the floor, y in [0, HEIGHT]).
const HEIGHT: f32 = 0.6;
/// The height of the eye (and of the horizon it looks along).
const EYE_Y: f32 = 0.3;
/// From the eye to the point it looks at, in the prism.
const EYE_DISTANCE: f64 = 3.0;
/// From the prism's centre to the wall (the plane z = -WALL_DISTANCE).
const WALL_DISTANCE: f64 = 10.0;
/// The camera's horizontal field of view (degrees), the same at every image size.
const HFOV_DEG: f64 = 30.0;
/// The slit's width on the wall (about 5 pixels at 640 x 360).
pub const SLIT_WIDTH: f32 = 0.05;
/// The wall's and the floor's extent in x (the eye looks at the wall obliquely, to the
/// left), and the wall's height.
const WALL_X: [f32; 2] = [-40.0, 12.0];
const WALL_TOP: f32 = 10.0;
/// The floor's extent towards the viewer.
const FLOOR_Z: f32 = 6.0;
/// The direction the light travels in: down, to the right and away from the viewer.
const LIGHT_DIRECTION: Vec3 = Vec3::new(0.3, -1.0, -0.6);
/// The light's irradiance (normal to it): the slit's radiance is about 1.
const IRRADIANCE: f32 = 6.0;

/// The prism's glass ([`GLASS`]).
fn glass_dispersion() -> Dispersion {
    preset(GLASS).expect("a known preset glass")
}

/// The layout in the xz-plane (a point `(x, z)`), every coordinate rounded to `f32` as the
/// scene stores it, so that [`slit_column`] traces the geometry the renderer sees.
struct Plan {
    /// The prism's cross-section: the apex, then the two base corners; the face
    /// `apex`-`base[1]` faces the eye (rays enter it) and `apex`-`base[0]` faces the wall
    /// (rays leave by it).
    apex: DVec2,
    base: [DVec2; 2],
    eye: DVec2,
    look_at: DVec2,
    /// The wall is the plane z = `wall_z`, facing +z; the slit's centre line is x = `slit_x`.
    wall_z: f64,
    slit_x: f64,
}

/// `v` as `f32` would store it.
fn round(v: DVec2) -> DVec2 {
    v.as_vec2().as_dvec2()
}

impl Plan {
    fn new() -> Plan {
        let n_d = f64::from(glass_dispersion().index_d());
        let a = APEX_DEG.to_radians();
        // The minimum deviation at n_d: the ray crosses the prism parallel to its base.
        let dev = 2.0 * (n_d * (a / 2.0).sin()).asin() - a;
        // The exit direction is -z; the incident one is turned by the deviation away from
        // the base, which lies towards +x.
        let d0 = DVec2::new(-dev.sin(), -dev.cos());
        let d1 = DVec2::new(0.0, -1.0);
        // Inside, the ray runs along the bisector of the two; the base is parallel to it.
        let along = (d0 + d1).normalize();
        let to_base = DVec2::new(-along.y, along.x);
        let h = SIDE * (a / 2.0).cos();
        let apex = round(-to_base * (2.0 / 3.0 * h));
        let base_mid = to_base * (h / 3.0);
        let base = [
            round(base_mid + along * (SIDE / 2.0)),
            round(base_mid - along * (SIDE / 2.0)),
        ];
        // Aim half way up the faces (the centroid is a third of the way up from the base).
        let look_at = round(-to_base * (h / 6.0));
        let eye = round(look_at - d0 * EYE_DISTANCE);
        let mut plan = Plan {
            apex,
            base,
            eye,
            look_at,
            wall_z: f64::from(-WALL_DISTANCE as f32),
            slit_x: 0.0,
        };
        let x = plan
            .wall_hit(eye, (look_at - eye).normalize(), n_d)
            .expect("the central ray crosses the prism");
        plan.slit_x = f64::from(x as f32);
        plan
    }

    /// The x at which the ray from `origin` along unit `dir` (outside the prism) meets the
    /// wall after entering the prism by the face towards the eye and leaving it by the face
    /// towards the wall, in glass of index `n`; `None` for a ray that misses either face or
    /// is totally reflected.
    fn wall_hit(&self, origin: DVec2, dir: DVec2, n: f64) -> Option<f64> {
        let entry = [self.apex, self.base[1]];
        let exit = [self.apex, self.base[0]];
        let faces = [entry, exit, self.base];
        let centroid = (self.apex + self.base[0] + self.base[1]) / 3.0;
        let mut o = origin;
        let mut d = dir;
        for (want, eta) in [(0, 1.0 / n), (1, n)] {
            let (t, k) = faces
                .iter()
                .enumerate()
                .filter_map(|(k, f)| segment_hit(o, d, f[0], f[1]).map(|t| (t, k)))
                .min_by(|a, b| a.0.total_cmp(&b.0))?;
            if k != want {
                return None;
            }
            let p = o + d * t;
            let [a, b] = faces[k];
            let e = (b - a).normalize();
            let mut outward = DVec2::new(e.y, -e.x);
            if outward.dot(p - centroid) < 0.0 {
                outward = -outward;
            }
            // The normal on the side the ray comes from.
            let facing = if d.dot(outward) < 0.0 {
                outward
            } else {
                -outward
            };
            d = refract(d, facing, eta)?;
            o = p;
        }
        if d.y >= 0.0 {
            return None;
        }
        let t = (self.wall_z - o.y) / d.y;
        Some(o.x + d.x * t)
    }
}

/// The `t > 0` at which the ray `o + t d` crosses the segment `a`-`b`.
fn segment_hit(o: DVec2, d: DVec2, a: DVec2, b: DVec2) -> Option<f64> {
    let e = b - a;
    let den = d.perp_dot(e);
    if den.abs() < 1e-15 {
        return None;
    }
    let ao = a - o;
    let t = ao.perp_dot(e) / den;
    let u = ao.perp_dot(d) / den;
    (t > 1e-9 && (0.0..=1.0).contains(&u)).then_some(t)
}

/// Snell's law: unit `d` through a surface of unit normal `n` (against `d`) with
/// `eta` = outside index / inside index; `None` past the critical angle.
fn refract(d: DVec2, n: DVec2, eta: f64) -> Option<DVec2> {
    let cos_i = -d.dot(n);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if sin2_t >= 1.0 {
        return None;
    }
    Some((d * eta + n * (eta * cos_i - (1.0 - sin2_t).sqrt())).normalize())
}

/// The scene's camera for a `width` x `height` image: the same eye, view and horizontal
/// field of view at every size (the vertical one follows the aspect), so that a short strip
/// around the horizon shows the slit's image at the same scale as the full image.
pub fn camera(width: u32, height: u32) -> Camera {
    let plan = Plan::new();
    let half_w = (HFOV_DEG.to_radians() / 2.0).tan();
    let vfov = 2.0 * (half_w * f64::from(height) / f64::from(width)).atan();
    let at = |p: DVec2| Vec3::new(p.x as f32, EYE_Y, p.y as f32);
    Camera {
        position: at(plan.eye),
        look_at: at(plan.look_at),
        up: Vec3::Y,
        vfov_deg: vfov.to_degrees() as f32,
    }
}

/// Where the slit appears at wavelength `lambda_nm` in a `width` x `height` image by
/// [`camera`]`(width, height)`: the continuous image x (pixels; pixel `i` covers
/// `[i, i + 1)`) of the ray through the horizon (image y = `height / 2`, a horizontal ray)
/// that reaches the slit's centre line after refracting into and out of the prism (Snell's
/// law with the glass's index at `lambda_nm`). `None` where that ray is outside the image.
///
/// Closed form, in `f64`: the camera maps image points to directions as
/// [`crate::camera::PinholeCamera`] does; the chief ray is traced in the xz-plane and the
/// column found by bisection.
pub fn slit_column(lambda_nm: f32, width: u32, height: u32) -> Option<f64> {
    let plan = Plan::new();
    let n = f64::from(glass_dispersion().index(lambda_nm));
    let cam = camera(width, height);
    let p = |v: Vec3| DVec2::new(f64::from(v.x), f64::from(v.z));
    let forward = (p(cam.look_at) - p(cam.position)).normalize();
    // PinholeCamera: right = forward x up, which for up = +y is (-forward.z, forward.x).
    let right = DVec2::new(-forward.y, forward.x);
    let half_h = (f64::from(cam.vfov_deg).to_radians() * 0.5).tan();
    let half_w = half_h * f64::from(width) / f64::from(height);
    // At y = height / 2 the vertical terms of the corner and of `y dy` cancel.
    let off = |x: f64| {
        let d = forward + right * (2.0 * half_w * x / f64::from(width) - half_w);
        plan.wall_hit(plan.eye, d.normalize(), n)
            .map(|at| at - plan.slit_x)
    };
    // A bracket from a scan of the columns, then bisection.
    let w = f64::from(width);
    let steps = width.max(16) * 4;
    let xs = (0..=steps).map(|k| w * f64::from(k) / f64::from(steps));
    let mut last: Option<(f64, f64)> = None;
    for x in xs {
        let Some(f) = off(x) else {
            last = None;
            continue;
        };
        if let Some((x0, f0)) = last
            && f0.signum() != f.signum()
        {
            let (mut lo, mut hi, mut flo) = (x0, x, f0);
            for _ in 0..80 {
                let mid = 0.5 * (lo + hi);
                let fm = off(mid)?;
                if fm.signum() == flo.signum() {
                    (lo, flo) = (mid, fm);
                } else {
                    hi = mid;
                }
            }
            return Some(0.5 * (lo + hi));
        }
        if f == 0.0 {
            return Some(x);
        }
        last = Some((x, f));
    }
    None
}

/// The image column of the slit in an RGB render ([`slit_column`] at the d line, whose
/// index is the material's `optics.ior`).
pub fn slit_column_rgb(width: u32, height: u32) -> Option<f64> {
    slit_column(LAMBDA_D, width, height)
}

/// A closed mesh from triangles, each turned so that its normal (`e1 x e2`) points away
/// from `inside`.
fn closed_mesh(name: &str, triangles: &[[Vec3; 3]], inside: Vec3) -> Mesh {
    let mut positions = Vec::with_capacity(triangles.len() * 3);
    let mut indices = Vec::with_capacity(triangles.len());
    for &[a, b, c] in triangles {
        let outward = (b - a).cross(c - a).dot(a - inside) > 0.0;
        let k = positions.len() as u32;
        positions.extend(if outward { [a, b, c] } else { [a, c, b] });
        indices.push([k, k + 1, k + 2]);
    }
    Mesh::new(name, positions, indices)
}

/// A quad `[a, b, c, d]` (in order around it) as two triangles.
fn quad(name: &str, q: [Vec3; 4], material: u32) -> ShadedMesh {
    ShadedMesh::flat(
        Mesh::new(name, q.to_vec(), vec![[0, 1, 2], [0, 2, 3]]),
        material,
    )
}

/// The scene (16 triangles: the prism 8, the wall 3 quads, the floor 1), 640 x 360.
pub fn prism() -> RenderScene {
    let plan = Plan::new();
    let mut b = Builder::default();
    let dispersion = glass_dispersion();
    let mut flint = glass("F2 flint", dispersion.index_d());
    flint.optics.dispersion = Some(dispersion);
    let glass_m = b.material(flint);
    let wall_m = b.material(Material::phong("black wall", [0.02; 3], [0.0; 3], 0.0));
    let slit_m = b.material(Material::phong("white slit", [1.0; 3], [0.0; 3], 0.0));
    let floor_m = b.material(Material::phong("grey floor", [0.1; 3], [0.0; 3], 0.0));

    // The prism: two caps and three sides, normals outward.
    let at = |p: DVec2, y: f32| Vec3::new(p.x as f32, y, p.y as f32);
    let corners = [plan.apex, plan.base[0], plan.base[1]];
    let lo = corners.map(|p| at(p, 0.0));
    let hi = corners.map(|p| at(p, HEIGHT));
    let mut triangles = vec![lo, hi];
    for k in 0..3 {
        let j = (k + 1) % 3;
        triangles.push([lo[k], lo[j], hi[j]]);
        triangles.push([lo[k], hi[j], hi[k]]);
    }
    let centre = (lo[0] + lo[1] + lo[2] + hi[0] + hi[1] + hi[2]) / 6.0;
    b.add(ShadedMesh::flat(
        closed_mesh("prism", &triangles, centre),
        glass_m,
    ));

    // The wall facing +z, in three strips: black, the white slit, black.
    let z = plan.wall_z as f32;
    let (s0, s1) = (
        plan.slit_x as f32 - SLIT_WIDTH / 2.0,
        plan.slit_x as f32 + SLIT_WIDTH / 2.0,
    );
    let strip = |name: &str, x0: f32, x1: f32, m: u32| {
        quad(
            name,
            [
                Vec3::new(x0, 0.0, z),
                Vec3::new(x1, 0.0, z),
                Vec3::new(x1, WALL_TOP, z),
                Vec3::new(x0, WALL_TOP, z),
            ],
            m,
        )
    };
    b.add(strip("wall left", WALL_X[0], s0, wall_m));
    b.add(strip("slit", s0, s1, slit_m));
    b.add(strip("wall right", s1, WALL_X[1], wall_m));
    // The floor, facing up.
    b.add(quad(
        "floor",
        [
            Vec3::new(WALL_X[0], 0.0, FLOOR_Z),
            Vec3::new(WALL_X[1], 0.0, FLOOR_Z),
            Vec3::new(WALL_X[1], 0.0, z),
            Vec3::new(WALL_X[0], 0.0, z),
        ],
        floor_m,
    ));

    let light = Parallel::new(LIGHT_DIRECTION, [IRRADIANCE; 3]).expect("a valid light");

    let (width, height) = DEFAULT_SIZE;
    let mut scene = b.finish(
        "prism",
        camera(width, height),
        vec![Light::Parallel(light)],
        2,
        [0.0; 3],
    );
    scene.width = width;
    scene.height = height;
    scene
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The slit's shadow rays (from any of its points towards the light) pass over the
    /// prism: at the prism's back they are above its top.
    #[test]
    fn the_slits_light_is_not_behind_the_prism() {
        let s = prism();
        let Light::Parallel(light) = &s.lights[0] else {
            unreachable!()
        };
        let to_light = -light.direction().as_dvec3();
        let plan = Plan::new();
        let back = [plan.apex, plan.base[0], plan.base[1]]
            .iter()
            .map(|p| p.y)
            .fold(f64::INFINITY, f64::min);
        assert!(to_light.z > 0.0, "the light comes from the viewer's side");
        // From the slit's foot (y = 0) to the prism's back.
        let y = to_light.y * (back - plan.wall_z) / to_light.z;
        assert!(y > f64::from(HEIGHT), "{y}");
    }

    #[test]
    fn the_slit_appears_through_the_prism_at_the_d_line_and_dispersion_spreads_it() {
        let (w, h) = DEFAULT_SIZE;
        let d = slit_column_rgb(w, h).unwrap();
        assert!((0.0..f64::from(w)).contains(&d), "{d}");
        let blue = slit_column(450.0, w, h).unwrap();
        let red = slit_column(650.0, w, h).unwrap();
        assert!(blue < d && d < red, "450 nm {blue}, d {d}, 650 nm {red}");
        assert!(red - blue > 20.0, "450 nm {blue}, 650 nm {red}");
    }

    #[test]
    fn the_prism_is_closed_with_outward_normals() {
        let s = prism();
        let m = &s.meshes[0].mesh;
        let c = m.positions.iter().copied().sum::<Vec3>() / m.positions.len() as f32;
        // Each triangle faces away from the centre, and the signed volume is positive.
        let mut volume = 0.0;
        for t in &m.indices {
            let [a, b, cc] = t.map(|i| m.positions[i as usize]);
            assert!((b - a).cross(cc - a).dot(a - c) > 0.0);
            volume += a.dot(b.cross(cc)) / 6.0;
        }
        let area = 3f32.sqrt() / 4.0 * (SIDE as f32).powi(2);
        assert!((volume - area * HEIGHT).abs() < 1e-4, "{volume}");
    }
}
