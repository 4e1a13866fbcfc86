//! `blobtrace bench edit`: the caching paper's Figure 8 — per-frame time of an
//! edit script with caches and without (exact naive, the paper's "no cache"),
//! each as local updates and as work from scratch, in one process; with a plot.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use serde::Serialize;

use super::edit::{FrameRow, replay};
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
    let frames = load_script(&a.script)?;
    let polygonize = PolygonizeArgs { res: a.res, cells: CellsArg::Cubes, vertex: VertexArg::Root, refine: 0 };
    let mut rows = vec![];
    for mode in [EvalMode::Cached, EvalMode::Naive] {
        let mut scene = Scene::load(&a.scene)?;
        polygonize.check(&scene)?;
        let (r, _) =
            with_threads(None, || replay(&mut scene, mode, &frames, &polygonize, a.size, true, |_, _, _| Ok(())))??;
        rows.push(r);
    }
    let totals = |r: &[FrameRow]| ModeTotals {
        local_polygonize_s: r.iter().map(|f| f.polygonize_s).sum(),
        full_polygonize_s: r.iter().map(|f| f.full_s.unwrap_or(0.0) - f.full_render_s.unwrap_or(0.0)).sum(),
        dirty_render_s: r.iter().map(|f| f.field_s).sum(),
        full_render_s: r.iter().map(|f| f.full_render_s.unwrap_or(0.0)).sum(),
    };
    let (cached, naive) = (totals(&rows[0]), totals(&rows[1]));
    let report = EditBenchReport {
        frames: frames.len(),
        res: a.res,
        local_polygonize_ratio: naive.local_polygonize_s / cached.local_polygonize_s.max(1e-9),
        dirty_render_speedup: cached.full_render_s / cached.dirty_render_s.max(1e-9),
        cached,
        naive,
    };
    plot(a, &rows)?;
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
fn plot(a: &EditBenchArgs, rows: &[Vec<FrameRow>]) -> anyhow::Result<()> {
    let local = |r: &[FrameRow]| r.iter().map(|f| f.polygonize_s).collect::<Vec<f64>>();
    let full = |r: &[FrameRow]| {
        r.iter().map(|f| f.full_s.unwrap_or(f64::NAN) - f.full_render_s.unwrap_or(0.0)).collect::<Vec<f64>>()
    };
    let (cl, cf, nl, nf) = (local(&rows[0]), full(&rows[0]), local(&rows[1]), full(&rows[1]));
    let series: [(&str, &[f64]); 4] =
        [("cached, local", &cl), ("cached, full", &cf), ("naive, local", &nl), ("naive, full", &nf)];
    let title = format!("polygonization seconds per frame, res {}", a.res);
    line_plot(&title, "s", &series, 760, 380).save_png(&a.output)
}
