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
use crate::scene::{Scene, Script, Size, load_script};

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

/// Totals of one mode.
#[derive(Clone, Copy, Debug, Serialize)]
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
    /// Worker threads the replays ran on.
    pub threads: usize,
    /// With caches.
    pub cached: ModeTotals,
    /// Exact naive evaluation.
    pub naive: ModeTotals,
    /// Naive local / cached local re-polygonization (the paper's Table 2 ratio).
    pub local_polygonize_ratio: f64,
    /// Cached full render / cached dirty-rectangle render.
    pub dirty_render_speedup: f64,
    /// Of the cached full renders' field evaluations, the share spent on
    /// pixels that differ from the frame before's (the first round's).
    pub changed_evaluation_share: f64,
    /// Its inverse: the most a dirty-rectangle frame bit-identical to the full
    /// one can save in field evaluations (it must trace the changed pixels
    /// again; it may also skip work a full frame does beside evaluating,
    /// such as marking the whole empty-space grid).
    pub evaluation_ceiling: f64,
    /// Each round's totals with caches, then without (the figures above are
    /// the fastest of each measure over the rounds).
    pub rounds: Vec<[ModeTotals; 2]>,
}

impl ModeTotals {
    /// The totals of one replay: local updates and work from scratch.
    fn of((local, scratch): &(Vec<FrameRow>, Vec<ScratchFrame>)) -> Self {
        ModeTotals {
            local_polygonize_s: local.iter().map(|f| f.polygonize_s).sum(),
            full_polygonize_s: scratch.iter().map(|f| f.polygonize_s).sum(),
            dirty_render_s: local.iter().map(|f| f.field_s).sum(),
            full_render_s: scratch.iter().map(|f| f.render_s).sum(),
        }
    }

    /// The fastest of each measure over `rounds`.
    fn fastest(rounds: impl Iterator<Item = ModeTotals>) -> Self {
        rounds
            .reduce(|a, b| ModeTotals {
                local_polygonize_s: a.local_polygonize_s.min(b.local_polygonize_s),
                full_polygonize_s: a.full_polygonize_s.min(b.full_polygonize_s),
                dirty_render_s: a.dirty_render_s.min(b.dirty_render_s),
                full_render_s: a.full_render_s.min(b.full_render_s),
            })
            .expect("at least one round")
    }
}

/// Runs `blobtrace bench edit`.
pub fn run(a: &EditBenchArgs) -> anyhow::Result<()> {
    super::check_output_file(&a.output, "png")?;
    let script = load_script(&a.script)?;
    let polygonize = PolygonizeArgs { res: a.res, cells: CellsArg::Cubes, vertex: VertexArg::Root, refine: 0 };
    // Per round, the replays of each mode; the plot shows the round whose
    // cached local updates were fastest.
    let mut rounds: Vec<Vec<Replayed>> = vec![];
    for _ in 0..a.repeat {
        let mut round = vec![];
        for mode in [EvalMode::Cached, EvalMode::Naive] {
            round.push(replay_both_ways(a, &script, &polygonize, mode)?);
        }
        rounds.push(round);
    }
    let totals: Vec<[ModeTotals; 2]> = rounds.iter().map(|r| [ModeTotals::of(&r[0]), ModeTotals::of(&r[1])]).collect();
    let (cached, naive) =
        (ModeTotals::fastest(totals.iter().map(|t| t[0])), ModeTotals::fastest(totals.iter().map(|t| t[1])));
    let shown = (0..rounds.len())
        .min_by(|&i, &j| totals[i][0].local_polygonize_s.total_cmp(&totals[j][0].local_polygonize_s))
        .unwrap_or(0);
    plot(a, &rounds[shown])?;
    let cached_full_frames = &rounds[0][0].1;
    let changed: f64 = cached_full_frames.iter().map(|f| f.changed_evaluations).sum();
    let all: f64 = cached_full_frames.iter().map(|f| f.evaluations).sum();
    let report = EditBenchReport {
        frames: script.frames.len(),
        res: a.res,
        threads: a.threads.unwrap_or_else(rayon::current_num_threads),
        local_polygonize_ratio: naive.local_polygonize_s / cached.local_polygonize_s.max(1e-9),
        dirty_render_speedup: cached.full_render_s / cached.dirty_render_s.max(1e-9),
        changed_evaluation_share: changed / all.max(1.0),
        evaluation_ceiling: all / changed.max(1.0),
        cached,
        naive,
        rounds: totals,
    };
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report).context("encoding the report")?);
    } else {
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
    Ok(())
}

/// One mode's replays of the script: local updates, and work from scratch.
type Replayed = (Vec<FrameRow>, Vec<ScratchFrame>);

/// Replays the script in `mode` incrementally and from scratch, each on a
/// freshly loaded scene.
fn replay_both_ways(
    a: &EditBenchArgs,
    script: &Script,
    polygonize: &PolygonizeArgs,
    mode: EvalMode,
) -> anyhow::Result<Replayed> {
    let load = || -> anyhow::Result<Scene> {
        let scene = Scene::load(&a.scene)?;
        polygonize.check(&scene)?;
        Ok(scene)
    };
    let (local, _) =
        with_threads(a.threads, || replay(&mut load()?, mode, script, polygonize, a.size, false, |_, _, _| Ok(())))??;
    let scratch = with_threads(a.threads, || replay_from_scratch(&mut load()?, mode, script, polygonize, a.size))??;
    Ok((local, scratch))
}

/// Figure 8: polygonization seconds per frame, cached and naive, local and from scratch.
fn plot(a: &EditBenchArgs, runs: &[Replayed]) -> anyhow::Result<()> {
    let local = |r: &[FrameRow]| r.iter().map(|f| f.polygonize_s).collect::<Vec<f64>>();
    let full = |r: &[ScratchFrame]| r.iter().map(|f| f.polygonize_s).collect::<Vec<f64>>();
    let (cl, cf, nl, nf) = (local(&runs[0].0), full(&runs[0].1), local(&runs[1].0), full(&runs[1].1));
    let series: [(&str, &[f64]); 4] =
        [("cached, local", &cl), ("cached, full", &cf), ("naive, local", &nl), ("naive, full", &nf)];
    let title = format!("polygonization seconds per frame, res {}", a.res);
    line_plot(&title, "s", &series, 760, 380).save_png(&a.output)
}
