//! Embree behind the traversal interface (paper section 3's queries): packets of 4, 8 and 16
//! lanes go to Embree's packet calls, one lane to its single-ray calls.

use coherent_accel::{Accel, AccelError, BuildStats, Hit1, Hits, Instance, Ray1, Rays, Scene};
use coherent_simd::Lanes;

use crate::scene::{Embree, EmbreeParams};

impl Accel for Embree {
    type Params = EmbreeParams;

    /// Fails with [`AccelError::Unavailable`] (cause and fix) when no Embree 4 library can
    /// be loaded.
    fn build(scene: &Scene, params: &EmbreeParams) -> Result<Self, AccelError> {
        Ok(Self::build_scene(scene, params)?)
    }

    fn set_instances(&mut self, instances: &[Instance]) -> Result<(), AccelError> {
        Ok(self.replace_instances(instances)?)
    }

    fn name(&self) -> &'static str {
        "embree"
    }

    /// Bytes this scene holds on the Embree device (geometry buffers and BVHs, by the
    /// device's memory monitor: what the device gained while building it).
    fn memory_bytes(&self) -> usize {
        self.stats.memory_bytes
    }

    fn stats(&self) -> BuildStats {
        BuildStats {
            memory_bytes: self.memory_bytes(),
            ..self.stats.clone()
        }
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
    fn intersect<L: Lanes>(&self, l: L, rays: &Rays<L>, active: L::Mask) -> Hits<L> {
        match L::N {
            4 => self.intersect_packet::<L, 4>(l, rays, active),
            8 => self.intersect_packet::<L, 8>(l, rays, active),
            16 => self.intersect_packet::<L, 16>(l, rays, active),
            _ => Hits::from_fn(l, |i| {
                use coherent_simd::SimdMask;
                if active.lane(i) {
                    self.first_hit1(&rays.lane(i))
                } else {
                    None
                }
            }),
        }
    }

    #[inline(always)]
    fn occluded<L: Lanes>(&self, l: L, rays: &Rays<L>, active: L::Mask) -> L::Mask {
        use coherent_simd::SimdMask;
        match L::N {
            4 => self.occluded_packet::<L, 4>(l, rays, active),
            8 => self.occluded_packet::<L, 8>(l, rays, active),
            16 => self.occluded_packet::<L, 16>(l, rays, active),
            _ => l.mask_from_fn(|i| active.lane(i) && self.any_hit1(&rays.lane(i))),
        }
    }

    #[inline(always)]
    fn intersect_all<L: Lanes>(
        &self,
        _l: L,
        rays: &Rays<L>,
        active: L::Mask,
        f: &mut impl FnMut(usize, Hit1),
    ) {
        use coherent_simd::SimdMask;
        match L::N {
            4 => self.intersect_all_packet::<L, 4>(rays, active, f),
            8 => self.intersect_all_packet::<L, 8>(rays, active, f),
            16 => self.intersect_all_packet::<L, 16>(rays, active, f),
            _ => {
                for i in 0..L::N {
                    if active.lane(i) {
                        self.every_hit1(&rays.lane(i), &mut |h| f(i, h));
                    }
                }
            }
        }
    }
}
