//! Which edges of a mesh's triangles are shared, and the mesh's triangle records with their
//! edge tolerances.
//!
//! The projection test accepts hits up to [`crate::EDGE_EPS`] beyond an edge so that a ray
//! through an edge two triangles share finds one of them despite rounding (no cracks). On an
//! edge no other triangle shares, the mesh's outline, that band only makes the surface
//! larger than it is: a silhouette edge lying on a row of pixel centres (the box of the
//! `cornell_pov` scene does) then covers pixels that Embree and obvhs, which test the exact
//! triangle, leave to the background. So only shared edges get the band; outline edges are
//! tested exactly.

use glam::Vec3;

use crate::TriAccel;

/// Per triangle, whether each of its edges (`p0-p1`, `p1-p2`, `p2-p0`) is an edge of another
/// triangle of `tris` too. Endpoints match by position (bit for bit, `-0.0` as `0.0`), in
/// either direction, so meshes with vertices split for normals or UVs are joined.
pub fn shared_edges(tris: &[[Vec3; 3]]) -> Vec<[bool; 3]> {
    let key = |p: Vec3| {
        let p = p + Vec3::ZERO; // -0.0 + 0.0 = 0.0
        [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
    };
    // (sorted endpoint keys, triangle * 3 + edge), sorted: shared edges are neighbours.
    let mut edges: Vec<([[u32; 3]; 2], u32)> = Vec::with_capacity(tris.len() * 3);
    for (t, p) in tris.iter().enumerate() {
        for e in 0..3 {
            let (a, b) = (key(p[e]), key(p[(e + 1) % 3]));
            let ends = if a <= b { [a, b] } else { [b, a] };
            edges.push((ends, (t * 3 + e) as u32));
        }
    }
    edges.sort_unstable();
    let mut shared = vec![[false; 3]; tris.len()];
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j].0 == edges[i].0 {
            j += 1;
        }
        if j - i > 1 {
            for &(_, id) in &edges[i..j] {
                shared[id as usize / 3][id as usize % 3] = true;
            }
        }
        i = j;
    }
    shared
}

/// The records of a mesh's non-degenerate triangles (degenerate ones, which
/// [`TriAccel::new`] rejects, are left out) with their edge tolerances set by
/// [`shared_edges`] among those triangles, and beside each record its vertices.
pub fn mesh_records(positions: &[Vec3], indices: &[[u32; 3]]) -> (Vec<TriAccel>, Vec<[Vec3; 3]>) {
    let mut recs = Vec::with_capacity(indices.len());
    let mut verts = Vec::with_capacity(indices.len());
    for (i, t) in indices.iter().enumerate() {
        let v = t.map(|j| positions[j as usize]);
        if let Some(rec) = TriAccel::new(v, i as u32) {
            recs.push(rec);
            verts.push(v);
        }
    }
    for (rec, shared) in recs.iter_mut().zip(shared_edges(&verts)) {
        *rec = rec.with_shared_edges(shared);
    }
    (recs, verts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_quad_shares_its_diagonal_only() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let tris = [[p[0], p[1], p[2]], [p[0], p[2], p[3]]];
        // Edge 2 of the first (p2-p0) is edge 0 of the second (p0-p2), reversed.
        assert_eq!(
            shared_edges(&tris),
            vec![[false, false, true], [true, false, false]]
        );
    }

    #[test]
    fn split_vertices_and_signed_zeros_still_join() {
        let a = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let b = [
            Vec3::new(-0.0, 0.0, -0.0),
            Vec3::new(0.0, -1.0, 0.0),
            Vec3::X,
        ];
        assert_eq!(
            shared_edges(&[a, b]),
            vec![[true, false, false], [false, false, true]]
        );
    }

    #[test]
    fn a_closed_mesh_shares_every_edge() {
        let m = crate::shapes::icosphere("ico", Vec3::ZERO, 1.0, 2);
        let tris: Vec<[Vec3; 3]> = (0..m.indices.len()).map(|i| m.triangle(i)).collect();
        assert!(shared_edges(&tris).iter().all(|s| *s == [true; 3]));
        let (recs, verts) = mesh_records(&m.positions, &m.indices);
        assert_eq!(
            (recs.len(), verts.len()),
            (m.indices.len(), m.indices.len())
        );
        assert!(
            recs.iter()
                .all(|r| *r == TriAccel::new(verts[r.prim as usize], r.prim).unwrap())
        );
    }

    #[test]
    fn degenerate_triangles_are_left_out_and_share_nothing() {
        let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y, 2.0 * Vec3::X];
        // The second triangle is a line along p0-p1: dropped, so p0-p1 stays an outline edge.
        let indices = vec![[0, 1, 2], [0, 3, 1]];
        let (recs, _) = mesh_records(&positions, &indices);
        assert_eq!(recs.len(), 1);
        assert_eq!(
            recs[0],
            TriAccel::new([Vec3::ZERO, Vec3::X, Vec3::Y], 0)
                .unwrap()
                .with_shared_edges([false; 3])
        );
    }
}
