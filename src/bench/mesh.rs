//! Polygonization benchmarks: the caching paper's Table 1 (time with and
//! without caches over resolutions), evaluations per triangle, the
//! polygonizer's triangle rate on one thread and on all, and the mesh ray
//! caster's ray rate — all measured in one process.

use std::path::PathBuf;

use serde::Serialize;

use crate::field::EvalMode;
use crate::frame::Size;
use crate::mesh::{CellShape, VertexPlacement};
use crate::pipeline::{
    MAX_RES, MeshReport, PipelineError, PolygonizeSettings, Result, Silent, cells_name, polygonize, render_mesh,
    with_threads,
};
use crate::progress::Progress;
use crate::scene::Scene;

/// What `bench mesh` measures.
#[derive(Clone, Debug)]
pub struct MeshBenchSettings {
    /// Scene file for Table 1 and ray casting.
    pub scene: PathBuf,
    /// Resolutions of Table 1 (those that would not fit in memory are skipped).
    pub res: Vec<u32>,
    /// Resolution of the sphere (triangle rate) and of the ray-cast mesh.
    pub detail_res: u32,
    /// Image size of the mesh ray casting.
    pub size: Size,
    /// Cell decomposition.
    pub cells: CellShape,
    /// Worker threads (default: all cores; the paper's timings ran on one processor).
    pub threads: Option<usize>,
}

/// Measures every figure of `bench mesh`.
pub fn bench_mesh(settings: &MeshBenchSettings, progress: &dyn Progress) -> Result<MeshBenchReport> {
    let out_of_range = |r: &u32| !(1..=MAX_RES).contains(r);
    let bad = match settings.res.iter().find(|r| out_of_range(r)) {
        Some(&r) => Some(("res", r)),
        None => out_of_range(&settings.detail_res).then_some(("detail_res", settings.detail_res)),
    };
    if let Some((setting, r)) = bad {
        return Err(PipelineError::setting(setting, format!("must be between 1 and {MAX_RES}, got {r}")));
    }
    let scene = Scene::load(&settings.scene)?;
    with_threads(settings.threads, || measure(settings, scene, progress))?
}

/// One row of Table 1.
#[derive(Debug, Serialize)]
pub struct TableRow {
    /// Lattice cells along the longest side.
    pub res: u32,
    /// Seconds polygonizing through the caches, emptied first.
    pub cached_s: f64,
    /// Seconds polygonizing with exact naive evaluation (the paper's "no cache").
    pub naive_s: f64,
    /// Seconds polygonizing with exact indexed evaluation.
    pub indexed_s: f64,
    /// naive / cached: the paper's ratio.
    pub naive_over_cached: f64,
    /// indexed / cached.
    pub indexed_over_cached: f64,
    /// The paper's ratio at this resolution, where it gives one.
    pub paper_ratio: Option<f64>,
    /// Triangles of the cached and the exact mesh.
    pub triangles: (usize, usize),
    /// Field evaluations per triangle, cached and exact.
    pub evals_per_triangle: (f64, f64),
    /// Fraction of the cache lattices evaluated after the cached run.
    pub cache_touched_fraction: f64,
}

/// Evaluations per triangle by vertex placement, on the exact field.
#[derive(Debug, Serialize)]
pub struct PlacementCost {
    /// Cell decomposition: `cubes` or `bcc`.
    pub cells: String,
    /// Resolution.
    pub res: u32,
    /// With root finding (vertices to 1e-4 of an edge).
    pub root: f64,
    /// With linear interpolation of corner values.
    pub linear: f64,
}

/// The polygonizer's triangle rate on the sphere.
#[derive(Debug, Serialize)]
pub struct TriangleRate {
    /// Cells across the sphere's bounds.
    pub res: u32,
    /// Triangles.
    pub triangles: usize,
    /// Triangles per second on one thread.
    pub one_thread: f64,
    /// Triangles per second on all threads.
    pub all_threads: f64,
    /// Threads in the second run.
    pub threads: usize,
}

/// Primary-ray rate of the mesh ray caster.
#[derive(Debug, Serialize)]
pub struct RayRate {
    /// Mesh resolution.
    pub res: u32,
    /// Triangles in the BVH.
    pub triangles: usize,
    /// Image size.
    pub width: u32,
    /// Image size.
    pub height: u32,
    /// Seconds building the CWBVH.
    pub bvh_build_s: f64,
    /// Primary rays per second.
    pub rays_per_second: f64,
}

/// What `bench mesh --json` prints.
#[derive(Debug, Serialize)]
pub struct MeshBenchReport {
    /// Worker threads of Table 1, the ray casting and the sphere's second run.
    pub threads: usize,
    /// Table 1 rows.
    pub table1: Vec<TableRow>,
    /// Resolutions skipped for memory.
    pub skipped_res: Vec<u32>,
    /// Evaluations per triangle, root finding against linear placement, for
    /// cubes and for the second paper's tetrahedra (whatever `--cells` says).
    pub evals_per_triangle: Vec<PlacementCost>,
    /// Sphere triangle rate.
    pub sphere: TriangleRate,
    /// Mesh ray casting on the scene's mesh.
    pub ray_casting: RayRate,
}

/// The first paper's cached/uncached ratios at 32, 64, 128, 256 and 512.
const PAPER_RATIOS: [(u32, f64); 5] = [(32, 0.8), (64, 1.4), (128, 3.0), (256, 6.5), (512, 16.0)];

/// Every figure of the report, on the calling pool's threads.
fn measure(a: &MeshBenchSettings, mut scene: Scene, progress: &dyn Progress) -> Result<MeshBenchReport> {
    let mut table1 = vec![];
    let mut skipped_res = vec![];
    for (row, &res) in a.res.iter().enumerate() {
        progress.update("Table 1 rows", row as u64, a.res.len() as u64);
        let settings = PolygonizeSettings { res, cells: a.cells, ..Default::default() };
        if settings.check(&scene.model).is_err() {
            skipped_res.push(res);
            continue;
        }
        table1.push(table_row(&mut scene, &settings)?);
    }
    progress.update("triangle and ray rates", 0, 0);
    let detail = PolygonizeSettings { res: a.detail_res, cells: a.cells, ..Default::default() };
    detail.check(&scene.model)?;
    let evals_per_triangle = [CellShape::Cubes, CellShape::Bcc]
        .into_iter()
        .map(|cells| placement_cost(&scene, PolygonizeSettings { cells, ..detail }))
        .collect::<Result<_>>()?;
    let sphere = triangle_rate(&detail)?;
    let (mesh, mesh_report) = polygonize(&scene.model, EvalMode::Indexed, &detail, &Silent)?;
    let (_, render) = render_mesh(&scene, &mesh, mesh_report, (a.size, 1), &Silent);
    let ray_casting = RayRate {
        res: detail.res,
        triangles: mesh.triangles.len(),
        width: a.size.0,
        height: a.size.1,
        bvh_build_s: render.bvh_build_seconds,
        rays_per_second: render.rays_per_second,
    };
    let threads = rayon::current_num_threads();
    Ok(MeshBenchReport { threads, table1, skipped_res, evals_per_triangle, sphere, ray_casting })
}

fn table_row(scene: &mut Scene, args: &PolygonizeSettings) -> Result<TableRow> {
    // The exact index packs a cell's list for the eight-wide sums on its
    // first sum there, and a cache fills its samples with exact sums. An
    // untimed exact polygonization packs the lists this row reads, so the
    // cached run starts from empty caches but packed lists, as the indexed
    // run does: a row's figures no longer depend on the rows before it (a
    // lone `--res 512` paid a third of a second for packing in its cached run).
    let run = |scene: &Scene, mode| polygonize(&scene.model, mode, args, &Silent).map(|(_, report)| report);
    run(scene, EvalMode::Indexed)?;
    scene.model.set_cache_budget(None);
    let cached = run(scene, EvalMode::Cached)?;
    let touched = cached.caches.as_ref().map_or(0.0, |c| c.touched_fraction);
    let (naive, indexed) = (run(scene, EvalMode::Naive)?, run(scene, EvalMode::Indexed)?);
    let ratio = |other: &MeshReport| other.seconds / cached.seconds.max(1e-9);
    Ok(TableRow {
        res: args.res,
        cached_s: cached.seconds,
        naive_s: naive.seconds,
        indexed_s: indexed.seconds,
        naive_over_cached: ratio(&naive),
        indexed_over_cached: ratio(&indexed),
        paper_ratio: PAPER_RATIOS.iter().find(|(r, _)| *r == args.res).map(|&(_, x)| x),
        triangles: (cached.triangles, indexed.triangles),
        evals_per_triangle: (per_triangle(&cached), per_triangle(&indexed)),
        cache_touched_fraction: touched,
    })
}

/// Evaluations per triangle of `args`'s cells with each vertex placement.
fn placement_cost(scene: &Scene, args: PolygonizeSettings) -> Result<PlacementCost> {
    let run = |vertex| polygonize(&scene.model, EvalMode::Indexed, &PolygonizeSettings { vertex, ..args }, &Silent);
    let (root, linear) = (run(VertexPlacement::default())?.1, run(VertexPlacement::Linear)?.1);
    let cells = cells_name(args.cells).to_string();
    Ok(PlacementCost { cells, res: args.res, root: per_triangle(&root), linear: per_triangle(&linear) })
}

/// The bundled sphere polygonized at `detail`'s resolution, on one thread and on all.
fn triangle_rate(detail: &PolygonizeSettings) -> Result<TriangleRate> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/sphere.ron");
    let sphere = Scene::load(path)?;
    let run = || polygonize(&sphere.model, EvalMode::Indexed, detail, &Silent).map(|(_, report)| report);
    let one = with_threads(Some(1), run)??;
    let all = run()?;
    Ok(TriangleRate {
        res: detail.res,
        triangles: all.triangles,
        one_thread: one.triangles_per_second,
        all_threads: all.triangles_per_second,
        threads: all.threads,
    })
}

/// Evaluations per triangle, NaN (null in JSON) for a mesh without any: the
/// bench's scenes all have a surface, so a NaN says a bench scene lost it.
fn per_triangle(report: &MeshReport) -> f64 {
    report.evals_per_triangle.unwrap_or(f64::NAN)
}
