//! The viewer's camera moves, as pure functions of the camera: orbit about the target, pan in
//! the view plane, dolly toward the target. Each keeps the camera usable (finite, the eye off
//! the target and off the up axis) or refuses the move with a message.

use crate::scene::camera::Camera;

/// How close an orbit may bring the view direction to the up axis (radians): the camera is
/// singular on it.
const POLE_MARGIN: f32 = 0.02;

/// The nearest a dolly brings the eye to the target, relative to the scene's scale at the
/// target (never 0: the eye on the target has no view direction).
const MIN_DISTANCE: f32 = 1e-3;
/// The farthest, relative to the same scale: far enough to see any scene as a dot, near
/// enough that lengths stay finite in `f32` (squares overflow past about 1.8e19).
const MAX_DISTANCE: f32 = 1e6;

/// One move of the camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Move {
    /// Turn the eye about the target: `yaw` radians about the up axis (positive: the eye
    /// moves to its right), `pitch` radians toward the up axis (positive: the eye rises),
    /// stopping short of the poles.
    Orbit { yaw: f32, pitch: f32 },
    /// Shift the eye and the target together in the view plane, by `dx` to the right and `dy`
    /// up, in units of the eye's distance to the target.
    Pan { dx: f32, dy: f32 },
    /// Scale the eye's distance to the target by `factor` (below 1: closer).
    Dolly { factor: f32 },
}

/// `camera` after `m`, or why the move cannot be made.
pub fn apply(camera: &Camera, m: Move) -> Result<Camera, String> {
    if let Some((field, why)) = camera.problem() {
        return Err(format!("the camera cannot move: {field} {why}"));
    }
    let moved = match m {
        Move::Orbit { yaw, pitch } => {
            finite("orbit", &[yaw, pitch])?;
            orbit(camera, yaw, pitch)
        }
        Move::Pan { dx, dy } => {
            finite("pan", &[dx, dy])?;
            pan(camera, dx, dy)
        }
        Move::Dolly { factor } => {
            finite("dolly", &[factor])?;
            if factor <= 0.0 {
                return Err(format!("dolly {factor}: the factor must be above 0"));
            }
            dolly(camera, factor)
        }
    };
    match moved.problem() {
        None => Ok(moved),
        Some((field, why)) => Err(format!(
            "{m:?} would leave the camera unusable: {field} {why}"
        )),
    }
}

fn finite(what: &str, v: &[f32]) -> Result<(), String> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(())
    } else {
        Err(format!("{what} {v:?}: the values must be finite numbers"))
    }
}

fn orbit(c: &Camera, yaw: f32, pitch: f32) -> Camera {
    let up = c.up.normalize();
    let offset = c.position - c.look_at;
    let d = offset.length();
    // The eye's angle from the up axis, then its direction about the axis.
    let polar = (offset.dot(up) / d).clamp(-1.0, 1.0).acos();
    let horizontal = offset - up * offset.dot(up);
    let h = if horizontal.length() > 1e-6 * d {
        horizontal.normalize()
    } else {
        up.any_orthonormal_vector()
    };
    // Yaw: the eye moves to its right, which is `h x up` seen from the target.
    let h = glam::Quat::from_axis_angle(up, yaw) * h;
    let polar = (polar - pitch).clamp(POLE_MARGIN, std::f32::consts::PI - POLE_MARGIN);
    Camera {
        position: c.look_at + d * (up * polar.cos() + h * polar.sin()),
        ..*c
    }
}

fn pan(c: &Camera, dx: f32, dy: f32) -> Camera {
    let forward = c.look_at - c.position;
    let d = forward.length();
    let right = forward.cross(c.up).normalize();
    let up = right.cross(forward).normalize();
    let shift = (right * dx + up * dy) * d;
    Camera {
        position: c.position + shift,
        look_at: c.look_at + shift,
        ..*c
    }
}

fn dolly(c: &Camera, factor: f32) -> Camera {
    let offset = c.position - c.look_at;
    let d = offset.length();
    let scale = c.look_at.length().max(1.0);
    let to = (d * factor).clamp(MIN_DISTANCE * scale, MAX_DISTANCE * scale);
    Camera {
        position: c.look_at + offset * (to / d),
        ..*c
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Whether two points are the same within `eps` of their scale.
    fn near(a: Vec3, b: Vec3, eps: f32) -> bool {
        (a - b).length() <= eps * a.length().max(b.length()).max(1.0)
    }

    fn cam() -> Camera {
        Camera {
            position: Vec3::new(1.0, 2.0, 5.0),
            look_at: Vec3::new(0.5, 1.0, 0.0),
            up: Vec3::Y,
            vfov_deg: 40.0,
        }
    }

    fn dist(c: &Camera) -> f32 {
        (c.position - c.look_at).length()
    }

    #[test]
    fn orbit_keeps_the_target_and_the_distance_and_stops_short_of_the_poles() {
        let c = cam();
        for (yaw, pitch) in [
            (0.3, 0.0),
            (-1.0, 0.2),
            (3.0, -0.5),
            (0.0, 10.0),
            (0.0, -10.0),
        ] {
            let o = apply(&c, Move::Orbit { yaw, pitch }).unwrap();
            assert_eq!(o.look_at, c.look_at);
            assert!(
                (dist(&o) - dist(&c)).abs() < 1e-4 * dist(&c),
                "{yaw} {pitch}"
            );
            assert!(o.problem().is_none(), "{o:?}");
            let polar = ((o.position - o.look_at).normalize().dot(Vec3::Y)).acos();
            let poles = POLE_MARGIN * 0.99..=std::f32::consts::PI - POLE_MARGIN * 0.99;
            assert!(poles.contains(&polar), "{polar}");
        }
        // Positive yaw moves the eye to its right; positive pitch raises it.
        let right = (c.look_at - c.position).cross(c.up);
        let o = apply(
            &c,
            Move::Orbit {
                yaw: 0.1,
                pitch: 0.0,
            },
        )
        .unwrap();
        assert!((o.position - c.position).dot(right) > 0.0);
        let o = apply(
            &c,
            Move::Orbit {
                yaw: 0.0,
                pitch: 0.1,
            },
        )
        .unwrap();
        assert!(o.position.y > c.position.y);
        // A full turn comes back.
        let o = apply(
            &c,
            Move::Orbit {
                yaw: std::f32::consts::TAU,
                pitch: 0.0,
            },
        )
        .unwrap();
        assert!(near(o.position, c.position, 1e-4), "{o:?}");
        // From the pole itself (eye straight above the target) the orbit still works.
        let top = Camera {
            position: Vec3::new(0.0, 5.0, 0.0),
            look_at: Vec3::ZERO,
            up: Vec3::Z,
            vfov_deg: 40.0,
        };
        let o = apply(
            &top,
            Move::Orbit {
                yaw: 0.5,
                pitch: 0.5,
            },
        )
        .unwrap();
        assert!((dist(&o) - 5.0).abs() < 1e-4);
    }

    #[test]
    fn pan_moves_eye_and_target_together_by_the_distance() {
        let c = cam();
        let p = apply(&c, Move::Pan { dx: 0.5, dy: -0.25 }).unwrap();
        let shift = p.position - c.position;
        assert!(near(p.look_at - c.look_at, shift, 1e-5));
        assert!((shift.length() - dist(&c) * (0.5f32.hypot(0.25))).abs() < 1e-4);
        assert!(
            shift.dot(c.look_at - c.position).abs() < 1e-4,
            "in the view plane"
        );
        assert!((dist(&p) - dist(&c)).abs() < 1e-4);
    }

    #[test]
    fn dolly_scales_the_distance_and_never_reaches_the_target() {
        let c = cam();
        let d = apply(&c, Move::Dolly { factor: 0.5 }).unwrap();
        assert!((dist(&d) - dist(&c) * 0.5).abs() < 1e-4);
        assert_eq!(d.look_at, c.look_at);
        let mut close = c;
        for _ in 0..200 {
            close = apply(&close, Move::Dolly { factor: 1e-3 }).unwrap();
            assert!(close.problem().is_none());
            assert!(dist(&close) > 0.0);
        }
        let mut far = c;
        for _ in 0..20 {
            far = apply(&far, Move::Dolly { factor: 1e30 }).unwrap();
            assert!(far.position.is_finite() && far.problem().is_none());
        }
        // Too far to pan from is refused, not made.
        assert!(apply(&far, Move::Pan { dx: 1e30, dy: 0.0 }).is_err());
    }

    #[test]
    fn bad_numbers_are_refused_with_a_message() {
        let c = cam();
        for m in [
            Move::Orbit {
                yaw: f32::NAN,
                pitch: 0.0,
            },
            Move::Pan {
                dx: 0.0,
                dy: f32::INFINITY,
            },
            Move::Dolly { factor: 0.0 },
            Move::Dolly { factor: -2.0 },
            Move::Dolly { factor: f32::NAN },
        ] {
            let e = apply(&c, m).unwrap_err();
            assert!(e.contains("finite") || e.contains("above 0"), "{e}");
        }
        let broken = Camera {
            position: Vec3::NAN,
            ..c
        };
        assert!(apply(&broken, Move::Dolly { factor: 1.0 }).is_err());
    }
}
