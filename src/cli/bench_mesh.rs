//! `blobtrace bench mesh`: the first paper's Table 1 (polygonization time with
//! and without caches over resolutions), evaluations per triangle, the
//! polygonizer's triangle rate on one thread and on all, and the mesh ray
//! caster's ray rate — all measured in one process.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde::Serialize;

use super::mesh::{CellsArg, MeshReport, PolygonizeArgs, VertexArg, polygonize_scene};
use super::render::render_polygonized;
use super::with_threads;
use crate::field::EvalMode;
use crate::scene::{Scene, Size};

/// Options of `blobtrace bench mesh`.
#[derive(Debug, Args)]
pub struct MeshBenchArgs {
    /// Scene file (RON) for Table 1 and ray casting.
    #[arg(default_value = "scenes/medusa.ron")]
    pub scene: PathBuf,
    /// Resolutions of Table 1 (those that would not fit in memory are skipped).
    #[arg(long, value_delimiter = ',', default_value = "32,64,128,256,512")]
    pub res: Vec<u32>,
    /// Resolution of the sphere (triangle rate) and of the ray-cast mesh.
    #[arg(long, default_value_t = 256)]
    pub detail_res: u32,
    /// Image size of the mesh ray casting.
    #[arg(long, value_parser = super::parse_size, default_value = "640x480")]
    pub size: Size,
    /// Cell decomposition.
    #[arg(long, value_enum, default_value_t = CellsArg::Cubes)]
    pub cells: CellsArg,
    /// Worker threads (default: all cores; the paper's timings ran on one processor).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
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

/// Runs `blobtrace bench mesh`.
pub fn run(a: &MeshBenchArgs) -> anyhow::Result<()> {
    let max = super::mesh::MAX_RES;
    if let Some(bad) = a.res.iter().chain([&a.detail_res]).find(|r| !(1..=max).contains(*r)) {
        anyhow::bail!("--res and --detail-res must be between 1 and {max}, got {bad}");
    }
    let scene = Scene::load(&a.scene)?;
    let report = with_threads(a.threads, || measure(a, scene))??;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report).context("encoding the report")?);
    } else {
        print_report(a, &report);
    }
    Ok(())
}

/// Every figure of the report, on the calling pool's threads.
fn measure(a: &MeshBenchArgs, mut scene: Scene) -> anyhow::Result<MeshBenchReport> {
    let mut table1 = vec![];
    let mut skipped_res = vec![];
    for &res in &a.res {
        let args = PolygonizeArgs { res, cells: a.cells, vertex: VertexArg::Root, refine: 0 };
        if args.check(&scene).is_err() {
            skipped_res.push(res);
            continue;
        }
        table1.push(table_row(&mut scene, &args));
    }
    let detail = PolygonizeArgs { res: a.detail_res, cells: a.cells, vertex: VertexArg::Root, refine: 0 };
    detail.check(&scene)?;
    let evals_per_triangle = [CellsArg::Cubes, CellsArg::Bcc]
        .into_iter()
        .map(|cells| placement_cost(&scene, PolygonizeArgs { cells, ..detail }))
        .collect();
    let sphere = triangle_rate(&detail)?;
    let (mesh, mesh_report) = polygonize_scene(&scene, EvalMode::Indexed, &detail);
    let (_, render) = render_polygonized(&scene, &mesh, mesh_report, a.size);
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

fn table_row(scene: &mut Scene, args: &PolygonizeArgs) -> TableRow {
    // The exact index packs a cell's list for the eight-wide sums on its
    // first sum there, and a cache fills its samples with exact sums. An
    // untimed exact polygonization packs the lists this row reads, so the
    // cached run starts from empty caches but packed lists, as the indexed
    // run does: a row's figures no longer depend on the rows before it (a
    // lone `--res 512` paid a third of a second for packing in its cached run).
    let _ = polygonize_scene(scene, EvalMode::Indexed, args);
    scene.model.set_cache_budget(None);
    let (_, cached) = polygonize_scene(scene, EvalMode::Cached, args);
    let touched = cached.caches.as_ref().map_or(0.0, |c| c.touched_fraction);
    let (_, naive) = polygonize_scene(scene, EvalMode::Naive, args);
    let (_, indexed) = polygonize_scene(scene, EvalMode::Indexed, args);
    let ratio = |other: &MeshReport| other.seconds / cached.seconds.max(1e-9);
    TableRow {
        res: args.res,
        cached_s: cached.seconds,
        naive_s: naive.seconds,
        indexed_s: indexed.seconds,
        naive_over_cached: ratio(&naive),
        indexed_over_cached: ratio(&indexed),
        paper_ratio: PAPER_RATIOS.iter().find(|(r, _)| *r == args.res).map(|&(_, x)| x),
        triangles: (cached.triangles, indexed.triangles),
        evals_per_triangle: (cached.evals_per_triangle, indexed.evals_per_triangle),
        cache_touched_fraction: touched,
    }
}

/// Evaluations per triangle of `args`'s cells with each vertex placement.
fn placement_cost(scene: &Scene, args: PolygonizeArgs) -> PlacementCost {
    let run = |vertex| polygonize_scene(scene, EvalMode::Indexed, &PolygonizeArgs { vertex, ..args }).1;
    let (root, linear) = (run(VertexArg::Root), run(VertexArg::Linear));
    PlacementCost { cells: root.cells, res: args.res, root: root.evals_per_triangle, linear: linear.evals_per_triangle }
}

/// The bundled sphere polygonized at `detail`'s resolution, on one thread and on all.
fn triangle_rate(detail: &PolygonizeArgs) -> anyhow::Result<TriangleRate> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/sphere.ron");
    let sphere = Scene::load(path)?;
    let one = with_threads(Some(1), || polygonize_scene(&sphere, EvalMode::Indexed, detail).1)?;
    let all = polygonize_scene(&sphere, EvalMode::Indexed, detail).1;
    Ok(TriangleRate {
        res: detail.res,
        triangles: all.triangles,
        one_thread: one.triangles_per_second,
        all_threads: all.triangles_per_second,
        threads: all.threads,
    })
}

fn print_report(a: &MeshBenchArgs, r: &MeshBenchReport) {
    println!("{}: polygonization seconds (Table 1), {} threads", a.scene.display(), r.threads);
    println!("  res     cached     naive   indexed  naive/cached (paper)  indexed/cached  triangles  evals/tri");
    for row in &r.table1 {
        println!(
            "  {:4} {:9.3} {:9.3} {:9.3} {:10.1}x ({:>5}) {:12.1}x {:10} {:6.2} / {:.2}",
            row.res,
            row.cached_s,
            row.naive_s,
            row.indexed_s,
            row.naive_over_cached,
            row.paper_ratio.map_or("-".into(), |p| format!("{p}x")),
            row.indexed_over_cached,
            row.triangles.0,
            row.evals_per_triangle.0,
            row.evals_per_triangle.1
        );
    }
    if !r.skipped_res.is_empty() {
        println!("  skipped (would not fit in memory): {:?}", r.skipped_res);
    }
    let per_cells: Vec<String> =
        r.evals_per_triangle.iter().map(|e| format!("{} {:.2} / {:.2}", e.cells, e.root, e.linear)).collect();
    println!("evaluations per triangle at res {} (root finding / linear): {}", a.detail_res, per_cells.join(", "));
    let s = &r.sphere;
    println!(
        "sphere at res {}: {} triangles, {:.0} triangles/s on 1 thread, {:.0} on {}",
        s.res, s.triangles, s.one_thread, s.all_threads, s.threads
    );
    let c = &r.ray_casting;
    println!(
        "mesh ray casting at res {} ({} triangles, BVH built in {:.3} s): {:.0} rays/s at {}x{}",
        c.res, c.triangles, c.bvh_build_s, c.rays_per_second, c.width, c.height
    );
}
