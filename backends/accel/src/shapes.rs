//! Generated meshes for tests, benchmarks and the built-in scenes (paper section 7 measures
//! generated stand-ins until real meshes are loaded): closed spheres, boxes and tori,
//! heightfield terrains, triangle soups.

use core::f32::consts::TAU;

use glam::Vec3;

use crate::Mesh;

/// A small deterministic generator (SplitMix64), so generated meshes are the same everywhere.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f32()
    }

    /// Uniform in the box `[lo, hi)`.
    pub fn vec3(&mut self, lo: Vec3, hi: Vec3) -> Vec3 {
        Vec3::new(
            self.range(lo.x, hi.x),
            self.range(lo.y, hi.y),
            self.range(lo.z, hi.z),
        )
    }

    /// Uniform on the unit sphere.
    pub fn unit_vector(&mut self) -> Vec3 {
        let z = self.range(-1.0, 1.0);
        let phi = self.range(0.0, TAU);
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}

/// An icosahedron subdivided `subdivisions` times, projected on the sphere: closed, with
/// shared vertices; `20 * 4^subdivisions` triangles, outward winding.
pub fn icosphere(name: &str, center: Vec3, radius: f32, subdivisions: u32) -> Mesh {
    let t = (1.0 + 5.0f32.sqrt()) / 2.0;
    let mut pos: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut mid = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, pos: &mut Vec<Vec3>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                pos.push(((pos[a as usize] + pos[b as usize]) * 0.5).normalize());
                pos.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(tris.len() * 4);
        for [a, b, c] in tris {
            let ab = midpoint(a, b, &mut pos);
            let bc = midpoint(b, c, &mut pos);
            let ca = midpoint(c, a, &mut pos);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    let positions = pos.into_iter().map(|p| center + p * radius).collect();
    Mesh::new(name, positions, tris)
}

/// A latitude-longitude sphere: closed (one vertex per pole), `2 * slices * (stacks - 1)`
/// triangles. Its many thin triangles at the poles and vertices where many edges meet make
/// it a harder watertightness test than the icosphere.
pub fn uv_sphere(name: &str, center: Vec3, radius: f32, stacks: u32, slices: u32) -> Mesh {
    let (stacks, slices) = (stacks.max(2), slices.max(3));
    let mut pos = vec![center + Vec3::Z * radius];
    for i in 1..stacks {
        let th = core::f32::consts::PI * i as f32 / stacks as f32;
        for j in 0..slices {
            let ph = TAU * j as f32 / slices as f32;
            pos.push(
                center + radius * Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()),
            );
        }
    }
    pos.push(center - Vec3::Z * radius);
    let south = pos.len() as u32 - 1;
    let ring = |i: u32, j: u32| 1 + (i - 1) * slices + j % slices;
    let mut tris = Vec::new();
    for j in 0..slices {
        tris.push([0, ring(1, j), ring(1, j + 1)]);
        tris.push([south, ring(stacks - 1, j + 1), ring(stacks - 1, j)]);
    }
    for i in 1..stacks - 1 {
        for j in 0..slices {
            let (a, b, c, d) = (
                ring(i, j),
                ring(i, j + 1),
                ring(i + 1, j),
                ring(i + 1, j + 1),
            );
            tris.push([a, c, d]);
            tris.push([a, d, b]);
        }
    }
    Mesh::new(name, pos, tris)
}

/// A closed box, 12 triangles, outward winding.
pub fn cuboid(name: &str, min: Vec3, max: Vec3) -> Mesh {
    let c = |i: u32| {
        Vec3::new(
            if i & 1 == 0 { min.x } else { max.x },
            if i & 2 == 0 { min.y } else { max.y },
            if i & 4 == 0 { min.z } else { max.z },
        )
    };
    let positions = (0..8).map(c).collect();
    let quads = [
        [0, 2, 3, 1], // -z
        [4, 5, 7, 6], // +z
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
    ];
    let tris = quads
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect();
    Mesh::new(name, positions, tris)
}

/// The point of a torus around the z axis, through the origin, at angle `a` around the axis
/// and `b` around the tube: the one torus formula, which the renderer's built-in scenes mesh
/// with UVs and turn to their +y axis.
#[inline]
pub fn torus_point(big_r: f32, small_r: f32, a: f32, b: f32) -> Vec3 {
    let r = big_r + small_r * b.cos();
    Vec3::new(r * a.cos(), r * a.sin(), small_r * b.sin())
}

/// A closed torus around the z axis: `2 * major * minor` triangles.
pub fn torus(name: &str, center: Vec3, big_r: f32, small_r: f32, major: u32, minor: u32) -> Mesh {
    let (major, minor) = (major.max(3), minor.max(3));
    let mut pos = Vec::new();
    for i in 0..major {
        let a = TAU * i as f32 / major as f32;
        for j in 0..minor {
            let b = TAU * j as f32 / minor as f32;
            pos.push(center + torus_point(big_r, small_r, a, b));
        }
    }
    let id = |i: u32, j: u32| (i % major) * minor + j % minor;
    let mut tris = Vec::new();
    for i in 0..major {
        for j in 0..minor {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    Mesh::new(name, pos, tris)
}

/// A heightfield over `[-size/2, size/2]^2` in x, y with `n x n` quads (`2 n^2` triangles):
/// a few octaves of smooth bumps, heights up to about `height`.
pub fn terrain(name: &str, size: f32, n: u32, height: f32, seed: u64) -> Mesh {
    let n = n.max(1);
    let mut rng = Rng::new(seed);
    let waves: Vec<(f32, f32, f32, f32)> = (0..12)
        .map(|o| {
            let f = (1.0 + o as f32) * 0.7 * TAU / size;
            let dir = rng.range(0.0, TAU);
            (
                f * dir.cos(),
                f * dir.sin(),
                rng.range(0.0, TAU),
                height / (1.0 + o as f32),
            )
        })
        .collect();
    let h = |x: f32, y: f32| -> f32 {
        waves
            .iter()
            .map(|&(fx, fy, ph, a)| a * 0.25 * (fx * x + fy * y + ph).sin())
            .sum()
    };
    let mut pos = Vec::with_capacity(((n + 1) * (n + 1)) as usize);
    for i in 0..=n {
        for j in 0..=n {
            let x = size * (j as f32 / n as f32 - 0.5);
            let y = size * (i as f32 / n as f32 - 0.5);
            pos.push(Vec3::new(x, y, h(x, y)));
        }
    }
    let id = |i: u32, j: u32| i * (n + 1) + j;
    let mut tris = Vec::with_capacity((2 * n * n) as usize);
    for i in 0..n {
        for j in 0..n {
            tris.push([id(i, j), id(i, j + 1), id(i + 1, j + 1)]);
            tris.push([id(i, j), id(i + 1, j + 1), id(i + 1, j)]);
        }
    }
    Mesh::new(name, pos, tris)
}

/// `n` random triangles with centres in `[-extent, extent]^3` and edges up to about `size`.
pub fn soup(name: &str, n: usize, extent: f32, size: f32, seed: u64) -> Mesh {
    let mut rng = Rng::new(seed);
    let tris: Vec<[Vec3; 3]> = (0..n)
        .map(|_| {
            let c = rng.vec3(Vec3::splat(-extent), Vec3::splat(extent));
            [0; 3].map(|_| c + rng.vec3(Vec3::splat(-size), Vec3::splat(size)) * 0.5)
        })
        .collect();
    Mesh::from_triangles(name, &tris)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// Every edge of a closed mesh is shared by exactly two triangles, in opposite directions.
    fn assert_closed(m: &Mesh) {
        let mut edges: HashMap<(u32, u32), i32> = HashMap::new();
        for t in &m.indices {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_default() += if a < b { 1 } else { -1 };
            }
        }
        assert!(
            edges.values().all(|&v| v == 0),
            "{}: open or badly wound",
            m.name
        );
        m.validate(0).unwrap();
    }

    #[test]
    fn closed_shapes_are_closed() {
        assert_closed(&icosphere("ico", Vec3::ZERO, 1.0, 2));
        assert_eq!(icosphere("ico", Vec3::ZERO, 1.0, 2).indices.len(), 320);
        assert_closed(&uv_sphere("uv", Vec3::ZERO, 1.0, 8, 12));
        assert_closed(&cuboid("box", Vec3::ZERO, Vec3::ONE));
        assert_closed(&torus("torus", Vec3::ZERO, 2.0, 0.5, 12, 8));
    }

    #[test]
    fn terrain_and_soup_sizes() {
        let t = terrain("t", 10.0, 8, 1.0, 1);
        assert_eq!(t.indices.len(), 128);
        t.validate(0).unwrap();
        assert_eq!(soup("s", 50, 1.0, 0.1, 2).indices.len(), 50);
    }
}
