//! The sliver remedy: a vertex that lands within a small fraction of a cell
//! of a lattice point is moved onto it. The two or three vertices around
//! one corner that would have made needles and slivers become one, and the
//! triangles that collapse are dropped. The surface moves by at most that
//! fraction of a cell; the report says how far from the field it ends up.

use glam::Vec3;
use rustc_hash::FxHashMap;
use serde::Serialize;

use crate::mesh::Mesh;

/// What [`snap_to_corners`] changed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct SnapReport {
    /// The snapping distance, as a fraction of a cell.
    pub fraction: f32,
    /// Vertices moved onto a lattice point.
    pub snapped: u64,
    /// Vertices merged away into another one on the same lattice point.
    pub merged: u64,
    /// Triangles that collapsed and were dropped.
    pub dropped_triangles: u64,
}

/// Moves every vertex within `fraction · cell` of its nearest lattice point
/// (given by `nearest`) onto it, merges the vertices that meet there (their
/// normals averaged), and drops the triangles that collapse.
pub fn snap_to_corners(mesh: &mut Mesh, cell: f32, fraction: f32, nearest: impl Fn(Vec3) -> Vec3) -> SnapReport {
    let mut report = SnapReport { fraction, ..SnapReport::default() };
    let reach = fraction * cell;
    let mut first_at: FxHashMap<[u32; 3], u32> = FxHashMap::default();
    let mut target: Vec<u32> = (0..mesh.positions.len() as u32).collect();
    for i in 0..mesh.positions.len() {
        let corner = nearest(mesh.positions[i]);
        if mesh.positions[i].distance(corner) > reach {
            continue;
        }
        report.snapped += 1;
        mesh.positions[i] = corner;
        let keeper = *first_at.entry(corner.to_array().map(f32::to_bits)).or_insert(i as u32);
        if keeper != i as u32 {
            target[i] = keeper;
            report.merged += 1;
            let merged = mesh.normals[keeper as usize] + mesh.normals[i];
            mesh.normals[keeper as usize] = merged;
        }
    }
    for &keeper in first_at.values() {
        let n = &mut mesh.normals[keeper as usize];
        *n = n.normalize_or_zero();
    }
    let before = mesh.triangles.len();
    for t in &mut mesh.triangles {
        *t = t.map(|i| target[i as usize]);
    }
    mesh.triangles.retain(|&[a, b, c]| a != b && b != c && c != a);
    report.dropped_triangles = (before - mesh.triangles.len()) as u64;
    super::drop_unused_vertices(mesh);
    report
}
