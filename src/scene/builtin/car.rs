//! `car`: stand-in for the paper's Car scene (section 7, Table 4: 233,000 triangles, 4
//! lights, depth 2; "measured tabulated BRDF, transparent and refractive objects"): a
//! rounded car body in tabulated-BDF paint (a base coat of pigment and metallic flakes, an
//! isotropic Ward model tabulated on `bdf::tabulate`'s isotropic grid, under a Fresnel
//! clear coat), a refractive glass cabin and headlamps, four instanced tyres, on asphalt
//! under a generated sky (environment light), the sun (parallel), a spot and a street lamp
//! (goniodiagram).

use std::path::Path;
use std::sync::Arc;

use glam::{Affine3A, Quat, Vec3};

use coherent_simd::scalar::Scalar;

use super::Builder;
use super::materials::glass;
use super::shapes::{superellipsoid, torus};
use crate::bdf::tabulate::isotropic_axes;
use crate::bdf::{Analytic, Bdf, IsotropicBdf, Ward};
use crate::light::photometry::{PhotometricTable, PhotometricType};
use crate::light::{Environment, GonioLookup, Goniodiagram, Light, Parallel, Spot, SpotFalloff};
use crate::material::{Material, fresnel_dielectric};
use crate::scene::{Camera, RenderScene, ShadedMesh};
use crate::tabulated::Grid;

/// The clear coat's index of refraction.
const COAT_IOR: f32 = 1.5;

/// The car paint, layered as real paint is. The clear coat is a Fresnel-weighted mirror
/// reflection (about 4 % head-on): it gives the paint its gloss. The base coat below it, red
/// pigment and a broad lobe of red metallic flakes (an isotropic Ward model), is tabulated on
/// a 13 x 13 x 17 grid as seen through the coat: each way through it weighted by the coat's
/// transmission `1 - F`, so that coat and base together never reflect more than arrives.
///
/// The flakes' lobe is broad because the sky lights it only through the environment
/// light's samples, drawn by the sky's luminance, not by the BDF. A glossy lobe catches one
/// at few shading points, which then shine several times brighter than their neighbours:
/// white salt over the paint at 1 sample per pixel. A glossy lobe is also finer than the
/// grid at grazing angles, where interpolation spreads its peak and the table reflects more
/// than the model.
pub fn paint() -> Material {
    let base = Analytic::Ward(Ward {
        diffuse: [0.32, 0.02, 0.03],
        specular: [0.30, 0.04, 0.04],
        alpha_x: 0.35,
        alpha_y: 0.35,
    });
    let axes = isotropic_axes([13, 13, 17]).expect("a valid grid");
    let through_coat = |theta: f32| 1.0 - fresnel_dielectric(Scalar, theta.cos(), COAT_IOR) as f64;
    let mut values = Vec::with_capacity(3 * 13 * 13 * 17);
    for &ti in axes[0].nodes() {
        for &to in axes[1].nodes() {
            for &dp in axes[2].nodes() {
                let f = base.eval_angles(ti.into(), 0.0, to.into(), dp.into());
                let t = through_coat(ti) * through_coat(to);
                values.extend(f.map(|v| (v * t) as f32));
            }
        }
    }
    let grid = Grid::new(axes, 3, values).expect("a valid grid");
    let table = IsotropicBdf::new(grid).expect("a valid table");
    let mut m = Material::phong("tabulated paint", [0.0; 3], [0.0; 3], 0.0);
    m.bdf = Some(Arc::new(Bdf::Isotropic(table)));
    m.optics.reflectance = [1.0; 3];
    m.optics.ior = COAT_IOR;
    m.optics.fresnel = true;
    m
}

/// A street lamp's goniodiagram (type C, rotationally symmetric): most light 50-70 degrees
/// from the nadir, little straight down, none above the horizon (candela).
pub fn street_lamp_table() -> PhotometricTable {
    let angles: Vec<f32> = (0..=18).map(|k| k as f32 * 10.0).collect();
    let candela = angles
        .iter()
        .map(|&g| {
            if g >= 90.0 {
                0.0
            } else {
                let x = (g - 60.0) / 25.0;
                3000.0 + 9000.0 * (-x * x).exp()
            }
        })
        .collect();
    PhotometricTable {
        kind: PhotometricType::C,
        planes: vec![0.0],
        angles,
        candela,
    }
}

/// A sky: blue overhead to pale at the horizon, dark ground below (latitude-longitude map,
/// rows from the up pole down).
fn sky() -> Environment {
    let (w, h) = (64, 32);
    let mut texels = Vec::with_capacity(w * h);
    for y in 0..h {
        let lat = 0.5 - (y as f32 + 0.5) / h as f32; // +0.5 up .. -0.5 down
        for _ in 0..w {
            texels.push(if lat > 0.0 {
                let t = (2.0 * lat).powf(0.5);
                [0.55 - 0.35 * t, 0.6 - 0.3 * t, 0.7]
            } else {
                [0.08, 0.07, 0.06]
            });
        }
    }
    Environment::new(
        "generated sky",
        w,
        h,
        &texels,
        1.0,
        Vec3::Y,
        Vec3::NEG_Z,
        16,
    )
    .expect("valid")
}

/// The scene (231,714 triangles: body 180,000, cabin 12,288, tyres 4 x 9,216, headlamps
/// 2 x 1,280, ground 2).
pub fn car() -> RenderScene {
    let mut b = Builder::default();
    let paint = b.material(paint());
    let glass_id = b.material(glass("car glass", 1.5));
    let rubber = b.material(Material::phong("rubber", [0.03; 3], [0.1; 3], 12.0));
    let asphalt = b.material(Material::phong(
        "asphalt",
        [0.18, 0.18, 0.19],
        [0.05; 3],
        8.0,
    ));

    b.add(super::shapes::quad(
        "ground",
        Vec3::new(-40.0, 0.0, 40.0),
        Vec3::new(80.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -80.0),
        (1, 1),
        20.0,
        asphalt,
    ));
    let body = b.mesh(superellipsoid(
        "body",
        Vec3::new(2.2, 0.5, 0.95),
        (0.3, 0.25),
        (450, 200),
        paint,
    ));
    b.place(body, Affine3A::from_translation(Vec3::new(0.0, 0.75, 0.0)));
    let cabin = b.mesh(superellipsoid(
        "cabin",
        Vec3::new(1.2, 0.45, 0.8),
        (0.45, 0.4),
        (96, 64),
        glass_id,
    ));
    b.place(
        cabin,
        Affine3A::from_translation(Vec3::new(-0.25, 1.2, 0.0)),
    );
    let tyre = b.mesh(torus("tyre", 0.3, 0.15, (96, 48), rubber));
    for (x, z) in [(1.35, 0.85), (1.35, -0.85), (-1.35, 0.85), (-1.35, -0.85)] {
        b.place(
            tyre,
            Affine3A::from_rotation_translation(
                Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
                Vec3::new(x, 0.45, z),
            ),
        );
    }
    let lamp = b.mesh(
        ShadedMesh::flat(
            coherent_accel::shapes::icosphere("headlamp", Vec3::ZERO, 1.0, 3),
            glass_id,
        )
        .with_smooth_normals(),
    );
    for z in [0.55, -0.55] {
        b.place(
            lamp,
            Affine3A::from_scale_rotation_translation(
                Vec3::new(0.08, 0.1, 0.16),
                Quat::IDENTITY,
                Vec3::new(2.12, 0.8, z),
            ),
        );
    }

    let lights = vec![
        Light::Environment(sky()),
        Light::Parallel(
            Parallel::new(Vec3::new(-0.5, -1.0, -0.3), [2.2, 2.0, 1.7]).expect("valid"),
        ),
        Light::Spot(
            Spot::new(
                Vec3::new(4.0, 5.0, 3.0),
                Vec3::new(-4.0, -4.5, -3.0),
                [60.0; 3],
                0.35,
                0.6,
                SpotFalloff::default(),
            )
            .expect("valid"),
        ),
        Light::Goniodiagram(
            Goniodiagram::new(
                Vec3::new(-3.5, 5.0, -2.5),
                Vec3::Y,
                Vec3::X,
                &street_lamp_table(),
                [1.0, 0.9, 0.7],
                GonioLookup::default(),
                Path::new("generated street lamp"),
            )
            .expect("valid"),
        ),
    ];
    let camera = Camera {
        position: Vec3::new(5.2, 2.2, 5.6),
        look_at: Vec3::new(0.0, 0.7, 0.0),
        up: Vec3::Y,
        vfov_deg: 40.0,
    };
    b.finish("car", camera, lights, 2, [0.0; 3])
}

#[cfg(test)]
mod tests {
    use coherent_simd::scalar::Scalar;
    use coherent_simd::{Lanes, Vec3s};
    use glam::Vec3;
    use rand::{Rng, SeedableRng, rngs::StdRng};

    use super::{paint, sky};
    use crate::bdf::Frames;
    use crate::material::ShadeHits;

    fn lum(r: f32, g: f32, b: f32) -> f32 {
        0.2126 * r + 0.7152 * g + 0.0722 * b
    }

    /// The paint on a surface facing the sky (normal +y), seen `theta_o` degrees from the
    /// normal.
    fn seen_at(theta_o: f32) -> (ShadeHits<Scalar>, Vec3) {
        let l = Scalar;
        let t = theta_o.to_radians();
        let wo = Vec3::new(t.sin(), t.cos(), 0.0);
        let hits = ShadeHits {
            active: true,
            material: l.splat_i32(0),
            frames: Frames {
                tangent: Vec3s::splat(l, Vec3::X),
                bitangent: Vec3s::splat(l, Vec3::NEG_Z),
                normal: Vec3s::splat(l, Vec3::Y),
            },
            wo: Vec3s::splat(l, wo),
            s: 0.0,
            t: 0.0,
            lod: 0.0,
        };
        (hits, wo)
    }

    /// Coat and base together reflect no more than arrives, at every viewing angle up to
    /// grazing: the base coat's albedo (`f cos` over the hemisphere) plus the coat's mirror
    /// reflectance stays below 1 per channel.
    #[test]
    fn paint_conserves_energy() {
        let (l, m) = (Scalar, paint());
        let (nt, np) = (60, 120);
        let (dt, dp) = (
            std::f32::consts::FRAC_PI_2 / nt as f32,
            std::f32::consts::TAU / np as f32,
        );
        for theta_o in (0..=85).step_by(5) {
            let (hits, _) = seen_at(theta_o as f32);
            let mut albedo = [0.0f32; 3];
            for i in 0..nt {
                let th = (i as f32 + 0.5) * dt;
                for j in 0..np {
                    let ph = (j as f32 + 0.5) * dp;
                    let wi = Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin());
                    let f = m.shade(l, &hits, &Vec3s::splat(l, wi)).reflected;
                    let dw = th.sin() * dt * dp;
                    albedo[0] += f.r * dw;
                    albedo[1] += f.g * dw;
                    albedo[2] += f.b * dw;
                }
            }
            let coat = m.shade(l, &hits, &Vec3s::splat(l, Vec3::Y)).reflection;
            let total = [albedo[0] + coat.r, albedo[1] + coat.g, albedo[2] + coat.b];
            assert!(
                total.iter().all(|&t| t < 1.0),
                "seen {theta_o} degrees from the normal the paint reflects {total:?}"
            );
        }
    }

    /// What the sky gives the paint at 1 sample per pixel (the environment light's samples,
    /// drawn by the sky's luminance, and the clear coat's mirror image of the sky) stays
    /// within twice its median: no shading point shines out of its neighbours as salt.
    #[test]
    fn sky_lights_the_paint_without_outliers() {
        let (l, m, sky) = (Scalar, paint(), sky());
        let n = Vec3s::splat(l, Vec3::Y);
        let mut rng = StdRng::seed_from_u64(1);
        for theta_o in [0.0, 30.0, 60.0, 75.0, 85.0] {
            let (hits, wo) = seen_at(theta_o);
            let mirror = Vec3s::splat(l, Vec3::new(-wo.x, wo.y, -wo.z));
            let coat = m.shade(l, &hits, &n).reflection * sky.radiance(l, &mirror);
            let mut estimates: Vec<f32> = (0..2000)
                .map(|_| {
                    let mut e = lum(coat.r, coat.g, coat.b);
                    for k in 0..sky.samples() {
                        let u = [rng.random::<f32>(), rng.random::<f32>()];
                        let s = sky.sample(l, &n, &n, true, k, u);
                        if s.active {
                            let f = m.shade(l, &hits, &s.wi).reflected * s.li;
                            e += lum(f.r, f.g, f.b);
                        }
                    }
                    e
                })
                .collect();
            estimates.sort_by(f32::total_cmp);
            let (median, max) = (
                estimates[estimates.len() / 2],
                estimates[estimates.len() - 1],
            );
            assert!(
                max < 2.0 * median,
                "seen {theta_o} degrees from the normal: an estimate of {max} against the median {median}"
            );
        }
    }
}
