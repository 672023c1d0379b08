//! Particles leaving the lights (forward Monte-Carlo ray tracing's first step): each kind of
//! light by its own emission, each particle carrying its share of the light's power, the light
//! chosen in proportion to its power so that every particle carries about the same.

use coherent_accel::Aabb;
use glam::Vec3;

use super::IllumError;
use crate::light::Light;
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
    lights: Vec<Light>,
    /// Per light, emitted power (W per channel).
    power: Vec<[f64; 3]>,
    /// Cumulative probabilities of choosing each light (by the sum of its channels).
    cdf: Vec<f64>,
}

/// The random numbers one emission takes.
pub const EMIT_DIMS: usize = 5;

impl Emitter {
    /// The lights of `scene` as particle sources; `bounds` are the scene's world bounds
    /// (parallel and environment lights emit from a disk that covers them). A scene whose
    /// lights emit no power is an error.
    pub fn new(scene: &RenderScene, bounds: Aabb) -> Result<Self, IllumError> {
        let _ = bounds;
        let mut power = Vec::with_capacity(scene.lights.len());
        for (i, light) in scene.lights.iter().enumerate() {
            power.push(match light {
                Light::Omni(o) => o
                    .intensity()
                    .map(|c| 4.0 * core::f64::consts::PI * f64::from(c)),
                other => {
                    return Err(IllumError::Light {
                        scene: scene.name.clone(),
                        light: i,
                        kind: other.kind().name(),
                        problem: "not emitted yet".into(),
                    });
                }
            });
        }
        let mut cdf = Vec::with_capacity(power.len());
        let mut acc = 0.0;
        for p in &power {
            acc += p.iter().sum::<f64>();
            cdf.push(acc);
        }
        if !(acc > 0.0) {
            return Err(IllumError::NoLight {
                scene: scene.name.clone(),
            });
        }
        for c in &mut cdf {
            *c /= acc;
        }
        Ok(Self {
            lights: scene.lights.clone(),
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

    /// One of `count` particles from the uniform numbers `u` (in [0, 1)): its light chosen by
    /// power with `u[0]`, the rest placing and aiming it. The powers of `count` particles sum
    /// to [`Emitter::power`] in expectation.
    pub fn emit(&self, u: [f32; EMIT_DIMS], count: u64) -> Particle {
        let k = self
            .cdf
            .partition_point(|&c| c <= f64::from(u[0]))
            .min(self.lights.len() - 1);
        let prob = self.cdf[k] - if k == 0 { 0.0 } else { self.cdf[k - 1] };
        let scale = 1.0 / (prob * count as f64);
        let power = self.power[k].map(|c| (c * scale) as f32);
        match &self.lights[k] {
            Light::Omni(o) => Particle {
                origin: o.position(),
                dir: uniform_sphere(u[1], u[2]),
                power,
            },
            _ => unreachable!("Emitter::new refuses the other kinds"),
        }
    }
}

/// A uniformly distributed unit vector.
pub fn uniform_sphere(u1: f32, u2: f32) -> Vec3 {
    let z = 1.0 - 2.0 * u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * core::f32::consts::PI * u2;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}
