//! `blobtrace edit`: replay an edit script through an edit session, each
//! frame updating only what its edits changed, timing each stage; `--verify`
//! checks every frame against a render and a polygonization from scratch.

use std::path::{Path, PathBuf};

use clap::Args;

use super::args::{LatticeArgs, LoadedScene, RunArgs, SceneArgs, print_json, with_threads};
use super::progress::Bars;
use crate::pipeline::{EditReport, EditSession, KeptFrames, check_names};
use crate::scene::load_script;

/// Options of `blobtrace edit`.
#[derive(Debug, Args)]
pub struct EditArgs {
    /// The scene, its image size, camera and field evaluation.
    #[command(flatten)]
    pub input: SceneArgs,
    /// Edit script (RON), e.g. scenes/scripts/medusa-head.ron.
    #[arg(long)]
    pub script: PathBuf,
    /// Polygonizer options.
    #[command(flatten)]
    pub polygonize: LatticeArgs,
    /// Directory for frames.csv, timing.png and, with --save-frames, every frame.
    #[arg(long, default_value = "edit")]
    pub out_dir: PathBuf,
    /// Render and polygonize every frame from scratch too, and check the
    /// incremental field image is bit-identical and the mesh has the same triangles.
    #[arg(long)]
    pub verify: bool,
    /// Also write every frame's field image with its dirty rectangles
    /// outlined (frame-NNNN.png), with the rest once the whole script has played.
    #[arg(long)]
    pub save_frames: bool,
    /// Threads and the JSON report.
    #[command(flatten)]
    pub run: RunArgs,
}

/// Runs `blobtrace edit`.
pub fn run(a: &EditArgs) -> anyhow::Result<()> {
    let LoadedScene { scene, mode, size } = a.input.load()?;
    let script = load_script(&a.script)?;
    check_names(&scene.model, &script)?;
    let bars = Bars::new();
    let (report, frames) = with_threads(a.run.threads, || -> anyhow::Result<(EditReport, KeptFrames)> {
        let mut session = EditSession::new(scene, mode, size, &a.polygonize.settings())?;
        let mut frames = KeptFrames::default();
        let report = session.replay(&script, a.verify, &bars, |i, frame, rects| match a.save_frames {
            true => frames.keep(i, frame, rects),
            false => Ok(()),
        })?;
        Ok((report, frames))
    })??;
    bars.finish();
    report.save(&a.out_dir, frames)?;
    if a.run.json {
        return print_json(&report);
    }
    print_summary(&a.out_dir, &report);
    Ok(())
}

fn print_summary(dir: &Path, report: &EditReport) {
    let full = report
        .full_s
        .map_or(String::new(), |f| format!(" against {f:.3} s from scratch ({} verified)", report.verified_frames));
    eprintln!(
        "{}: {} frames, {:.3} s incremental{full}, {:.1}% of the pixels in dirty rectangles and {:.1}% re-traced per frame",
        dir.display(),
        report.frames,
        report.incremental_s,
        100.0 * report.dirty_fraction,
        100.0 * report.retraced_fraction
    );
}
