//! The pinhole camera (paper section 7: primary rays for 1024 x 768 images; section 6.2's
//! sampler hands it continuous pixel coordinates): rays for packets of image-plane points,
//! with ray differentials (the change of the direction per pixel in x and y) so that
//! texture lookups find their mip level (section 4.1).

use coherent_accel::Rays;
use coherent_simd::{Lanes, SimdF32, Vec3s};
use glam::Vec3;

/// A camera that cannot form an image.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CameraError {
    #[error("camera: {0}")]
    Singular(String),
}

/// A pinhole camera with its image: pixel `(i, j)` covers `[i, i+1) x [j, j+1)`, `y` down.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PinholeCamera {
    /// The eye.
    pub position: Vec3,
    /// Unit view direction.
    forward: Vec3,
    /// Image-plane (at distance 1) step per pixel to the right.
    dx: Vec3,
    /// Image-plane step per pixel downwards.
    dy: Vec3,
    /// Direction through the image's top-left corner (pixel coordinates (0, 0)).
    corner: Vec3,
}

/// A packet of camera rays: unit directions, with per-lane direction differentials.
#[derive(Debug, Clone, Copy)]
pub struct CameraRays<L: Lanes> {
    pub rays: Rays<L>,
    /// Derivative of the unit direction per pixel along x.
    pub ddir_dx: Vec3s<L>,
    /// Derivative of the unit direction per pixel along y.
    pub ddir_dy: Vec3s<L>,
}

impl PinholeCamera {
    /// The camera at `position` looking at `look_at` with `up` roughly up, a vertical field
    /// of view of `vfov_deg` degrees, over a `width` x `height` image. A camera whose eye and
    /// target coincide, whose up is parallel to the view, whose field of view is not in
    /// (0, 180) or whose image is empty is an error.
    pub fn new(
        position: Vec3,
        look_at: Vec3,
        up: Vec3,
        vfov_deg: f32,
        width: u32,
        height: u32,
    ) -> Result<Self, CameraError> {
        if !(position.is_finite() && look_at.is_finite() && up.is_finite()) {
            return Err(CameraError::Singular(format!(
                "position {position}, look_at {look_at} and up {up} must be finite"
            )));
        }
        let forward = (look_at - position).normalize_or_zero();
        if forward == Vec3::ZERO {
            return Err(CameraError::Singular(format!(
                "position and look_at are the same point {position}"
            )));
        }
        let right = forward.cross(up).normalize_or_zero();
        if right == Vec3::ZERO || forward.cross(up).length() < 1e-6 * up.length() {
            return Err(CameraError::Singular(format!(
                "up {up} is parallel to the view direction {forward}"
            )));
        }
        if !(vfov_deg > 0.0 && vfov_deg < 180.0) {
            return Err(CameraError::Singular(format!(
                "the vertical field of view {vfov_deg} degrees is not in (0, 180)"
            )));
        }
        if width == 0 || height == 0 {
            return Err(CameraError::Singular(format!(
                "the image is {width}x{height} pixels"
            )));
        }
        let true_up = right.cross(forward);
        let half_h = (vfov_deg.to_radians() * 0.5).tan();
        let half_w = half_h * width as f32 / height as f32;
        let dx = right * (2.0 * half_w / width as f32);
        let dy = -true_up * (2.0 * half_h / height as f32);
        let corner = forward - right * half_w + true_up * half_h;
        Ok(Self {
            position,
            forward,
            dx,
            dy,
            corner,
        })
    }

    /// Unit view direction.
    pub fn forward(&self) -> Vec3 {
        self.forward
    }

    /// The unit direction through the image point `(x, y)` (pixel coordinates), one ray.
    pub fn direction1(&self, x: f32, y: f32) -> Vec3 {
        (self.corner + self.dx * x + self.dy * y).normalize()
    }

    /// Rays through the image points `(xs, ys)` (pixel coordinates) of each lane, from the
    /// eye, `t` in `[0, inf)` and in units of distance (unit directions).
    #[inline(always)]
    pub fn rays<L: Lanes>(&self, l: L, xs: L::F32s, ys: L::F32s) -> CameraRays<L> {
        let c = Vec3s::splat(l, self.corner);
        let dx = Vec3s::splat(l, self.dx);
        let dy = Vec3s::splat(l, self.dy);
        // d = corner + x dx + y dy, unnormalised.
        let d = dx.mul_add(xs, dy.mul_add(ys, c));
        let len2 = d.dot(d);
        let inv = l.splat(1.0) / len2.sqrt();
        let dir = d * inv;
        // d(d/|d|) = (dd - dir (dir . dd)) / |d|
        // Written out twice, not a closure: see `scripts/check-inlining.sh`.
        let ddir_dx = (dx - dir * dir.dot(dx)) * inv;
        let ddir_dy = (dy - dir * dir.dot(dy)) * inv;
        CameraRays {
            rays: Rays {
                origin: Vec3s::splat(l, self.position),
                dir,
                tmin: l.splat(0.0),
                tmax: l.splat(f32::INFINITY),
            },
            ddir_dx,
            ddir_dy,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use coherent_simd::scalar::Scalar;

    fn cam() -> PinholeCamera {
        PinholeCamera::new(
            Vec3::new(0.0, 0.0, 5.0),
            Vec3::ZERO,
            Vec3::Y,
            90.0,
            200,
            100,
        )
        .unwrap()
    }

    #[test]
    fn centre_looks_forward_and_corners_span_the_field_of_view() {
        let c = cam();
        let d = c.direction1(100.0, 50.0);
        assert!((d - Vec3::NEG_Z).length() < 1e-6, "{d}");
        // vfov 90: the top edge of the image is 45 degrees up, y down in pixels.
        let top = c.direction1(100.0, 0.0);
        assert!((top - Vec3::new(0.0, 1.0, -1.0).normalize()).length() < 1e-6);
        // Aspect 2: the right edge is at tan = 2.
        let right = c.direction1(200.0, 50.0);
        assert!((right - Vec3::new(2.0, 0.0, -1.0).normalize()).length() < 1e-6);
    }

    #[test]
    fn packet_rays_match_single_rays_and_differentials_match_finite_differences() {
        let c = cam();
        let l = Scalar;
        for &(x, y) in &[(3.5f32, 7.25f32), (150.0, 90.0), (100.0, 50.0)] {
            let r = c.rays(l, x, y);
            let d = r.rays.dir.lane(0);
            assert!((d - c.direction1(x, y)).length() < 1e-6);
            let h = 1e-2;
            let fd_x = (c.direction1(x + h, y) - c.direction1(x - h, y)) / (2.0 * h);
            let fd_y = (c.direction1(x, y + h) - c.direction1(x, y - h)) / (2.0 * h);
            assert!((r.ddir_dx.lane(0) - fd_x).length() < 1e-4, "{x} {y}");
            assert!((r.ddir_dy.lane(0) - fd_y).length() < 1e-4, "{x} {y}");
        }
    }

    #[test]
    fn singular_cameras_are_errors() {
        let p = Vec3::new(0.0, 0.0, 5.0);
        assert!(PinholeCamera::new(p, p, Vec3::Y, 60.0, 8, 8).is_err());
        assert!(PinholeCamera::new(p, Vec3::ZERO, Vec3::Z, 60.0, 8, 8).is_err());
        assert!(PinholeCamera::new(p, Vec3::ZERO, Vec3::Y, 0.0, 8, 8).is_err());
        assert!(PinholeCamera::new(p, Vec3::ZERO, Vec3::Y, 60.0, 0, 8).is_err());
        let e = PinholeCamera::new(p, p, Vec3::Y, 60.0, 8, 8).unwrap_err();
        assert!(e.to_string().contains("same point"), "{e}");
    }
}
