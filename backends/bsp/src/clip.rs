//! Clipping a triangle to a box ("perfect splits", Wald & Havran 2006): the exact bounds of
//! the part of a triangle inside a kd-tree voxel (paper section 3, object-level build).

use coherent_accel::Aabb;
use glam::{DVec3, Vec3};

/// The bounds of the part of triangle `t` inside `voxel`, or `None` when none is. Clips the
/// triangle (Sutherland-Hodgman, in f64) by the six planes, rounds the result outward to
/// f32 and cuts it by the voxel, so it never leaves out a part of the triangle.
pub fn clipped_bounds(t: &[Vec3; 3], voxel: &Aabb) -> Option<Aabb> {
    let tb = Aabb::from_points(*t);
    // Planes the triangle's box does not cross cannot cut it.
    let cuts: [[bool; 2]; 3] =
        core::array::from_fn(|k| [tb.min[k] < voxel.min[k], tb.max[k] > voxel.max[k]]);
    if !tb
        .intersection(*voxel)
        .min
        .cmple(tb.intersection(*voxel).max)
        .all()
    {
        return None;
    }
    if cuts.iter().flatten().all(|c| !c) {
        return Some(tb);
    }
    // A triangle clipped by 6 planes has at most 9 vertices.
    let mut poly = [DVec3::ZERO; 10];
    let mut tmp = [DVec3::ZERO; 10];
    let mut n = 3;
    for (d, s) in poly.iter_mut().zip(t) {
        *d = s.as_dvec3();
    }
    let (lo, hi) = (voxel.min.as_dvec3(), voxel.max.as_dvec3());
    for axis in 0..3 {
        for (side, (bound, keep_above)) in [(lo[axis], true), (hi[axis], false)]
            .into_iter()
            .enumerate()
        {
            if !cuts[axis][side] {
                continue;
            }
            n = clip_plane(&poly[..n], &mut tmp, axis, bound, keep_above);
            if n == 0 {
                return None;
            }
            core::mem::swap(&mut poly, &mut tmp);
        }
    }
    let mut min = DVec3::INFINITY;
    let mut max = DVec3::NEG_INFINITY;
    for p in &poly[..n] {
        min = min.min(*p);
        max = max.max(*p);
    }
    let b = Aabb::new(down(min), up(max)).intersection(*voxel);
    (!b.is_empty()).then_some(b)
}

/// Keeps the part of `poly` with `p[axis] >= bound` (or `<=`), into `out`; returns its length.
fn clip_plane(
    poly: &[DVec3],
    out: &mut [DVec3; 10],
    axis: usize,
    bound: f64,
    above: bool,
) -> usize {
    let inside = |p: &DVec3| {
        if above {
            p[axis] >= bound
        } else {
            p[axis] <= bound
        }
    };
    let mut n = 0;
    for i in 0..poly.len() {
        let a = poly[i];
        let b = poly[(i + 1) % poly.len()];
        let (ia, ib) = (inside(&a), inside(&b));
        if ia {
            out[n] = a;
            n += 1;
        }
        if ia != ib {
            let s = (bound - a[axis]) / (b[axis] - a[axis]);
            let mut p = a + (b - a) * s;
            p[axis] = bound;
            out[n] = p;
            n += 1;
        }
    }
    n
}

/// The largest f32 at or below `x`.
fn down(x: DVec3) -> Vec3 {
    Vec3::from_array(x.to_array().map(|v| {
        let f = v as f32;
        if f as f64 > v { f.next_down() } else { f }
    }))
}

/// The smallest f32 at or above `x`.
fn up(x: DVec3) -> Vec3 {
    Vec3::from_array(x.to_array().map(|v| {
        let f = v as f32;
        if (f as f64) < v { f.next_up() } else { f }
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clips_to_the_voxel() {
        let t = [
            Vec3::ZERO,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
        ];
        let v = Aabb::new(Vec3::new(1.0, -1.0, -1.0), Vec3::new(3.0, 3.0, 1.0));
        let b = clipped_bounds(&t, &v).unwrap();
        assert_eq!(b.min, Vec3::new(1.0, 0.0, 0.0));
        assert_eq!(b.max, Vec3::new(2.0, 1.0, 0.0));
        // The voxel beside the hypotenuse holds none of it.
        let v = Aabb::new(Vec3::new(1.5, 1.5, -1.0), Vec3::new(3.0, 3.0, 1.0));
        assert_eq!(clipped_bounds(&t, &v), None);
    }

    #[test]
    fn never_smaller_than_the_part_inside() {
        // Random-ish triangles and voxels: every sampled point of the triangle inside the voxel
        // is inside the clipped bounds.
        let mut s = 1u64;
        let mut rnd = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 40) as f32 / (1u64 << 24) as f32) * 4.0 - 2.0
        };
        for _ in 0..500 {
            let t = [0; 3].map(|_| Vec3::new(rnd(), rnd(), rnd()));
            let a = Vec3::new(rnd(), rnd(), rnd());
            let b = Vec3::new(rnd(), rnd(), rnd());
            let v = Aabb::new(a.min(b), a.max(b));
            let c = clipped_bounds(&t, &v);
            for i in 0..=20 {
                for j in 0..=20 - i {
                    let (u, w) = (i as f32 / 20.0, j as f32 / 20.0);
                    let p = t[0] * (1.0 - u - w) + t[1] * u + t[2] * w;
                    if p.cmpge(v.min).all() && p.cmple(v.max).all() {
                        let c = c.expect("a point inside, no bounds");
                        let slack = 1e-5;
                        assert!(
                            (p + slack).cmpge(c.min).all() && (p - slack).cmple(c.max).all(),
                            "{p} outside {c:?}"
                        );
                    }
                }
            }
        }
    }
}
