//! Physically accurate materials over packets (paper section 4): the four components (a
//! Phong-like bundle, reflection and refraction attributes, a texture, a tabulated BDF),
//! evaluated for a packet of hits one material at a time. Lanes that hit another material
//! are masked off, and the packet is processed once per distinct material in it (the
//! paper: "only one material is processed at a time"); the number of such passes is
//! counted.
//!
//! What a material evaluates, per lane, for a direction `wi` to a light and `wo` to the
//! viewer (both unit, away from the surface):
//! - the reflected part `f(wi, wo) cos(theta_i)`, where `f` is the tabulated BDF times the
//!   texture colour when the material has a BDF, and otherwise the normalised Phong model
//!   `kd tex / pi + ks (n + 2) / (2 pi) cos^n(alpha)` (`alpha` between `wo` and the mirror
//!   direction of `wi`, `tex` the texture colour or white); zero where either direction is
//!   below the surface;
//! - the ambient term `ka tex`;
//! - the weights of the mirror reflection and refraction rays: `reflectance F` and
//!   `transmittance (1 - F)` with the dielectric Fresnel factor `F(cos theta_o)` for the
//!   index of refraction, or plain `reflectance` and `transmittance` without Fresnel.

use std::sync::Arc;

use coherent_simd::{Lanes, Rgbs, SimdF32, SimdI32, SimdMask, Vec3s};
use thiserror::Error;

use crate::approx;
use crate::bdf::{Bdf, Frames};
use crate::texture::Texture;

/// The Phong-like bundle of attributes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Phong {
    pub diffuse: [f32; 3],
    pub specular: [f32; 3],
    /// The Phong exponent `n` (at least 0).
    pub exponent: f32,
    pub ambient: [f32; 3],
}

/// Reflection and refraction attributes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Optics {
    /// Weight of the mirror reflection ray.
    pub reflectance: [f32; 3],
    /// Weight of the refracted ray.
    pub transmittance: [f32; 3],
    /// Index of refraction inside the surface relative to outside.
    pub ior: f32,
    /// Scale reflection by the dielectric Fresnel factor and refraction by its complement.
    pub fresnel: bool,
    /// A glass's index per wavelength, for spectral renders (`None`: `ior` at every
    /// wavelength; RGB renders take `ior`, the index at the d line).
    pub dispersion: Option<crate::spectrum::dispersion::Dispersion>,
}

/// A material: the paper's four components.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    pub name: String,
    pub phong: Phong,
    pub optics: Optics,
    pub texture: Option<Arc<Texture>>,
    pub bdf: Option<Arc<Bdf>>,
}

/// A material that cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MaterialError {
    #[error("material {name}: {what} is {value}, {expected}")]
    BadAttribute {
        name: String,
        what: &'static str,
        value: f32,
        expected: &'static str,
    },
    #[error("a hit names material {id}, but the scene has {count} material(s)")]
    UnknownMaterial { id: i32, count: usize },
}

/// The hits of a packet, as the shading stage receives them.
#[derive(Debug, Clone, Copy)]
pub struct ShadeHits<L: Lanes> {
    /// Lanes that hit something.
    pub active: L::Mask,
    /// Material index of each lane's hit (into the material list).
    pub material: L::I32s,
    /// Shading frames at the hits.
    pub frames: Frames<L>,
    /// Unit direction from the hit to the viewer.
    pub wo: Vec3s<L>,
    /// Texture coordinates.
    pub s: L::F32s,
    pub t: L::F32s,
    /// Mip level (see [`crate::texture::lod_by_halving`]).
    pub lod: L::F32s,
}

/// What a material gives per lane (see the module documentation).
#[derive(Debug, Clone, Copy)]
pub struct Shading<L: Lanes> {
    /// `f(wi, wo) cos(theta_i)`.
    pub reflected: Rgbs<L>,
    /// The ambient term.
    pub ambient: Rgbs<L>,
    /// Weight of the mirror reflection ray.
    pub reflection: Rgbs<L>,
    /// Weight of the refracted ray.
    pub refraction: Rgbs<L>,
}

impl<L: Lanes> Shading<L> {
    /// All zero.
    #[inline(always)]
    pub fn zero(l: L) -> Self {
        let z = Rgbs::zero(l);
        Self {
            reflected: z,
            ambient: z,
            reflection: z,
            refraction: z,
        }
    }

    /// Per lane `if m { t } else { f }`.
    #[inline(always)]
    pub fn select(m: L::Mask, t: Self, f: Self) -> Self {
        Self {
            reflected: Rgbs::select(m, t.reflected, f.reflected),
            ambient: Rgbs::select(m, t.ambient, f.ambient),
            reflection: Rgbs::select(m, t.reflection, f.reflection),
            refraction: Rgbs::select(m, t.refraction, f.refraction),
        }
    }
}

/// Packets shaded and material passes made, accumulated over a render.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SplitCount {
    /// Packets with at least one active lane.
    pub packets: u64,
    /// Material passes (one per distinct material in a packet).
    pub passes: u64,
}

impl SplitCount {
    /// Passes per packet (1 = every packet was one material).
    pub fn passes_per_packet(&self) -> f64 {
        if self.packets == 0 {
            0.0
        } else {
            self.passes as f64 / self.packets as f64
        }
    }
}

#[inline(always)]
fn rgb<L: Lanes>(l: L, c: [f32; 3]) -> Rgbs<L> {
    Rgbs::splat(l, c)
}

/// The dielectric Fresnel reflectance for unpolarised light at `cos_o = |cos theta|`
/// going from outside into a medium of relative index `eta` (total internal reflection
/// gives 1).
#[inline(always)]
pub fn fresnel_dielectric<L: Lanes>(l: L, cos_o: L::F32s, eta: L::F32s) -> L::F32s {
    let one = l.splat(1.0);
    let zero = l.splat(0.0);
    let cos_o = cos_o.clamp(zero, one);
    let sin2_t = (one - cos_o * cos_o) / (eta * eta);
    let tir = sin2_t.ge(one);
    let cos_t = (one - sin2_t).max(zero).sqrt();
    let rs = (cos_o - eta * cos_t) / (cos_o + eta * cos_t);
    let rp = (eta * cos_o - cos_t) / (eta * cos_o + cos_t);
    let f = (rs * rs + rp * rp) * 0.5;
    tir.select(one, f.min(one))
}

impl Material {
    /// A plain Phong material with no texture, BDF, reflection or refraction.
    pub fn phong(
        name: impl Into<String>,
        diffuse: [f32; 3],
        specular: [f32; 3],
        exponent: f32,
    ) -> Self {
        Self {
            name: name.into(),
            phong: Phong {
                diffuse,
                specular,
                exponent,
                ambient: [0.0; 3],
            },
            optics: Optics {
                reflectance: [0.0; 3],
                transmittance: [0.0; 3],
                ior: 1.0,
                fresnel: false,
                dispersion: None,
            },
            texture: None,
            bdf: None,
        }
    }

    /// Checks the attributes: colours finite and not negative, the exponent finite and
    /// not negative, the index of refraction finite and positive.
    pub fn validate(&self) -> Result<(), MaterialError> {
        let bad = |what, value: f32, expected| MaterialError::BadAttribute {
            name: self.name.clone(),
            what,
            value,
            expected,
        };
        let colours = [
            ("the diffuse colour", self.phong.diffuse),
            ("the specular colour", self.phong.specular),
            ("the ambient colour", self.phong.ambient),
            ("the reflectance", self.optics.reflectance),
            ("the transmittance", self.optics.transmittance),
        ];
        for (what, c) in colours {
            if let Some(&v) = c.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
                return Err(bad(what, v, "expected a finite value >= 0"));
            }
        }
        let n = self.phong.exponent;
        if !(n.is_finite() && n >= 0.0) {
            return Err(bad("the Phong exponent", n, "expected a finite value >= 0"));
        }
        let ior = self.optics.ior;
        if !(ior.is_finite() && ior > 0.0) {
            return Err(bad(
                "the index of refraction",
                ior,
                "expected a finite value > 0",
            ));
        }
        Ok(())
    }

    /// The diffuse albedo per lane, `kd tex` (the texture colour at `(s, t)` and mip level
    /// `lod`, or white): what indirect light sees of the material. A tabulated BDF has no
    /// albedo of its own here, so its material's Phong diffuse colour stands for it.
    #[inline(always)]
    pub fn albedo<L: Lanes>(&self, l: L, s: L::F32s, t: L::F32s, lod: L::F32s) -> Rgbs<L> {
        let kd = rgb(l, self.phong.diffuse);
        match &self.texture {
            Some(tex) => tex.sample(l, s, t, lod) * kd,
            None => kd,
        }
    }

    /// Shades every lane of `hits` with this material for light direction `wi`. Lanes
    /// outside `mask` are computed from whatever they hold and must be discarded by the
    /// caller ([`shade`] does).
    #[inline(always)]
    pub fn shade<L: Lanes>(&self, l: L, hits: &ShadeHits<L>, wi: &Vec3s<L>) -> Shading<L> {
        let zero = l.splat(0.0);
        let one = l.splat(1.0);
        let n = hits.frames.normal;
        let cos_i = wi.dot(n);
        let cos_o = hits.wo.dot(n);
        let above = cos_i.gt(zero) & cos_o.gt(zero);

        let tex = match &self.texture {
            Some(t) => t.sample(l, hits.s, hits.t, hits.lod),
            None => rgb(l, [1.0; 3]),
        };
        let f = match &self.bdf {
            Some(bdf) => {
                let wi_local = hits.frames.to_local(*wi);
                let wo_local = hits.frames.to_local(hits.wo);
                tex * bdf.eval(l, &wi_local, &wo_local)
            }
            None => {
                let p = &self.phong;
                let diffuse =
                    (tex * rgb(l, p.diffuse)).scale(l.splat(core::f32::consts::FRAC_1_PI));
                // Mirror direction of wi about n, and the Phong lobe around it.
                let mirror = n * (cos_i + cos_i) - *wi;
                let cos_a = mirror.dot(hits.wo).clamp(zero, one);
                let lobe = if p.exponent == 0.0 {
                    one // 0^0 is 1 here, not exp(0 ln 0)
                } else {
                    approx::pow(l, cos_a, l.splat(p.exponent))
                };
                let lobe = lobe * ((p.exponent + 2.0) * 0.5 * core::f32::consts::FRAC_1_PI);
                rgb(l, p.specular).mul_add(lobe, diffuse)
            }
        };
        let reflected = Rgbs::select(above, f.scale(cos_i), Rgbs::zero(l));

        let ambient = tex * rgb(l, self.phong.ambient);
        let o = &self.optics;
        let (reflection, refraction) = if o.fresnel {
            // Leaving the surface from inside (wo below) sees the inverse index.
            let eta = cos_o.lt(zero).select(l.splat(1.0 / o.ior), l.splat(o.ior));
            let fr = fresnel_dielectric(l, cos_o.abs(), eta);
            (
                rgb(l, o.reflectance).scale(fr),
                rgb(l, o.transmittance).scale(one - fr),
            )
        } else {
            (rgb(l, o.reflectance), rgb(l, o.transmittance))
        };
        Shading {
            reflected,
            ambient,
            reflection,
            refraction,
        }
    }
}

/// Shades a packet: for each distinct material among the active lanes, in turn, the
/// material runs with the lanes of the other materials masked off (the paper's one
/// material at a time). Inactive lanes give zero. `count` gets one packet and one pass per
/// material processed. An active lane naming no material is an error (nothing is shaded).
#[inline(always)]
pub fn shade<L: Lanes>(
    l: L,
    materials: &[Material],
    hits: &ShadeHits<L>,
    wi: &Vec3s<L>,
    count: &mut SplitCount,
) -> Result<Shading<L>, MaterialError> {
    let ids = hits.material;
    let bad =
        hits.active & (ids.lt(l.splat_i32(0)) | ids.gt(l.splat_i32(materials.len() as i32 - 1)));
    if bad.any() {
        let lane = bad.bitmask().trailing_zeros() as usize;
        return Err(MaterialError::UnknownMaterial {
            id: ids.lane(lane),
            count: materials.len(),
        });
    }
    let mut out = Shading::zero(l);
    let mut todo = hits.active;
    if todo.any() {
        count.packets += 1;
    }
    while todo.any() {
        let id = ids.lane(todo.bitmask().trailing_zeros() as usize);
        let mine = todo & ids.eq(l.splat_i32(id));
        let s = materials[id as usize].shade(l, hits, wi);
        out = Shading::select(mine, s, out);
        todo = todo.and_not(mine);
        count.passes += 1;
    }
    Ok(out)
}
