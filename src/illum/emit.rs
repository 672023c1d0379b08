//! Particles leaving the lights (forward Monte-Carlo ray tracing's first step): each kind of
//! light by its own emission, as the renderer's [`Light::sample`] evaluates it, each particle
//! carrying its share of the light's power, the light chosen in proportion to its power so
//! that every particle carries about the same.
//!
//! Per kind (power per channel; how a particle is placed and aimed):
//! - omni: `4 pi I`; from the point, uniform directions.
//! - spot: `2 pi I int f(cos theta) d cos theta` by Simpson's rule over a fine table of the
//!   spot's own falloff; directions drawn from that table (piecewise constant in
//!   `cos theta`), weighted by falloff / table value.
//! - parallel: `E pi R^2`; from a disk of radius `R` (the bounds' bounding sphere, a little
//!   grown) perpendicular to the direction, outside the bounds, along the direction.
//! - direct: `pi I0`; from the point, cosine-weighted about the axis.
//! - linear: `4 pi I`; from the segment, uniform directions.
//! - circular, rectangular: `pi L A` (one-sided); from the surface, cosine-weighted about the
//!   normal.
//! - goniodiagram: the exact integral of the table's bilinear interpolant over the sphere;
//!   directions from a 2D CDF over the table's cells (cut to at most 1 degree), uniform in
//!   solid angle inside a cell, weighted by the light's own candela / cell mean.
//! - environment: `pi R^2 int L d omega` over the map's texels; directions by texel radiance
//!   times solid angle, from a disk of radius `R` on the far side of the bounds.
//!
//! Surface and linear lights emit from the same points as the renderer samples: a light
//! with fixed (unjittered) points emits from those points, each standing for its share of
//! the area (length); a jittered light from anywhere on its surface.
//!
//! Where the sampling is not proportional to the emission (spot, goniodiagram), a particle's
//! power is the light's own intensity over the sampling density, as the renderer evaluates
//! it, so the particles are unbiased for the renderer's light. Two small differences
//! remain: a goniodiagram's power (and its table) uses the exact angles, where the renderer
//! reads its table through approximate `acos`/`atan2`/`asin` (7e-5 rad), and the
//! environment's particles carry their texel's radiance, where a direction within that
//! angle of a texel's edge may be looked up in the next texel by the renderer; both are
//! within 1e-4 of the power in the tests.

use std::f64::consts::{PI, TAU};
use std::sync::Arc;

use coherent_accel::Aabb;
use coherent_simd::Vec3s;
use coherent_simd::scalar::Scalar;
use glam::Vec3;

use super::IllumError;
use crate::light::photometry::PhotometricType;
use crate::light::{
    Circular, Environment, GonioLookup, Goniodiagram, Light, Linear, Rectangular, Spot,
};
use crate::scene::RenderScene;

/// A particle as it leaves its light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Particle {
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
    /// Power carried (W per channel).
    pub power: [f32; 3],
}

/// The lights of a scene as particle sources.
#[derive(Debug, Clone)]
pub struct Emitter {
    /// The lights that emit (non-zero power), with their sampling tables.
    sources: Vec<Source>,
    /// Per source, its emitted power (W per channel).
    power: Vec<[f64; 3]>,
    /// Cumulative probabilities of choosing each source (by the sum of its channels):
    /// `sources.len() + 1` values from 0 to 1.
    cdf: Vec<f64>,
}

/// The random numbers one emission takes: `u[0]` picks the light; `u[1]`, `u[2]` the
/// direction, or the cell of a tabulated light (a spot's bin and the angle about its axis, a
/// goniodiagram's cell, the environment's texel), or the point on a parallel light's disk;
/// `u[3]`, `u[4]` the point on a surface or segment, or the direction inside the cell;
/// `u[5]`, `u[6]` the point on the environment's disk.
pub const EMIT_DIMS: usize = 7;

/// Sampling data of one emitting light.
#[derive(Debug, Clone)]
enum Source {
    Omni {
        position: Vec3,
    },
    Spot {
        spot: Spot,
        /// Two unit vectors across the axis, then the axis.
        frame: [Vec3; 3],
        cone: Arc<Cone>,
    },
    Parallel {
        dir: Vec3,
        disk: Disk,
    },
    Direct {
        position: Vec3,
        frame: [Vec3; 3],
    },
    Linear(Linear),
    Circular(Circular),
    Rectangular(Rectangular),
    Goniodiagram {
        light: Goniodiagram,
        table: Arc<GonioTable>,
    },
    Environment {
        axes: [Vec3; 3],
        map: Arc<EnvTable>,
        disk: Disk,
    },
}

/// The sphere around the scene bounds that parallel and environment lights cover.
#[derive(Debug, Clone, Copy)]
struct Disk {
    centre: Vec3,
    radius: f32,
}

/// A spot's falloff tabulated over `cos theta`.
#[derive(Debug)]
struct Cone {
    /// Bin edges in `cos theta`, from 1 down.
    mu: Vec<f64>,
    /// CDF over the bins.
    cdf: Vec<f64>,
    /// `int f(mu) d mu` over the sphere's `mu` (Simpson's rule per bin).
    integral: f64,
}

/// A goniodiagram's bilinear table cut into cells of at most [`GONIO_STEP`], with a CDF
/// over planes and one over angles per plane.
#[derive(Debug)]
struct GonioTable {
    kind: PhotometricType,
    /// Cell edges along the plane and angle axes (radians).
    planes: Vec<f64>,
    angles: Vec<f64>,
    marginal: Vec<f64>,
    /// Per plane cell, `angles.len()` values.
    conditional: Vec<f64>,
    /// Candela times steradians over the sphere.
    integral: f64,
}

/// The largest cell of a goniodiagram's sampling table (radians; 1 degree).
const GONIO_STEP: f64 = PI / 180.0;

/// Bins of a spot's table inside its outer cone, and beyond it.
const CONE_BINS: usize = 1024;
const TAIL_BINS: usize = 32;

/// An environment map's texels with a CDF over rows and one over columns per row.
#[derive(Debug)]
struct EnvTable {
    width: usize,
    height: usize,
    /// Radiance per texel (scaled), rows from the up pole.
    radiance: Vec<[f32; 3]>,
    /// `cos theta` at the row edges.
    cos: Vec<f64>,
    marginal: Vec<f64>,
    /// Per row, `width + 1` values.
    conditional: Vec<f32>,
    /// `int L d omega` per channel.
    integral: [f64; 3],
}

impl Emitter {
    /// The lights of `scene` as particle sources; `bounds` are the scene's world bounds
    /// (parallel and environment lights emit from a disk that covers them). A scene whose
    /// lights emit no power is an error.
    pub fn new(scene: &RenderScene, bounds: Aabb) -> Result<Self, IllumError> {
        Self::from_lights(&scene.name, &scene.lights, bounds)
    }

    /// [`Emitter::new`] for a list of lights; `scene` names the scene in errors.
    pub fn from_lights(scene: &str, lights: &[Light], bounds: Aabb) -> Result<Self, IllumError> {
        let mut sources = Vec::with_capacity(lights.len());
        let mut power = Vec::with_capacity(lights.len());
        let mut index = Vec::with_capacity(lights.len());
        for (i, light) in lights.iter().enumerate() {
            let fail = |problem: String| IllumError::Light {
                scene: scene.to_owned(),
                light: i,
                kind: light.kind().name(),
                problem,
            };
            let (source, p) = source(light, bounds).map_err(fail)?;
            if !p.iter().all(|c| c.is_finite() && *c <= f64::from(f32::MAX)) {
                return Err(fail(format!(
                    "its power {p:?} W is not finite in single precision"
                )));
            }
            if p.iter().sum::<f64>() > 0.0 {
                sources.push(source);
                power.push(p);
                index.push(i);
            }
        }
        let mut cdf = Vec::with_capacity(power.len() + 1);
        let total = cdf_of(power.iter().map(|p| p.iter().sum()), &mut cdf);
        if total.is_nan() || total <= 0.0 {
            return Err(IllumError::NoLight {
                scene: scene.to_owned(),
            });
        }
        if total > f64::from(f32::MAX) {
            // Each light's is finite: name the brightest.
            let (k, _) = power
                .iter()
                .map(|p| p.iter().sum::<f64>())
                .enumerate()
                .fold((0, 0.0), |a, (k, p)| if p > a.1 { (k, p) } else { a });
            return Err(IllumError::Light {
                scene: scene.to_owned(),
                light: index[k],
                kind: lights[index[k]].kind().name(),
                problem: format!(
                    "the lights' total power {total} W is not finite in single precision"
                ),
            });
        }
        Ok(Self {
            sources,
            power,
            cdf,
        })
    }

    /// Total emitted power (W per channel).
    pub fn power(&self) -> [f64; 3] {
        let mut t = [0.0; 3];
        for p in &self.power {
            for c in 0..3 {
                t[c] += p[c];
            }
        }
        t
    }

    /// One of `count` particles from the uniform numbers `u` (in [0, 1); others are clamped
    /// into it): its light chosen by power with `u[0]`, the rest placing and aiming it (see
    /// [`EMIT_DIMS`]). The powers of `count` particles sum to [`Emitter::power`] in
    /// expectation.
    pub fn emit(&self, u: [f32; EMIT_DIMS], count: u64) -> Particle {
        let u = u.map(unit);
        let (k, prob) = pick(&self.cdf, u[0]);
        let scale = 1.0 / (prob * count.max(1) as f64);
        let (origin, dir, power) = self.sources[k].emit(&u, self.power[k]);
        Particle {
            origin,
            dir,
            power: power.map(|c| (c * scale) as f32),
        }
    }
}

/// `x` in `[0, 1)` (NaN to 0).
fn unit(x: f32) -> f32 {
    if x >= 0.0 {
        x.min(1.0f32.next_down())
    } else {
        0.0
    }
}

/// Fills `out` with the CDF of `weights` (`n + 1` values from 0 to 1; all-zero weights give
/// zeros and a final 1); returns their sum.
fn cdf_of(weights: impl Iterator<Item = f64>, out: &mut Vec<f64>) -> f64 {
    let start = out.len();
    out.push(0.0);
    let mut acc = 0.0;
    for w in weights {
        acc += w;
        out.push(acc);
    }
    if acc > 0.0 {
        for c in &mut out[start..] {
            *c /= acc;
        }
    }
    *out.last_mut().unwrap() = 1.0;
    acc
}

/// The cell of `u` in a CDF (`n + 1` values from 0 to 1) and its probability: the last
/// cell whose lower value is at most `u`, which for `u` in `[0, 1)` has non-zero width.
fn pick<T: Copy + Into<f64>>(cdf: &[T], u: f32) -> (usize, f64) {
    let u = f64::from(u);
    let n = cdf.len() - 1;
    let k = cdf
        .partition_point(|&c| c.into() <= u)
        .saturating_sub(1)
        .min(n - 1);
    (k, cdf[k + 1].into() - cdf[k].into())
}

/// `[t, b, n]`: two unit vectors across the unit vector `n`, then `n`.
fn frame(n: Vec3) -> [Vec3; 3] {
    let (t, b) = n.any_orthonormal_pair();
    [t, b, n]
}

/// The direction `(x, y, z)` in `frame`.
fn in_frame(f: &[Vec3; 3], x: f64, y: f64, z: f64) -> Vec3 {
    (f[0].as_dvec3() * x + f[1].as_dvec3() * y + f[2].as_dvec3() * z)
        .normalize()
        .as_vec3()
}

/// A uniformly distributed unit vector.
pub fn uniform_sphere(u1: f32, u2: f32) -> Vec3 {
    let z = 1.0 - 2.0 * u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * core::f32::consts::PI * u2;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// A cosine-distributed unit vector about `f[2]`.
fn cosine_dir(f: &[Vec3; 3], u1: f32, u2: f32) -> Vec3 {
    let r = f64::from(u1).sqrt();
    let phi = TAU * f64::from(u2);
    in_frame(
        f,
        r * phi.cos(),
        r * phi.sin(),
        (1.0 - f64::from(u1)).sqrt(),
    )
}

/// The bounding sphere of `bounds`, a little grown so that a disk tangent to it lies
/// outside the bounds whatever the rounding.
fn bounding_sphere(bounds: Aabb, kind: &str) -> Result<Disk, String> {
    if bounds.is_empty() || !(bounds.min.is_finite() && bounds.max.is_finite()) {
        return Err(format!(
            "the scene bounds {:?}..{:?} are empty or not finite, and a {kind} light emits \
             from a disk that covers them",
            bounds.min, bounds.max
        ));
    }
    let centre = (bounds.min.as_dvec3() + bounds.max.as_dvec3()) * 0.5;
    let half = (bounds.max.as_dvec3() - bounds.min.as_dvec3()).length() * 0.5;
    let size = centre.abs().max_element().max(half).max(1e-6);
    let radius = half * 1.001 + 1e-5 * size;
    if !(radius as f32).is_finite() {
        return Err(format!(
            "the scene bounds {:?}..{:?} are too large",
            bounds.min, bounds.max
        ));
    }
    Ok(Disk {
        centre: centre.as_vec3(),
        radius: radius as f32,
    })
}

impl Disk {
    /// The disk's area.
    fn area(&self) -> f64 {
        PI * f64::from(self.radius).powi(2)
    }

    /// A uniform point of the disk across `dir` (unit, the way particles travel), on the far
    /// side of the sphere from where `dir` points.
    fn point(&self, dir: Vec3, u1: f32, u2: f32) -> Vec3 {
        let f = frame(dir);
        let r = f64::from(self.radius);
        let s = r * f64::from(u1).sqrt();
        let phi = TAU * f64::from(u2);
        (self.centre.as_dvec3() - dir.as_dvec3() * r
            + f[0].as_dvec3() * (s * phi.cos())
            + f[1].as_dvec3() * (s * phi.sin()))
        .as_vec3()
    }
}

/// A light's sampling data and its power (W per channel), or why it cannot emit.
fn source(light: &Light, bounds: Aabb) -> Result<(Source, [f64; 3]), String> {
    let times = |c: [f32; 3], k: f64| c.map(|c| f64::from(c) * k);
    Ok(match light {
        Light::Omni(o) => (
            Source::Omni {
                position: o.position(),
            },
            times(o.intensity(), 4.0 * PI),
        ),
        Light::Spot(s) => {
            let cone = cone(s);
            let p = times(s.intensity(), TAU * cone.integral);
            let source = Source::Spot {
                spot: s.clone(),
                frame: frame(s.axis()),
                cone: Arc::new(cone),
            };
            (source, p)
        }
        Light::Parallel(p) => {
            let disk = bounding_sphere(bounds, "parallel")?;
            let power = times(p.irradiance(), disk.area());
            (
                Source::Parallel {
                    dir: p.direction(),
                    disk,
                },
                power,
            )
        }
        Light::Direct(d) => (
            Source::Direct {
                position: d.position(),
                frame: frame(d.axis()),
            },
            times(d.intensity(), PI),
        ),
        Light::Linear(l) => (Source::Linear(l.clone()), times(l.intensity(), 4.0 * PI)),
        Light::Circular(c) => {
            let r = f64::from(c.disk().2);
            (
                Source::Circular(c.clone()),
                times(c.radiance(), PI * PI * r * r),
            )
        }
        Light::Rectangular(r) => {
            let area = f64::from(r.normal_area().1);
            (
                Source::Rectangular(r.clone()),
                times(r.radiance(), PI * area),
            )
        }
        Light::Goniodiagram(g) => {
            let table = gonio_table(g);
            let p = times(g.scale(), table.integral);
            let source = Source::Goniodiagram {
                light: g.clone(),
                table: Arc::new(table),
            };
            (source, p)
        }
        Light::Environment(e) => {
            let disk = bounding_sphere(bounds, "environment")?;
            let map = env_table(e);
            let p = map.integral.map(|c| c * disk.area());
            let source = Source::Environment {
                axes: e.axes(),
                map: Arc::new(map),
                disk,
            };
            (source, p)
        }
    })
}

/// The spot's falloff over `cos theta`: [`CONE_BINS`] bins even in `theta` inside the
/// outer cone and [`TAIL_BINS`] beyond it (where the falloff should be 0, but the table
/// takes whatever the spot's own function gives). Bins are drawn by the largest falloff at
/// their ends and middle, so that none where the spot lights is left out.
fn cone(spot: &Spot) -> Cone {
    let outer = f64::from(spot.cone().1).min(PI);
    let mut theta: Vec<f64> = (0..=CONE_BINS)
        .map(|k| outer * k as f64 / CONE_BINS as f64)
        .collect();
    if outer < PI {
        theta.extend((1..=TAIL_BINS).map(|k| outer + (PI - outer) * k as f64 / TAIL_BINS as f64));
    }
    let mut mu: Vec<f64> = theta.iter().map(|t| t.cos()).collect();
    mu[0] = 1.0;
    *mu.last_mut().unwrap() = mu.last().unwrap().max(-1.0);
    let f = |m: f64| f64::from(spot.falloff(Scalar, m as f32));
    let mut integral = 0.0;
    let mut weights = Vec::with_capacity(mu.len() - 1);
    for w in mu.windows(2) {
        let (fa, fm, fb) = (f(w[0]), f(0.5 * (w[0] + w[1])), f(w[1]));
        let d = w[0] - w[1];
        integral += d * (fa + 4.0 * fm + fb) / 6.0;
        weights.push(fa.max(fm).max(fb) * d);
    }
    let mut cdf = Vec::with_capacity(mu.len());
    cdf_of(weights.into_iter(), &mut cdf);
    Cone { mu, cdf, integral }
}

/// The nodes of a table's axis (`f32` radians) as one bilinear function sees them.
struct Tensor {
    nodes: [Vec<f64>; 2],
    /// Plane-major.
    values: Vec<f64>,
}

impl Tensor {
    /// The cell of `x` and the weight of its upper node, as `tabulated::Axis` finds them
    /// (clamped to the axis).
    fn locate(nodes: &[f64], x: f64) -> (usize, f64) {
        let i = nodes
            .partition_point(|&v| v <= x)
            .saturating_sub(1)
            .min(nodes.len() - 2);
        let t = ((x - nodes[i]) / (nodes[i + 1] - nodes[i])).clamp(0.0, 1.0);
        (i, t)
    }

    /// Bilinear interpolation at (plane, angle).
    fn eval(&self, p: f64, a: f64) -> f64 {
        let (i, s) = Self::locate(&self.nodes[0], p);
        let (j, t) = Self::locate(&self.nodes[1], a);
        let n = self.nodes[1].len();
        let v = |i: usize, j: usize| self.values[i * n + j];
        (v(i, j) * (1.0 - t) + v(i, j + 1) * t) * (1.0 - s)
            + (v(i + 1, j) * (1.0 - t) + v(i + 1, j + 1) * t) * s
    }
}

/// Edges from `lo` to `hi` through every node of `source` between them, cut to at most
/// `step`: the bilinear function is bilinear inside each cell.
fn edges(lo: f64, hi: f64, source: &[f64], step: f64) -> Vec<f64> {
    let mut breaks = vec![lo];
    breaks.extend(source.iter().copied().filter(|&x| x > lo && x < hi));
    breaks.push(hi);
    let mut out = vec![lo];
    for w in breaks.windows(2) {
        let n = ((w[1] - w[0]) / step).ceil().max(1.0) as usize;
        out.extend((1..n).map(|k| w[0] + (w[1] - w[0]) * k as f64 / n as f64));
        out.push(w[1]);
    }
    out
}

/// `int_a0^a1 J(a) da`: the solid angle per radian of plane angle of an angle cell
/// (`J = sin` for type C's gamma, `cos` for types A and B's latitude).
fn band(kind: PhotometricType, a0: f64, a1: f64) -> f64 {
    let (mid, half) = (0.5 * (a0 + a1), 0.5 * (a1 - a0));
    match kind {
        PhotometricType::C => 2.0 * mid.sin() * half.sin(),
        _ => 2.0 * mid.cos() * half.sin(),
    }
}

/// The goniodiagram's sampling table: the bilinear function the renderer interpolates
/// (the file's grid, or the uniform grid for [`GonioLookup::Uniform`]) over the range of
/// coordinates directions take, cut into cells of at most [`GONIO_STEP`], each weighted by
/// its exact integral (in closed form over the plane angle, 3-point Gauss-Legendre over the
/// angle, exact to ~1e-13 for 1-degree cells).
fn gonio_table(g: &Goniodiagram) -> GonioTable {
    let kind = g.kind();
    let to64 = |v: &[f32]| v.iter().map(|&x| f64::from(x)).collect::<Vec<_>>();
    let tensor = match g.lookup() {
        GonioLookup::Search => {
            let a = g.grid().axes();
            Tensor {
                nodes: [to64(a[0].nodes()), to64(a[1].nodes())],
                values: to64(g.grid().values()),
            }
        }
        GonioLookup::Uniform => {
            let u = g.uniform_table();
            Tensor {
                nodes: [to64(&u.nodes(0)), to64(&u.nodes(1))],
                values: to64(u.node_values()),
            }
        }
    };
    // The coordinates that directions take (`Goniodiagram::coords`).
    let (plane_range, angle_range) = match kind {
        PhotometricType::C => ((0.0, TAU), (0.0, PI)),
        _ => ((-PI, PI), (-PI / 2.0, PI / 2.0)),
    };
    let planes = edges(plane_range.0, plane_range.1, &tensor.nodes[0], GONIO_STEP);
    let angles = edges(angle_range.0, angle_range.1, &tensor.nodes[1], GONIO_STEP);
    let na = angles.len();
    let values: Vec<f64> = planes
        .iter()
        .flat_map(|&p| angles.iter().map(move |&a| (p, a)))
        .map(|(p, a)| tensor.eval(p, a))
        .collect();
    let jac = |a: f64| match kind {
        PhotometricType::C => a.sin(),
        _ => a.cos(),
    };
    let gauss = [
        (-(0.6f64).sqrt(), 5.0 / 9.0),
        (0.0, 8.0 / 9.0),
        ((0.6f64).sqrt(), 5.0 / 9.0),
    ];
    let mut conditional = Vec::with_capacity((planes.len() - 1) * na);
    let mut rows = Vec::with_capacity(planes.len() - 1);
    let mut weights = Vec::with_capacity(na - 1);
    for i in 0..planes.len() - 1 {
        let dp = planes[i + 1] - planes[i];
        weights.clear();
        for j in 0..na - 1 {
            let (a0, a1) = (angles[j], angles[j + 1]);
            // The mean over the plane angle is linear in the angle.
            let lo = 0.5 * (values[i * na + j] + values[(i + 1) * na + j]);
            let hi = 0.5 * (values[i * na + j + 1] + values[(i + 1) * na + j + 1]);
            let (mid, half) = (0.5 * (a0 + a1), 0.5 * (a1 - a0));
            let s: f64 = gauss
                .iter()
                .map(|&(x, w)| {
                    let t = 0.5 * (1.0 + x);
                    w * (lo + (hi - lo) * t) * jac(mid + half * x)
                })
                .sum();
            weights.push((dp * half * s).max(0.0));
        }
        rows.push(cdf_of(weights.iter().copied(), &mut conditional));
    }
    let mut marginal = Vec::with_capacity(planes.len());
    let integral = cdf_of(rows.into_iter(), &mut marginal);
    GonioTable {
        kind,
        planes,
        angles,
        marginal,
        conditional,
        integral,
    }
}

/// The environment's sampling table: each texel weighted by the sum of its channels times
/// its solid angle.
fn env_table(e: &Environment) -> EnvTable {
    let (w, h) = e.size();
    let radiance: Vec<[f32; 3]> = e.texels().collect();
    let cos: Vec<f64> = (0..=h)
        .map(|j| match j {
            0 => 1.0,
            _ if j == h => -1.0,
            _ => (PI * j as f64 / h as f64).cos(),
        })
        .collect();
    let mut integral = [0.0; 3];
    let mut conditional = Vec::with_capacity(h * (w + 1));
    let mut rows = Vec::with_capacity(h);
    let mut row = Vec::with_capacity(w + 1);
    for j in 0..h {
        let omega = solid_angle(h, w, j);
        let texels = &radiance[j * w..(j + 1) * w];
        for t in texels {
            for c in 0..3 {
                integral[c] += f64::from(t[c]) * omega;
            }
        }
        row.clear();
        let sum = cdf_of(
            texels
                .iter()
                .map(|t| t.iter().map(|&c| f64::from(c)).sum::<f64>()),
            &mut row,
        );
        conditional.extend(row.iter().map(|&c| c as f32));
        rows.push(sum * omega);
    }
    let mut marginal = Vec::with_capacity(h + 1);
    cdf_of(rows.into_iter(), &mut marginal);
    EnvTable {
        width: w,
        height: h,
        radiance,
        cos,
        marginal,
        conditional,
        integral,
    }
}

/// The solid angle of a texel of row `j` of an `h`-row, `w`-column map.
fn solid_angle(h: usize, w: usize, j: usize) -> f64 {
    let (t0, t1) = (PI * j as f64 / h as f64, PI * (j + 1) as f64 / h as f64);
    TAU / w as f64 * 2.0 * (0.5 * (t0 + t1)).sin() * (0.5 * (t1 - t0)).sin()
}

/// The renderer's point of a stratified light for the number `u` (in `[0, 1)`) of a light
/// with `count` fixed points: the stratum it picks and that stratum's fixed offset.
fn stratum(strata: &crate::light::Strata, u: f32) -> (u32, [f32; 2]) {
    let n = strata.count();
    let k = ((u * n as f32) as u32).min(n - 1);
    (k, strata.offset1(k))
}

impl Source {
    /// Origin, direction and the power of the particle times its probability (per channel;
    /// the light's power where the sampling is proportional to the emission).
    fn emit(&self, u: &[f32; EMIT_DIMS], power: [f64; 3]) -> (Vec3, Vec3, [f64; 3]) {
        match self {
            Source::Omni { position } => (*position, uniform_sphere(u[1], u[2]), power),
            Source::Spot { spot, frame, cone } => {
                let (k, p) = pick(&cone.cdf, u[1]);
                let (hi, lo) = (cone.mu[k], cone.mu[k + 1]);
                let mu = hi - (hi - lo) * f64::from(u[3]);
                let s = (1.0 - mu * mu).max(0.0).sqrt();
                let phi = TAU * f64::from(u[2]);
                let dir = in_frame(frame, s * phi.cos(), s * phi.sin(), mu);
                // As the renderer evaluates it: the axis against the direction away from
                // the light.
                let f = f64::from(spot.falloff(Scalar, spot.axis().dot(dir)));
                let w = f * TAU * (hi - lo) / p;
                (
                    spot.position(),
                    dir,
                    spot.intensity().map(|c| f64::from(c) * w),
                )
            }
            Source::Parallel { dir, disk } => (disk.point(*dir, u[1], u[2]), *dir, power),
            Source::Direct { position, frame } => (*position, cosine_dir(frame, u[1], u[2]), power),
            Source::Linear(l) => {
                let (a, b) = l.ends();
                let strata = l.strata();
                let s = if strata.jitter() {
                    u[3]
                } else {
                    let (k, o) = stratum(strata, u[3]);
                    (o[0] + k as f32) * (1.0 / strata.count() as f32)
                };
                ((b - a) * s + a, uniform_sphere(u[1], u[2]), power)
            }
            Source::Circular(c) => {
                let (centre, normal, radius) = c.disk();
                let (t, b) = c.tangents();
                let strata = c.strata();
                let (rings, sectors) = c.grid();
                // As the renderer places its points.
                let (x, phi) = if strata.jitter() {
                    (u[3], u[4] * core::f32::consts::TAU)
                } else {
                    let (k, o) = stratum(strata, u[3]);
                    (
                        (o[0] + (k / sectors) as f32) * (1.0 / rings as f32),
                        (o[1] + (k % sectors) as f32) * (core::f32::consts::TAU / sectors as f32),
                    )
                };
                let r = x.sqrt() * radius;
                let phi = phi - core::f32::consts::PI;
                let q = t * (r * phi.cos()) + b * (r * phi.sin()) + centre;
                (q, cosine_dir(&[t, b, normal], u[1], u[2]), power)
            }
            Source::Rectangular(r) => {
                let (corner, eu, ev) = r.frame();
                let strata = r.strata();
                let (nu, nv) = r.grid();
                let (s, t) = if strata.jitter() {
                    (u[3], u[4])
                } else {
                    let (k, o) = stratum(strata, u[3]);
                    (
                        (o[0] + (k % nu) as f32) * (1.0 / nu as f32),
                        (o[1] + (k / nu) as f32) * (1.0 / nv as f32),
                    )
                };
                let q = eu * s + ev * t + corner;
                let f = frame(r.normal_area().0);
                (q, cosine_dir(&f, u[1], u[2]), power)
            }
            Source::Goniodiagram { light, table } => table.emit(light, u),
            Source::Environment { axes, map, disk } => {
                let (j, pj) = pick(&map.marginal, u[1]);
                let w = map.width;
                let (i, pi) = pick(&map.conditional[j * (w + 1)..(j + 1) * (w + 1)], u[2]);
                let (c0, c1) = (map.cos[j], map.cos[j + 1]);
                let z = c0 - (c0 - c1) * f64::from(u[3]);
                let s = (1.0 - z * z).max(0.0).sqrt();
                let phi = TAU * (i as f64 + f64::from(u[4])) / w as f64;
                // Towards the map's texel; the particle travels the other way.
                let wi = in_frame(axes, s * phi.cos(), s * phi.sin(), z);
                let weight = disk.area() * solid_angle(map.height, w, j) / (pj * pi);
                let l = map.radiance[j * w + i];
                (
                    disk.point(-wi, u[5], u[6]),
                    -wi,
                    l.map(|c| f64::from(c) * weight),
                )
            }
        }
    }
}

impl GonioTable {
    /// A particle of the goniodiagram `g`: a cell by the table, a direction uniform in its
    /// solid angle, weighted by the light's own intensity over the density.
    fn emit(&self, g: &Goniodiagram, u: &[f32; EMIT_DIMS]) -> (Vec3, Vec3, [f64; 3]) {
        let na = self.angles.len();
        let (i, pi) = pick(&self.marginal, u[1]);
        let (j, pj) = pick(&self.conditional[i * na..(i + 1) * na], u[2]);
        let (p0, p1) = (self.planes[i], self.planes[i + 1]);
        let (a0, a1) = (self.angles[j], self.angles[j + 1]);
        let p = p0 + (p1 - p0) * f64::from(u[3]);
        let (sp, cp) = p.sin_cos();
        let local = match self.kind {
            PhotometricType::C => {
                let z = a0.cos() - band(self.kind, a0, a1) * f64::from(u[4]);
                let s = (1.0 - z * z).max(0.0).sqrt();
                [s * cp, s * sp, -z]
            }
            kind => {
                let y = a0.sin() + band(kind, a0, a1) * f64::from(u[4]);
                let c = (1.0 - y * y).max(0.0).sqrt();
                if kind == PhotometricType::B {
                    [c * sp, y, -c * cp]
                } else {
                    [y, c * sp, -c * cp]
                }
            }
        };
        let dir = in_frame(&g.axes(), local[0], local[1], local[2]);
        let candela = f64::from(g.candela(Scalar, &Vec3s::splat(Scalar, dir)));
        let omega = (p1 - p0) * band(self.kind, a0, a1);
        let w = candela * omega / (pi * pj);
        (g.position(), dir, g.scale().map(|c| f64::from(c) * w))
    }
}

#[cfg(test)]
// Index loops over the three channels of several arrays at once.
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::light::photometry::PhotometricTable;
    use crate::light::test_util::irradiance1;
    use crate::light::{Direct, Omni, Parallel, SpotFalloff};

    /// SplitMix64 numbers in `[0, 1)`.
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> f32 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut x = self.0;
            x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            x ^= x >> 31;
            (x >> 40) as f32 / (1u64 << 24) as f32
        }

        fn u(&mut self) -> [f32; EMIT_DIMS] {
            core::array::from_fn(|_| self.next())
        }
    }

    fn bounds() -> Aabb {
        Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0))
    }

    fn emitter(light: &Light) -> Emitter {
        Emitter::from_lights("test", std::slice::from_ref(light), bounds()).unwrap()
    }

    /// Particle power (and its square) per bin and channel, and over all particles.
    struct Tally {
        sum: Vec<[f64; 3]>,
        sq: Vec<[f64; 3]>,
        /// Per bin, the squares of the channels' sums.
        sq_all: Vec<f64>,
        total: [f64; 3],
        total_sq: [f64; 3],
        count: usize,
    }

    impl Tally {
        fn new(bins: usize) -> Self {
            Tally {
                sum: vec![[0.0; 3]; bins],
                sq: vec![[0.0; 3]; bins],
                sq_all: vec![0.0; bins],
                total: [0.0; 3],
                total_sq: [0.0; 3],
                count: 0,
            }
        }

        fn add(&mut self, bin: Option<usize>, power: [f32; 3]) {
            self.count += 1;
            for c in 0..3 {
                let w = f64::from(power[c]);
                self.total[c] += w;
                self.total_sq[c] += w * w;
                if let Some(b) = bin {
                    self.sum[b][c] += w;
                    self.sq[b][c] += w * w;
                }
            }
            if let Some(b) = bin {
                self.sq_all[b] += power.iter().map(|&c| f64::from(c)).sum::<f64>().powi(2);
            }
        }

        /// The powers of all particles sum to `power` within 5 standard deviations (plus
        /// 1e-6 relative for rounding and numerical integration).
        fn check_sum(&self, name: &str, power: [f64; 3]) {
            let n = self.count as f64;
            for c in 0..3 {
                let var = (self.total_sq[c] - self.total[c] * self.total[c] / n).max(0.0);
                let err = (self.total[c] - power[c]).abs();
                assert!(
                    err <= 5.0 * var.sqrt() + 1e-6 * power[c],
                    "{name}: channel {c}: particles carry {} W, the light {} W (sigma {})",
                    self.total[c],
                    power[c],
                    var.sqrt()
                );
            }
        }

        /// Each bin's irradiance (power over `area`) against `reference`: per channel within
        /// 5 sigma (the larger of the bin's sample deviation and the Poisson deviation of the
        /// particles' mean power at the reference) plus 1% for the reference's quadrature
        /// over the bin. Over the bins' channel sums, the mean squared deviation in sigmas
        /// (chi^2 per bin, expected 1) within 4 of its standard deviations
        /// (`1 + 4 sqrt(2 / bins)`), and the sum over all bins within 5 sigma plus 0.5%.
        /// Returns chi^2 per bin.
        fn check_bins(&self, name: &str, area: f64, reference: &[[f64; 3]]) -> f64 {
            let n = self.count as f64;
            let peak = reference.iter().flatten().copied().fold(0.0f64, f64::max);
            let sigma =
                |sq: f64, mean: f64, r: f64| ((sq / (area * area)).max(mean * r / area)).sqrt();
            let (mut chi2, mut lit) = (0.0, 0);
            let (mut all, mut all_ref, mut all_var) = (0.0, 0.0, 0.0);
            let mean_all = self.total.iter().sum::<f64>() / n;
            for (b, r) in reference.iter().enumerate() {
                for c in 0..3 {
                    let est = self.sum[b][c] / area;
                    let s = sigma(self.sq[b][c], self.total[c] / n, r[c]);
                    assert!(
                        (est - r[c]).abs() <= 5.0 * s + 0.01 * r[c] + 1e-9 * peak,
                        "{name}: bin {b} channel {c}: particles {est}, renderer {} (sigma {s})",
                        r[c]
                    );
                }
                let (est, r) = (self.sum[b].iter().sum::<f64>(), r.iter().sum::<f64>());
                let s = sigma(self.sq_all[b], mean_all, r);
                all += est / area;
                all_ref += r;
                all_var += s * s;
                if r > 1e-6 * peak {
                    chi2 += ((est / area - r) / s).powi(2);
                    lit += 1;
                }
            }
            let chi2 = chi2 / lit.max(1) as f64;
            let bound = 1.0 + 4.0 * (2.0 / lit.max(1) as f64).sqrt();
            assert!(
                chi2 <= bound,
                "{name}: chi^2 per bin {chi2} over {lit} bins (bound {bound})"
            );
            assert!(
                (all - all_ref).abs() <= 5.0 * all_var.sqrt() + 5e-3 * all_ref,
                "{name}: all bins: particles {all}, renderer {all_ref} (sigma {})",
                all_var.sqrt()
            );
            eprintln!(
                "{name}: chi^2 per bin {chi2:.3} ({lit} bins), all bins {:.5} of the renderer's (sigma {:.5})",
                all / all_ref,
                all_var.sqrt() / all_ref
            );
            chi2
        }
    }

    /// A sphere around a light, binned in `cos` of the angle to `frame[2]` (`mu` from
    /// `mu_lo` to 1) and in the angle about it.
    struct Sphere {
        centre: Vec3,
        r: f32,
        frame: [Vec3; 3],
        mu_lo: f64,
        nmu: usize,
        nphi: usize,
    }

    impl Sphere {
        fn around(centre: Vec3, r: f32, frame: [Vec3; 3]) -> Self {
            Sphere {
                centre,
                r,
                frame,
                mu_lo: -1.0,
                nmu: 13,
                nphi: 16,
            }
        }

        fn bins(&self) -> usize {
            self.nmu * self.nphi
        }

        fn bin_area(&self) -> f64 {
            let r = f64::from(self.r);
            TAU * r * r * (1.0 - self.mu_lo) / self.bins() as f64
        }

        /// The point at (`mu`, `phi`) and its inward normal.
        fn point(&self, mu: f64, phi: f64) -> (Vec3, Vec3) {
            let s = (1.0 - mu * mu).max(0.0).sqrt();
            let d = in_frame(&self.frame, s * phi.cos(), s * phi.sin(), mu);
            (self.centre + d * self.r, -d)
        }

        /// The renderer's irradiance per bin, averaged over `sub` x `sub` points of it.
        fn reference(&self, light: &Light, sub: usize) -> Vec<[f64; 3]> {
            let dmu = (1.0 - self.mu_lo) / self.nmu as f64;
            let dphi = TAU / self.nphi as f64;
            let mut out = vec![[0.0; 3]; self.bins()];
            for a in 0..self.nmu {
                for b in 0..self.nphi {
                    for sa in 0..sub {
                        for sb in 0..sub {
                            let mu = self.mu_lo + dmu * (a as f64 + (sa as f64 + 0.5) / sub as f64);
                            let phi = dphi * (b as f64 + (sb as f64 + 0.5) / sub as f64);
                            let (p, n) = self.point(mu, phi);
                            let e = irradiance1(light, p, n);
                            for c in 0..3 {
                                out[a * self.nphi + b][c] += f64::from(e[c]) / (sub * sub) as f64;
                            }
                        }
                    }
                }
            }
            out
        }

        /// The bin where a particle leaving from inside crosses the sphere (`None` below
        /// `mu_lo`).
        fn bin(&self, p: &Particle) -> Option<usize> {
            let oc = (p.origin - self.centre).as_dvec3();
            let d = p.dir.as_dvec3();
            let r = f64::from(self.r);
            let b = oc.dot(d);
            let t = -b + (b * b - oc.length_squared() + r * r).max(0.0).sqrt();
            let h = (oc + d * t) / r;
            let f = self.frame.map(|v| v.as_dvec3());
            let mu = h.dot(f[2]);
            if mu < self.mu_lo {
                return None;
            }
            let phi = h.dot(f[1]).atan2(h.dot(f[0])).rem_euclid(TAU);
            let a = (((mu - self.mu_lo) / (1.0 - self.mu_lo) * self.nmu as f64) as usize)
                .min(self.nmu - 1);
            let b = ((phi / TAU * self.nphi as f64) as usize).min(self.nphi - 1);
            Some(a * self.nphi + b)
        }

        /// `n` particles of `light` against the renderer's irradiance on the sphere
        /// (`sub` x `sub` points per bin) and their power against [`Emitter::power`].
        /// Returns chi^2 per bin and the particles' tally.
        fn check(&self, name: &str, light: &Light, n: usize, sub: usize, seed: u64) -> Tally {
            let em = emitter(light);
            let mut rng = Rng(seed);
            let mut tally = Tally::new(self.bins());
            for _ in 0..n {
                let p = em.emit(rng.u(), n as u64);
                assert!((p.dir.length() - 1.0).abs() < 1e-5, "{name}: {p:?}");
                tally.add(self.bin(&p), p.power);
            }
            tally.check_sum(name, em.power());
            tally.check_bins(name, self.bin_area(), &self.reference(light, sub));
            tally
        }

        /// The flux through the sphere by the renderer: irradiance times area, by the
        /// midpoint rule on a `nmu` x `nphi` grid.
        fn flux(&self, light: &Light, nmu: usize, nphi: usize) -> [f64; 3] {
            let dmu = (1.0 - self.mu_lo) / nmu as f64;
            let dphi = TAU / nphi as f64;
            let da = f64::from(self.r).powi(2) * dmu * dphi;
            let mut out = [0.0; 3];
            for a in 0..nmu {
                for b in 0..nphi {
                    let (p, n) =
                        self.point(self.mu_lo + dmu * (a as f64 + 0.5), dphi * (b as f64 + 0.5));
                    let e = irradiance1(light, p, n);
                    for c in 0..3 {
                        out[c] += f64::from(e[c]) * da;
                    }
                }
            }
            out
        }
    }

    fn close(name: &str, got: [f64; 3], want: [f64; 3], rel: f64) {
        for c in 0..3 {
            assert!(
                (got[c] - want[c]).abs() <= rel * want[c].abs() + 1e-12,
                "{name}: channel {c}: {got:?} vs {want:?}"
            );
        }
    }

    fn tilted() -> Vec3 {
        Vec3::new(0.3, 0.4, -1.0).normalize()
    }

    #[test]
    fn omni_emits_4_pi_i_uniformly() {
        let pos = Vec3::new(0.3, -0.2, 0.5);
        let light = Light::Omni(Omni::new(pos, [3.0, 2.0, 1.0]).unwrap());
        let want = [3.0, 2.0, 1.0].map(|i| 4.0 * PI * i);
        close("omni", emitter(&light).power(), want, 1e-12);
        let sphere = Sphere::around(pos, 2.0, frame(Vec3::Z));
        close("omni flux", sphere.flux(&light, 100, 8), want, 1e-5);
        sphere.check("omni", &light, 100_000, 2, 1);
    }

    fn spot(falloff: SpotFalloff) -> Spot {
        Spot::new(
            Vec3::new(0.1, 0.2, 0.3),
            tilted(),
            [2.0, 1.0, 0.5],
            0.3,
            0.8,
            falloff,
        )
        .unwrap()
    }

    #[test]
    fn spot_power_is_the_integral_of_its_falloff() {
        for mode in [SpotFalloff::Approx, SpotFalloff::Exact] {
            let s = spot(mode);
            let light = Light::Spot(s.clone());
            let power = emitter(&light).power();
            // The renderer's intensity on a sphere around the spot, axis-aligned, fine in mu.
            let sphere = Sphere::around(s.position(), 1.0, frame(s.axis()));
            close("spot flux", sphere.flux(&light, 20_000, 4), power, 1e-5);
            if mode == SpotFalloff::Exact {
                // The exact cosine falloff with the exact acos: 2 pi I int f sin theta.
                let (i, o) = (0.3f64, 0.8f64);
                let n = 100_000;
                let mut int = 1.0 - i.cos();
                for k in 0..n {
                    let t = i + (o - i) * (k as f64 + 0.5) / n as f64;
                    int += ((t - i) / (o - i) * PI / 2.0).cos() * t.sin() * (o - i) / n as f64;
                }
                close(
                    "spot exact",
                    power,
                    [2.0, 1.0, 0.5].map(|c| TAU * c * int),
                    1e-3,
                );
            }
        }
    }

    /// How far the particles' powers (channel sums) spread about their mean: 98% of them
    /// within 5%.
    fn spread(name: &str, em: &Emitter, n: usize) {
        let mean = em.power().iter().sum::<f64>() / n as f64;
        let mut rng = Rng(77);
        let mut r: Vec<f64> = (0..n)
            .map(|_| {
                let p = em.emit(rng.u(), n as u64);
                p.power.iter().map(|&c| f64::from(c)).sum::<f64>() / mean
            })
            .collect();
        r.sort_by(f64::total_cmp);
        let q = |f: f64| r[((n - 1) as f64 * f) as usize];
        eprintln!(
            "{name}: power / mean: min {:.3}, 1% {:.3}, median {:.3}, 99% {:.3}, max {:.3}",
            q(0.0),
            q(0.01),
            q(0.5),
            q(0.99),
            q(1.0)
        );
        assert!(q(0.01) >= 0.95 && q(0.99) <= 1.05, "{name}: powers spread");
    }

    #[test]
    fn spot_particles_follow_its_cone_and_falloff() {
        for (mode, seed) in [(SpotFalloff::Approx, 2), (SpotFalloff::Exact, 3)] {
            let s = spot(mode);
            let light = Light::Spot(s.clone());
            let mut sphere = Sphere::around(s.position(), 2.0, frame(s.axis()));
            sphere.mu_lo = 0.9f64.cos();
            let tally = sphere.check("spot", &light, 100_000, 4, seed);
            spread("spot", &emitter(&light), 100_000);
            // Nothing outside the cone.
            let inside: f64 = tally.sum.iter().map(|p| p[0]).sum();
            assert!(tally.total[0] - inside <= 1e-6 * tally.total[0], "{mode:?}");
            // Powers stay near the mean.
            let em = emitter(&light);
            let mean = em.power()[0] / 1000.0;
            let mut rng = Rng(9);
            for _ in 0..1000 {
                let p = em.emit(rng.u(), 1000).power[0] as f64;
                assert!(p <= 1.05 * mean, "{mode:?}: {p} vs mean {mean}");
            }
        }
    }

    #[test]
    fn direct_emits_pi_i_with_its_cosine() {
        let light = Light::Direct(
            Direct::new(Vec3::new(0.2, 0.1, 0.4), tilted(), [1.0, 2.0, 3.0]).unwrap(),
        );
        let want = [1.0, 2.0, 3.0].map(|i| PI * i);
        close("direct", emitter(&light).power(), want, 1e-12);
        let sphere = Sphere::around(Vec3::new(0.2, 0.1, 0.4), 1.5, frame(tilted()));
        close("direct flux", sphere.flux(&light, 2000, 4), want, 1e-5);
        sphere.check("direct", &light, 100_000, 2, 4);
    }

    #[test]
    fn linear_lights_emit_4_pi_i_from_the_renderers_points() {
        let (a, b) = (Vec3::new(-0.5, 0.1, 0.2), Vec3::new(0.4, -0.2, 0.4));
        for (jitter, points, seed) in [(false, 7, 5), (true, 64, 6)] {
            let light =
                Light::Linear(Linear::new(a, b, [1.0, 0.5, 2.0], points, 11, jitter).unwrap());
            let want = [1.0, 0.5, 2.0].map(|i| 4.0 * PI * i);
            close("linear", emitter(&light).power(), want, 1e-12);
            let sphere = Sphere::around((a + b) * 0.5, 1.2, frame((b - a).normalize()));
            close("linear flux", sphere.flux(&light, 800, 50), want, 2e-4);
            sphere.check("linear", &light, 100_000, 2, seed);
        }
    }

    #[test]
    fn circular_lights_emit_pi_l_a_from_their_front() {
        let (centre, r) = (Vec3::new(0.1, 0.2, -0.1), 0.5);
        for (jitter, grid, seed) in [(false, (3, 7), 7), (true, (16, 24), 8)] {
            let light = Light::Circular(
                Circular::new(centre, tilted(), r, [1.0, 2.0, 0.5], grid, 3, jitter).unwrap(),
            );
            let area = PI * 0.25;
            let want = [1.0, 2.0, 0.5].map(|l| PI * l * area);
            close("circular", emitter(&light).power(), want, 1e-6);
            let sphere = Sphere::around(centre, 1.5, frame(tilted()));
            close("circular flux", sphere.flux(&light, 100, 50), want, 1e-3);
            sphere.check("circular", &light, 100_000, 2, seed);
        }
    }

    #[test]
    fn rectangular_lights_emit_pi_l_a_from_their_front() {
        let corner = Vec3::new(-0.4, -0.3, 0.2);
        let (eu, ev) = (Vec3::new(0.9, 0.0, 0.2), Vec3::new(0.1, 0.6, 0.0));
        for (jitter, grid, seed) in [(false, (7, 3), 9), (true, (24, 16), 10)] {
            let light = Light::Rectangular(
                Rectangular::new(corner, eu, ev, [0.5, 1.0, 2.0], grid, 4, jitter).unwrap(),
            );
            let area = f64::from(eu.cross(ev).length());
            let want = [0.5, 1.0, 2.0].map(|l| PI * l * area);
            close("rectangular", emitter(&light).power(), want, 1e-6);
            let sphere = Sphere::around(
                corner + (eu + ev) * 0.5,
                1.5,
                frame(eu.cross(ev).normalize()),
            );
            close("rectangular flux", sphere.flux(&light, 100, 50), want, 1e-3);
            sphere.check("rectangular", &light, 100_000, 2, seed);
        }
    }

    /// A table over type C, B or A with a hard edge where the file's coverage ends (C:
    /// gamma 90 degrees; B: plane +-90; A: planes +-67.5).
    fn table(kind: PhotometricType) -> PhotometricTable {
        let (planes, angles): (Vec<f32>, Vec<f32>) = match kind {
            PhotometricType::C => (
                vec![0.0, 30.0, 75.0, 90.0, 150.0, 200.0, 270.0, 330.0, 360.0],
                vec![0.0, 10.0, 30.0, 50.0, 70.0, 90.0],
            ),
            PhotometricType::B => (
                vec![0.0, 30.0, 60.0, 90.0],
                vec![-90.0, -45.0, 0.0, 45.0, 90.0],
            ),
            PhotometricType::A => (
                vec![-67.5, -20.0, 0.0, 45.0, 67.5],
                vec![-90.0, -30.0, 0.0, 30.0, 90.0],
            ),
        };
        let f = |p: f32, a: f32| {
            let (p, a) = (p.to_radians(), a.to_radians());
            match kind {
                PhotometricType::C => 100.0 + 80.0 * a.cos() + 30.0 * (2.0 * p).cos() * a.sin(),
                PhotometricType::B => 50.0 + 40.0 * p.cos() + 20.0 * a.sin(),
                PhotometricType::A => 60.0 + 30.0 * (2.0 * p).cos() + 25.0 * a.sin(),
            }
        };
        let candela = planes
            .iter()
            .flat_map(|&p| angles.iter().map(move |&a| f(p, a)))
            .collect();
        PhotometricTable {
            kind,
            planes,
            angles,
            candela,
        }
    }

    fn gonio(kind: PhotometricType, lookup: GonioLookup) -> Goniodiagram {
        Goniodiagram::new(
            Vec3::new(0.1, 0.2, 0.3),
            Vec3::new(0.2, 0.3, 1.0),
            Vec3::new(1.0, -0.1, 0.2),
            &table(kind),
            [683.0, 400.0, 200.0],
            lookup,
            std::path::Path::new("test.ies"),
        )
        .unwrap()
    }

    /// A frame whose `mu` and angle about its third axis are the table's angle and plane
    /// (for type C, `mu = cos gamma`).
    fn table_frame(g: &Goniodiagram) -> [Vec3; 3] {
        let [ex, ey, ez] = g.axes();
        match g.kind() {
            PhotometricType::C => [ex, ey, -ez],
            PhotometricType::B => [-ez, ex, ey],
            PhotometricType::A => [-ez, ey, ex],
        }
    }

    const GONIO_CASES: [(PhotometricType, GonioLookup); 4] = [
        (PhotometricType::C, GonioLookup::Search),
        (PhotometricType::C, GonioLookup::Uniform),
        (PhotometricType::B, GonioLookup::Search),
        (PhotometricType::A, GonioLookup::Search),
    ];

    #[test]
    fn goniodiagram_power_is_the_integral_of_its_intensity() {
        for (kind, lookup) in GONIO_CASES {
            let g = gonio(kind, lookup);
            let light = Light::Goniodiagram(g.clone());
            let power = emitter(&light).power();
            // The renderer's intensity, integrated on a grid whose lines hold the edges.
            let sphere = Sphere::around(g.position(), 1.0, table_frame(&g));
            let flux = sphere.flux(&light, 2000, 720);
            eprintln!(
                "goniodiagram {kind:?} {lookup:?}: power / renderer {:.6}",
                power[0] / flux[0]
            );
            close(
                &format!("goniodiagram {kind:?} {lookup:?}"),
                flux,
                power,
                5e-4,
            );
        }
        // A constant table: 4 pi I.
        let t = PhotometricTable {
            kind: PhotometricType::C,
            planes: vec![0.0],
            angles: vec![0.0, 180.0],
            candela: vec![100.0, 100.0],
        };
        let g = Goniodiagram::new(
            Vec3::ZERO,
            Vec3::Z,
            Vec3::X,
            &t,
            [1.0; 3],
            GonioLookup::Search,
            std::path::Path::new("flat.ies"),
        )
        .unwrap();
        let want = g.scale().map(|s| 4.0 * PI * 100.0 * f64::from(s));
        close(
            "constant goniodiagram",
            emitter(&Light::Goniodiagram(g)).power(),
            want,
            1e-9,
        );
    }

    #[test]
    fn goniodiagram_particles_follow_its_diagram() {
        for (k, (kind, lookup)) in GONIO_CASES.into_iter().enumerate() {
            let g = gonio(kind, lookup);
            let light = Light::Goniodiagram(g.clone());
            let sphere = Sphere::around(g.position(), 2.0, table_frame(&g));
            let name = format!("goniodiagram {kind:?} {lookup:?}");
            let tally = sphere.check(&name, &light, 200_000, 4, 20 + k as u64);
            spread(&name, &emitter(&light), tally.count);
        }
    }

    /// Particles crossing a square patch (centre `q`, normal `n`, half-side 0.6, inside the
    /// bounds; 3 x 3 bins) from its front, against the renderer's irradiance at the bins'
    /// centres.
    fn plane_check(
        name: &str,
        light: &Light,
        em: &Emitter,
        (q, n): (Vec3, Vec3),
        count: usize,
        seed: u64,
    ) {
        let (k, half) = (3, 0.6f32);
        let f = frame(n);
        let side = 2.0 * f64::from(half) / k as f64;
        let bin = |x: f64| ((x + f64::from(half)) / side).floor();
        let mut tally = Tally::new(k * k);
        let mut rng = Rng(seed);
        for _ in 0..count {
            let p = em.emit(rng.u(), count as u64);
            let (o, d) = (p.origin.as_dvec3(), p.dir.as_dvec3());
            let nd = n.as_dvec3();
            let cos = d.dot(nd);
            let mut at = None;
            if cos < 0.0 {
                let t = (q.as_dvec3() - o).dot(nd) / cos;
                let h = o + d * t - q.as_dvec3();
                let (x, y) = (bin(h.dot(f[0].as_dvec3())), bin(h.dot(f[1].as_dvec3())));
                if t > 0.0 && (0.0..k as f64).contains(&x) && (0.0..k as f64).contains(&y) {
                    at = Some(y as usize * k + x as usize);
                }
            }
            tally.add(at, p.power);
        }
        tally.check_sum(name, em.power());
        let reference: Vec<[f64; 3]> = (0..k * k)
            .map(|b| {
                let (x, y) = ((b % k) as f32 + 0.5, (b / k) as f32 + 0.5);
                let s = side as f32;
                let p = q + f[0] * (x * s - half) + f[1] * (y * s - half);
                irradiance1(light, p, n).map(f64::from)
            })
            .collect();
        tally.check_bins(name, side * side, &reference);
    }

    /// The particles' origins lie on a disk across their direction that covers the bounds
    /// and lies before them.
    fn check_disk(name: &str, em: &Emitter, count: usize) {
        let b = bounds();
        let c = (b.min + b.max) * 0.5;
        let r = (b.max - b.min).length() * 0.5;
        let mut rng = Rng(99);
        let mut widest = 0.0f32;
        for _ in 0..count {
            let p = em.emit(rng.u(), count as u64);
            let along = (p.origin - c).dot(p.dir);
            assert!(
                along <= -r,
                "{name}: {p:?} starts inside the bounds' sphere"
            );
            let across = ((p.origin - c) - p.dir * along).length();
            widest = widest.max(across);
            assert!(across <= r * 1.01, "{name}: {p:?} off the disk");
        }
        assert!(
            widest >= r * 0.99,
            "{name}: the disk does not cover the bounds ({widest})"
        );
    }

    #[test]
    fn parallel_light_emits_e_pi_r2_through_a_disk_covering_the_bounds() {
        let dir = Vec3::new(0.3, -0.2, -1.0).normalize();
        let light = Light::Parallel(Parallel::new(dir, [2.0, 1.0, 0.5]).unwrap());
        let em = emitter(&light);
        // The disk: the bounds' bounding sphere (radius sqrt 3), grown by 0.1%.
        let disk = bounding_sphere(bounds(), "parallel").unwrap();
        let r = f64::from(disk.radius);
        assert!(r >= 3f64.sqrt() && r <= 3f64.sqrt() * 1.0011, "{r}");
        close(
            "parallel",
            em.power(),
            [2.0, 1.0, 0.5].map(|e| e * disk.area()),
            1e-12,
        );
        check_disk("parallel", &em, 10_000);
        let n = Vec3::new(0.2, 0.3, 1.0).normalize();
        plane_check(
            "parallel",
            &light,
            &em,
            (Vec3::new(0.1, -0.2, 0.0), n),
            200_000,
            30,
        );
    }

    /// A map with a bright spot and a gradient, scaled by 2, tilted.
    fn sky(samples: u32) -> Environment {
        let (w, h) = (32, 16);
        let mut t = Vec::new();
        for j in 0..h {
            for i in 0..w {
                let spot = if (10..13).contains(&i) && (3..5).contains(&j) {
                    50.0
                } else {
                    0.0
                };
                t.push([0.1 + i as f32 * 0.01 + spot, 0.2 + spot, 0.05 * j as f32]);
            }
        }
        Environment::new(
            "sky",
            w,
            h,
            &t,
            2.0,
            Vec3::new(0.2, 1.0, 0.1),
            Vec3::new(1.0, 0.0, 0.3),
            samples,
        )
        .unwrap()
    }

    #[test]
    fn environment_power_is_pi_r2_times_its_radiance_over_the_sphere() {
        let env = sky(16);
        let light = Light::Environment(env.clone());
        let em = emitter(&light);
        // The renderer's radiance over the sphere, 8 x 4 points per texel.
        let (w, h) = env.size();
        let (nt, np) = (8 * h, 4 * w);
        let mut int = [0.0f64; 3];
        let l = Scalar;
        for a in 0..nt {
            let theta = PI * (a as f64 + 0.5) / nt as f64;
            for b in 0..np {
                let phi = TAU * (b as f64 + 0.5) / np as f64;
                let d = in_frame(
                    &env.axes(),
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                );
                let e = light.radiance_seen(l, &Vec3s::splat(l, d)).lane(0);
                for c in 0..3 {
                    int[c] += f64::from(e[c]) * theta.sin() * (PI / nt as f64) * (TAU / np as f64);
                }
            }
        }
        let area = bounding_sphere(bounds(), "environment").unwrap().area();
        close("environment", em.power(), int.map(|l| l * area), 1e-4);
        // A constant map: pi R^2 4 pi L.
        let flat = Light::Environment(
            Environment::constant([1.0, 2.0, 3.0], Vec3::Z, Vec3::X, 4).unwrap(),
        );
        let p = emitter(&flat).power();
        close(
            "constant map",
            p,
            [1.0, 2.0, 3.0].map(|l| l * 4.0 * PI * area),
            1e-6,
        );
    }

    #[test]
    fn environment_particles_light_a_patch_as_the_renderer_does() {
        let light = Light::Environment(sky(16));
        let em = emitter(&light);
        check_disk("environment", &em, 10_000);
        spread("environment", &em, 100_000);
        // The renderer's estimate with many samples as the reference.
        let fine = Light::Environment(sky(65_536));
        for (k, n) in [Vec3::Z, Vec3::new(0.3, -0.5, 0.8).normalize(), -Vec3::X]
            .into_iter()
            .enumerate()
        {
            plane_check(
                &format!("environment {n}"),
                &fine,
                &em,
                (Vec3::new(0.05, 0.1, -0.1), n),
                300_000,
                40 + k as u64,
            );
        }
    }

    #[test]
    fn lights_are_chosen_by_power_so_particles_carry_the_same() {
        let lights = vec![
            Light::Omni(Omni::new(Vec3::new(0.1, 0.2, 0.3), [1.0, 2.0, 3.0]).unwrap()),
            Light::Omni(Omni::new(Vec3::new(0.5, 0.5, 0.5), [0.0; 3]).unwrap()),
            Light::Rectangular(
                Rectangular::new(Vec3::ZERO, Vec3::X, Vec3::Y, [5.0; 3], (7, 3), 1, true).unwrap(),
            ),
            Light::Parallel(Parallel::new(-Vec3::Z, [0.5, 0.2, 0.1]).unwrap()),
            Light::Direct(Direct::new(Vec3::ZERO, Vec3::Y, [3.0, 0.0, 1.0]).unwrap()),
        ];
        let em = Emitter::from_lights("mixed", &lights, bounds()).unwrap();
        let total: f64 = em.power().iter().sum();
        let n = 20_000;
        let mut rng = Rng(50);
        for _ in 0..n {
            let p = em.emit(rng.u(), n as u64);
            assert_ne!(p.origin, Vec3::new(0.5, 0.5, 0.5), "the dark light emitted");
            let sum: f64 = p.power.iter().map(|&c| f64::from(c)).sum();
            assert!((sum - total / n as f64).abs() <= 1e-5 * sum, "{p:?}");
        }
        // Numbers out of range and no count still give a finite particle.
        for u in [[f32::NAN; EMIT_DIMS], [1.0; EMIT_DIMS], [-3.0; EMIT_DIMS]] {
            let p = em.emit(u, 0);
            assert!(
                p.origin.is_finite() && p.dir.is_finite() && p.power.iter().all(|c| c.is_finite()),
                "{p:?}"
            );
        }
    }

    #[test]
    fn a_scene_emits_its_lights_power() {
        let scene = crate::scene::builtin::by_name("cornell").unwrap();
        let em = Emitter::new(&scene, bounds()).unwrap();
        let Light::Rectangular(r) = &scene.lights[0] else {
            panic!("the Cornell box's light is a rectangle");
        };
        let a = f64::from(r.normal_area().1);
        close(
            "cornell",
            em.power(),
            r.radiance().map(|l| PI * a * f64::from(l)),
            1e-6,
        );
    }

    #[test]
    fn scenes_without_emitting_lights_are_errors() {
        let dark = [
            vec![],
            vec![Light::Omni(Omni::new(Vec3::ZERO, [0.0; 3]).unwrap())],
            vec![Light::Environment(
                Environment::new("black", 2, 1, &[[1.0; 3]; 2], 0.0, Vec3::Z, Vec3::X, 1).unwrap(),
            )],
        ];
        for lights in dark {
            let e = Emitter::from_lights("dark", &lights, bounds()).unwrap_err();
            assert!(matches!(e, IllumError::NoLight { .. }), "{e}");
            assert!(e.to_string().contains("dark"), "{e}");
        }
    }

    #[test]
    fn lights_that_cannot_emit_are_errors_naming_them() {
        let omni = Light::Omni(Omni::new(Vec3::ZERO, [1.0; 3]).unwrap());
        let parallel = Light::Parallel(Parallel::new(Vec3::Z, [1.0; 3]).unwrap());
        let e = Emitter::from_lights("s", &[omni.clone(), parallel], Aabb::EMPTY).unwrap_err();
        let msg = e.to_string();
        assert!(
            matches!(
                e,
                IllumError::Light {
                    light: 1,
                    kind: "parallel",
                    ..
                }
            ) && msg.contains("bounds"),
            "{msg}"
        );
        let huge = Light::Omni(Omni::new(Vec3::ZERO, [f32::MAX; 3]).unwrap());
        let e = Emitter::from_lights("s", &[omni, huge], bounds()).unwrap_err();
        assert!(
            matches!(
                e,
                IllumError::Light {
                    light: 1,
                    kind: "omni",
                    ..
                }
            ),
            "{e}"
        );
        let big = Light::Omni(Omni::new(Vec3::ZERO, [2e37; 3]).unwrap());
        let e = Emitter::from_lights("s", &[big.clone(), big], bounds()).unwrap_err();
        assert!(matches!(e, IllumError::Light { kind: "omni", .. }), "{e}");
    }
}
