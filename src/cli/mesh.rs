//! `blobtrace mesh`: polygonize a scene and write PLY, OBJ or STL; and the
//! polygonizer options shared with `render --mesh` and `bench mesh`.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::{Args, ValueEnum};
use serde::Serialize;

use super::render::CacheReport;
use super::{EvalOptions, check_output_dir, scene_stem, with_threads};
use crate::compare::{CacheErrorStats, cache_error_at, cache_error_stats, error_colors};
use crate::field::{EvalMode, ModelField};
use crate::mesh::{
    CellShape, Lattice, Mesh, MeshFormat, PolygonizeOptions, PolygonizeStats, Polygonizer, Topology, TriangleQuality,
    VertexPlacement, skeleton_seeds, write_mesh,
};
use crate::scene::Scene;

/// Cell decomposition.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum CellsArg {
    /// Cubes with the watertight marching-cubes table.
    #[default]
    Cubes,
    /// Body-centred-cubic tetrahedra.
    Bcc,
}

/// Vertex placement on crossed edges.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum VertexArg {
    /// Illinois root finding to 1e-4 of the edge.
    #[default]
    Root,
    /// Linear interpolation of the corner values (no evaluation; a preview).
    Linear,
}

/// How to polygonize: shared by every command that builds a mesh.
#[derive(Clone, Copy, Debug, Args)]
pub struct PolygonizeArgs {
    /// Lattice cells along the longest side of the model's bounds.
    #[arg(long, default_value_t = 128)]
    pub res: u32,
    /// Cell decomposition.
    #[arg(long, value_enum, default_value_t = CellsArg::Cubes)]
    pub cells: CellsArg,
    /// Vertex placement.
    #[arg(long, value_enum, default_value_t = VertexArg::Root)]
    pub vertex: VertexArg,
    /// Refine K levels: polygonize at res·2^K, grown from the surface found at
    /// res instead of from the skeletons (coarse and fine meshes of one lattice family).
    #[arg(long, default_value_t = 0, value_name = "K")]
    pub refine: u32,
}

/// Highest resolution accepted: lattice coordinates and memory stay reasonable.
pub(super) const MAX_RES: u32 = 8192;
/// Bytes the polygonizer and its mesh hold per crossed cell (corners, cells,
/// vertices, triangles and hash-map overhead), measured on the bundled scenes.
const BYTES_PER_CROSSED_CELL: f64 = 400.0;
/// Most refinement levels accepted.
const MAX_REFINE: u32 = 6;
/// Resolution of the cheap probe that sizes the surface before the real run.
const PROBE_RES: u32 = 24;

impl PolygonizeArgs {
    /// The polygonizer's options.
    #[must_use]
    pub fn options(&self) -> PolygonizeOptions {
        PolygonizeOptions {
            cells: match self.cells {
                CellsArg::Cubes => CellShape::Cubes,
                CellsArg::Bcc => CellShape::Bcc,
            },
            vertex: match self.vertex {
                VertexArg::Root => VertexPlacement::default(),
                VertexArg::Linear => VertexPlacement::Linear,
            },
        }
    }

    /// [`Self::check`] for commands that update a mesh locally after edits,
    /// which they do on the lattice of `--res` alone: `--refine` is refused
    /// rather than ignored.
    pub fn check_unrefined(&self, scene: &Scene, command: &str) -> anyhow::Result<()> {
        anyhow::ensure!(
            self.refine == 0,
            "--refine does not apply to `{command}`, whose local updates run on the --res lattice (use `mesh` or `render --mesh`)"
        );
        self.check(scene)
    }

    /// Checks the resolution before any work: in range, and the mesh it would
    /// make (sized by a coarse probe polygonization, exact so that no cache is
    /// warmed) fits in memory.
    pub fn check(&self, scene: &Scene) -> anyhow::Result<()> {
        anyhow::ensure!((1..=MAX_RES).contains(&self.res), "--res must be between 1 and {MAX_RES}, got {}", self.res);
        anyhow::ensure!(self.refine <= MAX_REFINE, "--refine must be at most {MAX_REFINE}, got {}", self.refine);
        let fine_res = u64::from(self.res) << self.refine;
        anyhow::ensure!(
            fine_res <= u64::from(MAX_RES),
            "--res {} refined {} times exceeds {MAX_RES}",
            self.res,
            self.refine
        );
        let probe_res = self.res.min(PROBE_RES);
        let probe_options = PolygonizeOptions { vertex: VertexPlacement::Linear, ..self.options() };
        let probe = Lattice::for_model(&scene.model, probe_res);
        let crossed = run_polygonizer(scene, EvalMode::Indexed, probe, probe_options, 0).1.crossed_cells as f64;
        let scale = (fine_res as f64 / f64::from(probe_res)).powi(2);
        let needed = crossed * scale * BYTES_PER_CROSSED_CELL;
        let available = available_memory_bytes();
        anyhow::ensure!(
            needed < 0.8 * available,
            "--res {} would need about {:.1} GiB for the mesh, more than the {:.1} GiB available",
            self.res,
            needed / GIB,
            available / GIB
        );
        Ok(())
    }
}

const GIB: f64 = 1024.0 * 1024.0 * 1024.0;

/// Memory available to the process in bytes (Linux `MemAvailable`; 8 GiB where unknown).
fn available_memory_bytes() -> f64 {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|s| {
            let line = s.lines().find(|l| l.starts_with("MemAvailable:"))?;
            line.split_whitespace().nth(1)?.parse::<f64>().ok()
        })
        .map_or(8.0 * GIB, |kb| kb * 1024.0)
}

/// Options of `blobtrace mesh`.
#[derive(Debug, Args)]
pub struct MeshArgs {
    /// Scene file (RON), e.g. scenes/medusa.ron.
    pub scene: PathBuf,
    /// Output mesh: .ply (binary, with normals and colours), .obj or .stl.
    /// Defaults to SCENE's name with .ply in the current directory.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Polygonizer options.
    #[command(flatten)]
    pub polygonize: PolygonizeArgs,
    /// Worker threads (default: all cores). The mesh is identical for any count.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Field evaluation: exact or cached, and the cache budget.
    #[command(flatten)]
    pub field: EvalOptions,
    /// Colour the vertices by error_C = |f_C − f| (cached against exact field) and
    /// store it in the PLY as `error`; print its mean and maximum.
    #[command(flatten)]
    pub error: CacheErrorArgs,
    /// Print one JSON object of statistics on stdout instead of a summary line.
    #[arg(long)]
    pub json: bool,
}

/// Colouring a mesh by the caches' reconstruction error.
#[derive(Clone, Copy, Debug, Args)]
pub struct CacheErrorArgs {
    /// Colour vertices by error_C = |f_C(p) − f(p)| (needs Cache nodes).
    #[arg(long)]
    pub error: bool,
    /// The error drawn brightest (default 0.05, a tenth of the usual iso-value).
    #[arg(long, default_value_t = 0.05, value_name = "E")]
    pub error_scale: f32,
}

impl CacheErrorArgs {
    /// With `--error`, colours `mesh` by error_C and records its statistics in `report`.
    pub fn apply(&self, scene: &Scene, mesh: &mut Mesh, report: &mut MeshReport) -> anyhow::Result<()> {
        if !self.error {
            return Ok(());
        }
        anyhow::ensure!(
            scene.model.counts().caches > 0,
            "--error measures the caches, and the scene has no Cache nodes"
        );
        anyhow::ensure!(
            self.error_scale.is_finite() && self.error_scale > 0.0,
            "--error-scale must be positive, got {}",
            self.error_scale
        );
        let errors = cache_error_at(&scene.model, &mesh.positions);
        report.error_c = Some(cache_error_stats(&errors, scene.model.threshold()));
        mesh.colors = Some(error_colors(&errors, self.error_scale));
        mesh.error = Some(errors);
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
    /// Field evaluations per triangle.
    pub evals_per_triangle: f64,
    /// Evaluations by kind and cells visited.
    #[serde(flatten)]
    pub work: PolygonizeStats,
    /// Cells the surface crosses.
    pub crossed_cells: u64,
    /// Triangles per second.
    pub triangles_per_second: f64,
    /// Triangle shape quality.
    pub quality: TriangleQuality,
    /// Edge sharing and orientation.
    pub topology: Topology,
    /// True when every edge is shared by exactly two consistently oriented triangles.
    pub closed_manifold: bool,
    /// Evaluation mode: naive, indexed or cached.
    pub eval: String,
    /// Threads used.
    pub threads: usize,
    /// What the caches hold and did, when polygonizing cached.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub caches: Option<CacheReport>,
    /// error_C at the vertices, with `--error`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error_c: Option<CacheErrorStats>,
}

/// Runs `blobtrace mesh`.
pub fn run(a: &MeshArgs) -> anyhow::Result<()> {
    let mut scene = Scene::load(&a.scene)?;
    let mode = a.field.apply(&mut scene.model)?;
    let output = a.output.clone().unwrap_or_else(|| PathBuf::from(format!("{}.ply", scene_stem(&a.scene))));
    let format = MeshFormat::from_path(&output).map_err(anyhow::Error::msg)?;
    check_output_dir(&output)?;
    let (mesh, report) = with_threads(a.threads, || -> anyhow::Result<_> {
        a.polygonize.check(&scene)?;
        let (mut mesh, mut report) = polygonize_scene(&scene, mode, &a.polygonize);
        a.error.apply(&scene, &mut mesh, &mut report)?;
        Ok((mesh, report))
    })??;
    write_mesh(&output, &mesh, format).with_context(|| format!("writing {}", output.display()))?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report).context("encoding the report")?);
    } else {
        eprintln!(
            "{}: {} triangles, {} vertices in {:.3} s, {:.2} field evaluations per triangle{}",
            output.display(),
            report.triangles,
            report.vertices,
            report.seconds,
            report.evals_per_triangle,
            if report.closed_manifold { ", closed" } else { ", NOT closed" }
        );
        if let Some(e) = report.error_c {
            eprintln!(
                "error_C at the vertices: mean {:.2e} ({:.2}% of T), max {:.2e} ({:.1}% of T)",
                e.mean,
                100.0 * e.mean_relative,
                e.max,
                100.0 * e.max_relative
            );
        }
    }
    Ok(())
}

/// Polygonizes `scene` evaluating its field in `mode`, from scratch (caches as
/// they are), and reports what it took.
#[must_use]
pub fn polygonize_scene(scene: &Scene, mode: EvalMode, args: &PolygonizeArgs) -> (Mesh, MeshReport) {
    let coarse = Lattice::for_model(&scene.model, args.res);
    let lattice = coarse.refined(args.refine);
    let start = Instant::now();
    let (mesh, counts) = run_polygonizer(scene, mode, coarse, args.options(), args.refine);
    let seconds = start.elapsed().as_secs_f64();
    let topology = mesh.topology();
    let field_evals = counts.stats.field_evals();
    let report = MeshReport {
        seconds,
        res: args.res << args.refine,
        coarse_res: (args.refine > 0).then_some(args.res),
        cell_size: lattice.cell,
        cells: format!("{:?}", args.cells).to_lowercase(),
        vertex: format!("{:?}", args.vertex).to_lowercase(),
        triangles: mesh.triangles.len(),
        vertices: mesh.positions.len(),
        field_evals,
        evals_per_triangle: field_evals as f64 / mesh.triangles.len().max(1) as f64,
        work: counts.stats,
        crossed_cells: counts.crossed_cells,
        triangles_per_second: mesh.triangles.len() as f64 / seconds.max(1e-9),
        quality: mesh.quality(),
        topology,
        closed_manifold: topology.is_closed_manifold(),
        eval: format!("{mode:?}").to_lowercase(),
        threads: rayon::current_num_threads(),
        caches: (mode == EvalMode::Cached).then(|| CacheReport::of(&scene.model)),
        error_c: None,
    };
    (mesh, report)
}

/// What a polygonizer run counted.
struct RunCounts {
    stats: PolygonizeStats,
    crossed_cells: u64,
}

/// Polygonizes on `lattice` from the skeletons, then, for `refine > 0`, on the
/// lattice `2^refine` times finer from that surface. Counts cover both runs.
fn run_polygonizer(
    scene: &Scene,
    mode: EvalMode,
    lattice: Lattice,
    options: PolygonizeOptions,
    refine: u32,
) -> (Mesh, RunCounts) {
    let field = ModelField::new(&scene.model, mode);
    let mut coarse = Polygonizer::new(lattice, options);
    coarse.polygonize(&field, &skeleton_seeds(&scene.model, scene.model.root()));
    let mut stats = coarse.stats();
    let polygonizer = if refine == 0 {
        coarse
    } else {
        let mut fine = Polygonizer::new(lattice.refined(refine), options);
        fine.refine(&field, &coarse, refine);
        stats = stats.plus(&fine.stats());
        fine
    };
    let mesh = polygonizer.mesh();
    (mesh, RunCounts { stats, crossed_cells: polygonizer.crossed_cells() as u64 })
}
