//! The optional mesh remedies a polygonization can end with, in the order
//! they run: snapping vertices onto lattice corners, dropping small islands,
//! then fixing normals against the exact field (last, so merged and kept
//! vertices alike are checked).

use glam::{Vec3, Vec3A};
use rayon::prelude::*;
use serde::Serialize;

use super::error::{PipelineError, Result};
use crate::field::{EvalMode, Field, Model, ModelField};
use crate::mesh::repair::{NormalFix, SnapReport, drop_small_components, fix_normals, snap_to_corners};
use crate::mesh::{CellShape, Lattice, Mesh};

/// Which remedies to apply; all off by default.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeshRepair {
    /// Snap vertices within this fraction of a cell of a lattice point onto it.
    pub snap: Option<f32>,
    /// Drop connected pieces of fewer triangles than this.
    pub min_component: Option<u32>,
    /// Re-take normals that point against their faces from the exact field's gradient.
    pub fix_normals: bool,
}

/// Largest snapping fraction accepted: beyond half a cell, vertices of
/// neighbouring corners would meet.
pub const MAX_SNAP: f32 = 0.3;

impl MeshRepair {
    /// True when no remedy is asked for.
    #[must_use]
    pub fn is_none(&self) -> bool {
        *self == Self::default()
    }

    /// Checks the settings for a mesh made of `cells`.
    pub fn check(&self, cells: CellShape) -> Result<()> {
        if self.snap.is_some() && cells != CellShape::Cubes {
            return Err(PipelineError::setting("snap", "snaps the corners of cubes: use it with --cells cubes"));
        }
        if let Some(f) = self.snap
            && !(f > 0.0 && f <= MAX_SNAP)
        {
            return Err(PipelineError::setting("snap", format!("must be in (0, {MAX_SNAP}] of a cell, got {f}")));
        }
        if self.min_component == Some(0) {
            return Err(PipelineError::setting("min_component", "must be at least 1 triangle"));
        }
        Ok(())
    }
}

/// What the remedies did.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct RepairReport {
    /// The corner snap, with the distance to the surface before and after.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub snap: Option<SnapEffect>,
    /// Pieces dropped for being smaller than `--min-component`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dropped_components: Option<usize>,
    /// Normals re-taken.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub normals: Option<NormalFix>,
}

/// A snap and its effect on the smallest angle and on the distance to the field.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SnapEffect {
    /// What moved.
    #[serde(flatten)]
    pub snap: SnapReport,
    /// The smallest triangle angle before and after, in degrees.
    pub min_angle_degrees: [f64; 2],
    /// The largest first-order distance from a vertex to the surface,
    /// `|f(p) − T| / |∇f(p)|` on the exact field, in cells, before and after.
    pub max_distance_cells: [f64; 2],
    /// The mean of that distance, in cells, before and after.
    pub mean_distance_cells: [f64; 2],
}

/// Applies `repair` to `mesh`, polygonized from `model` on `lattice` (with cubes, when it snaps).
#[must_use]
pub fn repair_mesh(model: &Model, lattice: Lattice, mesh: &mut Mesh, repair: &MeshRepair) -> RepairReport {
    let exact = ModelField::new(model, EvalMode::Indexed);
    let mut report = RepairReport::default();
    if let Some(fraction) = repair.snap {
        let before = (min_angle(mesh), distances(&exact, mesh, lattice.cell));
        let snap = snap_to_corners(mesh, lattice.cell, fraction);
        let after = (min_angle(mesh), distances(&exact, mesh, lattice.cell));
        report.snap = Some(SnapEffect {
            snap,
            min_angle_degrees: [before.0, after.0],
            max_distance_cells: [before.1.0, after.1.0],
            mean_distance_cells: [before.1.1, after.1.1],
        });
    }
    if let Some(min) = repair.min_component {
        report.dropped_components = Some(drop_small_components(mesh, min));
    }
    if repair.fix_normals {
        report.normals = Some(fix_normals(mesh, |p| Vec3::from(exact.gradient(Vec3A::from(p)))));
    }
    report
}

fn min_angle(mesh: &Mesh) -> f64 {
    crate::mesh::quality::ShapeQuality::of(&mesh.positions, &mesh.triangles).min_angle_degrees
}

/// The largest and mean first-order distance from the vertices to the surface, in cells.
fn distances(field: &ModelField, mesh: &Mesh, cell: f32) -> (f64, f64) {
    let t = field.threshold();
    let d: Vec<f64> = mesh
        .positions
        .par_iter()
        .map(|&p| {
            let (v, g) = field.value_and_gradient(Vec3A::from(p));
            let slope = g.length();
            if slope > 0.0 { f64::from((v - t).abs() / slope / cell) } else { 0.0 }
        })
        .collect();
    let max = d.iter().copied().fold(0.0, f64::max);
    (max, d.iter().sum::<f64>() / d.len().max(1) as f64)
}
