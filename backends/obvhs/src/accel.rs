//! obvhs behind the traversal interface (paper section 3's queries). obvhs traverses single
//! rays only: the packet forms are the interface's defaults, which serve a packet lane by
//! lane (results label these rows accordingly).

use coherent_accel::{Accel, AccelError, BuildStats, Hit1, Instance, Ray1, Scene};

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
}
