//! `blobtrace render`: trace a scene's field to a PNG and an EXR.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::Args;
use serde::Serialize;

use super::progress::Progress;
use super::{EvalArg, check_output_dir, scene_stem, with_threads};
use crate::field::ModelField;
use crate::frame::Frame;
use crate::scene::{Scene, Size};
use crate::trace::{RenderSettings, RenderStats, render};

/// Options of `blobtrace render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    /// Scene file (RON), e.g. scenes/medusa.ron.
    pub scene: PathBuf,
    /// Output PNG (8-bit sRGB). Defaults to SCENE's name with .png in the current directory.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Also write every AOV (R,G,B,A, Z, N.X/N.Y/N.Z, steps.Y, evals.Y) to this EXR.
    #[arg(long)]
    pub exr: Option<PathBuf>,
    /// Image size WIDTHxHEIGHT, overriding the scene's `size`.
    #[arg(long, value_parser = super::parse_size)]
    pub size: Option<Size>,
    /// Worker threads (default: all cores). The image is identical for any count.
    #[arg(long)]
    pub threads: Option<usize>,
    /// How exact evaluation finds nearby primitives.
    #[arg(long, value_enum, default_value_t = EvalArg::Indexed)]
    pub eval: EvalArg,
    /// Print one JSON object of statistics on stdout instead of a summary line.
    #[arg(long)]
    pub json: bool,
}

/// Statistics printed by `render --json`.
#[derive(Debug, Serialize)]
pub struct RenderReport {
    /// Wall-clock seconds spent tracing.
    pub seconds: f64,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Rays, hits, evaluations and steps.
    #[serde(flatten)]
    pub stats: RenderStats,
    /// Rays traced per second.
    pub rays_per_second: f64,
    /// Field evaluations per ray.
    pub evals_per_ray: f64,
    /// Evaluation mode.
    pub eval: String,
    /// Threads used.
    pub threads: usize,
}

/// Runs `blobtrace render`.
pub fn run(a: &RenderArgs) -> anyhow::Result<()> {
    let scene = Scene::load(&a.scene)?;
    let output = a.output.clone().unwrap_or_else(|| PathBuf::from(format!("{}.png", scene_stem(&a.scene))));
    check_output_dir(&output)?;
    if let Some(exr) = &a.exr {
        check_output_dir(exr)?;
    }
    let size = a.size.unwrap_or(scene.size);
    let (frame, report) = with_threads(a.threads, || render_scene(&scene, size, a.eval))?;
    frame.save_png(&output)?;
    if let Some(exr) = &a.exr {
        frame.save_exr(exr)?;
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report).context("encoding the report")?);
    } else {
        eprintln!(
            "{}: {}x{} in {:.3} s, {} of {} rays hit, {:.1} field evaluations per ray",
            output.display(),
            report.width,
            report.height,
            report.seconds,
            report.stats.hits,
            report.stats.rays,
            report.evals_per_ray
        );
    }
    Ok(())
}

/// Renders `scene` at `size` with exact evaluation, timing it.
pub fn render_scene(scene: &Scene, size: Size, eval: EvalArg) -> (Frame, RenderReport) {
    let settings = RenderSettings::for_scene(scene, size);
    let field = ModelField::new(&scene.model, eval.into());
    let progress = Progress::new(u64::from(size.1), "tracing");
    let start = Instant::now();
    let (frame, stats) = render(&field, &settings, &|rows| progress.set(rows));
    let seconds = start.elapsed().as_secs_f64();
    progress.finish();
    let report = RenderReport {
        seconds,
        width: size.0,
        height: size.1,
        stats,
        rays_per_second: stats.rays as f64 / seconds.max(1e-9),
        evals_per_ray: stats.field_evals as f64 / stats.rays.max(1) as f64,
        eval: format!("{eval:?}").to_lowercase(),
        threads: rayon::current_num_threads(),
    };
    (frame, report)
}
