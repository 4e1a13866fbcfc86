//! Comparing a scene's traced field with its polygonized surface through the
//! same camera: both renders, the per-pixel error images, their statistics,
//! and the files a comparison is looked at through (renders, EXRs, heat maps
//! with printed scales, one panel, stats.json).

use std::path::Path;

use serde::Serialize;

use super::error::{PipelineError, Result};
use super::polygonize::{PolygonizeSettings, color_by_cache_error, polygonize_checked};
use super::render::{MeshRenderReport, RenderReport, render_field, render_mesh};
use crate::compare::{
    DiffReport, FlipStats, Metric, Thresholds, default_pixels_per_degree, differences, flip_errors, flip_stats, judge,
};
use crate::draw::{Rgb8Image, Scale, frame_image, heat_map, panel, silhouette_map};
use crate::field::EvalMode;
use crate::frame::{Frame, Size};
use crate::output::FileSet;
use crate::progress::Progress;
use crate::scene::Scene;

/// What to compare.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompareSettings {
    /// Image size.
    pub size: Size,
    /// How to polygonize.
    pub polygonize: PolygonizeSettings,
    /// Also render the mesh coloured by error_C, brightest at this error (needs Cache nodes).
    pub error_scale: Option<f32>,
    /// Full scales of the heat maps; each unset one is chosen from the data.
    pub scales: ErrorScales,
    /// The tolerances behind each error's "fraction above tolerance".
    pub tolerances: Tolerances,
}

/// Full scales of a comparison's heat maps (`None`: chosen from the data).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ErrorScales {
    /// Depth error, lattice cells either way.
    pub depth_cells: Option<f32>,
    /// Normal error, degrees.
    pub normal_deg: Option<f32>,
    /// Colour difference, largest linear RGB channel.
    pub color: Option<f32>,
}

impl ErrorScales {
    /// Checks that every scale given is positive.
    pub fn check(&self) -> Result<()> {
        for (setting, v) in
            [("scale_depth", self.depth_cells), ("scale_normal", self.normal_deg), ("scale_color", self.color)]
        {
            if let Some(v) = v
                && !(v.is_finite() && v > 0.0)
            {
                return Err(PipelineError::setting(setting, format!("must be positive, got {v}")));
            }
        }
        Ok(())
    }
}

/// Tolerances behind each error image's "fraction above tolerance".
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Tolerances {
    /// Depth, in lattice cells.
    pub depth_cells: f32,
    /// Normal angle, in degrees.
    pub normal_deg: f32,
    /// Colour, largest linear RGB difference.
    pub color: f32,
}

impl Default for Tolerances {
    fn default() -> Self {
        Self { depth_cells: 0.25, normal_deg: 5.0, color: 0.05 }
    }
}

impl Tolerances {
    /// Checks that every tolerance is a non-negative number.
    pub fn check(&self) -> Result<()> {
        for (setting, v) in
            [("tol_depth", self.depth_cells), ("tol_normal", self.normal_deg), ("tol_color", self.color)]
        {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(PipelineError::setting(setting, format!("must be a non-negative number, got {v}")));
            }
        }
        Ok(())
    }
}

/// Wall-clock seconds of each stage of a comparison.
#[derive(Clone, Debug, Serialize)]
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
#[derive(Clone, Debug, Serialize)]
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

/// A comparison's statistics (what stats.json holds).
#[derive(Clone, Debug, Serialize)]
pub struct CompareReport {
    /// Seconds per stage: field render, polygonization, BVH build, mesh render, diff.
    pub stage_seconds: StageSeconds,
    /// Pixels hit by one render only.
    pub mismatch_px: usize,
    /// Depth error (mesh − field), in lattice cells: magnitudes.
    pub depth_error_cells: ErrorStats,
    /// Mean signed depth error over pixels both hit, in lattice cells
    /// (positive: the mesh lies behind the field's surface).
    pub depth_bias_cells: f64,
    /// Normal angle error, degrees.
    pub normal_error_deg: ErrorStats,
    /// Colour difference.
    pub color_error: ErrorStats,
    /// ꟻLIP's pooled statistics of the mesh render against the field render.
    pub flip: FlipStats,
    /// The tolerances used.
    pub tolerances: Tolerances,
    /// The heat maps' full scales, as given or chosen from the data.
    pub scales: UsedScales,
    /// The field render.
    pub ray: RenderReport,
    /// The mesh render, with the polygonization.
    pub mesh: MeshRenderReport,
}

/// The full scales a comparison's heat maps were drawn with.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct UsedScales {
    /// Depth error, lattice cells either way.
    pub depth_cells: f32,
    /// Normal error, degrees.
    pub normal_deg: f32,
    /// Colour difference.
    pub color: f32,
}

/// The per-pixel errors of the mesh render against the field render.
#[derive(Clone, Debug)]
pub struct ErrorImages {
    /// Mesh − field depth, in lattice cells.
    pub depth_cells: Vec<f32>,
    /// Angle between normals, degrees.
    pub normal_deg: Vec<f32>,
    /// Largest linear RGB difference.
    pub color: Vec<f32>,
    /// LDR-ꟻLIP error of the mesh render against the field render (the
    /// reference), as their PNGs show them.
    pub flip: Vec<f32>,
}

impl ErrorImages {
    /// The errors of `mesh` against `ray`, depth counted in lattice cells of side `cell`.
    #[must_use]
    pub fn of(ray: &Frame, mesh: &Frame, cell: f32) -> Self {
        Self {
            depth_cells: differences(mesh, ray, Metric::Depth).into_iter().map(|d| d / cell).collect(),
            normal_deg: differences(mesh, ray, Metric::Normal),
            color: differences(mesh, ray, Metric::Abs),
            flip: flip_errors(&ray.to_srgb8(), &mesh.to_srgb8(), ray.width, ray.height, default_pixels_per_degree()),
        }
    }
}

/// A finished comparison.
#[derive(Clone, Debug)]
pub struct Comparison {
    /// The traced field.
    pub ray: Frame,
    /// The ray-cast mesh.
    pub mesh: Frame,
    /// The mesh coloured by error_C, when asked.
    pub by_error: Option<Frame>,
    /// The error scale of `by_error`.
    pub error_scale: Option<f32>,
    /// Per-pixel errors.
    pub errors: ErrorImages,
    /// Statistics.
    pub report: CompareReport,
}

/// Renders `scene` both ways in `mode` and measures where they disagree;
/// checks the polygonization settings before any work.
pub fn compare(
    scene: &Scene,
    mode: EvalMode,
    settings: &CompareSettings,
    progress: &dyn Progress,
) -> Result<Comparison> {
    settings.scales.check()?;
    settings.tolerances.check()?;
    settings.polygonize.check(&scene.model)?;
    let (ray, ray_report) = render_field(scene, (settings.size, 1), mode, progress);
    let (mesh_model, mut mesh_report) = polygonize_checked(&scene.model, mode, &settings.polygonize, progress);
    let by_error = match settings.error_scale {
        Some(scale) => {
            let mut by_error = mesh_model.clone();
            // A cold copy of the model: error_C asks every cache, whatever auto mode decided.
            color_by_cache_error(&mut scene.model.clone(), &mut by_error, scale, &mut mesh_report)?;
            Some(render_mesh(scene, &by_error, mesh_report.clone(), (settings.size, 1), progress).0)
        }
        None => None,
    };
    let (mesh, mesh_render) = render_mesh(scene, &mesh_model, mesh_report, (settings.size, 1), progress);
    let (errors, report) = measure(&ray, &mesh, ray_report, mesh_render, settings);
    Ok(Comparison { ray, mesh, by_error, error_scale: settings.error_scale, errors, report })
}

/// The error images and their statistics.
fn measure(
    ray: &Frame,
    mesh: &Frame,
    ray_report: RenderReport,
    mesh_report: MeshRenderReport,
    settings: &CompareSettings,
) -> (ErrorImages, CompareReport) {
    let start = std::time::Instant::now();
    let tolerances = settings.tolerances;
    let errors = ErrorImages::of(ray, mesh, mesh_report.mesh.cell_size);
    let given = settings.scales;
    let scales = UsedScales {
        depth_cells: given.depth_cells.unwrap_or_else(|| Scale::from_data(&errors.depth_cells, true, 1.0).max()),
        normal_deg: given.normal_deg.unwrap_or_else(|| Scale::from_data(&errors.normal_deg, false, 10.0).max()),
        color: given.color.unwrap_or_else(|| Scale::from_data(&errors.color, false, 0.1).max()),
    };
    let depth_error_cells = error_stats(&errors.depth_cells, ray.width, tolerances.depth_cells);
    let normal_error_deg = error_stats(&errors.normal_deg, ray.width, tolerances.normal_deg);
    let color_error = error_stats(&errors.color, ray.width, tolerances.color);
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
        depth_bias_cells: finite_mean(&errors.depth_cells),
        normal_error_deg,
        color_error,
        flip: flip_stats(&errors.flip, ray.width, ray.height, default_pixels_per_degree()),
        tolerances,
        scales,
        ray: ray_report,
        mesh: mesh_report,
    };
    (errors, report)
}

/// The mean of the finite values (pixels both renders hit), signs kept.
fn finite_mean(values: &[f32]) -> f64 {
    let (sum, n) = values.iter().filter(|v| v.is_finite()).fold((0.0, 0usize), |(s, n), &v| (s + f64::from(v), n + 1));
    sum / n.max(1) as f64
}

/// The statistics of one error image over the pixels both renders hit.
fn error_stats(values: &[f32], width: u32, tolerance: f32) -> ErrorStats {
    // Pixels hit by one render only are the silhouette map's business.
    let both: Vec<f32> = values.iter().map(|&v| if v.is_infinite() { f32::NAN } else { v }).collect();
    let t =
        Thresholds { fail: tolerance, failpercent: 100.0, warn: tolerance, warnpercent: 100.0, ..Default::default() };
    ErrorStats::from(&judge(Metric::Abs, &both, &vec![false; both.len()], width, t))
}

/// The files [`Comparison::save`] writes into its directory every time.
pub const COMPARE_OUTPUTS: [&str; 11] = [
    "ray.png",
    "mesh.png",
    "ray.exr",
    "mesh.exr",
    "silhouette.png",
    "depth_error.png",
    "normal_error.png",
    "color_error.png",
    "flip_error.png",
    "panel.png",
    "stats.json",
];

/// The files [`Comparison::save`] writes only when the comparison holds
/// them: the mesh by error_C, only with a cache-error image
/// ([`CompareSettings::error_scale`]).
pub const COMPARE_OPTIONAL_OUTPUTS: [&str; 1] = ["mesh_error.png"];

impl Comparison {
    /// Writes the renders, EXRs, heat maps, the panel and stats.json into
    /// `dir`, all of them or none; returns stats.json's text.
    pub fn save(&self, dir: &Path) -> Result<String> {
        let mut files = FileSet::new();
        let mut frames = vec![("ray.png", &self.ray), ("mesh.png", &self.mesh)];
        frames.extend(self.by_error.as_ref().map(|frame| ("mesh_error.png", frame)));
        for (name, frame) in frames {
            let path = dir.join(name);
            files.add(&path, frame.png_bytes_for(&path)?);
        }
        let heat_maps = self.heat_maps();
        for (_, name, img) in &heat_maps {
            let path = dir.join(name);
            files.add(&path, img.png_bytes_for(&path)?);
        }
        let panel = self.panel(heat_maps.into_iter().map(|(title, _, img)| (title, img)).collect());
        let path = dir.join("panel.png");
        files.add(&path, panel.png_bytes_for(&path)?);
        for (name, frame) in [("ray.exr", &self.ray), ("mesh.exr", &self.mesh)] {
            let path = dir.join(name);
            files.add(&path, frame.exr_bytes(&path)?);
        }
        let json = serde_json::to_string_pretty(&self.report).expect("reports encode as JSON");
        files.add(dir.join("stats.json"), json.clone().into_bytes());
        files.commit()?;
        Ok(json)
    }

    /// The heat maps: panel title (with the headline statistics), file name, image.
    fn heat_maps(&self) -> [(String, &'static str, Rgb8Image); 5] {
        let (ray, mesh, errors, r) = (&self.ray, &self.mesh, &self.errors, &self.report);
        let (w, h) = (ray.width, ray.height);
        let heat = |values: &[f32], scale, title, unit| heat_map(values, w, h, scale, title, unit);
        let (d, n, c, f, s) = (&r.depth_error_cells, &r.normal_error_deg, &r.color_error, &r.flip, r.scales);
        [
            (
                format!("silhouette: {} px hit by one only", r.mismatch_px),
                "silhouette.png",
                silhouette_map(&ray.depth, &mesh.depth, w, h, ["field", "mesh"]),
            ),
            (
                format!("depth error: bias {:+.3}, mean {:.3}, p99 {:.3} cells", r.depth_bias_cells, d.mean, d.p99),
                "depth_error.png",
                heat(&errors.depth_cells, Scale::Signed { max: s.depth_cells }, "depth error, mesh - field", "cells"),
            ),
            (
                format!("normal error: mean {:.2}, p99 {:.1}, max {:.0} deg", n.mean, n.p99, n.max),
                "normal_error.png",
                heat(&errors.normal_deg, Scale::Magnitude { max: s.normal_deg }, "normal error, angle", "deg"),
            ),
            (
                format!("colour difference: mean {:.4}, p99 {:.3}, max {:.2}", c.mean, c.p99, c.max),
                "color_error.png",
                heat(&errors.color, Scale::Magnitude { max: s.color }, "colour difference, max |dRGB|", "linear"),
            ),
            (
                format!("FLIP: mean {:.4}, weighted median {:.3}, max {:.2}", f.mean, f.weighted_median, f.max),
                "flip_error.png",
                heat(&errors.flip, Scale::Magnitude { max: 1.0 }, "FLIP error, mesh vs field", ""),
            ),
        ]
    }

    /// The panel: both renders, the mesh by error_C when asked, and the heat maps.
    fn panel(&self, heat_maps: Vec<(String, Rgb8Image)>) -> Rgb8Image {
        let mesh = &self.report.mesh.mesh;
        let mut items = vec![
            ("field (ray traced)".to_string(), frame_image(&self.ray)),
            (
                format!(
                    "mesh, res {} ({} triangles): {}",
                    mesh.res,
                    mesh.triangles,
                    mesh.quality.as_ref().map_or("quality not checked".into(), |q| q.headline())
                ),
                frame_image(&self.mesh),
            ),
        ];
        if let (Some(f), Some(scale)) = (&self.by_error, self.error_scale) {
            items.push((format!("mesh by error_C, magma 0..{scale}"), frame_image(f)));
        }
        items.extend(heat_maps);
        panel(&items, if self.by_error.is_some() { 4 } else { 3 })
    }
}
