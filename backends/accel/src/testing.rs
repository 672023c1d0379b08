//! Helpers for testing an accelerator against [`BruteForce`] (paper section 3's three
//! queries): random scenes (soups with planar, shared-edge and degenerate triangles, random
//! instance transforms), random rays (axis-parallel, aimed at vertices and edges, finite
//! bounds), and checks of every query, single-ray and packet, with the tie rule of the
//! [`Accel`] contract. Used by the BSP's tests; any other accelerator can use them too.

use coherent_simd::{Backend, Kernel, Lanes, Only, SimdMask};
use glam::{Affine3A, Quat, Vec3};

use crate::shapes::{Rng, soup};
use crate::{Accel, BruteForce, Hit1, Hits, Instance, Ray1, Rays, Scene};

/// What a test kernel gives: nothing (it asserts) or an error to report.
pub trait Outcome {
    fn result(self) -> Result<(), String>;
}

impl Outcome for () {
    fn result(self) -> Result<(), String> {
        Ok(())
    }
}

impl Outcome for Result<(), String> {
    fn result(self) -> Result<(), String> {
        self
    }
}

/// Runs the kernel `mk` makes on every backend of [`Backend::TRAVERSAL_TESTED`] (the one
/// list of backends the traversal tests cover), skipping with a message those this machine
/// cannot run. The kernel is compiled only for that set (`Only`). A failure names its
/// backend (a kernel that asserts: the last "backend" line of the test's output).
pub fn on_tested_backends<K: Kernel<Output: Outcome>>(mk: impl Fn() -> K) -> Result<(), String> {
    for b in Backend::TRAVERSAL_TESTED {
        match b.unavailable_reason() {
            Some(why) => eprintln!("skipping backend {}: {why}", b.name()),
            None => {
                eprintln!("backend {}", b.name());
                b.run(Only::<K, { Backend::TRAVERSAL_TESTED_BITS }>(mk()))
                    .map_err(|e| e.to_string())?
                    .result()
                    .map_err(|e| format!("backend {}: {e}", b.name()))?
            }
        }
    }
    Ok(())
}

/// An accelerator's lane queries for tests, each in a function of its own per lane type and
/// accelerator ([`Lanes::apart`]) that every call in the test crate shares. A test kernel calls
/// the queries at many places, and inlined (as a packet query and a beam of one packet are in
/// a kernel) each call is a copy of a whole walk: the BSP's beam test crate compiled for many
/// minutes. The answers are the same code's, bit for bit.
pub struct Apart<'a, A>(pub &'a A);

impl<A: Accel> Apart<'_, A> {
    /// [`Accel::intersect`].
    #[inline(always)]
    pub fn intersect<L: Lanes>(&self, l: L, rays: &Rays<L>, active: L::Mask) -> Hits<L> {
        l.apart(
            #[inline(always)]
            |l| self.0.intersect(l, rays, active),
        )
    }

    /// [`Accel::occluded`].
    #[inline(always)]
    pub fn occluded<L: Lanes>(&self, l: L, rays: &Rays<L>, active: L::Mask) -> L::Mask {
        l.apart(
            #[inline(always)]
            |l| self.0.occluded(l, rays, active),
        )
    }

    /// [`Accel::intersect_all`]: the hits of each lane, in the order the walk found them.
    #[inline(always)]
    pub fn intersect_all<L: Lanes>(&self, l: L, rays: &Rays<L>, active: L::Mask) -> Vec<Vec<Hit1>> {
        l.apart(
            #[inline(always)]
            |l| {
                let mut all = vec![vec![]; L::N];
                self.0
                    .intersect_all(l, rays, active, &mut |i, h| all[i].push(h));
                all
            },
        )
    }

    /// [`Accel::intersect_beam`].
    #[inline(always)]
    pub fn intersect_beam<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        hits: &mut [Hits<L>],
    ) {
        l.apart(
            #[inline(always)]
            |l| self.0.intersect_beam(l, rays, active, hits),
        )
    }

    /// [`Accel::occluded_beam`].
    #[inline(always)]
    pub fn occluded_beam<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        occluded: &mut [L::Mask],
    ) {
        l.apart(
            #[inline(always)]
            |l| self.0.occluded_beam(l, rays, active, occluded),
        )
    }
}

/// A random scene: `meshes` soups of about `tris` triangles in total (with some planar,
/// axis-aligned and degenerate triangles), placed by `instances` instances (identity or
/// random rotation, non-uniform scale and translation).
pub fn random_scene(seed: u64, tris: usize, meshes: usize, instances: usize) -> Scene {
    let mut rng = Rng::new(seed);
    let mut scene = Scene::default();
    for m in 0..meshes.max(1) {
        let n = (tris / meshes.max(1)).max(1);
        let size = [0.3, 2.0, 8.0][rng.next_u64() as usize % 3];
        let mut mesh = soup(&format!("soup{m}"), n, 5.0, size, rng.next_u64());
        // Triangles lying in axis planes (planar split events), and shared positions.
        for t in 0..n {
            let [a, b, c] = mesh.indices[t];
            match rng.next_u64() % 16 {
                0 => {
                    let k = (rng.next_u64() % 3) as usize;
                    let v = mesh.positions[a as usize][k];
                    mesh.positions[b as usize][k] = v;
                    mesh.positions[c as usize][k] = v;
                }
                1 if t > 0 => {
                    // Share an edge with the previous triangle.
                    let [p, q, _] = mesh.indices[t - 1];
                    mesh.indices[t] = [p, q, c];
                }
                2 => {
                    // Degenerate: collapsed onto a line.
                    let p = mesh.positions[a as usize];
                    mesh.positions[c as usize] = p + (mesh.positions[b as usize] - p) * 0.5;
                }
                _ => {}
            }
        }
        scene.add_mesh(mesh);
    }
    for _ in 0..instances {
        let mesh = rng.next_u64() as usize % scene.meshes.len();
        let m = if rng.next_u64().is_multiple_of(3) {
            Affine3A::IDENTITY
        } else {
            let q = Quat::from_axis_angle(rng.unit_vector(), rng.range(0.0, 6.3));
            let s = Vec3::new(
                rng.range(0.2, 3.0),
                rng.range(0.2, 3.0),
                rng.range(0.2, 3.0),
            );
            let t = rng.vec3(Vec3::splat(-8.0), Vec3::splat(8.0));
            Affine3A::from_scale_rotation_translation(s, q, t)
        };
        scene.instances.push(Instance::new(mesh, m));
    }
    scene
}

/// One triangle in the plane z = 0, legs of 4 along x and y: the edge-case tests aim rays at
/// its vertices, edges and inside.
pub fn one_triangle() -> Scene {
    Scene::single(crate::Mesh::new(
        "one",
        vec![
            Vec3::ZERO,
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::new(0.0, 4.0, 0.0),
        ],
        vec![[0, 1, 2]],
    ))
}

/// Random rays at a scene: from a box around it, random or axis-parallel directions, some
/// aimed at triangle vertices, edges and interiors, some with finite `tmax` or `tmin > 0`.
pub fn random_rays(seed: u64, scene: &Scene, n: usize) -> Vec<Ray1> {
    let mut rng = Rng::new(seed ^ 0x5eed);
    (0..n)
        .map(|_| {
            let o = rng.vec3(Vec3::splat(-15.0), Vec3::splat(15.0));
            let mut d = match rng.next_u64() % 8 {
                0 => {
                    // Axis-parallel.
                    let mut d = Vec3::ZERO;
                    d[(rng.next_u64() % 3) as usize] = if rng.f32() < 0.5 { -1.0 } else { 1.0 };
                    d
                }
                1 => {
                    let mut d = rng.unit_vector();
                    d[(rng.next_u64() % 3) as usize] = 0.0;
                    d
                }
                2..=4 if !scene.instances.is_empty() => {
                    // At a point of a triangle: a vertex, an edge or inside.
                    let inst = &scene.instances[rng.next_u64() as usize % scene.instances.len()];
                    let mesh = &scene.meshes[inst.mesh];
                    let [a, b, c] = mesh.triangle(rng.next_u64() as usize % mesh.indices.len());
                    let p = match rng.next_u64() % 3 {
                        0 => a,
                        1 => a.lerp(b, rng.f32()),
                        _ => {
                            let (u, v) = (rng.f32(), rng.f32());
                            let (u, v) = if u + v > 1.0 {
                                (1.0 - u, 1.0 - v)
                            } else {
                                (u, v)
                            };
                            a + (b - a) * u + (c - a) * v
                        }
                    };
                    inst.world_from_object.transform_point3(p) - o
                }
                _ => rng.unit_vector(),
            };
            if rng.next_u64().is_multiple_of(4) {
                d *= rng.range(0.01, 10.0);
            }
            let tmin = if rng.next_u64().is_multiple_of(5) {
                rng.range(0.0, 2.0)
            } else {
                0.0
            };
            let tmax = if rng.next_u64().is_multiple_of(4) {
                rng.range(tmin, 30.0)
            } else {
                f32::INFINITY
            };
            Ray1::new(o, d, tmin, tmax)
        })
        .collect()
}

/// `a` and `b` are the same distance, within 1e-5 relative (absolute near 0).
pub fn same_t(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-5 * a.abs().max(b.abs()).max(1.0)
}

/// Whether a hit lies at least [`crate::EDGE_EPS`] inside all edges of its triangle: hits
/// nearer an edge than that (inside or out) may be missed by an accelerator (see [`Accel`]:
/// rounding decides on which side of the edge they truly are).
pub fn in_core(h: &Hit1) -> bool {
    let e = crate::EDGE_EPS;
    h.u >= e && h.v >= e && h.u + h.v <= 1.0 - e
}

fn all_hits(bf: &BruteForce, ray: &Ray1) -> Vec<Hit1> {
    let mut all = vec![];
    bf.intersect_all1(ray, &mut |h| all.push(h));
    all
}

/// `h` is one of `all` (same triangle, instance and `t`).
fn is_real(all: &[Hit1], h: &Hit1) -> bool {
    all.iter()
        .any(|a| (a.prim, a.inst) == (h.prim, h.inst) && same_t(a.t, h.t))
}

/// Checks a first hit against brute force: it must be a real hit, no farther than the nearest
/// hit on a triangle proper (ties aside), and a miss only when there is no such hit. When the
/// brute-force first hit is on a triangle proper this means: the same hit, or a tie.
pub fn check_first(bf: &BruteForce, ray: &Ray1, got: Option<Hit1>) -> Result<(), String> {
    let all = all_hits(bf, ray);
    let core = all
        .iter()
        .filter(|h| in_core(h))
        .min_by(|a, b| a.t.total_cmp(&b.t));
    match (got, core) {
        (None, None) => Ok(()),
        (None, Some(c)) => Err(format!("{ray:?}: missed {c:?}")),
        (Some(g), _) if !is_real(&all, &g) => {
            Err(format!("{ray:?}: {g:?} is no hit; hits {all:?}"))
        }
        (Some(g), Some(c)) if g.t > c.t && !same_t(g.t, c.t) => {
            Err(format!("{ray:?}: got {g:?} beyond {c:?}"))
        }
        (Some(g), _) => {
            let w = bf.intersect1(ray).expect("brute force has a hit");
            let same = (w.prim, w.inst) == (g.prim, g.inst);
            if same && ((w.u - g.u).abs() > 1e-4 || (w.v - g.v).abs() > 1e-4) {
                return Err(format!("{ray:?}: same triangle, want {w:?}, got {g:?}"));
            }
            Ok(())
        }
    }
}

/// All hits as a sorted list of (instance, triangle, t).
pub fn sorted(mut v: Vec<Hit1>) -> Vec<(u32, u32, f32)> {
    v.sort_by_key(|h| (h.inst, h.prim));
    v.into_iter().map(|h| (h.inst, h.prim, h.t)).collect()
}

/// Checks all hits against brute force: each reported once, each real, and every hit on a
/// triangle proper among them.
pub fn check_all(bf: &BruteForce, ray: &Ray1, got: Vec<Hit1>) -> Result<(), String> {
    let all = all_hits(bf, ray);
    let g = sorted(got.clone());
    let dup = g.windows(2).any(|w| (w[0].0, w[0].1) == (w[1].0, w[1].1));
    let unreal = got.iter().find(|h| !is_real(&all, h));
    let missed = all
        .iter()
        .filter(|h| in_core(h))
        .find(|h| !is_real(&got, h));
    match (dup, unreal, missed) {
        (false, None, None) => Ok(()),
        _ => Err(format!(
            "{ray:?}: all hits, want {:?}, got {g:?} (duplicate {dup}, not a hit {unreal:?}, missed {missed:?})",
            sorted(all.clone())
        )),
    }
}

/// Checks occlusion against brute force: occluded only when something is hit, and surely when
/// a triangle proper is hit.
pub fn check_occluded(bf: &BruteForce, ray: &Ray1, got: bool) -> Result<(), String> {
    let all = all_hits(bf, ray);
    let any = !all.is_empty();
    let core = all.iter().any(in_core);
    if (got && !any) || (core && !got) {
        Err(format!("{ray:?}: occluded {got}, hits {all:?}"))
    } else {
        Ok(())
    }
}

/// Every query of `accel`, single-ray and in packets of `L`, against brute force over `rays`.
/// Packets use the active lanes of `mask_seed`'s pattern (inactive lanes must stay misses).
pub fn check_all_queries<L: Lanes, A: Accel>(
    l: L,
    bf: &BruteForce,
    accel: &A,
    rays: &[Ray1],
    mask_seed: u64,
) -> Result<(), String> {
    for r in rays {
        check_first(bf, r, accel.intersect1(r))?;
        check_occluded(bf, r, accel.occluded1(r))?;
        let mut all = vec![];
        accel.intersect_all1(r, &mut |h| all.push(h));
        check_all(bf, r, all)?;
    }
    let mut rng = Rng::new(mask_seed);
    for chunk in rays.chunks(L::N) {
        let p = Rays::from_fn(l, |i| chunk[i % chunk.len()]);
        let bits = if rng.next_u64().is_multiple_of(2) {
            u32::MAX
        } else {
            rng.next_u64() as u32
        };
        let active = l.mask_from_fn(|i| i < chunk.len() && bits >> i & 1 == 1);
        let q = Apart(accel);
        let hits = q.intersect(l, &p, active);
        let occ = q.occluded(l, &p, active);
        let all = q.intersect_all(l, &p, active);
        for (i, hits_i) in all.into_iter().enumerate() {
            let r = p.lane(i);
            if active.lane(i) {
                check_first(bf, &r, hits.lane(i)).map_err(|e| format!("lane {i}: {e}"))?;
                check_occluded(bf, &r, occ.lane(i)).map_err(|e| format!("lane {i}: {e}"))?;
                check_all(bf, &r, hits_i).map_err(|e| format!("lane {i}: {e}"))?;
            } else if hits.lane(i).is_some() || occ.lane(i) || !hits_i.is_empty() {
                return Err(format!("inactive lane {i} reported a hit"));
            }
        }
    }
    Ok(())
}

/// The beam queries of `accel` ([`Accel::intersect_beam`], [`Accel::occluded_beam`]) against
/// brute force: `rays` packed into packets of `L` in order (the last one padded by repeating
/// its rays), all traced as one beam, under random masks of active lanes.
pub fn check_beam_queries<L: Lanes, A: Accel>(
    l: L,
    bf: &BruteForce,
    accel: &A,
    rays: &[Ray1],
    mask_seed: u64,
) -> Result<(), String> {
    let mut rng = Rng::new(mask_seed);
    let packets: Vec<Rays<L>> = rays
        .chunks(L::N)
        .map(|c| Rays::from_fn(l, |i| c[i % c.len()]))
        .collect();
    let active: Vec<L::Mask> = rays
        .chunks(L::N)
        .map(|c| {
            let bits = if !rng.next_u64().is_multiple_of(4) {
                u32::MAX
            } else {
                rng.next_u64() as u32
            };
            l.mask_from_fn(|i| i < c.len() && bits >> i & 1 == 1)
        })
        .collect();
    let mut hits = vec![crate::Hits::miss(l); packets.len()];
    let mut occ = vec![l.splat_mask(false); packets.len()];
    Apart(accel).intersect_beam(l, &packets, &active, &mut hits);
    Apart(accel).occluded_beam(l, &packets, &active, &mut occ);
    for (j, p) in packets.iter().enumerate() {
        for i in 0..L::N {
            let r = p.lane(i);
            if active[j].lane(i) {
                check_first(bf, &r, hits[j].lane(i))
                    .map_err(|e| format!("beam packet {j} lane {i}: {e}"))?;
                check_occluded(bf, &r, occ[j].lane(i))
                    .map_err(|e| format!("beam packet {j} lane {i}: {e}"))?;
            } else if hits[j].lane(i).is_some() || occ[j].lane(i) {
                return Err(format!("beam packet {j}: inactive lane {i} reported a hit"));
            }
        }
    }
    Ok(())
}

/// How the rays of a coherent test beam ([`beam_rays`]) are related.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BeamKind {
    /// One origin, directions through a `side` x `side` grid on a small screen (camera
    /// rays of a tile).
    Camera,
    /// One end point: rays from points on the scene's triangles to a common point, ending
    /// just before it (shadow rays toward a point light).
    Shadow,
}

/// A coherent beam of `side * side` rays at `scene`, in tile order (row by row), for the
/// beam tests: `kind` says how they are related. The origin (or end point) is random around
/// the scene; the tile is aimed at a random triangle point so that it sees geometry.
pub fn beam_rays(seed: u64, scene: &Scene, side: usize, kind: BeamKind) -> Vec<Ray1> {
    let mut rng = Rng::new(seed ^ 0xbea7);
    let target = |rng: &mut Rng| -> Vec3 {
        if scene.instances.is_empty() {
            return rng.vec3(Vec3::splat(-5.0), Vec3::splat(5.0));
        }
        let inst = &scene.instances[rng.next_u64() as usize % scene.instances.len()];
        let mesh = &scene.meshes[inst.mesh];
        let [a, b, c] = mesh.triangle(rng.next_u64() as usize % mesh.indices.len());
        let (u, v) = (rng.f32() * 0.5, rng.f32() * 0.5);
        inst.world_from_object
            .transform_point3(a + (b - a) * u + (c - a) * v)
    };
    let eye = rng.vec3(Vec3::splat(-15.0), Vec3::splat(15.0));
    let look = target(&mut rng);
    let fwd = (look - eye).normalize_or(Vec3::Z);
    let up = if fwd.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
    let right = fwd.cross(up).normalize();
    let up = right.cross(fwd);
    // A tile of about a degree to a whole view.
    let bf = BruteForce::build(scene, &()).ok();
    let width = [0.02, 0.2, 1.0][rng.next_u64() as usize % 3];
    let n = side.max(1);
    (0..n * n)
        .map(|k| {
            let (x, y) = ((k % n) as f32, (k / n) as f32);
            let s = (x + 0.5) / n as f32 - 0.5;
            let t = (y + 0.5) / n as f32 - 0.5;
            let d = fwd + right * (s * width) + up * (t * width);
            match kind {
                BeamKind::Camera => Ray1::infinite(eye, d),
                BeamKind::Shadow => {
                    // From the point of the scene this camera ray meets (or a point along it).
                    let hit = bf
                        .as_ref()
                        .and_then(|bf| bf.intersect1(&Ray1::infinite(eye, d)));
                    let o = match hit {
                        Some(h) => eye + d * h.t,
                        None => eye + d * rng.range(1.0, 20.0),
                    };
                    Ray1::new(o, eye - o, 1e-4, 1.0 - 1e-4)
                }
            }
        })
        .collect()
}

/// Builds brute force and `A` with `params` (panics on bad scenes: test helper).
pub fn build_both<A: Accel>(scene: &Scene, params: &A::Params) -> (BruteForce, A) {
    (
        BruteForce::build(scene, &()).unwrap(),
        A::build(scene, params).unwrap(),
    )
}
