//! `blobtrace render`: trace a scene's field (or ray cast its mesh) to a PNG and an EXR.

use std::path::{Path, PathBuf};

use clap::Args;

use super::args::{
    LoadedScene, PolygonizeArgs, RunArgs, SceneArgs, check_output_file, output_or_default, print_json, with_threads,
};
use super::exit::UsageError;
use super::progress::Bars;
use crate::field::EvalMode;
use crate::frame::Size;
use crate::pipeline::{RenderFiles, polygonize, render_field, render_mesh};
use crate::scene::Scene;
use crate::trace::samples::MAX_SAMPLES;

/// Options of `blobtrace render`.
#[derive(Debug, Args)]
pub struct RenderArgs {
    /// The scene, its image size, camera and field evaluation.
    #[command(flatten)]
    pub input: SceneArgs,
    /// Output PNG (8-bit sRGB). Defaults to SCENE's name with .png in the current directory.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Also write every AOV (R,G,B,A, Z, N.X/N.Y/N.Z, steps.Y, evals.Y) to this EXR.
    #[arg(long)]
    pub exr: Option<PathBuf>,
    /// Also write where the time went: heat maps of field evaluations and
    /// tracing steps per pixel (magma, each with its scale), as a PNG. Field
    /// renders only.
    #[arg(long, value_name = "PNG")]
    pub cost_png: Option<PathBuf>,
    /// Rays per pixel, 1 to 1024, for anti-aliasing: the first through the
    /// pixel's centre, the rest spread evenly over it (the same for any
    /// thread count). The colour is their mean, alpha the fraction that
    /// hit, Z the nearest hit. Default 1, the centre alone, as references are made.
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub spp: u32,
    /// Render the polygonized surface (ray cast through a BVH) instead of the field.
    #[arg(long)]
    pub mesh: bool,
    /// Polygonizer options, with --mesh.
    #[command(flatten)]
    pub polygonize: PolygonizeArgs,
    /// Threads and the JSON report.
    #[command(flatten)]
    pub run: RunArgs,
}

/// Runs `blobtrace render`.
pub fn run(a: &RenderArgs) -> anyhow::Result<()> {
    let LoadedScene { scene, mode, size } = a.input.load()?;
    let output = output_or_default(a.output.as_deref(), &a.input.scene, "png");
    check_output_file(&output, "png")?;
    if let Some(exr) = &a.exr {
        check_output_file(exr, "exr")?;
    }
    if let Some(cost) = &a.cost_png {
        check_output_file(cost, "png")?;
        if a.mesh {
            return Err(UsageError("--cost-png draws a field render's work: leave out --mesh".into()).into());
        }
    }
    if !(1..=MAX_SAMPLES).contains(&a.spp) {
        return Err(UsageError(format!("--spp: {} rays per pixel; 1 to {MAX_SAMPLES}", a.spp)).into());
    }
    if a.mesh { run_mesh(a, &scene, mode, size, &output) } else { run_field(a, &scene, mode, size, &output) }
}

fn run_field(a: &RenderArgs, scene: &Scene, mode: EvalMode, size: Size, output: &Path) -> anyhow::Result<()> {
    let bars = Bars::new();
    let (frame, report) = with_threads(a.run.threads, || render_field(scene, (size, a.spp), mode, &bars))?;
    bars.finish();
    RenderFiles { png: output, exr: a.exr.as_deref(), cost_png: a.cost_png.as_deref() }.save(&frame)?;
    warn_if_empty(report.stats.hits);
    if a.run.json {
        return print_json(&report);
    }
    let s = &report.stats;
    eprintln!(
        "{}: {size} in {:.3} s, {} of {} rays hit, {:.1} field evaluations per ray",
        output.display(),
        report.seconds,
        s.hits,
        s.rays,
        report.evals_per_ray
    );
    Ok(())
}

fn run_mesh(a: &RenderArgs, scene: &Scene, mode: EvalMode, size: Size, output: &Path) -> anyhow::Result<()> {
    let bars = Bars::new();
    let (frame, report) = with_threads(a.run.threads, || -> anyhow::Result<_> {
        let (mesh, mesh_report) = polygonize(&scene.model, mode, &a.polygonize.settings(), &bars)?;
        Ok(render_mesh(scene, &mesh, mesh_report, (size, a.spp), &bars))
    })??;
    bars.finish();
    RenderFiles { png: output, exr: a.exr.as_deref(), cost_png: None }.save(&frame)?;
    warn_if_empty(report.stats.hits);
    if a.run.json {
        return print_json(&report);
    }
    let (m, s) = (&report.mesh, &report.stats);
    eprintln!(
        "{}: {size} mesh of {} triangles (res {}) in {:.3} s, ray cast in {:.3} s, {} of {} rays hit",
        output.display(),
        m.triangles,
        m.res,
        m.seconds,
        report.seconds,
        s.hits,
        s.rays
    );
    Ok(())
}

/// Says so when no ray hit the surface: an empty image is rarely what was meant.
fn warn_if_empty(hits: u64) {
    if hits == 0 {
        eprintln!(
            "warning: no ray hit the surface (is the threshold above the field's maximum, or the camera looking away?)"
        );
    }
}
