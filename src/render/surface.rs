//! The shading context of a packet (paper section 3: "all intersection data are put into the
//! shade context"): per lane, from the accelerator's hit (triangle, instance, barycentrics),
//! the world-space point, geometric and shading normals, texture coordinates and their
//! screen derivatives (for the mip level, section 4.1) and the material id, gathered from
//! flat tables over every mesh and instance so that lanes hitting different objects are
//! served by the same gathers.

// Index loops in per-packet code: it must inline into the backends' `#[target_feature]`
// entry points (see docs/architecture.md#inlining).
#![allow(clippy::needless_range_loop)]

use coherent_accel::Hits;
use coherent_simd::{Lanes, SimdF32, SimdMask, Vec3s};
use glam::{Affine3A, Mat3};

use crate::scene::RenderScene;

/// Every mesh's shading data and every instance's transform, flattened for per-lane gathers.
#[derive(Debug, Clone)]
pub struct Geometry {
    /// Object-space vertex positions of all meshes, one array per component.
    pos: [Vec<f32>; 3],
    /// Per-vertex unit normals (zero for meshes without normals: flat shading).
    nrm: [Vec<f32>; 3],
    /// Per-vertex texture coordinates (zero for meshes without them).
    uv: [Vec<f32>; 2],
    /// Three global vertex indices per global triangle.
    indices: Vec<u32>,
    /// Material id per global triangle.
    material: Vec<u32>,
    /// Per instance: its mesh's first global triangle.
    tri_offset: Vec<u32>,
    /// Per instance: `world_from_object`, 12 arrays (3x3 column-major, then translation).
    xform: [Vec<f32>; 12],
    /// Per instance: the cofactor matrix of the linear part (`det * inverse transpose`), which
    /// carries normals (and the cross product of world edges) to world space; 9 arrays.
    cofactor: [Vec<f32>; 9],
    /// Whether any mesh has vertex normals, and whether any has texture coordinates. Without
    /// them the tables above hold zeros, and the gathers that would read them are skipped:
    /// their result is known (the geometric normal; coordinates and derivatives of zero).
    has_normals: bool,
    has_uvs: bool,
}

/// The shading context of a packet's hits (lanes outside `active` hold unspecified values).
#[derive(Debug, Clone, Copy)]
pub struct Surface<L: Lanes> {
    /// Lanes that hit something.
    pub active: L::Mask,
    /// The hit point, world space.
    pub p: Vec3s<L>,
    /// Unit geometric normal (the triangle's winding: `e1 x e2`), world space.
    pub ng: Vec3s<L>,
    /// Unit shading normal (interpolated vertex normals, or `ng`), on `ng`'s side.
    pub ns: Vec3s<L>,
    /// Unit tangent along the triangle's first edge, orthogonal to `ns`.
    pub tangent: Vec3s<L>,
    /// Texture coordinates.
    pub s: L::F32s,
    pub t: L::F32s,
    /// Their derivatives per pixel along x and y (from the ray differentials).
    pub ds_dx: L::F32s,
    pub dt_dx: L::F32s,
    pub ds_dy: L::F32s,
    pub dt_dy: L::F32s,
    /// Derivatives of the hit point per pixel along x and y (the pixel's footprint).
    pub dp_dx: Vec3s<L>,
    pub dp_dy: Vec3s<L>,
    /// Material id.
    pub material: L::I32s,
}

/// Ray differentials of a packet: derivatives of origin and unit direction per pixel.
#[derive(Debug, Clone, Copy)]
pub struct Differentials<L: Lanes> {
    pub dorigin_dx: Vec3s<L>,
    pub dorigin_dy: Vec3s<L>,
    pub ddir_dx: Vec3s<L>,
    pub ddir_dy: Vec3s<L>,
}

impl Geometry {
    /// Flattens a validated scene.
    pub fn new(scene: &RenderScene) -> Self {
        let mut g = Geometry {
            pos: Default::default(),
            nrm: Default::default(),
            uv: Default::default(),
            indices: Vec::new(),
            material: Vec::new(),
            tri_offset: Vec::new(),
            xform: Default::default(),
            cofactor: Default::default(),
            has_normals: scene.meshes.iter().any(|m| m.normals.is_some()),
            has_uvs: scene.meshes.iter().any(|m| m.uvs.is_some()),
        };
        let mut mesh_tri_offset = Vec::with_capacity(scene.meshes.len());
        for m in &scene.meshes {
            let v0 = g.pos[0].len() as u32;
            mesh_tri_offset.push(g.material.len() as u32);
            for (i, p) in m.mesh.positions.iter().enumerate() {
                for c in 0..3 {
                    g.pos[c].push(p[c]);
                }
                let n = m.normals.as_ref().map_or(glam::Vec3::ZERO, |n| n[i]);
                for c in 0..3 {
                    g.nrm[c].push(n[c]);
                }
                let uv = m.uvs.as_ref().map_or(glam::Vec2::ZERO, |u| u[i]);
                g.uv[0].push(uv.x);
                g.uv[1].push(uv.y);
            }
            for (k, tri) in m.mesh.indices.iter().enumerate() {
                for c in 0..3 {
                    g.indices.push(v0 + tri[c]);
                }
                g.material.push(m.material.get(k).copied().unwrap_or(0));
            }
        }
        for inst in &scene.instances {
            g.tri_offset.push(mesh_tri_offset[inst.mesh]);
            let m: &Affine3A = &inst.world_from_object;
            let cols = [
                m.matrix3.x_axis,
                m.matrix3.y_axis,
                m.matrix3.z_axis,
                m.translation,
            ];
            for (j, c) in cols.iter().enumerate() {
                g.xform[3 * j].push(c.x);
                g.xform[3 * j + 1].push(c.y);
                g.xform[3 * j + 2].push(c.z);
            }
            let lin = Mat3::from(m.matrix3);
            let cof = lin.inverse().transpose() * lin.determinant();
            let ccols = [cof.x_axis, cof.y_axis, cof.z_axis];
            for (j, c) in ccols.iter().enumerate() {
                g.cofactor[3 * j].push(c.x);
                g.cofactor[3 * j + 1].push(c.y);
                g.cofactor[3 * j + 2].push(c.z);
            }
        }
        g
    }

    /// Replaces the instance transforms (moving objects; meshes unchanged).
    pub fn set_instances(&mut self, scene: &RenderScene, instances: &[coherent_accel::Instance]) {
        let mut s = scene.clone();
        s.instances = instances.to_vec();
        *self = Geometry::new(&s);
    }

    /// The shading context of `hits` for rays `origin + t dir` (unit `dir`) with their
    /// differentials.
    #[inline(always)]
    pub fn surface<L: Lanes>(
        &self,
        l: L,
        hits: &Hits<L>,
        origin: &Vec3s<L>,
        dir: &Vec3s<L>,
        diff: &Differentials<L>,
    ) -> Surface<L> {
        let active = hits.hit_mask(l);
        let zero_i = l.splat_i32(0);
        let inst = active.select_i32(hits.inst, zero_i);
        let prim = active.select_i32(hits.prim, zero_i);
        // One instance (a scene whose static objects were merged, a bare mesh): every lane
        // reads the same transform, so it is splatted, not gathered (19 gathers per packet).
        let single = self.tri_offset.len() == 1;
        let tri = if single {
            l.splat_i32(self.tri_offset[0] as i32)
        } else {
            l.gather_u32(&self.tri_offset, inst)
        } + prim;
        let t = active.select(hits.t, l.splat(0.0));
        let (b1, b2) = (
            active.select(hits.u, l.splat(0.0)),
            active.select(hits.v, l.splat(0.0)),
        );
        let b0 = l.splat(1.0) - b1 - b2;
        let material = l.gather_u32(&self.material, tri);

        // Vertices: global indices, object-space positions.
        let first = tri * l.splat_i32(3);
        let mut vi = [zero_i; 3];
        let mut po = [Vec3s::splat(l, glam::Vec3::ZERO); 3];
        for k in 0..3 {
            vi[k] = l.gather_u32(&self.indices, first + l.splat_i32(k as i32));
            po[k] = Vec3s::new(
                l.gather(&self.pos[0], vi[k]),
                l.gather(&self.pos[1], vi[k]),
                l.gather(&self.pos[2], vi[k]),
            );
        }
        // World-space edges through the instance's linear part.
        let mut m = [l.splat(0.0); 9];
        for k in 0..9 {
            m[k] = if single {
                l.splat(self.xform[k][0])
            } else {
                l.gather(&self.xform[k], inst)
            };
        }
        let e1 = mat3_mul(&m, po[1] - po[0]);
        let e2 = mat3_mul(&m, po[2] - po[0]);
        let ng = e1.cross(e2).normalize();

        // Shading normal: interpolated vertex normals through the cofactor matrix.
        let mut n_world = Vec3s::splat(l, glam::Vec3::ZERO);
        if self.has_normals {
            let mut n_obj = n_world;
            let w = [b0, b1, b2];
            for k in 0..3 {
                let n = Vec3s::new(
                    l.gather(&self.nrm[0], vi[k]),
                    l.gather(&self.nrm[1], vi[k]),
                    l.gather(&self.nrm[2], vi[k]),
                );
                n_obj = n.mul_add(w[k], n_obj);
            }
            let mut c = [l.splat(0.0); 9];
            for k in 0..9 {
                c[k] = if single {
                    l.splat(self.cofactor[k][0])
                } else {
                    l.gather(&self.cofactor[k], inst)
                };
            }
            n_world = mat3_mul(&c, n_obj);
        }
        let len2: L::F32s = n_world.dot(n_world);
        // No vertex normals (zero) or a degenerate interpolation: the geometric normal.
        let smooth = len2.gt(l.splat(1e-12));
        let ns = n_world * (l.splat(1.0) / smooth.select(len2, l.splat(1.0)).sqrt());
        let ns = Vec3s::select(smooth, ns, ng);
        // Keep the shading normal on the geometric normal's side.
        let flip = ns.dot(ng).lt(l.splat(0.0));
        let ns = Vec3s::select(flip, -ns, ns);
        let tangent = (e1 - ns * ns.dot(e1)).normalize();

        // Texture coordinates and their per-vertex differences.
        let mut st = [[l.splat(0.0); 3]; 2];
        if self.has_uvs {
            for k in 0..3 {
                st[0][k] = l.gather(&self.uv[0], vi[k]);
                st[1][k] = l.gather(&self.uv[1], vi[k]);
            }
        }
        let s = b0 * st[0][0] + b1 * st[0][1] + b2 * st[0][2];
        let tt = b0 * st[1][0] + b1 * st[1][1] + b2 * st[1][2];

        // The footprint: transfer the ray differentials to the hit's tangent plane (pbrt's
        // construction), dp = do + t dd - dir (ng . (do + t dd)) / (ng . dir).
        let p = dir.mul_add(t, *origin);
        let ndotd = ng.dot(*dir);
        let safe = ndotd.abs().gt(l.splat(1e-8));
        let inv_nd = l.splat(1.0) / safe.select(ndotd, l.splat(1.0));
        // Loops, not closures: a closure called twice may stay out of line, and outside the
        // kernel's `#[target_feature]` function every intrinsic becomes a call
        // (`scripts/check-inlining.sh`).
        let mut dp = [
            (diff.dorigin_dx, diff.ddir_dx),
            (diff.dorigin_dy, diff.ddir_dy),
        ];
        for d in &mut dp {
            let q = d.1.mul_add(t, d.0);
            let k = safe.select(ng.dot(q) * inv_nd, l.splat(0.0));
            d.0 = q - *dir * k;
        }
        let (dp_dx, dp_dy) = (dp[0].0, dp[1].0);
        // dp = a e1 + b e2 in the least-squares sense; then ds = a ds1 + b ds2.
        let (g11, g12, g22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let det = g11 * g22 - g12 * g12;
        let ok = det.gt(l.splat(0.0));
        let inv_det = l.splat(1.0) / ok.select(det, l.splat(1.0));
        let (ds1, ds2) = (st[0][1] - st[0][0], st[0][2] - st[0][0]);
        let (dt1, dt2) = (st[1][1] - st[1][0], st[1][2] - st[1][0]);
        let mut uv_diff = [(l.splat(0.0), l.splat(0.0)); 2];
        for (out, dp) in uv_diff.iter_mut().zip([dp_dx, dp_dy]) {
            let (r1, r2) = (e1.dot(dp), e2.dot(dp));
            let a = ok.select((g22 * r1 - g12 * r2) * inv_det, l.splat(0.0));
            let b = ok.select((g11 * r2 - g12 * r1) * inv_det, l.splat(0.0));
            *out = (a * ds1 + b * ds2, a * dt1 + b * dt2);
        }
        let [(ds_dx, dt_dx), (ds_dy, dt_dy)] = uv_diff;
        Surface {
            active,
            p,
            ng,
            ns,
            tangent,
            s,
            t: tt,
            ds_dx,
            dt_dx,
            ds_dy,
            dt_dy,
            dp_dx,
            dp_dy,
            material: active.select_i32(material, l.splat_i32(-1)),
        }
    }
}

/// `m v` for a column-major 3x3 matrix per lane.
#[inline(always)]
fn mat3_mul<L: Lanes>(m: &[L::F32s; 9], v: Vec3s<L>) -> Vec3s<L> {
    Vec3s::new(
        m[0].mul_add(v.x, m[3].mul_add(v.y, m[6] * v.z)),
        m[1].mul_add(v.x, m[4].mul_add(v.y, m[7] * v.z)),
        m[2].mul_add(v.x, m[5].mul_add(v.y, m[8] * v.z)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use coherent_simd::scalar::Scalar;

    /// The surface of each triangle of instance `inst` at one point, as text (every field,
    /// the sign of zero and NaN included).
    fn surfaces(g: &Geometry, scene: &RenderScene, inst: usize) -> Vec<String> {
        let l = Scalar;
        let mesh = &scene.meshes[scene.instances[inst].mesh].mesh;
        let origin = Vec3s::splat(l, glam::Vec3::new(0.1, 0.2, 3.0));
        let dir = Vec3s::splat(l, glam::Vec3::new(0.1, -0.2, -1.0).normalize());
        let d = Vec3s::splat(l, glam::Vec3::new(1e-3, 2e-3, -1e-3));
        let diff = Differentials {
            dorigin_dx: d,
            dorigin_dy: -d,
            ddir_dx: d * 0.5,
            ddir_dy: d * 2.0,
        };
        (0..mesh.indices.len())
            .map(|k| {
                let hits = Hits::<Scalar> {
                    t: 1.5,
                    u: 0.2,
                    v: 0.3,
                    prim: l.splat_i32(k as i32),
                    inst: l.splat_i32(inst as i32),
                };
                format!("{:?}", g.surface(l, &hits, &origin, &dir, &diff))
            })
            .collect()
    }

    #[test]
    fn skipped_gathers_give_the_surface_the_gathers_gave() {
        let mut scene = crate::scene::load("cornell").unwrap();
        // Without vertex normals and texture coordinates, the tables hold zeros: reading
        // them or not is the same surface.
        for m in &mut scene.meshes {
            m.normals = None;
            m.uvs = None;
        }
        let skip = Geometry::new(&scene);
        assert!(!skip.has_normals && !skip.has_uvs);
        let mut read = skip.clone();
        (read.has_normals, read.has_uvs) = (true, true);
        assert!(scene.instances.len() > 1);
        for i in 0..scene.instances.len() {
            assert_eq!(
                surfaces(&skip, &scene, i),
                surfaces(&read, &scene, i),
                "{i}"
            );
        }
        // One instance: its transform splatted is the transform gathered.
        let full = crate::scene::load("cornell").unwrap();
        let mut one = full.clone();
        one.instances.truncate(1);
        let (mut g1, mut g) = (Geometry::new(&one), Geometry::new(&full));
        // Read the normals (zeros where a mesh has none) to use the cofactor matrix too.
        (g1.has_normals, g.has_normals) = (true, true);
        assert_eq!(surfaces(&g1, &one, 0), surfaces(&g, &full, 0));
    }
}
