//! `blobtrace bench`: performance figures measured in one process, reported as
//! ratios against the baseline on the same scene, so a noisy machine affects
//! both sides alike.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Subcommand};
use serde::Serialize;

use super::render::{RenderReport, render_scene};
use super::with_threads;
use std::time::Instant;

use glam::Vec3A;

use crate::field::{EvalMode, Model, NodeId, NodeKind};
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
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
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
    let (indexed_frame, indexed) = with_threads(a.threads, || render_scene(&scene, size, EvalMode::Indexed))?;
    let (naive_frame, naive) = with_threads(a.threads, || render_scene(&scene, size, EvalMode::Naive))?;
    let mismatch_px = indexed_frame.alpha.iter().zip(&naive_frame.alpha).filter(|(a, b)| a != b).count();
    let report = EvalBenchReport { speedup: naive.seconds / indexed.seconds.max(1e-9), naive, indexed, mismatch_px };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report).context("encoding the report")?);
        return Ok(());
    }
    println!("{} at {size}, {} threads", a.scene.display(), report.indexed.threads);
    for (name, r) in [("naive", &report.naive), ("indexed", &report.indexed)] {
        println!(
            "  {name:8} {:8.3} s  {:10.0} rays/s  {:6.1} evals/ray  {:6.1} steps/ray",
            r.seconds,
            r.rays_per_second,
            r.evals_per_ray,
            r.stats.steps as f64 / r.stats.rays.max(1) as f64
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
    /// Per cache: the cost of one lookup against one exact evaluation of its subtree.
    pub lookups: Vec<LookupCost>,
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
    /// Bytes held against a dense four-byte grid over the subtree.
    pub bytes: u64,
    /// Bytes a dense grid of four-byte samples would take.
    pub dense_bytes: u64,
}

fn cache(a: &EvalBenchArgs) -> anyhow::Result<()> {
    let scene = Scene::load(&a.scene)?;
    anyhow::ensure!(scene.model.counts().caches > 0, "{}: the scene has no Cache nodes", a.scene.display());
    let size = a.size.unwrap_or(scene.size);
    let run = |mode| with_threads(a.threads, || render_scene(&scene, size, mode));
    let (_, naive) = run(EvalMode::Naive)?;
    let (exact_frame, exact) = run(EvalMode::Indexed)?;
    let (cold_frame, cold) = run(EvalMode::Cached)?;
    let (warm_frame, warm) = run(EvalMode::Cached)?;
    anyhow::ensure!(
        cold_frame.color == warm_frame.color,
        "internal error: the warm cached render differs from the cold one"
    );
    let diff = warm_frame.geometry_difference(&exact_frame);
    let lookups = with_threads(Some(1), || lookup_costs(&scene.model))?;
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
        lookups,
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report).context("encoding the report")?);
        return Ok(());
    }
    print_cache_report(a, size, &report, cold.stats.rays);
    Ok(())
}

fn print_cache_report(a: &EvalBenchArgs, size: Size, r: &CacheBenchReport, rays: u64) {
    println!("{} at {size}, {} threads", a.scene.display(), r.cached.threads);
    for (name, s) in [
        ("exact naive", r.exact_naive_s),
        ("exact indexed", r.exact_s),
        ("cached cold", r.cached_cold_s),
        ("cached warm", r.cached_warm_s),
    ] {
        println!("  {name:14} {s:8.3} s  {:10.0} rays/s", rays as f64 / s.max(1e-9));
    }
    println!(
        "  warm cached is {:.1}x faster than naive, {:.1}x faster than indexed; cold is {:.2}x indexed's speed",
        r.warm_vs_naive, r.warm_vs_exact, r.cold_vs_exact
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
                bytes: stats.bytes,
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
