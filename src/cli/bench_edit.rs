//! `blobtrace bench edit`: the caching paper's Figure 8 — per-frame time of an
//! edit script with caches and without (exact naive, the paper's "no cache"),
//! each as local updates and as work from scratch, in one process; with a plot.
//! The incremental and from-scratch replays each start from a freshly loaded
//! scene, so neither finds samples the other filled.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde::Serialize;

use super::edit::{FrameRow, ScratchFrame, replay, replay_from_scratch};
use super::mesh::{CellsArg, PolygonizeArgs, VertexArg};
use super::with_threads;
use crate::compare::line_plot;
use crate::field::EvalMode;
use crate::scene::{Scene, Size, load_script};

/// Options of `blobtrace bench edit`.
#[derive(Debug, Args)]
pub struct EditBenchArgs {
    /// Scene file (RON).
    #[arg(default_value = "scenes/medusa.ron")]
    pub scene: PathBuf,
    /// Edit script (RON).
    #[arg(long, default_value = "scenes/medusa-head.ron")]
    pub script: PathBuf,
    /// Mesh resolution (the paper's 60 and 120).
    #[arg(long, default_value_t = 60)]
    pub res: u32,
    /// Image size of the ray-cast path.
    #[arg(long, value_parser = super::parse_size, default_value = "160x120")]
    pub size: Size,
    /// Where to write the plot.
    #[arg(short, long, default_value = "figure8.png")]
    pub output: PathBuf,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Totals of one mode.
#[derive(Debug, Serialize)]
pub struct ModeTotals {
    /// Local re-polygonization seconds over all frames.
    pub local_polygonize_s: f64,
    /// From-scratch polygonization seconds over all frames.
    pub full_polygonize_s: f64,
    /// Dirty-rectangle field seconds over all frames.
    pub dirty_render_s: f64,
    /// Full field render seconds over all frames.
    pub full_render_s: f64,
}

/// What `bench edit --json` prints.
#[derive(Debug, Serialize)]
pub struct EditBenchReport {
    /// Frames of the script.
    pub frames: usize,
    /// Mesh resolution.
    pub res: u32,
    /// With caches.
    pub cached: ModeTotals,
    /// Exact naive evaluation.
    pub naive: ModeTotals,
    /// Naive local / cached local re-polygonization (the paper's Table 2 ratio).
    pub local_polygonize_ratio: f64,
    /// Cached full render / cached dirty-rectangle render.
    pub dirty_render_speedup: f64,
}

/// Runs `blobtrace bench edit`.
pub fn run(a: &EditBenchArgs) -> anyhow::Result<()> {
    super::check_output_file(&a.output, "png")?;
    let script = load_script(&a.script)?;
    let polygonize = PolygonizeArgs { res: a.res, cells: CellsArg::Cubes, vertex: VertexArg::Root, refine: 0 };
    let mut runs = vec![];
    for mode in [EvalMode::Cached, EvalMode::Naive] {
        let load = || -> anyhow::Result<Scene> {
            let scene = Scene::load(&a.scene)?;
            polygonize.check(&scene)?;
            Ok(scene)
        };
        let (local, _) =
            with_threads(None, || replay(&mut load()?, mode, &script, &polygonize, a.size, false, |_, _, _| Ok(())))??;
        let scratch = with_threads(None, || replay_from_scratch(&mut load()?, mode, &script, &polygonize, a.size))??;
        runs.push((local, scratch));
    }
    let totals = |(local, scratch): &(Vec<FrameRow>, Vec<ScratchFrame>)| ModeTotals {
        local_polygonize_s: local.iter().map(|f| f.polygonize_s).sum(),
        full_polygonize_s: scratch.iter().map(|f| f.polygonize_s).sum(),
        dirty_render_s: local.iter().map(|f| f.field_s).sum(),
        full_render_s: scratch.iter().map(|f| f.render_s).sum(),
    };
    let (cached, naive) = (totals(&runs[0]), totals(&runs[1]));
    let report = EditBenchReport {
        frames: script.frames.len(),
        res: a.res,
        local_polygonize_ratio: naive.local_polygonize_s / cached.local_polygonize_s.max(1e-9),
        dirty_render_speedup: cached.full_render_s / cached.dirty_render_s.max(1e-9),
        cached,
        naive,
    };
    plot(a, &runs)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report).context("encoding the report")?);
    } else {
        println!(
            "{} frames at res {}: local polygonization {:.3} s cached, {:.3} s naive ({:.1}x); from scratch {:.3} s cached, {:.3} s naive",
            report.frames,
            report.res,
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
    }
    Ok(())
}

/// Figure 8: polygonization seconds per frame, cached and naive, local and from scratch.
fn plot(a: &EditBenchArgs, runs: &[(Vec<FrameRow>, Vec<ScratchFrame>)]) -> anyhow::Result<()> {
    let local = |r: &[FrameRow]| r.iter().map(|f| f.polygonize_s).collect::<Vec<f64>>();
    let full = |r: &[ScratchFrame]| r.iter().map(|f| f.polygonize_s).collect::<Vec<f64>>();
    let (cl, cf, nl, nf) = (local(&runs[0].0), full(&runs[0].1), local(&runs[1].0), full(&runs[1].1));
    let series: [(&str, &[f64]); 4] =
        [("cached, local", &cl), ("cached, full", &cf), ("naive, local", &nl), ("naive, full", &nf)];
    let title = format!("polygonization seconds per frame, res {}", a.res);
    line_plot(&title, "s", &series, 760, 380).save_png(&a.output)
}
