//! `BruteForce`: every ray against every triangle of every instance. The reference every
//! accelerator is tested against (paper section 3's two intersection methods, without a
//! subdivision).

use coherent_simd::{Lanes, SimdF32, SimdMask};
use glam::Affine3A;

use crate::{
    Accel, AccelError, BuildStats, Hit1, Hits, Instance, Ray1, Rays, Scene, TriAccel,
    scene::validate_instances,
};

/// The reference accelerator: no structure at all. Uses the same triangle records and ray
/// transforms as the real accelerators, so answers agree bit for bit.
#[derive(Debug, Clone)]
pub struct BruteForce {
    meshes: Vec<Vec<TriAccel>>,
    instances: Vec<Instance>,
    object_from_world: Vec<Affine3A>,
    stats: BuildStats,
}

impl BruteForce {
    /// The triangle records of mesh `mesh` (degenerate triangles left out).
    pub fn records(&self, mesh: usize) -> &[TriAccel] {
        &self.meshes[mesh]
    }
}

impl Accel for BruteForce {
    type Params = ();

    fn build(scene: &Scene, _: &()) -> Result<Self, AccelError> {
        let t0 = std::time::Instant::now();
        let object_from_world = scene.validate()?;
        let mut degenerate = 0;
        let meshes: Vec<Vec<TriAccel>> = scene
            .meshes
            .iter()
            .map(|m| {
                let (recs, _) = crate::edges::mesh_records(&m.positions, &m.indices);
                degenerate += m.indices.len() - recs.len();
                recs
            })
            .collect();
        let mut bf = Self {
            stats: BuildStats {
                triangles: meshes.iter().map(Vec::len).sum(),
                degenerate,
                instances: scene.instances.len(),
                ..BuildStats::default()
            },
            meshes,
            instances: scene.instances.clone(),
            object_from_world,
        };
        bf.stats.build_seconds = t0.elapsed().as_secs_f64();
        bf.stats.memory_bytes = bf.memory_bytes();
        Ok(bf)
    }

    fn set_instances(&mut self, instances: &[Instance]) -> Result<(), AccelError> {
        self.object_from_world = validate_instances(instances, self.meshes.len())?;
        self.instances = instances.to_vec();
        self.stats.instances = instances.len();
        Ok(())
    }

    fn name(&self) -> &'static str {
        "brute"
    }

    fn memory_bytes(&self) -> usize {
        self.meshes
            .iter()
            .map(|m| m.len() * size_of::<TriAccel>())
            .sum::<usize>()
            + self.instances.len() * (size_of::<Instance>() + size_of::<Affine3A>())
    }

    fn stats(&self) -> BuildStats {
        self.stats.clone()
    }

    fn intersect1(&self, ray: &Ray1) -> Option<Hit1> {
        if !ray.is_valid() {
            return None;
        }
        let mut best: Option<Hit1> = None;
        let mut tmax = ray.tmax;
        for (inst, (i, m)) in self
            .instances
            .iter()
            .zip(&self.object_from_world)
            .enumerate()
        {
            let r = ray.transformed(m);
            for tri in &self.meshes[i.mesh] {
                if let Some((t, u, v)) = tri.intersect1(r.origin, r.dir, r.tmin, tmax) {
                    tmax = t;
                    best = Some(Hit1 {
                        t,
                        u,
                        v,
                        prim: tri.prim,
                        inst: inst as u32,
                    });
                }
            }
        }
        best
    }

    fn occluded1(&self, ray: &Ray1) -> bool {
        if !ray.is_valid() {
            return false;
        }
        self.instances
            .iter()
            .zip(&self.object_from_world)
            .any(|(i, m)| {
                let r = ray.transformed(m);
                self.meshes[i.mesh]
                    .iter()
                    .any(|tri| tri.intersect1(r.origin, r.dir, r.tmin, r.tmax).is_some())
            })
    }

    fn intersect_all1(&self, ray: &Ray1, f: &mut impl FnMut(Hit1)) {
        if !ray.is_valid() {
            return;
        }
        for (inst, (i, m)) in self
            .instances
            .iter()
            .zip(&self.object_from_world)
            .enumerate()
        {
            let r = ray.transformed(m);
            for tri in &self.meshes[i.mesh] {
                if let Some((t, u, v)) = tri.intersect1(r.origin, r.dir, r.tmin, r.tmax) {
                    f(Hit1 {
                        t,
                        u,
                        v,
                        prim: tri.prim,
                        inst: inst as u32,
                    });
                }
            }
        }
    }

    /// Packet form with the packet triangle test (checks it against the single-ray test).
    #[inline(always)]
    fn intersect<L: Lanes>(&self, l: L, rays: &Rays<L>, active: L::Mask) -> Hits<L> {
        let mut hits = Hits::miss(l);
        let active = active & rays.valid(l);
        if active.none() {
            return hits;
        }
        let mut tmax = rays.tmax;
        for (inst, (i, m)) in self
            .instances
            .iter()
            .zip(&self.object_from_world)
            .enumerate()
        {
            let r = rays.transformed(l, m);
            for tri in &self.meshes[i.mesh] {
                let (hit, t, u, v) = tri.intersect(l, &r.origin, &r.dir, r.tmin, tmax, active);
                if hit.any() {
                    tmax = hit.select(t, tmax);
                    let new = Hits {
                        t,
                        u,
                        v,
                        prim: l.splat_i32(tri.prim as i32),
                        inst: l.splat_i32(inst as i32),
                    };
                    hits = Hits::select(hit, &new, &hits);
                }
            }
        }
        hits
    }

    #[inline(always)]
    fn occluded<L: Lanes>(&self, l: L, rays: &Rays<L>, active: L::Mask) -> L::Mask {
        let active = active & rays.valid(l);
        let mut occ = l.splat_mask(false);
        for (i, m) in self.instances.iter().zip(&self.object_from_world) {
            let r = rays.transformed(l, m);
            for tri in &self.meshes[i.mesh] {
                let (hit, ..) =
                    tri.intersect(l, &r.origin, &r.dir, r.tmin, r.tmax, active.and_not(occ));
                occ |= hit;
                if (active.and_not(occ)).none() {
                    return occ;
                }
            }
        }
        occ
    }

    fn intersect_all<L: Lanes>(
        &self,
        l: L,
        rays: &Rays<L>,
        active: L::Mask,
        f: &mut impl FnMut(usize, Hit1),
    ) {
        let active = active & rays.valid(l);
        if active.none() {
            return;
        }
        for (inst, (i, m)) in self
            .instances
            .iter()
            .zip(&self.object_from_world)
            .enumerate()
        {
            let r = rays.transformed(l, m);
            for tri in &self.meshes[i.mesh] {
                let (hit, t, u, v) = tri.intersect(l, &r.origin, &r.dir, r.tmin, r.tmax, active);
                let mut bits = hit.bitmask();
                while bits != 0 {
                    let lane = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    f(
                        lane,
                        Hit1 {
                            t: t.lane(lane),
                            u: u.lane(lane),
                            v: v.lane(lane),
                            prim: tri.prim,
                            inst: inst as u32,
                        },
                    );
                }
            }
        }
    }
}
