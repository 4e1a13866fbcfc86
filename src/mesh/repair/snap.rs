//! The sliver remedy of marching-cubes implementations: a lattice corner
//! that a crossing lands within a small fraction `δ` of a cell of is
//! *snapped* (taken to lie on the surface), and every vertex on an edge
//! leaving a snapped corner moves onto it (to the nearer end when both ends
//! are snapped). The vertices that meet on a corner become one, the
//! triangles that collapse are dropped, and two triangles folded onto each
//! other cancel. Afterwards no vertex lies within `δ` of a snapped corner it
//! does not sit on, which is what removes the needles and slivers; each
//! moved vertex sits on a corner within `δ` of the surface. A corner whose
//! merge would pinch two sheets or open a hole is not snapped.
//!
//! Vertices are matched to their lattice edges by position: a vertex on a
//! cube edge shares two coordinates with the edge's ends (up to the
//! rounding of its interpolation, far below [`ON_PLANE`]).

use glam::{IVec3, Vec3};
use rustc_hash::{FxHashMap, FxHashSet};
use serde::Serialize;

use crate::mesh::quality::{EdgeKind, Edges, kind};
use crate::mesh::{Mesh, Topology};

/// What [`snap_to_corners`] changed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct SnapReport {
    /// The snapping distance, as a fraction of a cell.
    pub fraction: f32,
    /// Lattice corners snapped.
    pub corners: u64,
    /// Vertices moved onto a snapped corner.
    pub moved: u64,
    /// Triangles that collapsed or cancelled and were dropped.
    pub dropped_triangles: u64,
}

/// Snaps the corners of a cube lattice of side `cell` (corner `k` at `k·cell`)
/// that some vertex of `mesh` lies within `fraction · cell` of, and moves
/// every vertex on an edge leaving a snapped corner onto it. A corner whose
/// merge would leave an edge shared by more than two triangles (two sheets
/// closer than the snapping distance, pinched together) is not snapped.
pub fn snap_to_corners(mesh: &mut Mesh, cell: f32, fraction: f32) -> SnapReport {
    let edges: Vec<Option<[IVec3; 2]>> = mesh.positions.iter().map(|&p| lattice_edge(p, cell)).collect();
    let reach = fraction * cell;
    let mut snapped: FxHashSet<IVec3> = mesh
        .positions
        .iter()
        .zip(&edges)
        .filter_map(|(&p, edge)| edge.and_then(|e| e.into_iter().find(|&k| p.distance(corner_at(k, cell)) <= reach)))
        .collect();
    // Holes the merge would open count against a corner only where the mesh had none.
    let closed = Topology::of(&mesh.triangles).boundary_edges == 0;
    loop {
        let mut trial = mesh.clone();
        let merge = merge_onto_corners(&mut trial, &edges, &snapped, cell);
        let pinched = pinched_corners(&trial.triangles, &merge.corner_of_keeper, closed);
        if pinched.is_empty() {
            let report = SnapReport {
                fraction,
                corners: snapped.len() as u64,
                moved: merge.moved,
                dropped_triangles: (mesh.triangles.len() - trial.triangles.len()) as u64,
            };
            super::drop_unused_vertices(&mut trial);
            *mesh = trial;
            return report;
        }
        snapped.retain(|k| !pinched.contains(k));
    }
}

fn corner_at(k: IVec3, cell: f32) -> Vec3 {
    k.as_vec3() * cell
}

/// What a merge did: vertices moved, and the corner each keeper vertex now sits on.
struct Merge {
    moved: u64,
    corner_of_keeper: FxHashMap<u32, IVec3>,
}

/// Moves the vertices on edges leaving `snapped` corners onto them (the
/// nearer end when both are), one vertex per corner, and drops the triangles
/// that collapse or cancel. Vertex numbers are kept (unused ones stay).
fn merge_onto_corners(mesh: &mut Mesh, edges: &[Option<[IVec3; 2]>], snapped: &FxHashSet<IVec3>, cell: f32) -> Merge {
    let mut keeper_at: FxHashMap<IVec3, u32> = FxHashMap::default();
    let mut target: Vec<u32> = (0..mesh.positions.len() as u32).collect();
    let mut moved = 0;
    for i in 0..mesh.positions.len() {
        let Some([a, b]) = edges[i] else { continue };
        let p = mesh.positions[i];
        let corner = match (snapped.contains(&a), snapped.contains(&b)) {
            (true, true) if p.distance(corner_at(b, cell)) < p.distance(corner_at(a, cell)) => b,
            (true, _) => a,
            (false, true) => b,
            (false, false) => continue,
        };
        moved += 1;
        mesh.positions[i] = corner_at(corner, cell);
        let keeper = *keeper_at.entry(corner).or_insert(i as u32);
        target[i] = keeper;
        if keeper != i as u32 {
            let merged = mesh.normals[keeper as usize] + mesh.normals[i];
            mesh.normals[keeper as usize] = merged;
        }
    }
    for &keeper in keeper_at.values() {
        let n = &mut mesh.normals[keeper as usize];
        *n = n.normalize_or_zero();
    }
    for t in &mut mesh.triangles {
        *t = t.map(|i| target[i as usize]);
    }
    mesh.triangles.retain(|&[a, b, c]| a != b && b != c && c != a);
    cancel_fins(&mut mesh.triangles);
    Merge { moved, corner_of_keeper: keeper_at.into_iter().map(|(k, v)| (v, k)).collect() }
}

/// The snapped corners on an edge that is no longer shared by exactly two
/// triangles (a boundary edge counts too where the mesh was `closed`).
fn pinched_corners(triangles: &[[u32; 3]], corner_of_keeper: &FxHashMap<u32, IVec3>, closed: bool) -> FxHashSet<IVec3> {
    let mut pinched = FxHashSet::default();
    Edges::of(triangles).for_each_group(|sides| {
        match kind(sides) {
            EdgeKind::Manifold => return,
            EdgeKind::Boundary if !closed => return,
            _ => {}
        }
        let edge = sides[0].edge;
        for end in [(edge >> 32) as u32, edge as u32] {
            pinched.extend(corner_of_keeper.get(&end).copied());
        }
    });
    pinched
}

/// How close, in cells, a coordinate must be to a lattice plane to lie on it.
pub const ON_PLANE: f32 = 1e-4;

/// The cube edge (its two corners, in lattice units) that `p` lies on: the
/// one axis along which `p` is not on a lattice plane. A vertex exactly on
/// a corner gets that corner twice; a point off every edge gets `None`.
#[must_use]
pub fn lattice_edge(p: Vec3, cell: f32) -> Option<[IVec3; 2]> {
    let mut lo = IVec3::ZERO;
    let mut free_axis = None;
    for axis in 0..3 {
        let x = p[axis] / cell;
        if (x - x.round()).abs() <= ON_PLANE {
            lo[axis] = x.round() as i32;
        } else if free_axis.replace(axis).is_some() {
            return None;
        } else {
            lo[axis] = x.floor() as i32;
        }
    }
    let mut hi = lo;
    if let Some(axis) = free_axis {
        hi[axis] += 1;
    }
    Some([lo, hi])
}

/// Removes pairs of triangles over the same three vertices walked in
/// opposite directions: two sheets a merge folded onto each other, which
/// would leave every edge of theirs shared four times.
fn cancel_fins(triangles: &mut Vec<[u32; 3]>) {
    let sorted = |t: [u32; 3]| {
        let mut s = t;
        s.sort_unstable();
        s
    };
    // The orientation: whether the rotation starting at the smallest id ascends.
    let ascending = |t: [u32; 3]| {
        let first = (0..3).min_by_key(|&i| t[i]).unwrap_or(0);
        t[(first + 1) % 3] < t[(first + 2) % 3]
    };
    let mut order: Vec<usize> = (0..triangles.len()).collect();
    order.sort_unstable_by_key(|&i| (sorted(triangles[i]), i));
    let mut drop = vec![false; triangles.len()];
    for group in order.chunk_by(|&a, &b| sorted(triangles[a]) == sorted(triangles[b])) {
        let (up, down): (Vec<usize>, Vec<usize>) = group.iter().partition(|&&i| ascending(triangles[i]));
        for (&a, &b) in up.iter().zip(&down) {
            drop[a] = true;
            drop[b] = true;
        }
    }
    let mut i = 0;
    triangles.retain(|_| {
        i += 1;
        !drop[i - 1]
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertices_are_matched_to_the_cube_edge_they_lie_on() {
        let cell = 0.3;
        let on_x = Vec3::new(2.0 * cell + 0.1, -cell, 5.0 * cell);
        assert_eq!(lattice_edge(on_x, cell), Some([IVec3::new(2, -1, 5), IVec3::new(3, -1, 5)]));
        let corner = Vec3::new(cell, 0.0, -2.0 * cell);
        assert_eq!(lattice_edge(corner, cell), Some([IVec3::new(1, 0, -2); 2]));
        assert_eq!(lattice_edge(Vec3::new(0.1, 0.1, 0.0), cell), None);
        let rounded = Vec3::new(2.0 * cell * (1.0 - 1e-7), 0.12, 0.0);
        assert_eq!(lattice_edge(rounded, cell), Some([IVec3::new(2, 0, 0), IVec3::new(2, 1, 0)]));
    }
}
