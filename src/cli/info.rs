//! `blobtrace info`: what a scene holds.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde::Serialize;

use crate::field::{CacheDecision, ModelCounts};
use crate::pipeline::EvalSettings;
use crate::scene::Scene;
use crate::trace::kernel::{self, TracerDecision};

/// Options of `blobtrace info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// Scene file (RON).
    pub scene: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

/// What `info --json` prints.
#[derive(Debug, Serialize)]
pub struct InfoReport {
    /// Node counts.
    #[serde(flatten)]
    pub counts: ModelCounts,
    /// Names of `Named` nodes, sorted.
    pub names: Vec<String>,
    /// Iso-value.
    pub threshold: f32,
    /// Bounds of the model's support: `[min, max]`.
    pub bounds: [[f32; 3]; 2],
    /// Default image size.
    pub size: [u32; 2],
    /// What auto mode decides for each cache, and the estimate behind it.
    pub cache_decisions: Vec<CacheDecision>,
    /// Which ray tracer `--tracer auto` picks, and why.
    pub tracer: TracerDecision,
}

/// Runs `blobtrace info`.
pub fn run(a: &InfoArgs) -> anyhow::Result<()> {
    let mut scene = Scene::load(&a.scene)?;
    // The tracer is chosen for the field auto mode shows.
    let mode = EvalSettings::default().apply(&mut scene.model)?;
    let m = &scene.model;
    let b = m.bounds();
    let report = InfoReport {
        counts: m.counts(),
        names: m.names().into_iter().map(String::from).collect(),
        threshold: m.threshold(),
        bounds: [b.min.to_array(), b.max.to_array()],
        size: [scene.size.0, scene.size.1],
        cache_decisions: m.cache_decisions(),
        tracer: kernel::decide(m, mode).1,
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report).context("encoding the report")?);
        return Ok(());
    }
    let c = report.counts;
    println!("{}", a.scene.display());
    println!("  nodes       {}", c.nodes);
    println!("  primitives  {}", c.primitives);
    println!("  caches      {}", c.caches);
    println!("  indexed blends {}", c.indexed_blends);
    println!("  threshold   {}", report.threshold);
    println!("  bounds      {:?} .. {:?}", report.bounds[0], report.bounds[1]);
    println!("  size        {}x{}", report.size[0], report.size[1]);
    if !report.names.is_empty() {
        println!("  names       {}", report.names.join(", "));
    }
    print_decisions(&report.cache_decisions);
    let t = &report.tracer;
    println!("  tracer      {} in --tracer auto: {}", t.tracer, t.reason);
    Ok(())
}

/// The caches' auto-mode decisions as a table: work in point terms (one
/// point's term of a sum), exact against a lattice answer.
fn print_decisions(decisions: &[CacheDecision]) {
    if decisions.is_empty() {
        return;
    }
    println!("  caches in --mode auto (work per answer, in point terms; exact = value × steps):");
    println!(
        "    {:<16} {:>5} {:>8} {:>6} {:>10} {:>10}  decision",
        "cache", "res", "value", "steps", "exact", "lattice"
    );
    for d in decisions {
        let verdict = if d.uses_lattice { "lattice" } else { "exact" };
        println!(
            "    {:<16} {:>5} {:>8.1} {:>6.1} {:>10.1} {:>10.1}  {verdict} ({})",
            d.name, d.res, d.value_cost, d.steps, d.exact_cost, d.lattice_cost, d.reason
        );
    }
}
