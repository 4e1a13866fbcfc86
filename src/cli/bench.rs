//! `blobtrace bench`: performance figures measured in one process, reported as
//! ratios against the baseline on the same scene, so a noisy machine affects
//! both sides alike.

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Subcommand};
use serde::Serialize;

use super::render::{RenderReport, render_scene};
use super::{EvalArg, with_threads};
use crate::scene::{Scene, Size};

/// Benchmarks.
#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// Exact field rendering: indexed evaluation against the naive tree traversal.
    Eval(EvalBenchArgs),
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
    }
}

fn eval(a: &EvalBenchArgs) -> anyhow::Result<()> {
    let scene = Scene::load(&a.scene)?;
    let size = a.size.unwrap_or(scene.size);
    let (indexed_frame, indexed) = with_threads(a.threads, || render_scene(&scene, size, EvalArg::Indexed))?;
    let (naive_frame, naive) = with_threads(a.threads, || render_scene(&scene, size, EvalArg::Naive))?;
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
