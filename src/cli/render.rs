//! `blobtrace render`: trace a scene's field to a PNG and an EXR.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::Args;
use serde::Serialize;

use super::mesh::{MeshReport, PolygonizeArgs, polygonize_scene};
use super::progress::Progress;
use super::{EvalOptions, check_output_file, scene_stem, with_threads};
use crate::bvh::{MeshBvh, MeshRenderStats, StaticMesh, render_mesh};
use crate::cache::{CacheStats, SLOT_BYTES};
use crate::field::{EvalMode, Model, NodeKind};
use crate::frame::Frame;
use crate::mesh::Mesh;
use crate::scene::{Scene, Size};
use crate::trace::{RenderSettings, RenderStats, render_model};

/// Options of `blobtrace render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    /// Scene file (RON), e.g. scenes/medusa.ron.
    pub scene: PathBuf,
    /// Output PNG (8-bit sRGB). Defaults to SCENE's name with .png in the current directory.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Also write every AOV (R,G,B,A, Z, N.X/N.Y/N.Z, steps.Y, evals.Y) to this EXR.
    #[arg(long)]
    pub exr: Option<PathBuf>,
    /// Image size WIDTHxHEIGHT, overriding the scene's `size`.
    #[arg(long, value_parser = super::parse_size)]
    pub size: Option<Size>,
    /// Worker threads (default: all cores). The image is identical for any count.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Field evaluation: exact or cached, and the cache budget.
    #[command(flatten)]
    pub field: EvalOptions,
    /// Render the polygonized surface (ray cast through a BVH) instead of the field.
    #[arg(long)]
    pub mesh: bool,
    /// Polygonizer options, with --mesh.
    #[command(flatten)]
    pub polygonize: PolygonizeArgs,
    /// Print one JSON object of statistics on stdout instead of a summary line.
    #[arg(long)]
    pub json: bool,
}

/// Statistics printed by `render --mesh --json`.
#[derive(Debug, Serialize)]
pub struct MeshRenderReport {
    /// Wall-clock seconds spent ray casting the mesh.
    pub seconds: f64,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Rays, hits and triangle tests.
    #[serde(flatten)]
    pub stats: MeshRenderStats,
    /// Rays cast per second.
    pub rays_per_second: f64,
    /// Seconds building the BVH.
    pub bvh_build_seconds: f64,
    /// The polygonization.
    pub mesh: MeshReport,
}

/// Statistics printed by `render --json`.
#[derive(Debug, Serialize)]
pub struct RenderReport {
    /// Wall-clock seconds spent tracing, marking the empty space included.
    pub seconds: f64,
    /// Fraction of the empty-space grid's cells where the surface cannot be.
    pub empty_fraction: f64,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Rays, hits, evaluations and steps.
    #[serde(flatten)]
    pub stats: RenderStats,
    /// Rays traced per second.
    pub rays_per_second: f64,
    /// Field evaluations per ray.
    pub evals_per_ray: f64,
    /// Evaluation mode: naive, indexed or cached.
    pub eval: String,
    /// Threads used.
    pub threads: usize,
    /// What the caches hold and did, when rendering cached.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub caches: Option<CacheReport>,
}

/// Cache statistics of a cached render: totals, then each cache.
#[derive(Clone, Debug, Serialize)]
pub struct CacheReport {
    /// Samples evaluated from the subtrees (including re-evaluations after eviction).
    pub samples_evaluated: u64,
    /// Blocks held.
    pub blocks: u64,
    /// Bytes of sample storage held.
    pub bytes: u64,
    /// Lattice points over the caches' subtrees (what dense grids would hold).
    pub grid_points: u64,
    /// Samples held over lattice points.
    pub touched_fraction: f64,
    /// Reconstructions asked of the caches.
    pub lookups: u64,
    /// Blocks evicted to stay within the budget.
    pub evictions: u64,
    /// The budget in bytes, if any.
    pub budget_bytes: Option<u64>,
    /// Each cache, by the name above it.
    pub per_cache: Vec<NamedCacheStats>,
}

/// One cache's statistics.
#[derive(Clone, Debug, Serialize)]
pub struct NamedCacheStats {
    /// The nearest name above the cache.
    pub name: String,
    /// Its resolution.
    pub res: u32,
    /// What it holds and did.
    #[serde(flatten)]
    pub stats: CacheStats,
}

impl CacheReport {
    /// The statistics of every cache of `model`.
    #[must_use]
    pub fn of(model: &Model) -> Self {
        let per_cache: Vec<NamedCacheStats> = model
            .cache_stats()
            .into_iter()
            .map(|(id, name, stats)| {
                let res = match model.node(id).kind {
                    NodeKind::Cache { spec, .. } => spec.res,
                    _ => 0,
                };
                NamedCacheStats { name, res, stats }
            })
            .collect();
        let sum = |f: fn(&CacheStats) -> u64| per_cache.iter().map(|c| f(&c.stats)).sum::<u64>();
        let (held, grid_points) = (sum(|s| s.samples_held), sum(|s| s.grid_points));
        Self {
            samples_evaluated: sum(|s| s.samples_evaluated),
            blocks: sum(|s| s.blocks),
            bytes: sum(|s| s.bytes),
            grid_points,
            touched_fraction: held as f64 / grid_points.max(1) as f64,
            lookups: sum(|s| s.lookups),
            evictions: model.pool().evictions(),
            budget_bytes: model.pool().budget_slots().map(|n| (n * SLOT_BYTES) as u64),
            per_cache,
        }
    }
}

/// Runs `blobtrace render`.
pub fn run(a: &RenderArgs) -> anyhow::Result<()> {
    let mut scene = Scene::load(&a.scene)?;
    let mode = a.field.apply(&mut scene.model)?;
    let output = a.output.clone().unwrap_or_else(|| PathBuf::from(format!("{}.png", scene_stem(&a.scene))));
    check_output_file(&output, "png")?;
    if let Some(exr) = &a.exr {
        check_output_file(exr, "exr")?;
    }
    let size = a.size.unwrap_or(scene.size);
    if a.mesh {
        return render_mesh_scene(a, &scene, mode, size, &output);
    }
    let (frame, report) = with_threads(a.threads, || render_scene(&scene, size, mode))?;
    save_frame(&frame, &output, a.exr.as_deref())?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report).context("encoding the report")?);
    } else {
        eprintln!(
            "{}: {}x{} in {:.3} s, {} of {} rays hit, {:.1} field evaluations per ray",
            output.display(),
            report.width,
            report.height,
            report.seconds,
            report.stats.hits,
            report.stats.rays,
            report.evals_per_ray
        );
    }
    Ok(())
}

fn save_frame(frame: &Frame, png: &std::path::Path, exr: Option<&std::path::Path>) -> anyhow::Result<()> {
    frame.save_png(png)?;
    if let Some(exr) = exr {
        frame.save_exr(exr)?;
    }
    Ok(())
}

/// `render --mesh`: polygonize, build the BVH, ray cast the mesh.
fn render_mesh_scene(
    a: &RenderArgs,
    scene: &Scene,
    mode: EvalMode,
    size: Size,
    output: &std::path::Path,
) -> anyhow::Result<()> {
    let (frame, report) = with_threads(a.threads, || -> anyhow::Result<_> {
        a.polygonize.check(scene)?;
        let (mesh, mesh_report) = polygonize_scene(scene, mode, &a.polygonize);
        Ok(render_polygonized(scene, &mesh, mesh_report, size))
    })??;
    save_frame(&frame, output, a.exr.as_deref())?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report).context("encoding the report")?);
    } else {
        eprintln!(
            "{}: {}x{} mesh of {} triangles (res {}) in {:.3} s, ray cast in {:.3} s, {} of {} rays hit",
            output.display(),
            report.width,
            report.height,
            report.mesh.triangles,
            report.mesh.res,
            report.mesh.seconds,
            report.seconds,
            report.stats.hits,
            report.stats.rays
        );
    }
    Ok(())
}

/// Builds the BVH over `mesh` and ray casts it with `scene`'s camera at `size`, timing it.
#[must_use]
pub fn render_polygonized(
    scene: &Scene,
    mesh: &Mesh,
    mesh_report: MeshReport,
    size: Size,
) -> (Frame, MeshRenderReport) {
    let settings = RenderSettings::for_scene(scene, size);
    let bvh = MeshBvh::build(mesh);
    let progress = Progress::new(u64::from(size.1), "ray casting the mesh");
    let start = Instant::now();
    let (frame, stats) = render_mesh(&StaticMesh { mesh, bvh: &bvh }, &settings, &|rows| progress.set(rows));
    let seconds = start.elapsed().as_secs_f64();
    progress.finish();
    let report = MeshRenderReport {
        seconds,
        width: size.0,
        height: size.1,
        stats,
        rays_per_second: stats.rays as f64 / seconds.max(1e-9),
        bvh_build_seconds: bvh.build_seconds,
        mesh: mesh_report,
    };
    (frame, report)
}

/// Renders `scene` at `size` evaluating its field in `mode`, timing it.
pub fn render_scene(scene: &Scene, size: Size, mode: EvalMode) -> (Frame, RenderReport) {
    let settings = RenderSettings::for_scene(scene, size);
    let progress = Progress::new(u64::from(size.1), "tracing");
    let start = Instant::now();
    let (frame, stats, empty) = render_model(&scene.model, mode, &settings, &|rows| progress.set(rows));
    let seconds = start.elapsed().as_secs_f64();
    progress.finish();
    let report = RenderReport {
        seconds,
        empty_fraction: empty.empty_fraction(),
        width: size.0,
        height: size.1,
        stats,
        rays_per_second: stats.rays as f64 / seconds.max(1e-9),
        evals_per_ray: stats.field_evals as f64 / stats.rays.max(1) as f64,
        eval: format!("{mode:?}").to_lowercase(),
        threads: rayon::current_num_threads(),
        caches: (mode == EvalMode::Cached).then(|| CacheReport::of(&scene.model)),
    };
    (frame, report)
}
