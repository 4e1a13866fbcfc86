//! Rendering a scene: by tracing its field, or by ray casting a mesh of it
//! through a BVH, each timed and reported; and the files a render is written
//! to (a PNG, an EXR of every AOV, the cost picture), all or none.

use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use super::cache_report::CacheReport;
use super::cost_map::cost_map;
use super::error::Result;
use super::polygonize::MeshReport;
use crate::bvh::{MeshBvh, MeshRenderStats, StaticMesh, blank_mesh_frame, render_mesh_into as cast_mesh};
use crate::field::{EmptySpace, EvalMode};
use crate::frame::{Frame, Size};
use crate::mesh::Mesh;
use crate::output::FileSet;
use crate::progress::{Progress, rows};
use crate::scene::Scene;
use crate::trace::{RenderSettings, RenderStats, blank_field_frame, render_model_into};

impl Scene {
    /// The scene's camera and background at `size`, with default lights and
    /// the tracer knobs sized to its model.
    #[must_use]
    pub fn render_settings(&self, size: Size) -> RenderSettings {
        RenderSettings::new(self.camera, size, self.background, &self.model)
    }
}

/// Statistics of a field render.
#[derive(Clone, Debug, Serialize)]
pub struct RenderReport {
    /// Wall-clock seconds spent tracing, marking the empty space or listing
    /// the supports of each screen tile included; the frame it fills is
    /// made before the clock starts.
    pub seconds: f64,
    /// The ray tracer: `kernel` or `segment`.
    pub tracer: &'static str,
    /// Fraction of the empty-space grid's cells where the surface cannot be
    /// (the segment tracer's marks).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub empty_fraction: Option<f64>,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Rays per pixel.
    pub samples: u32,
    /// Rays, hits (rays that hit), evaluations and steps.
    #[serde(flatten)]
    pub stats: RenderStats,
    /// Rays traced per second.
    pub rays_per_second: f64,
    /// Field evaluations per ray.
    pub evals_per_ray: f64,
    /// Field evaluations per ray that hit.
    pub evals_per_hit: f64,
    /// Supports crossed per ray (the kernel tracer's steps).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub supports_per_ray: Option<f64>,
    /// Evaluation mode: naive, indexed or cached.
    pub eval: String,
    /// Threads used.
    pub threads: usize,
    /// Points the exact sums add at a time (8 or 4; see [`crate::field::SUMS_ENV`]).
    pub point_sum_lanes: u32,
    /// What auto mode decides for each cache and the estimate behind it
    /// (whatever the mode: the decisions are the scene's).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub cache_decisions: Vec<crate::field::CacheDecision>,
    /// What the caches hold and did, when rendering cached.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub caches: Option<CacheReport>,
}

/// Statistics of a mesh render, with the polygonization's.
#[derive(Clone, Debug, Serialize)]
pub struct MeshRenderReport {
    /// Wall-clock seconds spent ray casting the mesh (its frame made before the clock starts).
    pub seconds: f64,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Rays per pixel.
    pub samples: u32,
    /// Rays, hits (rays that hit) and triangle tests.
    #[serde(flatten)]
    pub stats: MeshRenderStats,
    /// Rays cast per second.
    pub rays_per_second: f64,
    /// Seconds building the BVH.
    pub bvh_build_seconds: f64,
    /// The polygonization.
    pub mesh: MeshReport,
}

/// Renders `scene` at `size` by tracing its field in `mode`, `samples` rays
/// per pixel (see [`crate::trace::samples`]), timing it.
pub fn render_field(
    scene: &Scene,
    (size, samples): (Size, u32),
    mode: EvalMode,
    progress: &dyn Progress,
) -> (Frame, RenderReport) {
    let settings = RenderSettings { samples, ..scene.render_settings(size) };
    // The frame is made before the clock starts, as the model is: `seconds`
    // is the rendering (as the Segment Tracing reference's frame time is,
    // whose pixel buffers are made and zeroed before its clock).
    let blank = blank_field_frame(&settings);
    let start = Instant::now();
    let (mut frame, stats, empty) =
        render_model_into(blank, &scene.model, mode, &settings, &rows(progress, "tracing", size.1));
    let seconds = start.elapsed().as_secs_f64();
    frame.add_planar_depth(&settings.camera);
    let report = RenderReport {
        seconds,
        // Only the segment tracer marks empty space.
        tracer: if empty.is_some() { "segment" } else { "kernel" },
        empty_fraction: empty.as_ref().map(EmptySpace::empty_fraction),
        width: size.0,
        height: size.1,
        samples,
        stats,
        rays_per_second: stats.rays as f64 / seconds.max(1e-9),
        evals_per_ray: stats.field_evals as f64 / stats.rays.max(1) as f64,
        evals_per_hit: stats.field_evals as f64 / stats.hits.max(1) as f64,
        supports_per_ray: empty.is_none().then(|| stats.steps as f64 / stats.rays.max(1) as f64),
        eval: format!("{mode:?}").to_lowercase(),
        threads: rayon::current_num_threads(),
        point_sum_lanes: crate::field::point_sum_lanes(),
        cache_decisions: scene.model.cache_decisions(),
        caches: (mode == EvalMode::Cached).then(|| CacheReport::of(&scene.model)),
    };
    (frame, report)
}

/// Builds the BVH over `mesh` and ray casts it with `scene`'s camera at
/// `size`, `samples` rays per pixel, timing it.
pub fn render_mesh(
    scene: &Scene,
    mesh: &Mesh,
    mesh_report: MeshReport,
    (size, samples): (Size, u32),
    progress: &dyn Progress,
) -> (Frame, MeshRenderReport) {
    let settings = RenderSettings { samples, ..scene.render_settings(size) };
    let bvh = MeshBvh::build(mesh);
    // Made before the clock, as a field render's frame is.
    let blank = blank_mesh_frame(&settings);
    let start = Instant::now();
    let target = StaticMesh { mesh, bvh: &bvh };
    let (mut frame, stats) = cast_mesh(blank, &target, &settings, &rows(progress, "ray casting the mesh", size.1));
    let seconds = start.elapsed().as_secs_f64();
    frame.add_planar_depth(&settings.camera);
    let report = MeshRenderReport {
        seconds,
        width: size.0,
        height: size.1,
        samples,
        stats,
        rays_per_second: stats.rays as f64 / seconds.max(1e-9),
        bvh_build_seconds: bvh.build_seconds,
        mesh: mesh_report,
    };
    (frame, report)
}

/// The files a render is written to: a PNG, and when asked an EXR of every
/// AOV and the cost picture (which needs a field render's work counts).
#[derive(Clone, Copy, Debug)]
pub struct RenderFiles<'a> {
    /// The 8-bit sRGB image.
    pub png: &'a Path,
    /// Every AOV, as floats.
    pub exr: Option<&'a Path>,
    /// Where the time went (see [`cost_map`]).
    pub cost_png: Option<&'a Path>,
}

impl RenderFiles<'_> {
    /// Writes `frame` to every file asked for, all of them or none.
    pub fn save(&self, frame: &Frame) -> Result<()> {
        let mut files = FileSet::new();
        files.add(self.png, frame.png_bytes_for(self.png)?);
        if let Some(exr) = self.exr {
            files.add(exr, frame.exr_bytes(exr)?);
        }
        if let Some(path) = self.cost_png {
            files.add(path, cost_map(frame)?.png_bytes_for(path)?);
        }
        Ok(files.commit()?)
    }
}
