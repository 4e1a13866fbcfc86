//! Polygonizing a model: settings, the memory estimate that refuses a
//! lattice whose mesh cannot fit, the polygonizer run (with refinement), its
//! report, and colouring a mesh by the caches' reconstruction error.

use std::time::Instant;

use serde::Serialize;

use super::available_memory_bytes;
use super::cache_report::CacheReport;
use super::error::{PipelineError, Result};
use super::eval::MB;
use super::mesh_repair::{MeshRepair, RepairReport, repair_mesh};
use crate::compare::{CacheErrorStats, cache_error_at, cache_error_stats};
use crate::draw::error_colors;
use crate::field::{EvalMode, Model, ModelField};
use crate::mesh::{
    CellShape, Lattice, Mesh, PolygonizeOptions, PolygonizeStats, Polygonizer, VertexPlacement,
    quality::{MeshQuality, QualityLevel},
    skeleton_seeds,
};
use crate::progress::{Progress, Silent, stage};

/// How to polygonize.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PolygonizeSettings {
    /// Lattice cells along the longest side of the model's bounds.
    pub res: u32,
    /// Cell decomposition.
    pub cells: CellShape,
    /// Vertex placement on crossed edges.
    pub vertex: VertexPlacement,
    /// Refine this many levels: polygonize at `res · 2^refine`, grown from the
    /// surface found at `res` instead of from the skeletons.
    pub refine: u32,
    /// Remedies applied to the mesh once it is made (none by default).
    pub repair: MeshRepair,
    /// How much of the quality report to compute (all of it by default).
    pub quality: QualityLevel,
}

impl Default for PolygonizeSettings {
    fn default() -> Self {
        Self {
            res: 128,
            cells: CellShape::Cubes,
            vertex: VertexPlacement::default(),
            refine: 0,
            repair: MeshRepair::default(),
            quality: QualityLevel::Full,
        }
    }
}

/// Highest resolution accepted: lattice coordinates and memory stay reasonable.
pub const MAX_RES: u32 = 8192;
/// Most refinement levels accepted.
pub const MAX_REFINE: u32 = 6;
/// Bytes the polygonizer and its mesh hold per crossed cell (corners, cells,
/// vertices, triangles and hash-map overhead), measured on the bundled scenes.
const BYTES_PER_CROSSED_CELL: f64 = 400.0;
/// Resolution of the cheap probe that sizes the surface before the real run.
const PROBE_RES: u32 = 24;
const GIB: f64 = 1024.0 * 1024.0 * 1024.0;

impl PolygonizeSettings {
    /// The polygonizer's options.
    #[must_use]
    pub fn options(&self) -> PolygonizeOptions {
        PolygonizeOptions { cells: self.cells, vertex: self.vertex }
    }

    /// Resolution of the lattice the mesh is made on (refinement included).
    #[must_use]
    pub fn fine_res(&self) -> u32 {
        self.res << self.refine
    }

    /// Checks the settings before any work: in range, and the mesh they would
    /// make (sized by a coarse probe polygonization, exact so that no cache is
    /// warmed) fits in memory.
    pub fn check(&self, model: &Model) -> Result<()> {
        self.check_ranges()?;
        let fine_res = u64::from(self.res) << self.refine;
        let probe_res = self.res.min(PROBE_RES);
        let probe_options = PolygonizeOptions { vertex: VertexPlacement::Linear, ..self.options() };
        let probe = Lattice::for_model(model, probe_res);
        let crossed =
            run_polygonizer(model, EvalMode::Indexed, probe, probe_options, 0, &Silent).1.crossed_cells as f64;
        let needed = crossed * (fine_res as f64 / f64::from(probe_res)).powi(2) * BYTES_PER_CROSSED_CELL;
        let available = available_memory_bytes().unwrap_or(8.0 * GIB);
        if needed >= 0.8 * available {
            return Err(PipelineError::MeshTooLarge {
                res: self.res,
                need_gib: needed / GIB,
                available_gib: available / GIB,
            });
        }
        Ok(())
    }

    /// [`Self::check`] for local updates after edits, which run on the
    /// lattice of `res` alone: refinement is refused rather than ignored.
    pub fn check_unrefined(&self, model: &Model) -> Result<()> {
        if self.refine != 0 {
            return Err(PipelineError::setting(
                "refine",
                "does not apply to local updates, which run on the res lattice (polygonize or render the mesh instead)",
            ));
        }
        self.check(model)
    }

    fn check_ranges(&self) -> Result<()> {
        self.repair.check(self.cells)?;
        if !(1..=MAX_RES).contains(&self.res) {
            return Err(PipelineError::setting("res", format!("must be between 1 and {MAX_RES}, got {}", self.res)));
        }
        if self.refine > MAX_REFINE {
            return Err(PipelineError::setting("refine", format!("must be at most {MAX_REFINE}, got {}", self.refine)));
        }
        if (u64::from(self.res) << self.refine) > u64::from(MAX_RES) {
            let problem = format!("{} refined {} times exceeds {MAX_RES}", self.res, self.refine);
            return Err(PipelineError::setting("res", problem));
        }
        Ok(())
    }
}

/// Statistics of one polygonization.
#[derive(Clone, Debug, Serialize)]
pub struct MeshReport {
    /// Wall-clock seconds polygonizing (seeding, growing, vertices, assembling the mesh).
    pub seconds: f64,
    /// Lattice cells along the longest side of the bounds (of the fine mesh, when refined).
    pub res: u32,
    /// The coarse resolution the fine mesh grew from, when refined.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coarse_res: Option<u32>,
    /// Side of a lattice cell in scene units.
    pub cell_size: f32,
    /// Cell decomposition.
    pub cells: String,
    /// Vertex placement.
    pub vertex: String,
    /// Triangles.
    pub triangles: usize,
    /// Vertices.
    pub vertices: usize,
    /// Every field evaluation (corner values, root finding, gradients, colours).
    pub field_evals: u64,
    /// Field evaluations per triangle (none without triangles).
    pub evals_per_triangle: Option<f64>,
    /// Evaluations by kind and cells visited.
    #[serde(flatten)]
    pub work: PolygonizeStats,
    /// Cells the surface crosses.
    pub crossed_cells: u64,
    /// Triangles per second.
    pub triangles_per_second: f64,
    /// True when every edge is shared by exactly two consistently oriented
    /// triangles, and there is one (no triangles bound nothing).
    pub closed_manifold: bool,
    /// Why the mesh may not be what was meant: it has no triangles.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warning: Option<String>,
    /// Pieces, watertightness, genus, triangle shape, normals, self-intersections
    /// (as far as the settings' quality level asks; none when it is off).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub quality: Option<MeshQuality>,
    /// Wall-clock seconds measuring `quality` (not in `seconds`).
    pub quality_seconds: f64,
    /// The process's memory as the meshing began and at its peak (Linux;
    /// `None` elsewhere).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub memory: Option<MeshMemory>,
    /// What the remedies asked for did (after `seconds`, before `quality`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub repairs: Option<RepairReport>,
    /// Evaluation mode: naive, indexed or cached.
    pub eval: String,
    /// Threads used.
    pub threads: usize,
    /// What the caches hold and did, when polygonizing cached.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub caches: Option<CacheReport>,
    /// error_C at the vertices, when the mesh is coloured by it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error_c: Option<CacheErrorStats>,
}

/// What memory a polygonization took: the process's resident memory as it
/// began (the model, its caches and whatever else the process holds) and its
/// peak while it ran (the vertices, the polygonizer's stores and the
/// mesh, less the quality report, which comes after). Measuring resets the
/// process's peak to its memory at the start ([`super::reset_peak_resident`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MeshMemory {
    /// Resident memory as the meshing began, in MB.
    pub before_mb: f64,
    /// The process's peak resident memory while meshing, in MB.
    pub peak_mb: f64,
    /// The meshing's own peak: `peak_mb - before_mb`, in MB.
    pub meshing_mb: f64,
    /// The meshing's own peak per triangle of the mesh, in bytes.
    pub bytes_per_triangle: Option<f64>,
}

impl MeshMemory {
    /// The memory of a meshing that began holding `before` bytes and made
    /// `triangles` triangles, read now.
    fn measured(before: Option<f64>, triangles: usize) -> Option<Self> {
        let (before, peak) = (before?, super::peak_resident_bytes()?);
        let own = (peak - before).max(0.0);
        Some(Self {
            before_mb: before / MB,
            peak_mb: peak / MB,
            meshing_mb: own / MB,
            bytes_per_triangle: (triangles > 0).then(|| own / triangles as f64),
        })
    }
}

/// The warning of a mesh without triangles.
pub const NO_SURFACE: &str =
    "no surface: the field never exceeds the threshold on the lattice (is the threshold above the field's maximum?)";

/// Polygonizes `model` evaluating its field in `mode`, from scratch (caches as
/// they are), after checking the settings and that the mesh fits in memory;
/// reports what it took (the check untimed).
pub fn polygonize(
    model: &Model,
    mode: EvalMode,
    settings: &PolygonizeSettings,
    progress: &dyn Progress,
) -> Result<(Mesh, MeshReport)> {
    stage(progress, "sizing the mesh", || settings.check(model))?;
    Ok(polygonize_checked(model, mode, settings, progress))
}

/// [`polygonize`] with settings already checked against `model`.
pub(super) fn polygonize_checked(
    model: &Model,
    mode: EvalMode,
    settings: &PolygonizeSettings,
    progress: &dyn Progress,
) -> (Mesh, MeshReport) {
    let coarse = Lattice::for_model(model, settings.res);
    let before = super::resident_bytes();
    super::reset_peak_resident();
    let (mut mesh, counts) = run_polygonizer(model, mode, coarse, settings.options(), settings.refine, progress);
    let fine = coarse.refined(settings.refine);
    let repairs = (!settings.repair.is_none())
        .then(|| stage(progress, "repairing the mesh", || repair_mesh(model, fine, &mut mesh, &settings.repair)));
    let memory = MeshMemory::measured(before, mesh.triangles.len());
    let mut report = report(model, mode, settings, &mesh, counts, &fine, progress);
    (report.repairs, report.memory) = (repairs, memory);
    (mesh, report)
}

fn report(
    model: &Model,
    mode: EvalMode,
    settings: &PolygonizeSettings,
    mesh: &Mesh,
    counts: RunCounts,
    lattice: &Lattice,
    progress: &dyn Progress,
) -> MeshReport {
    let seconds = counts.seconds;
    let start = Instant::now();
    let quality = stage(progress, "checking the mesh", || MeshQuality::at_level(mesh, settings.quality, Some(lattice)));
    let quality_seconds = start.elapsed().as_secs_f64();
    // Watertightness is reported whatever the level: it costs one pass over the edges.
    let closed_manifold = quality.as_ref().map_or_else(|| mesh.topology().is_closed_manifold(), |q| q.watertight)
        && !mesh.triangles.is_empty();
    let field_evals = counts.stats.field_evals();
    MeshReport {
        seconds,
        res: settings.fine_res(),
        coarse_res: (settings.refine > 0).then_some(settings.res),
        cell_size: lattice.cell,
        cells: cells_name(settings.cells).into(),
        vertex: vertex_name(settings.vertex).into(),
        triangles: mesh.triangles.len(),
        vertices: mesh.positions.len(),
        field_evals,
        evals_per_triangle: (!mesh.triangles.is_empty()).then(|| field_evals as f64 / mesh.triangles.len() as f64),
        work: counts.stats,
        crossed_cells: counts.crossed_cells,
        triangles_per_second: mesh.triangles.len() as f64 / seconds.max(1e-9),
        closed_manifold,
        warning: mesh.triangles.is_empty().then(|| NO_SURFACE.to_string()),
        quality,
        quality_seconds,
        memory: None,
        repairs: None,
        eval: format!("{mode:?}").to_lowercase(),
        threads: rayon::current_num_threads(),
        caches: (mode == EvalMode::Cached).then(|| CacheReport::of(model)),
        error_c: None,
    }
}

/// The name reports give a cell decomposition.
#[must_use]
pub fn cells_name(cells: CellShape) -> &'static str {
    match cells {
        CellShape::Cubes => "cubes",
        CellShape::Bcc => "bcc",
    }
}

/// The name reports give a vertex placement.
#[must_use]
pub fn vertex_name(vertex: VertexPlacement) -> &'static str {
    match vertex {
        VertexPlacement::Linear => "linear",
        _ => "root",
    }
}

/// What a polygonizer run counted.
struct RunCounts {
    /// Wall-clock seconds of the run.
    seconds: f64,
    stats: PolygonizeStats,
    crossed_cells: u64,
}

/// Polygonizes on `lattice` from the skeletons, then, for `refine > 0`, on the
/// lattice `2^refine` times finer from that surface. Counts cover both runs.
fn run_polygonizer(
    model: &Model,
    mode: EvalMode,
    lattice: Lattice,
    options: PolygonizeOptions,
    refine: u32,
    progress: &dyn Progress,
) -> (Mesh, RunCounts) {
    let start = Instant::now();
    let field = ModelField::new(model, mode);
    let mut coarse = Polygonizer::new(lattice, options);
    coarse.polygonize_reporting(&field, &skeleton_seeds(model, model.root()), progress);
    let mut stats = coarse.stats();
    let polygonizer = if refine == 0 {
        coarse
    } else {
        let mut fine = Polygonizer::new(lattice.refined(refine), options);
        stage(progress, "refining the mesh", || fine.refine(&field, &coarse, refine));
        stats = stats.plus(&fine.stats());
        fine
    };
    let mesh = stage(progress, "assembling the mesh", || polygonizer.mesh());
    let seconds = start.elapsed().as_secs_f64();
    (mesh, RunCounts { seconds, stats, crossed_cells: polygonizer.crossed_cells() as u64 })
}

/// A polygonizer over `model` on `lattice`, grown from the skeletons: what
/// local updates after edits start from, and what they are checked against.
#[must_use]
pub fn polygonizer_on(model: &Model, mode: EvalMode, lattice: Lattice, options: PolygonizeOptions) -> Polygonizer {
    let mut polygonizer = Polygonizer::new(lattice, options);
    polygonizer.polygonize(&ModelField::new(model, mode), &skeleton_seeds(model, model.root()));
    polygonizer
}

/// Colours `mesh` by error_C = |f_C(p) − f(p)| at its vertices, brightest at
/// `scale`, stores the errors in it and their statistics in `report`.
pub fn color_by_cache_error(model: &mut Model, mesh: &mut Mesh, scale: f32, report: &mut MeshReport) -> Result<()> {
    if model.counts().caches == 0 {
        return Err(PipelineError::Unsuitable("error_C measures the caches, and the scene has no Cache nodes".into()));
    }
    if !(scale.is_finite() && scale > 0.0) {
        return Err(PipelineError::setting("error_scale", format!("must be positive, got {scale}")));
    }
    // error_C is the caches' own error, whether or not auto mode uses them.
    let errors = model.with_every_lattice(|m| cache_error_at(m, &mesh.positions));
    report.error_c = Some(cache_error_stats(&errors, model.threshold()));
    mesh.colors = Some(error_colors(&errors, scale));
    mesh.error = Some(errors);
    Ok(())
}
