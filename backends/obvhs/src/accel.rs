//! obvhs behind the traversal interface (paper section 3's queries). obvhs traverses single
//! rays only: the packet forms are the interface's defaults, which serve a packet lane by
//! lane (results label these rows accordingly). The beam forms are this crate's large-packet
//! walk over BVH2s ([`crate::packet`]).

use coherent_accel::{Accel, AccelError, BuildStats, Hit1, Hits, Instance, Ray1, Rays, Scene};
use coherent_simd::Lanes;

use crate::scene::{Obvhs, ObvhsParams};

impl Accel for Obvhs {
    type Params = ObvhsParams;

    fn build(scene: &Scene, params: &ObvhsParams) -> Result<Self, AccelError> {
        Self::build_scene(scene, params)
    }

    fn set_instances(&mut self, instances: &[Instance]) -> Result<(), AccelError> {
        self.replace_instances(instances)
    }

    fn name(&self) -> &'static str {
        "obvhs"
    }

    fn memory_bytes(&self) -> usize {
        self.memory()
    }

    fn stats(&self) -> BuildStats {
        self.stats_now()
    }

    fn intersect1(&self, ray: &Ray1) -> Option<Hit1> {
        self.first_hit1(ray)
    }

    fn occluded1(&self, ray: &Ray1) -> bool {
        self.any_hit1(ray)
    }

    fn intersect_all1(&self, ray: &Ray1, f: &mut impl FnMut(Hit1)) {
        self.every_hit1(ray, f)
    }

    #[inline(always)]
    fn intersect_beam<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        hits: &mut [Hits<L>],
    ) {
        self.beam_first_hits(l, rays, active, hits)
    }

    #[inline(always)]
    fn occluded_beam<L: Lanes>(
        &self,
        l: L,
        rays: &[Rays<L>],
        active: &[L::Mask],
        occluded: &mut [L::Mask],
    ) {
        self.beam_occluded(l, rays, active, occluded)
    }
}
