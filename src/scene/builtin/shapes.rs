//! Deterministic geometry and procedural textures for the built-in scenes (paper section 7's
//! test scenes are rebuilt in memory, no download): parametric surfaces with UVs and smooth
//! normals, subdivided quads, and checker, wood, marble and brick textures.

use std::sync::Arc;

use coherent_accel::Mesh;
use coherent_accel::shapes::{Rng, torus_point};
use glam::{Vec2, Vec3};

use crate::scene::ShadedMesh;
use crate::texture::{Texture, Wrap};

/// A parametric surface `f(u, v)`, `u, v` in `[0, 1]`, on an `nu x nv` grid of quads
/// (`2 nu nv` triangles), with UVs `(u, v)` and smooth normals.
pub fn surface(
    name: &str,
    nu: u32,
    nv: u32,
    material: u32,
    f: impl Fn(f32, f32) -> Vec3,
) -> ShadedMesh {
    let mut positions = Vec::with_capacity(((nu + 1) * (nv + 1)) as usize);
    let mut uvs = Vec::with_capacity(positions.capacity());
    for j in 0..=nv {
        for i in 0..=nu {
            let (u, v) = (i as f32 / nu as f32, j as f32 / nv as f32);
            positions.push(f(u, v));
            uvs.push(Vec2::new(u, v));
        }
    }
    let id = |i: u32, j: u32| j * (nu + 1) + i;
    let mut indices = Vec::with_capacity((2 * nu * nv) as usize);
    for j in 0..nv {
        for i in 0..nu {
            indices.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            indices.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    ShadedMesh::flat(Mesh::new(name, positions, indices), material)
        .with_smooth_normals()
        .with_uvs(uvs)
}

/// The quad `corner + u eu + v ev` subdivided `nu x nv` (facing `eu x ev`), UVs scaled by
/// `tiles`.
pub fn quad(
    name: &str,
    corner: Vec3,
    eu: Vec3,
    ev: Vec3,
    (nu, nv): (u32, u32),
    tiles: f32,
    material: u32,
) -> ShadedMesh {
    let mut m = surface(name, nu, nv, material, |u, v| corner + eu * u + ev * v);
    if let Some(uvs) = &mut m.uvs {
        uvs.iter_mut().for_each(|t| *t *= tiles);
    }
    // A flat quad: the geometric normal everywhere.
    let n = eu.cross(ev).normalize();
    m.normals = Some(vec![n; m.mesh.positions.len()]);
    m
}

/// A superellipsoid with semi-axes `r` and exponents `e1` (north-south) and `e2` (east-west):
/// 1 gives an ellipsoid, smaller values a box with rounded edges.
pub fn superellipsoid(
    name: &str,
    r: Vec3,
    (e1, e2): (f32, f32),
    (nu, nv): (u32, u32),
    material: u32,
) -> ShadedMesh {
    let sp = |x: f32, e: f32| x.signum() * x.abs().powf(e);
    surface(name, nu, nv, material, |u, v| {
        let lon = (u - 0.5) * std::f32::consts::TAU;
        let lat = (v - 0.5) * std::f32::consts::PI;
        let (cl, sl) = (sp(lat.cos(), e1), sp(lat.sin(), e1));
        Vec3::new(
            r.x * cl * sp(lon.cos(), e2),
            r.y * sl,
            r.z * cl * sp(lon.sin(), e2),
        )
    })
}

/// A surface of revolution about +y of the profile `(radius, height)` pieces (linear between
/// the points), `segments` around.
pub fn lathe(name: &str, profile: &[(f32, f32)], segments: u32, material: u32) -> ShadedMesh {
    let n = profile.len() as u32 - 1;
    surface(name, segments, n, material, |u, v| {
        let k = v * n as f32;
        let i = (k.floor() as usize).min(n as usize - 1);
        let t = k - i as f32;
        let (r0, y0) = profile[i];
        let (r1, y1) = profile[i + 1];
        let (r, y) = (r0 + (r1 - r0) * t, y0 + (y1 - y0) * t);
        let a = u * std::f32::consts::TAU;
        Vec3::new(r * a.cos(), y, -r * a.sin())
    })
}

/// A torus about +y: `2 major minor` triangles.
pub fn torus(
    name: &str,
    big_r: f32,
    small_r: f32,
    (major, minor): (u32, u32),
    material: u32,
) -> ShadedMesh {
    surface(name, major, minor, material, |u, v| {
        let (a, b) = (u * std::f32::consts::TAU, v * std::f32::consts::TAU);
        // z up to +y up: a rotation, exact in f32.
        let p = torus_point(big_r, small_r, a, b);
        Vec3::new(p.x, p.z, -p.y)
    })
}

fn texture(name: &str, size: usize, f: impl Fn(f32, f32) -> [f32; 3]) -> Arc<Texture> {
    let mut texels = Vec::with_capacity(size * size);
    for y in 0..size {
        for x in 0..size {
            texels.push(f(
                (x as f32 + 0.5) / size as f32,
                (y as f32 + 0.5) / size as f32,
            ));
        }
    }
    Arc::new(
        Texture::from_linear(name, size, size, &texels, Wrap::Repeat)
            .expect("generated texels are finite and non-negative"),
    )
}

/// A checkerboard of `n x n` squares of colours `a` and `b`.
pub fn checker(name: &str, size: usize, n: u32, a: [f32; 3], b: [f32; 3]) -> Arc<Texture> {
    texture(name, size, |u, v| {
        let k = (u * n as f32) as u32 + (v * n as f32) as u32;
        if k.is_multiple_of(2) { a } else { b }
    })
}

/// Smooth value noise in `[0, 1]` with period 1 (a sum of random sines; deterministic).
fn noise(seed: u64) -> impl Fn(f32, f32) -> f32 {
    let mut rng = Rng::new(seed);
    let waves: Vec<(f32, f32, f32, f32)> = (0..10)
        .map(|o| {
            let f = (1 + o) as f32;
            (
                (rng.range(-3.0, 3.0) * f).round(),
                (rng.range(-3.0, 3.0) * f).round(),
                rng.range(0.0, std::f32::consts::TAU),
                1.0 / (1.0 + o as f32),
            )
        })
        .collect();
    let total: f32 = waves.iter().map(|w| w.3).sum();
    move |u, v| {
        let s: f32 = waves
            .iter()
            .map(|&(fx, fy, ph, a)| a * (std::f32::consts::TAU * (fx * u + fy * v) + ph).sin())
            .sum();
        0.5 + 0.5 * s / total
    }
}

/// Wood: rings around a point off the texture, perturbed by noise.
pub fn wood(name: &str, size: usize, seed: u64) -> Arc<Texture> {
    let n = noise(seed);
    texture(name, size, |u, v| {
        let r = ((u - 0.5).powi(2) * 4.0 + (v + 0.8).powi(2) * 0.05).sqrt();
        let ring = (r * 40.0 + 3.0 * n(u, v)).fract();
        let t = 0.55 + 0.45 * (ring * std::f32::consts::TAU).sin();
        [0.45 * t + 0.12, 0.27 * t + 0.06, 0.12 * t + 0.03]
    })
}

/// Marble: veins of a sine of noise.
pub fn marble(name: &str, size: usize, seed: u64) -> Arc<Texture> {
    let n = noise(seed);
    texture(name, size, |u, v| {
        let t = 0.5 + 0.5 * ((u + v) * 12.0 + 6.0 * n(u, v)).sin();
        let t = t.powf(0.4);
        [0.25 + 0.6 * t, 0.25 + 0.58 * t, 0.27 + 0.55 * t]
    })
}

/// Bricks in running bond with mortar lines.
pub fn brick(name: &str, size: usize, seed: u64) -> Arc<Texture> {
    let n = noise(seed);
    texture(name, size, |u, v| {
        let (rows, cols) = (8.0, 4.0);
        let row = (v * rows).floor();
        let x = u * cols + if row as u32 % 2 == 1 { 0.5 } else { 0.0 };
        let (fx, fy) = (x.fract(), (v * rows).fract());
        if fx < 0.04 || fy < 0.08 {
            [0.5, 0.5, 0.48]
        } else {
            let t = 0.8 + 0.4 * n(u, v);
            [0.55 * t, 0.2 * t, 0.12 * t]
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn surfaces_count_and_shade() {
        let s = superellipsoid("s", Vec3::ONE, (0.5, 0.5), (16, 8), 0);
        assert_eq!(s.mesh.indices.len(), 2 * 16 * 8);
        assert_eq!(s.problem(1), None);
        let t = torus("t", 1.0, 0.3, (12, 6), 0);
        assert_eq!(t.mesh.indices.len(), 144);
        let l = lathe("l", &[(0.0, 0.0), (1.0, 0.0), (0.5, 1.0)], 10, 0);
        assert_eq!(l.mesh.indices.len(), 40);
        for tex in [wood("w", 32, 1), marble("m", 32, 2), brick("b", 32, 3)] {
            let c = tex.sample1(0.3, 0.7, 0.0);
            assert!(c.iter().all(|x| x.is_finite() && *x >= 0.0));
        }
    }
}
