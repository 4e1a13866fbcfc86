//! Replaying an edit script: through an [`EditSession`], frame by frame,
//! optionally verifying each against work from scratch; and from scratch
//! alone, the baseline local updates are measured against.

use std::collections::HashSet;
use std::time::Instant;

use serde::Serialize;

use super::edit_session::{EditSession, FrameRow};
use super::error::{PipelineError, Result};
use super::polygonize::{PolygonizeSettings, polygonizer_on};
use crate::field::{Edit, EvalMode, Model};
use crate::frame::{Frame, Size};
use crate::mesh::Lattice;
use crate::progress::Progress;
use crate::scene::{Scene, Script};
use crate::trace::{PixelRect, render_model};

/// Checks before any work that every edit names a node that exists by then
/// (names added and removed by earlier edits of the script count).
pub fn check_names(model: &Model, script: &Script) -> Result<()> {
    let mut known: HashSet<String> = model.names().into_iter().map(String::from).collect();
    for (i, edits) in script.frames.iter().enumerate() {
        for e in edits {
            if !known.contains(e.node()) {
                return Err(
                    PipelineError::Unsuitable(format!("no node is named {:?}", e.node())).at(script.frame_label(i))
                );
            }
            match e {
                Edit::AddPoint { name, .. } => known.insert(name.clone()),
                Edit::Remove { node } => known.remove(node),
                _ => true,
            };
        }
    }
    Ok(())
}

/// A replay's frames and totals.
#[derive(Clone, Debug, Serialize)]
pub struct EditReport {
    /// Frames replayed.
    pub frames: usize,
    /// Frames checked against from-scratch results.
    pub verified_frames: usize,
    /// Total seconds of the from-scratch renders and polygonizations (when verified).
    pub full_s: Option<f64>,
    /// Total seconds of the incremental updates.
    pub incremental_s: f64,
    /// Mean fraction of the pixels inside the dirty rectangles per frame.
    pub dirty_fraction: f64,
    /// Mean fraction of the pixels whose rays were traced again per frame.
    pub retraced_fraction: f64,
    /// Evaluation mode.
    pub eval: String,
    /// Each frame.
    pub per_frame: Vec<FrameRow>,
}

impl EditReport {
    fn of(rows: Vec<FrameRow>, verified: usize, mode: EvalMode) -> Self {
        let n = rows.len().max(1) as f64;
        Self {
            frames: rows.len(),
            verified_frames: verified,
            full_s: rows.iter().map(|r| r.full_s).sum::<Option<f64>>(),
            incremental_s: rows.iter().map(|r| r.incremental_s).sum(),
            dirty_fraction: rows.iter().map(|r| r.dirty_fraction).sum::<f64>() / n,
            retraced_fraction: rows.iter().map(|r| r.retraced_fraction).sum::<f64>() / n,
            eval: format!("{mode:?}").to_lowercase(),
            per_frame: rows,
        }
    }
}

impl EditSession {
    /// Replays the frames of `script`, updating incrementally and timing each
    /// frame; with `verify`, checks each frame against from-scratch results
    /// and stops at the first that differs. `after_frame` sees each frame's
    /// field image and dirty rectangles.
    pub fn replay(
        &mut self,
        script: &Script,
        verify: bool,
        progress: &dyn Progress,
        mut after_frame: impl FnMut(usize, &Frame, &[PixelRect]) -> Result<()>,
    ) -> Result<EditReport> {
        check_names(&self.scene().model, script)?;
        let (mut rows, mut verified) = (vec![], 0);
        let n = script.frames.len() as u64;
        let stage = if verify { "replaying and verifying frames" } else { "replaying frames" };
        for (i, edits) in script.frames.iter().enumerate() {
            progress.update(stage, i as u64, n);
            let at = |e: PipelineError| e.at(script.frame_label(i));
            let mut update = self.apply(edits).map_err(at)?;
            if verify {
                let check = self.verify();
                if let Some(what) = check.mismatch {
                    return Err(at(PipelineError::Mismatch(what)));
                }
                update.row.full_s = Some(check.full_s);
                update.row.full_render_s = Some(check.render_s);
                verified += 1;
            }
            after_frame(i, self.field_frame(), &update.dirty).map_err(at)?;
            rows.push(update.row);
        }
        progress.update(stage, n, n);
        Ok(EditReport::of(rows, verified, self.mode()))
    }
}

/// Seconds one frame takes from scratch: a full render, a full polygonization.
#[derive(Clone, Copy, Debug, Default)]
pub struct ScratchFrame {
    /// Rendering the field.
    pub render_s: f64,
    /// Polygonizing the field.
    pub polygonize_s: f64,
    /// The full render's field evaluations.
    pub evaluations: f64,
    /// Those of them spent on pixels that differ from the frame before's:
    /// what a dirty-rectangle frame, bit-identical to this one, must at least
    /// trace again.
    pub changed_evaluations: f64,
}

/// Replays the frames of `script` on `scene`, rendering and polygonizing every frame
/// from scratch: the baseline of the incremental updates, with caches that only
/// its own work has filled (a from-scratch frame run after an incremental one
/// would find the samples that frame filled). Like the incremental replay, it
/// starts from the scene rendered and polygonized once, untimed.
pub fn replay_from_scratch(
    scene: &mut Scene,
    mode: EvalMode,
    script: &Script,
    polygonize: &PolygonizeSettings,
    size: Size,
    progress: &dyn Progress,
) -> Result<Vec<ScratchFrame>> {
    polygonize.check_unrefined(&scene.model)?;
    check_names(&scene.model, script)?;
    let settings = scene.render_settings(size);
    // The lattice stays the first frame's, as a session's does.
    let lattice = Lattice::for_model(&scene.model, polygonize.res);
    let mut before = render_model(&scene.model, mode, &settings, &|_| {}).0;
    let _ = polygonizer_on(&scene.model, mode, lattice, polygonize.options());
    let mut rows = vec![];
    let n = script.frames.len() as u64;
    for (i, edits) in script.frames.iter().enumerate() {
        progress.update("replaying frames from scratch", i as u64, n);
        for edit in edits {
            scene.model.apply(edit).map_err(|e| PipelineError::from(e).at(script.frame_label(i)))?;
        }
        let clock = Instant::now();
        let after = render_model(&scene.model, mode, &settings, &|_| {}).0;
        let render_s = clock.elapsed().as_secs_f64();
        let clock = Instant::now();
        let _ = polygonizer_on(&scene.model, mode, lattice, polygonize.options());
        let polygonize_s = clock.elapsed().as_secs_f64();
        let (evaluations, changed_evaluations) = evaluations_where_changed(&before, &after);
        rows.push(ScratchFrame { render_s, polygonize_s, evaluations, changed_evaluations });
        before = after;
    }
    progress.update("replaying frames from scratch", n, n);
    Ok(rows)
}

/// The field evaluations of `after`'s pixels, all of them and those whose
/// colour, depth or normal differ from `before`'s.
fn evaluations_where_changed(before: &Frame, after: &Frame) -> (f64, f64) {
    let Some(evals) = after.aov("evals.Y") else { return (0.0, 0.0) };
    let differs = |i: usize| {
        after.depth[i].to_bits() != before.depth[i].to_bits()
            || after.color[i] != before.color[i]
            || after.normal[i] != before.normal[i]
    };
    (0..evals.len()).fold((0.0, 0.0), |(all, changed), i| {
        let e = f64::from(evals[i]);
        (all + e, if differs(i) { changed + e } else { changed })
    })
}
