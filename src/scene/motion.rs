//! Keyframed instance motion (paper section 3: moving an object only changes its
//! transformation, so only the top level of the two-level tree is rebuilt per frame).

use glam::{Affine3A, Quat, Vec3};

/// One keyframe: at `time` the instance sits at `translation`, turned by `rotation`, scaled
/// by `scale`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Keyframe {
    pub time: f32,
    pub translation: Vec3,
    pub rotation: Quat,
    pub scale: Vec3,
}

impl Keyframe {
    pub fn transform(&self) -> Affine3A {
        Affine3A::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }
}

/// The motion of instance `instance` of the scene: keyframes in increasing time, linear in
/// translation and scale, spherical-linear in rotation between them, held before the first
/// and after the last.
#[derive(Debug, Clone, PartialEq)]
pub struct InstanceMotion {
    pub instance: usize,
    pub keys: Vec<Keyframe>,
}

impl InstanceMotion {
    /// The instance's `world_from_object` at `time` (the keys must not be empty).
    pub fn at(&self, time: f32) -> Affine3A {
        let keys = &self.keys;
        let first = keys[0];
        if time <= first.time || keys.len() == 1 {
            return first.transform();
        }
        for w in keys.windows(2) {
            let (a, b) = (w[0], w[1]);
            if time <= b.time {
                let span = b.time - a.time;
                let s = if span > 0.0 {
                    (time - a.time) / span
                } else {
                    1.0
                };
                return Affine3A::from_scale_rotation_translation(
                    a.scale.lerp(b.scale, s),
                    a.rotation.slerp(b.rotation, s),
                    a.translation.lerp(b.translation, s),
                );
            }
        }
        keys[keys.len() - 1].transform()
    }

    /// Why the motion cannot be used (`None` when it can): no keys, times not finite or not
    /// increasing, non-finite values.
    pub fn problem(&self) -> Option<String> {
        if self.keys.is_empty() {
            return Some("no keyframes".to_string());
        }
        for (i, k) in self.keys.iter().enumerate() {
            if !(k.time.is_finite()
                && k.translation.is_finite()
                && k.rotation.is_finite()
                && k.scale.is_finite())
            {
                return Some(format!("keyframe {i} is not finite"));
            }
            // A zero scale is singular, and so is a frame between keys whose scales differ
            // in sign along an axis (the linear blend passes through zero).
            if k.scale.cmpeq(Vec3::ZERO).any() {
                return Some(format!(
                    "keyframe {i}: scale {:?} is singular (a zero component)",
                    k.scale.to_array()
                ));
            }
            if i > 0 && (k.scale * self.keys[i - 1].scale).cmplt(Vec3::ZERO).any() {
                return Some(format!(
                    "keyframe {i}: scale {:?} differs in sign from the previous keyframe's {:?}, \
                     so a frame between them would scale by zero",
                    k.scale.to_array(),
                    self.keys[i - 1].scale.to_array()
                ));
            }
            if i > 0 && k.time <= self.keys[i - 1].time {
                return Some(format!(
                    "keyframe {i}: time {} does not follow {}",
                    k.time,
                    self.keys[i - 1].time
                ));
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_and_holds() {
        let key = |time, x| Keyframe {
            time,
            translation: Vec3::new(x, 0.0, 0.0),
            rotation: Quat::IDENTITY,
            scale: Vec3::ONE,
        };
        let m = InstanceMotion {
            instance: 0,
            keys: vec![key(0.0, 0.0), key(2.0, 4.0)],
        };
        assert_eq!(m.problem(), None);
        assert_eq!(m.at(-1.0).translation.x, 0.0);
        assert_eq!(m.at(1.0).translation.x, 2.0);
        assert_eq!(m.at(3.0).translation.x, 4.0);
        let bad = InstanceMotion {
            instance: 0,
            keys: vec![key(1.0, 0.0), key(1.0, 1.0)],
        };
        assert!(bad.problem().unwrap().contains("does not follow"));
        let scaled = |s: f32| Keyframe {
            scale: Vec3::new(1.0, s, 1.0),
            ..key(1.0, 0.0)
        };
        let flat = InstanceMotion {
            instance: 0,
            keys: vec![key(0.0, 0.0), scaled(0.0)],
        };
        assert!(flat.problem().unwrap().contains("singular"));
        let flip = InstanceMotion {
            instance: 0,
            keys: vec![key(0.0, 0.0), scaled(-1.0)],
        };
        assert!(flip.problem().unwrap().contains("differs in sign"));
    }
}
