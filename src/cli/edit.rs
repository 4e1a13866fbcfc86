//! `blobtrace edit`: replay an edit script through an edit session, each
//! frame updating only what its edits changed, timing each stage; `--verify`
//! checks every frame against a render and a polygonization from scratch.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use clap::Args;

use super::args::{CameraArgs, EvalOptions, LatticeArgs, create_dir, load_scene, parse_size, print_json, with_threads};
use super::progress::Bars;
use crate::draw::{frame_image, line_plot};
use crate::frame::{Frame, Size};
use crate::output::FileSet;
use crate::pipeline::{EditReport, EditSession, PipelineError, check_names, outline_dirty};
use crate::scene::load_script;
use crate::trace::PixelRect;

/// Options of `blobtrace edit`.
#[derive(Debug, Args)]
pub struct EditArgs {
    /// Scene file (RON).
    pub scene: PathBuf,
    /// Edit script (RON), e.g. scenes/scripts/medusa-head.ron.
    #[arg(long)]
    pub script: PathBuf,
    /// Image size WIDTHxHEIGHT (default: the scene's).
    #[arg(long, value_parser = parse_size)]
    pub size: Option<Size>,
    /// Camera overrides.
    #[command(flatten)]
    pub camera: CameraArgs,
    /// Polygonizer options.
    #[command(flatten)]
    pub polygonize: LatticeArgs,
    /// Field evaluation.
    #[command(flatten)]
    pub field: EvalOptions,
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
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs `blobtrace edit`.
pub fn run(a: &EditArgs) -> anyhow::Result<()> {
    let mut scene = load_scene(&a.scene, &a.camera)?;
    let mode = a.field.apply(&mut scene.model)?;
    let script = load_script(&a.script)?;
    check_names(&scene.model, &script)?;
    let size = a.size.unwrap_or(scene.size);
    let bars = Bars::new();
    let (report, frames) = with_threads(a.threads, || -> anyhow::Result<(EditReport, FileSet)> {
        let mut session = EditSession::new(scene, mode, size, &a.polygonize.settings())?;
        // Frames are kept as they come and written with the rest, once the
        // whole script has played: a script that fails writes nothing.
        let mut frames = FileSet::new();
        let save = |i: usize, frame: &Frame, rects: &[PixelRect]| match a.save_frames {
            true => keep_frame(&mut frames, &a.out_dir, i, frame, rects),
            false => Ok(()),
        };
        let report = session.replay(&script, a.verify, &bars, save)?;
        Ok((report, frames))
    })??;
    bars.finish();
    write_outputs(&a.out_dir, &report, frames)?;
    if a.json {
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

/// Adds frame `i`, its dirty rectangles outlined, to the files to write.
fn keep_frame(
    files: &mut FileSet,
    dir: &Path,
    i: usize,
    frame: &Frame,
    rects: &[PixelRect],
) -> Result<(), PipelineError> {
    let mut img = frame_image(frame);
    outline_dirty(&mut img, rects);
    let path = dir.join(format!("frame-{i:04}.png"));
    let bytes = img.png_bytes_for(&path)?;
    files.add(path, bytes);
    Ok(())
}

/// frames.csv and timing.png, with the frames kept in `files`: all or none.
fn write_outputs(dir: &Path, r: &EditReport, mut files: FileSet) -> anyhow::Result<()> {
    let incremental: Vec<f64> = r.per_frame.iter().map(|f| f.incremental_s).collect();
    let field: Vec<f64> = r.per_frame.iter().map(|f| f.field_s).collect();
    let mesh: Vec<f64> = r.per_frame.iter().map(|f| f.polygonize_s + f.bvh_s + f.mesh_render_s).collect();
    let full: Vec<f64> = r.per_frame.iter().map(|f| f.full_s.unwrap_or(f64::NAN)).collect();
    let mut series: Vec<(&str, &[f64])> = vec![("incremental", &incremental), ("field", &field), ("mesh", &mesh)];
    if r.full_s.is_some() {
        series.push(("from scratch", &full));
    }
    create_dir(dir)?;
    let title = format!("seconds per frame ({})", r.eval);
    let timing = dir.join("timing.png");
    files.add(dir.join("frames.csv"), frames_csv(r).into_bytes());
    files.add(&timing, line_plot(&title, "s", &series, 720, 360).png_bytes_for(&timing)?);
    Ok(files.commit()?)
}

fn frames_csv(r: &EditReport) -> String {
    let mut csv = String::from(
        "frame,dirty_fraction,retraced_fraction,field_evals,apply_s,field_s,polygonize_s,bvh_s,bvh_rebuilt,mesh_render_s,diff_s,incremental_s,full_s,samples_cleared,triangles\n",
    );
    for f in &r.per_frame {
        let full = f.full_s.map_or(String::new(), |v| format!("{v:.6}"));
        let _ = writeln!(
            csv,
            "{},{:.5},{:.5},{},{:.6},{:.6},{:.6},{:.6},{},{:.6},{:.6},{:.6},{full},{},{}",
            f.frame,
            f.dirty_fraction,
            f.retraced_fraction,
            f.field_evals,
            f.apply_s,
            f.field_s,
            f.polygonize_s,
            f.bvh_s,
            f.bvh_rebuilt,
            f.mesh_render_s,
            f.diff_s,
            f.incremental_s,
            f.samples_cleared,
            f.triangles
        );
    }
    csv
}
