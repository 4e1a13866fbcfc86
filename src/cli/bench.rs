//! `blobtrace bench`: performance figures measured in one process, reported as
//! ratios against the baseline on the same scene, so a noisy machine affects
//! both sides alike. Renders are repeated in interleaved rounds and the
//! fastest of each kind counts: on a shared machine one render of the same
//! work takes up to half as long again as another, and the fastest is the
//! one least disturbed.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Subcommand};
use serde::Serialize;

use super::render::{RenderReport, render_scene};
use super::with_threads;
use std::time::Instant;

use glam::Vec3A;

use crate::field::{EvalMode, Model, NodeId, NodeKind};
use crate::frame::Frame;
use crate::scene::{Scene, Size};

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
    Mesh(super::bench_mesh::MeshBenchArgs),
    /// The caching paper's Figure 8: an edit script's per-frame times with and
    /// without caches, local updates against work from scratch.
    Edit(super::bench_edit::EditBenchArgs),
}

/// Options of `blobtrace bench eval`.
#[derive(Debug, Args)]
pub struct EvalBenchArgs {
    /// Scene file (RON).
    #[arg(default_value = "scenes/medusa.ron")]
    pub scene: PathBuf,
    /// Image size WIDTHxHEIGHT (default: the scene's).
    #[arg(long, value_parser = super::parse_size)]
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

/// The fastest of repeated renders of one kind, and every round's seconds.
struct Fastest {
    best: Option<(Frame, RenderReport)>,
    runs_s: Vec<f64>,
}

impl Fastest {
    fn new() -> Self {
        Self { best: None, runs_s: vec![] }
    }

    /// Counts one round's render.
    fn offer(&mut self, (frame, report): (Frame, RenderReport)) {
        self.runs_s.push(report.seconds);
        if self.best.as_ref().is_none_or(|(_, b)| report.seconds < b.seconds) {
            self.best = Some((frame, report));
        }
    }

    /// The fastest render, and the seconds of every round.
    fn take(self) -> (Frame, RenderReport, Vec<f64>) {
        let (frame, report) = self.best.expect("at least one round");
        (frame, report, self.runs_s)
    }
}

/// What `bench eval --json` prints.
#[derive(Debug, Serialize)]
pub struct EvalBenchReport {
    /// The naive render.
    pub naive: RenderReport,
    /// The indexed render.
    pub indexed: RenderReport,
    /// Seconds of the naive render over seconds of the indexed render.
    pub speedup: f64,
    /// Pixels whose hit/miss differs between the two renders.
    pub mismatch_px: usize,
    /// Seconds of each round's naive render.
    pub naive_runs_s: Vec<f64>,
    /// Seconds of each round's indexed render.
    pub indexed_runs_s: Vec<f64>,
}

/// Runs `blobtrace bench`.
pub fn run(c: &BenchCommand) -> anyhow::Result<()> {
    match c {
        BenchCommand::Eval(a) => eval(a),
        BenchCommand::Cache(a) => cache(a),
        BenchCommand::Mesh(a) => super::bench_mesh::run(a),
        BenchCommand::Edit(a) => super::bench_edit::run(a),
    }
}

fn eval(a: &EvalBenchArgs) -> anyhow::Result<()> {
    let scene = Scene::load(&a.scene)?;
    let size = a.size.unwrap_or(scene.size);
    let (mut indexed, mut naive) = (Fastest::new(), Fastest::new());
    for _ in 0..a.repeat {
        indexed.offer(with_threads(a.threads, || render_scene(&scene, size, EvalMode::Indexed))?);
        naive.offer(with_threads(a.threads, || render_scene(&scene, size, EvalMode::Naive))?);
    }
    let ((indexed_frame, indexed, indexed_runs_s), (naive_frame, naive, naive_runs_s)) = (indexed.take(), naive.take());
    let mismatch_px = indexed_frame.alpha.iter().zip(&naive_frame.alpha).filter(|(a, b)| a != b).count();
    let report = EvalBenchReport {
        speedup: naive.seconds / indexed.seconds.max(1e-9),
        naive,
        indexed,
        mismatch_px,
        naive_runs_s,
        indexed_runs_s,
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report).context("encoding the report")?);
        return Ok(());
    }
    println!("{} at {size}, {} threads, fastest of {} rounds", a.scene.display(), report.indexed.threads, a.repeat);
    for (name, r, runs) in
        [("naive", &report.naive, &report.naive_runs_s), ("indexed", &report.indexed, &report.indexed_runs_s)]
    {
        println!(
            "  {name:8} {:8.3} s  {:10.0} rays/s  {:6.1} evals/ray  {:6.1} steps/ray   rounds: {}",
            r.seconds,
            r.rays_per_second,
            r.evals_per_ray,
            r.stats.steps as f64 / r.stats.rays.max(1) as f64,
            seconds_list(runs)
        );
    }
    println!("  indexed is {:.1}x faster; {} pixels differ in hit/miss", report.speedup, report.mismatch_px);
    Ok(())
}

/// What `bench cache --json` prints.
#[derive(Debug, Serialize)]
pub struct CacheBenchReport {
    /// Seconds of the exact naive render.
    pub exact_naive_s: f64,
    /// Seconds of the exact indexed render.
    pub exact_s: f64,
    /// Seconds of the cached render with empty caches.
    pub cached_cold_s: f64,
    /// Seconds of the same cached render again, caches filled.
    pub cached_warm_s: f64,
    /// Pixels hit by one of the exact and cached renders only.
    pub mismatch_px: usize,
    /// Mean depth difference over pixels both hit (scene units).
    pub mean_depth_err: f64,
    /// 99th percentile normal angle difference over pixels both hit.
    pub p99_normal_err_deg: f32,
    /// Bytes of sample storage held after the cached renders.
    pub cache_bytes: u64,
    /// Speed-ups: naive / warm, indexed / warm, indexed / cold.
    pub warm_vs_naive: f64,
    /// Exact indexed seconds over warm cached seconds.
    pub warm_vs_exact: f64,
    /// Exact indexed seconds over cold cached seconds.
    pub cold_vs_exact: f64,
    /// The cached render's statistics.
    pub cached: RenderReport,
    /// The exact indexed render's statistics: with the cached render's,
    /// where the ratio between the two comes from (evaluations asked, and
    /// the time each costs).
    pub exact: RenderReport,
    /// Per cache: the cost of one lookup against one exact evaluation of its subtree.
    pub lookups: Vec<LookupCost>,
    /// Seconds of each round's renders, by kind.
    pub runs_s: CacheBenchRuns,
}

/// Seconds of each round's renders in `bench cache`.
#[derive(Debug, Serialize)]
pub struct CacheBenchRuns {
    /// Exact naive renders.
    pub exact_naive: Vec<f64>,
    /// Exact indexed renders.
    pub exact: Vec<f64>,
    /// Cached renders from empty caches (each round loads the scene afresh).
    pub cached_cold: Vec<f64>,
    /// The same cached renders again, caches filled.
    pub cached_warm: Vec<f64>,
}

/// One cache's lookup cost against its subtree's size.
#[derive(Debug, Serialize)]
pub struct LookupCost {
    /// The cache's name.
    pub name: String,
    /// Primitives under the cache.
    pub primitives: usize,
    /// Nanoseconds per warm cached value lookup.
    pub cached_ns: f64,
    /// Nanoseconds per exact (indexed) value of the subtree at the same points.
    pub exact_ns: f64,
    /// Bytes of samples the warm render's cache holds.
    pub bytes: u64,
    /// Bytes a dense grid of four-byte samples would take.
    pub dense_bytes: u64,
}

fn cache(a: &EvalBenchArgs) -> anyhow::Result<()> {
    let scene = Scene::load(&a.scene)?;
    anyhow::ensure!(scene.model.counts().caches > 0, "{}: the scene has no Cache nodes", a.scene.display());
    let size = a.size.unwrap_or(scene.size);
    let (mut naive, mut exact, mut cold, mut warm) = (Fastest::new(), Fastest::new(), Fastest::new(), Fastest::new());
    for _ in 0..a.repeat {
        // Every round's cold render starts from empty caches.
        let scene = Scene::load(&a.scene)?;
        let run = |mode| with_threads(a.threads, || render_scene(&scene, size, mode));
        naive.offer(run(EvalMode::Naive)?);
        exact.offer(run(EvalMode::Indexed)?);
        cold.offer(run(EvalMode::Cached)?);
        warm.offer(run(EvalMode::Cached)?);
    }
    let ((_, naive, naive_runs), (exact_frame, exact, exact_runs)) = (naive.take(), exact.take());
    let ((cold_frame, cold, cold_runs), (warm_frame, warm, warm_runs)) = (cold.take(), warm.take());
    anyhow::ensure!(
        cold_frame.color == warm_frame.color,
        "internal error: the warm cached render differs from the cold one"
    );
    let diff = warm_frame.geometry_difference(&exact_frame);
    let mut lookups = with_threads(Some(1), || lookup_costs(&scene.model))?;
    // What each cache holds is what the renders filled, not the few lookups timed.
    let held = warm.caches.iter().flat_map(|c| &c.per_cache);
    for (lookup, cache) in lookups.iter_mut().zip(held) {
        lookup.bytes = cache.stats.bytes;
    }
    let cache_bytes = warm.caches.as_ref().map_or(0, |c| c.bytes);
    let report = CacheBenchReport {
        exact_naive_s: naive.seconds,
        exact_s: exact.seconds,
        cached_cold_s: cold.seconds,
        cached_warm_s: warm.seconds,
        mismatch_px: diff.mismatch_px,
        mean_depth_err: diff.mean_depth_err,
        p99_normal_err_deg: diff.p99_normal_err_deg,
        cache_bytes,
        warm_vs_naive: naive.seconds / warm.seconds.max(1e-9),
        warm_vs_exact: exact.seconds / warm.seconds.max(1e-9),
        cold_vs_exact: exact.seconds / cold.seconds.max(1e-9),
        cached: warm,
        exact,
        lookups,
        runs_s: CacheBenchRuns {
            exact_naive: naive_runs,
            exact: exact_runs,
            cached_cold: cold_runs,
            cached_warm: warm_runs,
        },
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report).context("encoding the report")?);
        return Ok(());
    }
    print_cache_report(a, size, &report, cold.stats.rays);
    Ok(())
}

fn print_cache_report(a: &EvalBenchArgs, size: Size, r: &CacheBenchReport, rays: u64) {
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
    println!(
        "  {:12} {:>10} {:>12} {:>12} {:>10} {:>12}",
        "cache", "primitives", "cached ns", "exact ns", "MB held", "MB dense"
    );
    for l in &r.lookups {
        println!(
            "  {:12} {:>10} {:>12.1} {:>12.1} {:>10.2} {:>12.2}",
            l.name,
            l.primitives,
            l.cached_ns,
            l.exact_ns,
            l.bytes as f64 / 1048576.0,
            l.dense_bytes as f64 / 1048576.0
        );
    }
}

/// Seconds to three places, comma-separated.
fn seconds_list(runs: &[f64]) -> String {
    runs.iter().map(|s| format!("{s:.3}")).collect::<Vec<_>>().join(", ")
}

/// Points where lookups are timed: inside the subtree's support, where a
/// polygonizer or tracer asks (empty space is cheap for both).
const LOOKUP_POINTS: usize = 20_000;

fn lookup_costs(model: &Model) -> Vec<LookupCost> {
    model
        .cache_stats()
        .into_iter()
        .filter_map(|(id, name, stats)| {
            let NodeKind::Cache { child, .. } = model.node(id).kind else { return None };
            let points = support_points(model, child);
            let time = |mode: EvalMode, node: NodeId| {
                let start = Instant::now();
                let sum: f32 = points.iter().map(|&p| model.node_value(node, p, mode)).sum();
                std::hint::black_box(sum);
                start.elapsed().as_secs_f64() * 1e9 / points.len().max(1) as f64
            };
            time(EvalMode::Cached, id); // fill
            Some(LookupCost {
                name,
                primitives: model.primitives_under(id),
                cached_ns: time(EvalMode::Cached, id),
                exact_ns: time(EvalMode::Indexed, child),
                // Filled in from the warm render by the caller.
                bytes: 0,
                dense_bytes: stats.grid_points * 4,
            })
        })
        .collect()
}

/// Up to [`LOOKUP_POINTS`] deterministic random points where `node`'s field is non-zero.
fn support_points(model: &Model, node: NodeId) -> Vec<Vec3A> {
    let b = model.node(node).bounds;
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut out = Vec::with_capacity(LOOKUP_POINTS);
    for _ in 0..LOOKUP_POINTS * 50 {
        let p = b.min + b.size() * Vec3A::new(next(), next(), next());
        if model.node_value(node, p, EvalMode::Indexed) > 0.0 {
            out.push(p);
            if out.len() == LOOKUP_POINTS {
                break;
            }
        }
    }
    out
}
