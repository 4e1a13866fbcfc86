//! The caching paper's Figure 8 and Table 2: an edit script's per-frame
//! time with caches and without (exact naive, the paper's "no cache"), each
//! as local updates and as work from scratch, in one process; with a plot.
//! The incremental and from-scratch replays each start from a freshly loaded
//! scene, so neither finds samples the other filled.

use std::path::PathBuf;

use serde::Serialize;

use crate::draw::line_plot;
use crate::field::EvalMode;
use crate::frame::Size;
use crate::pipeline::{
    EditSession, FrameRow, PipelineError, PolygonizeSettings, Result, ScratchFrame, Silent, replay_from_scratch,
    with_threads,
};
use crate::progress::Progress;
use crate::scene::{Scene, Script, load_script};

/// What `bench edit` replays.
#[derive(Clone, Debug)]
pub struct EditBenchSettings {
    /// Scene file.
    pub scene: PathBuf,
    /// Edit script.
    pub script: PathBuf,
    /// Mesh resolution (the paper's 60 and 120).
    pub res: u32,
    /// Image size of the ray-cast path.
    pub size: Size,
    /// Where to write the plot.
    pub plot: PathBuf,
    /// Rounds of replays, each mode once per round; the fastest of each measure counts.
    pub repeat: u32,
    /// Worker threads (default: all cores; the paper's timings ran on one processor).
    pub threads: Option<usize>,
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

/// Replays the script with and without caches, locally and from scratch; writes the plot.
pub fn bench_edit(a: &EditBenchSettings, progress: &dyn Progress) -> Result<EditBenchReport> {
    let script = load_script(&a.script)?;
    let polygonize = PolygonizeSettings { res: a.res, ..Default::default() };
    // Per round, the replays of each mode; the plot shows the round whose
    // cached local updates were fastest.
    let mut rounds: Vec<Vec<Replayed>> = vec![];
    for r in 0..a.repeat {
        let mut round = vec![];
        for mode in [EvalMode::Cached, EvalMode::Naive] {
            let done = 2 * u64::from(r) + u64::from(mode == EvalMode::Naive);
            progress.update("replays (cached, naive per round)", done, 2 * u64::from(a.repeat));
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
    Ok(EditBenchReport {
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
    })
}

/// One mode's replays of the script: local updates, and work from scratch.
type Replayed = (Vec<FrameRow>, Vec<ScratchFrame>);

/// Replays the script in `mode` incrementally and from scratch, each on a
/// freshly loaded scene.
fn replay_both_ways(
    a: &EditBenchSettings,
    script: &Script,
    polygonize: &PolygonizeSettings,
    mode: EvalMode,
) -> Result<Replayed> {
    let local = with_threads(a.threads, || -> Result<Vec<FrameRow>> {
        let mut session = EditSession::new(Scene::load(&a.scene)?, mode, a.size, polygonize)?;
        Ok(session.replay(script, false, &Silent, |_, _, _| Ok(()))?.per_frame)
    })??;
    let scratch = with_threads(a.threads, || -> Result<Vec<ScratchFrame>> {
        replay_from_scratch(&mut Scene::load(&a.scene)?, mode, script, polygonize, a.size, &Silent)
    })??;
    Ok((local, scratch))
}

/// Figure 8: polygonization seconds per frame, cached and naive, local and from scratch.
fn plot(a: &EditBenchSettings, runs: &[Replayed]) -> Result<()> {
    let local = |r: &[FrameRow]| r.iter().map(|f| f.polygonize_s).collect::<Vec<f64>>();
    let full = |r: &[ScratchFrame]| r.iter().map(|f| f.polygonize_s).collect::<Vec<f64>>();
    let (cl, cf, nl, nf) = (local(&runs[0].0), full(&runs[0].1), local(&runs[1].0), full(&runs[1].1));
    let series: [(&str, &[f64]); 4] =
        [("cached, local", &cl), ("cached, full", &cf), ("naive, local", &nl), ("naive, full", &nf)];
    let title = format!("polygonization seconds per frame, res {}", a.res);
    line_plot(&title, "s", &series, 760, 380)
        .save_png(&a.plot)
        .map_err(|e| PipelineError::File { path: a.plot.clone(), message: format!("{e:#}") })
}
