//! `blobtrace bench`: performance figures measured in one process, reported
//! as ratios against the baseline on the same scene (the measuring is
//! [`crate::bench`]'s; this file parses and prints).

use std::path::PathBuf;

use clap::{Args, Subcommand};

use super::args::{CellsArg, TracerArg, check_output_file, parse_size, print_json};
use super::progress::Bars;
use crate::bench::{
    CacheBenchReport, EditBenchReport, EditBenchSettings, EvalBenchReport, LookupCost, MeshBenchReport,
    MeshBenchSettings, PointModel, RenderBenchSettings, ScaleBenchReport, ScaleBenchSettings, ScaleRow, Seconds,
    ViewBenchReport, ViewBenchSettings, bench_cache, bench_edit, bench_eval, bench_mesh, bench_scale, bench_view,
    measure_point_set,
};
use crate::frame::Size;
use crate::pipeline::RenderReport;

/// Benchmarks.
#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// Exact field rendering: indexed evaluation against the naive tree traversal.
    Eval(EvalBenchArgs),
    /// Cached rendering (cold and warm) against exact rendering (naive and
    /// indexed), with the cached image's accuracy and the cost of one lookup.
    Cache(EvalBenchArgs),
    /// Polygonization with and without caches over resolutions (the paper's
    /// Table 1), evaluations per triangle, triangle and ray rates.
    Mesh(MeshBenchArgs),
    /// The caching paper's Figure 8: an edit script's per-frame times with and
    /// without caches, local updates against work from scratch.
    Edit(EditBenchArgs),
    /// The previewer's latency without a window: orbit steps, zoom steps,
    /// moves of the first named node and an edit script's frames, each kind's
    /// median and slowest frame time and the frame rate it allows.
    View(ViewBenchArgs),
    /// Load time, resident memory, render and mesh time of point sets of 10³
    /// points and up (sparse, a dense cloud, one long spline), with a log–log
    /// plot of each against the count (PNG) and the figures as JSON beside it.
    Scale(ScaleBenchArgs),
}

/// Options of `blobtrace bench scale`.
#[derive(Debug, Args)]
pub struct ScaleBenchArgs {
    /// Point counts (each from 1,000 to 10,000,000, the most a scene holds; counts that would not fit in memory are skipped).
    #[arg(long, value_delimiter = ',', default_value = "1000,10000,100000,1000000", value_parser = parse_count)]
    pub points: Vec<usize>,
    /// Point sets: sparse (the particles scene's density at any count), dense (a branching walk), spline (one SplinePoints node, up to 10⁶ points), or all.
    #[arg(long, value_enum, default_value_t = ModelsArg::All)]
    pub model: ModelsArg,
    /// Image size of the renders WIDTHxHEIGHT.
    #[arg(long, value_parser = parse_size, default_value = "500x500")]
    pub size: Size,
    /// Lattice cell of the meshes, in model units (the particles' support radius is 2.25).
    #[arg(long, default_value_t = 0.644, value_parser = parse_cell)]
    pub mesh_cell: f32,
    /// Mesh only point sets of at most this many points.
    #[arg(long, default_value_t = 100_000)]
    pub mesh_up_to: usize,
    /// Where to write the plot (PNG); the JSON goes beside it.
    #[arg(short, long, default_value = "scale.png")]
    pub output: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Measure this one point set (MODEL:POINTS) in this process and print
    /// its row as JSON: what `bench scale` runs once per point set.
    #[arg(long, hide = true, value_parser = parse_one)]
    pub one: Option<(PointModel, usize)>,
}

fn parse_one(s: &str) -> Result<(PointModel, usize), String> {
    let (model, n) = s.split_once(':').ok_or_else(|| format!("expected MODEL:POINTS, got {s:?}"))?;
    let Some(model) = PointModel::ALL.into_iter().find(|m| m.name() == model) else {
        return Err(format!("no point set {model:?} (sparse, dense or spline)"));
    };
    Ok((model, parse_count(n)?))
}

/// Which point sets `bench scale` measures.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum ModelsArg {
    /// Chains at the particles scene's density.
    Sparse,
    /// One branching random walk.
    Dense,
    /// One `SplinePoints` node along a random walk.
    Spline,
    /// Sparse and dense.
    Both,
    /// All three.
    All,
}

/// A point count from 1,000 to the most a scene holds.
fn parse_count(s: &str) -> Result<usize, String> {
    let most = crate::scene::MAX_PRIMITIVES as f64;
    match s.trim().replace('_', "").parse::<f64>() {
        Ok(n) if (1e3..=most).contains(&n) && n.fract() == 0.0 => Ok(n as usize),
        _ => Err(format!(
            "expected a whole number of points from 1000 to {most} (the most a scene holds; 1e6 is fine), got {s:?}"
        )),
    }
}

fn parse_cell(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(c) if c.is_finite() && c > 0.0 => Ok(c),
        _ => Err(format!("expected a positive cell size, got {s:?}")),
    }
}

/// Options of `blobtrace bench view`.
#[derive(Debug, Args)]
pub struct ViewBenchArgs {
    /// Scene file (RON).
    #[arg(default_value = "scenes/medusa.ron")]
    pub scene: PathBuf,
    /// Image size WIDTHxHEIGHT.
    #[arg(long, value_parser = parse_size, default_value = "640x480")]
    pub size: Size,
    /// Edit script (RON) whose frames are replayed as one more kind of event.
    #[arg(long)]
    pub script: Option<PathBuf>,
    /// Events of each kind (orbit, zoom, node move).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub events: u32,
    /// Ray tracer (see `render --help`).
    #[arg(long, value_enum, default_value_t = TracerArg::Auto)]
    pub tracer: TracerArg,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Options of `blobtrace bench eval`.
#[derive(Debug, Args)]
pub struct EvalBenchArgs {
    /// Scene file (RON).
    #[arg(default_value = "scenes/medusa.ron")]
    pub scene: PathBuf,
    /// Image size WIDTHxHEIGHT (default: the scene's).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<Size>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Rounds of renders, each kind once per round; the fastest of each counts.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub repeat: u32,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

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
    #[arg(long, value_parser = parse_size, default_value = "640x480")]
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

/// Options of `blobtrace bench edit`.
#[derive(Debug, Args)]
pub struct EditBenchArgs {
    /// Scene file (RON).
    #[arg(default_value = "scenes/medusa.ron")]
    pub scene: PathBuf,
    /// Edit script (RON).
    #[arg(long, default_value = "scenes/scripts/medusa-head.ron")]
    pub script: PathBuf,
    /// Mesh resolution (the paper's 60 and 120).
    #[arg(long, default_value_t = 60)]
    pub res: u32,
    /// Image size of the ray-cast path.
    #[arg(long, value_parser = parse_size, default_value = "160x120")]
    pub size: Size,
    /// Where to write the plot.
    #[arg(short, long, default_value = "figure8.png")]
    pub output: PathBuf,
    /// Rounds of replays, each mode once per round; the fastest of each measure counts.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub repeat: u32,
    /// Worker threads (default: all cores; the paper's timings ran on one processor).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Runs `blobtrace bench` (each bar is gone before the figures print).
pub fn run(c: &BenchCommand) -> anyhow::Result<()> {
    match c {
        BenchCommand::Eval(a) => {
            let report = bench_eval(&a.settings(), &Bars::new())?;
            emit(a.json, &report, |r| print_eval(a, size_of(&r.segment), r))
        }
        BenchCommand::Cache(a) => {
            let report = bench_cache(&a.settings(), &Bars::new())?;
            emit(a.json, &report, |r| print_cache_report(a, size_of(&r.cached), r, r.cached.stats.rays))
        }
        BenchCommand::Mesh(a) => {
            let report = bench_mesh(&a.settings(), &Bars::new())?;
            emit(a.json, &report, |r| print_mesh(a, r))
        }
        BenchCommand::Edit(a) => {
            check_output_file(&a.output, "png")?;
            let report = bench_edit(&a.settings(), &Bars::new())?;
            emit(a.json, &report, |r| print_edit(a, r))
        }
        BenchCommand::View(a) => {
            let settings = ViewBenchSettings {
                scene: a.scene.clone(),
                size: a.size,
                script: a.script.clone(),
                events: a.events,
                threads: a.threads,
                tracer: a.tracer.choice(),
            };
            emit(a.json, &bench_view(&settings)?, print_view)
        }
        BenchCommand::Scale(a) => {
            if let Some((model, n)) = a.one {
                return print_json(&measure_point_set(&a.settings(), model, n)?);
            }
            check_output_file(&a.output, "png")?;
            let run = |model, n| a.run_in_child(model, n);
            let report = bench_scale(&a.settings(), &Bars::new(), &run)?;
            emit(a.json, &report, print_scale)
        }
    }
}

impl ScaleBenchArgs {
    /// Measures one point set in a fresh process of this program, so its
    /// memory figures start from nothing the sets before it left behind.
    fn run_in_child(&self, model: PointModel, n: usize) -> crate::pipeline::Result<ScaleRow> {
        let failed = |message: String| {
            crate::pipeline::PipelineError::Unsuitable(format!("bench scale {}:{n}: {message}", model.name()))
        };
        let exe = std::env::current_exe().map_err(|e| failed(e.to_string()))?;
        let mut child = std::process::Command::new(exe);
        child.args(["bench", "scale", "--one", &format!("{}:{n}", model.name())]);
        child.args(["--size", &self.size.to_string(), "--mesh-cell", &self.mesh_cell.to_string()]);
        child.args(["--mesh-up-to", &self.mesh_up_to.to_string()]);
        if let Some(t) = self.threads {
            child.args(["--threads", &t.to_string()]);
        }
        let out = child.stderr(std::process::Stdio::inherit()).output().map_err(|e| failed(e.to_string()))?;
        if !out.status.success() {
            return Err(failed(format!("the measuring process exited with {}", out.status)));
        }
        serde_json::from_slice(&out.stdout).map_err(|e| failed(e.to_string()))
    }

    fn settings(&self) -> ScaleBenchSettings {
        let mut counts = self.points.clone();
        counts.sort_unstable();
        counts.dedup();
        let models = match self.model {
            ModelsArg::Sparse => vec![PointModel::Sparse],
            ModelsArg::Dense => vec![PointModel::Dense],
            ModelsArg::Spline => vec![PointModel::Spline],
            ModelsArg::Both => vec![PointModel::Sparse, PointModel::Dense],
            ModelsArg::All => PointModel::ALL.to_vec(),
        };
        ScaleBenchSettings {
            counts,
            models,
            size: self.size,
            mesh_cell: self.mesh_cell,
            mesh_up_to: self.mesh_up_to,
            plot: self.output.clone(),
            threads: self.threads,
        }
    }
}

fn print_scale(r: &ScaleBenchReport) {
    println!("point sets of radius 2.25, {} threads; renders {}, meshes at cell {}", r.threads, r.size, r.mesh_cell);
    println!(
        "  {:<7} {:>10} {:>9} {:>11} {:>9} {:>9} {:>8} {:>9} {:>11}",
        "model", "points", "load s", "resident MB", "peak MB", "render s", "tracer", "mesh s", "triangles"
    );
    let mb = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.0}"));
    for row in &r.rows {
        println!(
            "  {:<7} {:>10} {:>9.3} {:>11} {:>9} {:>9.3} {:>8} {:>9} {:>11}",
            row.model.name(),
            row.points,
            row.load_seconds,
            mb(row.resident_mb),
            mb(row.peak_mb),
            row.render_seconds,
            row.tracer,
            row.mesh_seconds.map_or("-".into(), |s| format!("{s:.3}")),
            row.mesh.map_or("-".into(), |m| m.1.to_string()),
        );
    }
    for why in &r.stopped {
        println!("  skipped {why}");
    }
    println!("plot: {} (JSON beside it)", r.plot);
}

fn print_view(r: &ViewBenchReport) {
    println!(
        "{}: the previewer at {}, {} threads; first frame after {:.3} s, refined after {:.3} s; ms from each event (median / slowest)",
        r.scene, r.size, r.threads, r.launch_seconds, r.launch_refined_seconds
    );
    println!(
        "  {:<20} {:>6} {:>15} {:>15} {:>15} {:>9}",
        "event", "events", "first pass", "field refined", "all refined", "frames/s"
    );
    let ms = |s: Seconds| format!("{:.1} / {:.1}", 1e3 * s.median, 1e3 * s.max);
    for e in &r.events {
        println!(
            "  {:<20} {:>6} {:>15} {:>15} {:>15} {:>9.1}",
            e.kind,
            e.events,
            ms(e.first_pass),
            ms(e.field_refined),
            ms(e.refined),
            e.frame_rate
        );
    }
}

/// Prints `report` as JSON, or as `print` writes it.
fn emit<R: serde::Serialize>(json: bool, report: &R, print: impl FnOnce(&R)) -> anyhow::Result<()> {
    if json {
        return print_json(report);
    }
    print(report);
    Ok(())
}

/// The image size a render bench ran at.
fn size_of(r: &RenderReport) -> String {
    format!("{}x{}", r.width, r.height)
}

impl EvalBenchArgs {
    fn settings(&self) -> RenderBenchSettings {
        RenderBenchSettings { scene: self.scene.clone(), size: self.size, threads: self.threads, repeat: self.repeat }
    }
}

impl MeshBenchArgs {
    fn settings(&self) -> MeshBenchSettings {
        MeshBenchSettings {
            scene: self.scene.clone(),
            res: self.res.clone(),
            detail_res: self.detail_res,
            size: self.size,
            cells: self.cells.into(),
            threads: self.threads,
        }
    }
}

impl EditBenchArgs {
    fn settings(&self) -> EditBenchSettings {
        EditBenchSettings {
            scene: self.scene.clone(),
            script: self.script.clone(),
            res: self.res,
            size: self.size,
            plot: self.output.clone(),
            repeat: self.repeat,
            threads: self.threads,
        }
    }
}

fn print_eval(a: &EvalBenchArgs, size: String, report: &EvalBenchReport) {
    println!("{} at {size}, {} threads, fastest of {} rounds", a.scene.display(), report.segment.threads, a.repeat);
    let runs = &report.runs_s;
    let rows = [
        ("kernel", report.kernel.as_ref(), &runs.kernel),
        ("segment", Some(&report.segment), &runs.segment),
        ("naive", Some(&report.naive), &runs.naive),
    ];
    for (name, r, runs) in rows {
        let Some(r) = r else {
            println!("  {name:8} does not apply: the model is not a sum of polynomial kernels");
            continue;
        };
        println!(
            "  {name:8} {:8.3} s  {:10.0} rays/s  {:6.0} ns/ray  {:6.1} evals/ray  {:6.1} {}/ray   rounds: {}",
            r.seconds,
            r.rays_per_second,
            1e9 * r.seconds / r.stats.rays.max(1) as f64 * r.threads as f64,
            r.evals_per_ray,
            r.stats.steps as f64 / r.stats.rays.max(1) as f64,
            if r.tracer == "kernel" { "supports" } else { "steps" },
            seconds_list(runs)
        );
    }
    if let (Some(k), Some(n), Some(px)) = (report.kernel_vs_segment, report.kernel_vs_naive, report.kernel_mismatch_px)
    {
        println!("  kernel is {k:.1}x the segment tracer, {n:.1}x naive; {px} pixels differ in hit/miss from segment");
    }
    println!("  segment is {:.1}x naive; {} pixels differ in hit/miss", report.segment_vs_naive, report.mismatch_px);
}

fn print_cache_report(a: &EvalBenchArgs, size: String, r: &CacheBenchReport, rays: u64) {
    println!("{} at {size}, {} threads, fastest of {} rounds", a.scene.display(), r.cached.threads, a.repeat);
    let runs = &r.runs_s;
    for (name, s, all) in [
        ("exact naive", r.exact_naive_s, &runs.exact_naive),
        ("exact indexed", r.exact_s, &runs.exact),
        ("cached cold", r.cached_cold_s, &runs.cached_cold),
        ("cached warm", r.cached_warm_s, &runs.cached_warm),
    ] {
        println!("  {name:14} {s:8.3} s  {:10.0} rays/s   rounds: {}", rays as f64 / s.max(1e-9), seconds_list(all));
    }
    println!(
        "  warm cached is {:.1}x faster than naive, {:.1}x faster than indexed; cold is {:.2}x indexed's speed",
        r.warm_vs_naive, r.warm_vs_exact, r.cold_vs_exact
    );
    let per_eval_ns = |r: &RenderReport| 1e9 * r.seconds / r.stats.field_evals.max(1) as f64;
    println!(
        "  field work: exact indexed {} evaluations in {} steps ({:.0} ns each), cached warm {} in {} steps ({:.0} ns each)",
        r.exact.stats.field_evals,
        r.exact.stats.steps,
        per_eval_ns(&r.exact),
        r.cached.stats.field_evals,
        r.cached.stats.steps,
        per_eval_ns(&r.cached),
    );
    println!(
        "  accuracy: {} pixels differ in hit/miss ({:.3}%), mean depth error {:.2e}, p99 normal error {:.2} deg",
        r.mismatch_px,
        100.0 * r.mismatch_px as f64 / rays.max(1) as f64,
        r.mean_depth_err,
        r.p99_normal_err_deg
    );
    print_lookup_costs(&r.lookups);
}

/// Each cache's lookup cost against an exact evaluation of its subtree.
fn print_lookup_costs(lookups: &[LookupCost]) {
    println!(
        "  {:12} {:>10} {:>12} {:>12} {:>12} {:>10} {:>12}",
        "cache", "primitives", "cached ns", "exact ns", "exact work", "MB held", "MB dense"
    );
    for l in lookups {
        println!(
            "  {:12} {:>10} {:>12.1} {:>12.1} {:>12.1} {:>10.2} {:>12.2}",
            l.name,
            l.primitives,
            l.cached_ns,
            l.exact_ns,
            l.exact_cost,
            l.bytes as f64 / 1048576.0,
            l.dense_bytes as f64 / 1048576.0
        );
    }
}

/// Seconds to three places, comma-separated.
fn seconds_list(runs: &[f64]) -> String {
    runs.iter().map(|s| format!("{s:.3}")).collect::<Vec<_>>().join(", ")
}

fn print_mesh(a: &MeshBenchArgs, r: &MeshBenchReport) {
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

fn print_edit(a: &EditBenchArgs, report: &EditBenchReport) {
    println!(
        "{} frames at res {}, {} threads: local polygonization {:.3} s cached, {:.3} s naive ({:.1}x); from scratch {:.3} s cached, {:.3} s naive",
        report.frames,
        report.res,
        report.threads,
        report.cached.local_polygonize_s,
        report.naive.local_polygonize_s,
        report.local_polygonize_ratio,
        report.cached.full_polygonize_s,
        report.naive.full_polygonize_s
    );
    println!(
        "ray casting at {}: dirty rectangles {:.3} s, full frames {:.3} s ({:.1}x); plot in {}",
        a.size,
        report.cached.dirty_render_s,
        report.cached.full_render_s,
        report.dirty_render_speedup,
        a.output.display()
    );
    println!(
        "the pixels each frame changes take {:.1}% of the full frames' field evaluations: a bit-identical dirty frame evaluates at most {:.1}x fewer",
        100.0 * report.changed_evaluation_share,
        report.evaluation_ceiling
    );
}
