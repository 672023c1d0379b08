//! The scene's pinhole camera (paper section 7: primary rays from the eye through the image
//! plane): where it is, what it looks at, which way is up and the vertical field of view.
//! Rays are made by the renderer; this is the description and its checks.

use glam::Vec3;

/// A pinhole camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    /// Vertical field of view in degrees, in (0, 180).
    pub vfov_deg: f32,
}

impl Camera {
    /// Why the camera cannot make rays (`None` when it can): a non-finite value, the eye on
    /// the target, an up vector that is zero or parallel to the view direction, a field of
    /// view outside (0, 180) degrees. The string names the field.
    pub fn problem(&self) -> Option<(&'static str, String)> {
        let finite = [self.position, self.look_at, self.up];
        for (field, v) in ["position", "look_at", "up"].into_iter().zip(finite) {
            if !v.is_finite() {
                return Some((field, format!("{v} is not finite")));
            }
        }
        let forward = self.look_at - self.position;
        let len = forward.length();
        if len <= 1e-6 * self.position.length().max(1.0) {
            return Some((
                "look_at",
                format!("equals the position {} (no view direction)", self.position),
            ));
        }
        let up_len = self.up.length();
        if up_len == 0.0 {
            return Some(("up", "is zero".to_string()));
        }
        let sin = forward.cross(self.up).length() / (len * up_len);
        if sin < 1e-4 {
            return Some((
                "up",
                format!(
                    "{} is parallel to the view direction {} (the camera is singular)",
                    self.up,
                    forward / len
                ),
            ));
        }
        if !(self.vfov_deg > 0.0 && self.vfov_deg < 180.0) {
            return Some((
                "vfov_deg",
                format!("{} is outside (0, 180) degrees", self.vfov_deg),
            ));
        }
        None
    }

    /// A camera that frames a box (`min`, `max`) from the front-right and a little above
    /// (+y up), at a distance that fits its bounding sphere in the view.
    pub fn framing(min: Vec3, max: Vec3) -> Camera {
        let center = 0.5 * (min + max);
        let radius = (0.5 * (max - min).length()).max(1e-3);
        let vfov_deg = 45.0_f32;
        let dist = radius / (0.5 * vfov_deg.to_radians()).sin() * 1.05;
        Camera {
            position: center + Vec3::new(0.35, 0.25, 1.0).normalize() * dist,
            look_at: center,
            up: Vec3::Y,
            vfov_deg,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera {
            position: Vec3::new(0.0, 0.0, 5.0),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            vfov_deg: 40.0,
        }
    }

    #[test]
    fn singular_cameras_are_named() {
        assert_eq!(cam().problem(), None);
        let c = Camera {
            up: Vec3::Z,
            ..cam()
        };
        assert_eq!(c.problem().unwrap().0, "up");
        let c = Camera {
            look_at: c.position,
            ..cam()
        };
        assert_eq!(c.problem().unwrap().0, "look_at");
        let c = Camera {
            vfov_deg: 180.0,
            ..cam()
        };
        assert_eq!(c.problem().unwrap().0, "vfov_deg");
        let c = Camera {
            position: Vec3::NAN,
            ..cam()
        };
        assert_eq!(c.problem().unwrap().0, "position");
    }

    #[test]
    fn framing_sees_the_box() {
        let c = Camera::framing(Vec3::splat(-1.0), Vec3::splat(1.0));
        assert_eq!(c.problem(), None);
        assert!((c.position - c.look_at).length() > 3.0_f32.sqrt());
    }
}
