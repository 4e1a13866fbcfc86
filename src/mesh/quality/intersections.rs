//! Self-intersections: pairs of triangles that share no vertex yet cut
//! through each other. Candidates come from a BVH over the triangles (the
//! same obvhs tree the mesh renderer builds), queried with each triangle's
//! box; each candidate pair is decided exactly enough in double precision by
//! testing every side of either triangle against the other's interior.

use std::time::Duration;

use glam::{DVec3, Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::bvh2::builder::build_bvh2_from_tris;
use obvhs::triangle::Triangle;
use rayon::prelude::*;

/// Pairs `(s, t)`, `s < t`, of triangles that share no vertex and intersect, in order.
#[must_use]
pub fn self_intersections(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<(u32, u32)> {
    if triangles.len() < 2 {
        return vec![];
    }
    let geometry: Vec<Triangle> = triangles
        .iter()
        .map(|t| {
            let [v0, v1, v2] = t.map(|i| Vec3A::from(positions[i as usize]));
            Triangle { v0, v1, v2 }
        })
        .collect();
    let bvh = build_bvh2_from_tris(&geometry, BvhBuildParams::fastest_build(), &mut Duration::default());
    let corners = |t: u32| triangles[t as usize].map(|i| positions[i as usize].as_dvec3());
    (0..triangles.len() as u32)
        .into_par_iter()
        .flat_map_iter(|s| {
            let tri = &geometry[s as usize];
            let mut found = vec![];
            bvh.aabb_traverse(Aabb::from_points(&[tri.v0, tri.v1, tri.v2]), |bvh, node| {
                let node = &bvh.nodes[node as usize];
                for k in node.first_index..node.first_index + node.prim_count {
                    let t = bvh.primitive_indices[k as usize];
                    if t <= s || !boxes_meet(tri, &geometry[t as usize]) {
                        continue;
                    }
                    let share = triangles[s as usize].iter().any(|v| triangles[t as usize].contains(v));
                    if !share && triangles_cross(corners(s), corners(t)) {
                        found.push((s, t));
                    }
                }
                true
            });
            found.sort_unstable();
            found.into_iter()
        })
        .collect()
}

/// True when the bounding boxes of two triangles overlap.
fn boxes_meet(a: &Triangle, b: &Triangle) -> bool {
    let (a_lo, a_hi) = (a.v0.min(a.v1).min(a.v2), a.v0.max(a.v1).max(a.v2));
    let (b_lo, b_hi) = (b.v0.min(b.v1).min(b.v2), b.v0.max(b.v1).max(b.v2));
    a_lo.cmple(b_hi).all() && b_lo.cmple(a_hi).all()
}

/// True when some side of either triangle passes through the other's interior.
#[must_use]
pub fn triangles_cross(a: [DVec3; 3], b: [DVec3; 3]) -> bool {
    // Most candidates lie wholly on one side of the other's plane.
    if one_side_of(a, b) || one_side_of(b, a) {
        return false;
    }
    let sides = |t: [DVec3; 3]| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])];
    sides(a).iter().any(|&(p, q)| segment_crosses(p, q, b)) || sides(b).iter().any(|&(p, q)| segment_crosses(p, q, a))
}

/// True when the corners of `a` lie strictly on one side of the plane of `b`.
fn one_side_of(a: [DVec3; 3], b: [DVec3; 3]) -> bool {
    let normal = (b[1] - b[0]).cross(b[2] - b[0]);
    let side = a.map(|p| (p - b[0]).dot(normal));
    side.iter().all(|&d| d > 0.0) || side.iter().all(|&d| d < 0.0)
}

/// True when the open segment `p q` meets the open triangle `t` (Möller–Trumbore).
fn segment_crosses(p: DVec3, q: DVec3, t: [DVec3; 3]) -> bool {
    let dir = q - p;
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let h = dir.cross(e2);
    let det = e1.dot(h);
    if det.abs() < 1e-30 {
        // Parallel: a coplanar overlap is not counted (a known limit; the
        // polygonizer's cells keep its triangles apart).
        return false;
    }
    let s = p - t[0];
    let u = s.dot(h) / det;
    let w = dir.dot(s.cross(e1)) / det;
    let along = e2.dot(s.cross(e1)) / det;
    u > 0.0 && w > 0.0 && u + w < 1.0 && along > 0.0 && along < 1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crossing_triangles_are_found_and_touching_ones_are_not() {
        let flat = [DVec3::new(-1.0, -1.0, 0.0), DVec3::new(1.0, -1.0, 0.0), DVec3::new(0.0, 1.0, 0.0)];
        let through = [DVec3::new(0.0, 0.0, -1.0), DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.0, 2.0, 1.0)];
        assert!(triangles_cross(flat, through));
        let above = through.map(|p| p + DVec3::Z * 1.5);
        assert!(!triangles_cross(flat, above));
        let touching = [DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.0, 1.0, 1.0)];
        assert!(!triangles_cross(flat, touching), "a corner resting on the face does not cut it");
    }
}
