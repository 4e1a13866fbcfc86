//! `blobtrace compare`: render a scene by tracing its field and by ray casting
//! its polygonized surface with the same camera, and show where they disagree —
//! renders, EXRs of every AOV, heat maps with printed scales, one panel, and
//! statistics.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use serde::Serialize;

use super::mesh::{CacheErrorArgs, PolygonizeArgs, polygonize_scene};
use super::render::{MeshRenderReport, RenderReport, render_polygonized, render_scene};
use super::{EvalOptions, with_threads};
use crate::compare::{
    DiffReport, Metric, Rgb8Image, Scale, Thresholds, differences, frame_image, heat_map, judge, panel, silhouette_map,
};
use crate::frame::Frame;
use crate::scene::{Scene, Size};

/// Options of `blobtrace compare`.
#[derive(Debug, Args)]
pub struct CompareArgs {
    /// Scene file (RON), e.g. scenes/medusa.ron.
    pub scene: PathBuf,
    /// Image size WIDTHxHEIGHT, overriding the scene's `size`.
    #[arg(long, value_parser = super::parse_size)]
    pub size: Option<Size>,
    /// Polygonizer options.
    #[command(flatten)]
    pub polygonize: PolygonizeArgs,
    /// Field evaluation for both the tracer and the polygonizer.
    #[command(flatten)]
    pub field: EvalOptions,
    /// Also render the mesh coloured by error_C (needs Cache nodes).
    #[command(flatten)]
    pub error: CacheErrorArgs,
    /// Directory for the images and stats.json (created if missing).
    #[arg(long, default_value = "compare")]
    pub out_dir: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print stats.json on stdout too.
    #[arg(long)]
    pub json: bool,
}

/// Tolerances behind each error image's "fraction above tolerance".
#[derive(Debug, Serialize)]
pub struct Tolerances {
    /// Depth, in lattice cells.
    pub depth_cells: f32,
    /// Normal angle, in degrees.
    pub normal_deg: f32,
    /// Colour, largest linear RGB difference.
    pub color: f32,
}

/// Wall-clock seconds of each stage of `compare`.
#[derive(Debug, Serialize)]
pub struct StageSeconds {
    /// Tracing the field.
    pub field_render: f64,
    /// Polygonizing.
    pub polygonize: f64,
    /// Building the CWBVH.
    pub bvh_build: f64,
    /// Ray casting the mesh.
    pub mesh_render: f64,
    /// Computing the error images' statistics.
    pub diff: f64,
}

/// Statistics of one error image.
#[derive(Debug, Serialize)]
pub struct ErrorStats {
    /// Mean of the magnitudes over pixels both renders hit (all pixels for colour).
    pub mean: f64,
    /// Median.
    pub median: f32,
    /// 95th percentile.
    pub p95: f32,
    /// 99th percentile.
    pub p99: f32,
    /// Largest.
    pub max: f32,
    /// Fraction of the compared pixels above the tolerance.
    pub fraction_above_tolerance: f64,
    /// Pixels compared.
    pub compared_px: usize,
}

impl From<&DiffReport> for ErrorStats {
    fn from(r: &DiffReport) -> Self {
        Self {
            mean: r.mean,
            median: r.median,
            p95: r.p95,
            p99: r.p99,
            max: r.max,
            fraction_above_tolerance: r.over_fail_percent / 100.0,
            compared_px: r.compared,
        }
    }
}

/// What `compare` writes to stats.json.
#[derive(Debug, Serialize)]
pub struct CompareReport {
    /// Seconds per stage: field render, polygonization, BVH build, mesh render, diff.
    pub stage_seconds: StageSeconds,
    /// Pixels hit by one render only.
    pub mismatch_px: usize,
    /// Depth error (mesh − field), in lattice cells.
    pub depth_error_cells: ErrorStats,
    /// Normal angle error, degrees.
    pub normal_error_deg: ErrorStats,
    /// Colour difference.
    pub color_error: ErrorStats,
    /// The tolerances used.
    pub tolerances: Tolerances,
    /// The field render.
    pub ray: RenderReport,
    /// The mesh render, with the polygonization.
    pub mesh: MeshRenderReport,
}

/// Runs `blobtrace compare`.
pub fn run(a: &CompareArgs) -> anyhow::Result<()> {
    let mut scene = Scene::load(&a.scene)?;
    let mode = a.field.apply(&mut scene.model)?;
    let size = a.size.unwrap_or(scene.size);
    let (ray, mesh, error_render, errors, report) = with_threads(a.threads, || -> anyhow::Result<_> {
        a.polygonize.check(&scene)?;
        std::fs::create_dir_all(&a.out_dir).with_context(|| format!("creating {}", a.out_dir.display()))?;
        // A set half old and half new is worse than none: every name must be writable first.
        for name in OUTPUTS {
            super::check_output_dir(&a.out_dir.join(name))?;
        }
        let (ray, ray_report) = render_scene(&scene, size, mode);
        let (mesh_model, mut mesh_report) = polygonize_scene(&scene, mode, &a.polygonize);
        let mut by_error = mesh_model.clone();
        a.error.apply(&scene, &mut by_error, &mut mesh_report)?;
        let error_render = a.error.error.then(|| render_polygonized(&scene, &by_error, mesh_report.clone(), size).0);
        let (mesh, mesh_render) = render_polygonized(&scene, &mesh_model, mesh_report, size);
        let (errors, report) = measure(&ray, &mesh, ray_report, mesh_render);
        Ok((ray, mesh, error_render, errors, report))
    })??;
    let heat_maps = write_outputs(&a.out_dir, &ray, &mesh, &errors)?;
    if let Some(frame) = &error_render {
        frame.save_png(&a.out_dir.join("mesh_error.png"))?;
    }
    write_panel(&a.out_dir, &ray, &mesh, error_render.as_ref(), a.error.error_scale, &report, heat_maps)?;
    let json = serde_json::to_string_pretty(&report).context("encoding the report")?;
    crate::output::write_atomic(&a.out_dir.join("stats.json"), json.as_bytes()).context("writing stats.json")?;
    if a.json {
        println!("{json}");
    } else {
        eprintln!(
            "{}: {} pixels hit by one render only; depth error mean {:.3} cells (p99 {:.3}); normal error mean {:.2}° (p99 {:.2}°); mesh of {} triangles",
            a.out_dir.display(),
            report.mismatch_px,
            report.depth_error_cells.mean,
            report.depth_error_cells.p99,
            report.normal_error_deg.mean,
            report.normal_error_deg.p99,
            report.mesh.mesh.triangles
        );
    }
    Ok(())
}

/// The per-pixel errors of the mesh render against the field render.
struct ErrorImages {
    /// Mesh − field depth, in lattice cells.
    depth_cells: Vec<f32>,
    /// Angle between normals, degrees.
    normal_deg: Vec<f32>,
    /// Largest linear RGB difference.
    color: Vec<f32>,
}

impl ErrorImages {
    fn of(ray: &Frame, mesh: &Frame, cell: f32) -> Self {
        Self {
            depth_cells: differences(mesh, ray, Metric::Depth).into_iter().map(|d| d / cell).collect(),
            normal_deg: differences(mesh, ray, Metric::Normal),
            color: differences(mesh, ray, Metric::Abs),
        }
    }
}

/// The error images and their statistics.
fn measure(
    ray: &Frame,
    mesh: &Frame,
    ray_report: RenderReport,
    mesh_report: MeshRenderReport,
) -> (ErrorImages, CompareReport) {
    let start = std::time::Instant::now();
    let tolerances = Tolerances { depth_cells: 0.25, normal_deg: 5.0, color: 0.05 };
    let errors = ErrorImages::of(ray, mesh, mesh_report.mesh.cell_size);
    let stats = |values: &[f32], tolerance: f32| {
        // Pixels hit by one render only are the silhouette map's business.
        let both: Vec<f32> = values.iter().map(|&v| if v.is_infinite() { f32::NAN } else { v }).collect();
        let t = Thresholds {
            fail: tolerance,
            failpercent: 100.0,
            warn: tolerance,
            warnpercent: 100.0,
            ..Default::default()
        };
        ErrorStats::from(&judge(Metric::Abs, &both, &vec![false; both.len()], t))
    };
    let depth_error_cells = stats(&errors.depth_cells, tolerances.depth_cells);
    let normal_error_deg = stats(&errors.normal_deg, tolerances.normal_deg);
    let color_error = stats(&errors.color, tolerances.color);
    let stage_seconds = StageSeconds {
        field_render: ray_report.seconds,
        polygonize: mesh_report.mesh.seconds,
        bvh_build: mesh_report.bvh_build_seconds,
        mesh_render: mesh_report.seconds,
        diff: start.elapsed().as_secs_f64(),
    };
    let report = CompareReport {
        stage_seconds,
        mismatch_px: ray.depth.iter().zip(&mesh.depth).filter(|(a, b)| a.is_finite() != b.is_finite()).count(),
        depth_error_cells,
        normal_error_deg,
        color_error,
        tolerances,
        ray: ray_report,
        mesh: mesh_report,
    };
    (errors, report)
}

/// Every file `compare` writes into its output directory.
const OUTPUTS: [&str; 11] = [
    "ray.png",
    "mesh.png",
    "ray.exr",
    "mesh.exr",
    "silhouette.png",
    "depth_error.png",
    "normal_error.png",
    "color_error.png",
    "panel.png",
    "mesh_error.png",
    "stats.json",
];

/// Writes the renders, EXRs and heat maps; returns the heat maps with their panel titles.
fn write_outputs(
    dir: &Path,
    ray: &Frame,
    mesh: &Frame,
    errors: &ErrorImages,
) -> anyhow::Result<Vec<(String, Rgb8Image)>> {
    ray.save_png(&dir.join("ray.png"))?;
    mesh.save_png(&dir.join("mesh.png"))?;
    ray.save_exr(&dir.join("ray.exr"))?;
    mesh.save_exr(&dir.join("mesh.exr"))?;
    let (w, h) = (ray.width, ray.height);
    let heat = |values: &[f32], scale, title, unit| heat_map(values, w, h, scale, title, unit);
    let maps = [
        ("silhouette", "silhouette.png", silhouette_map(&ray.depth, &mesh.depth, w, h, ["field", "mesh"])),
        (
            "depth error",
            "depth_error.png",
            heat(&errors.depth_cells, Scale::Signed { max: 1.0 }, "depth error, mesh - field", "cells"),
        ),
        (
            "normal error",
            "normal_error.png",
            heat(&errors.normal_deg, Scale::Magnitude { max: 10.0 }, "normal error", "deg"),
        ),
        (
            "colour difference",
            "color_error.png",
            heat(&errors.color, Scale::Magnitude { max: 0.1 }, "colour difference", ""),
        ),
    ];
    for (_, file, img) in &maps {
        img.save_png(&dir.join(file))?;
    }
    Ok(maps.into_iter().map(|(title, _, img)| (title.to_string(), img)).collect())
}

/// The panel: both renders, the mesh by error_C when asked, and the heat maps.
fn write_panel(
    dir: &Path,
    ray: &Frame,
    mesh: &Frame,
    by_error: Option<&Frame>,
    error_scale: f32,
    report: &CompareReport,
    heat_maps: Vec<(String, Rgb8Image)>,
) -> anyhow::Result<()> {
    let mut items = vec![
        ("field (ray traced)".to_string(), frame_image(ray)),
        (format!("mesh, res {} ({} triangles)", report.mesh.mesh.res, report.mesh.mesh.triangles), frame_image(mesh)),
    ];
    if let Some(f) = by_error {
        items.push((format!("mesh by error_C, magma 0..{error_scale}"), frame_image(f)));
    }
    items.extend(heat_maps);
    panel(&items, if by_error.is_some() { 4 } else { 3 }).save_png(&dir.join("panel.png"))
}
