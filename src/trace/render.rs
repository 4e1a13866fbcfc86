//! Rendering a frame by tracing one primary ray per pixel through a field,
//! rows in parallel. Each pixel depends only on its own ray, so the image is
//! bit-identical for any number of threads.

use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{Vec3, Vec3A};
use rayon::prelude::*;

use super::segment::{TraceOptions, trace_ray};
use super::shade::Lighting;
use crate::camera::Camera;
use crate::field::Field;
use crate::frame::Frame;
use crate::scene::{Scene, Size};

/// Everything a field render needs besides the field.
#[derive(Clone, Copy, Debug)]
pub struct RenderSettings {
    /// Camera.
    pub camera: Camera,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Colour of missed pixels (linear RGB).
    pub background: Vec3,
    /// Lights.
    pub lighting: Lighting,
    /// Tracer knobs.
    pub trace: TraceOptions,
}

impl RenderSettings {
    /// The scene's camera and background at `size`, with default lights and tracer knobs.
    #[must_use]
    pub fn for_scene(scene: &Scene, size: Size) -> Self {
        Self {
            camera: scene.camera,
            width: size.0,
            height: size.1,
            background: scene.background,
            lighting: Lighting::default(),
            trace: TraceOptions::default(),
        }
    }
}

/// One traced pixel.
#[derive(Clone, Copy, Debug)]
struct PixelSample {
    color: Vec3,
    depth: f32,
    normal: Vec3,
    steps: u32,
    evals: u32,
}

/// Totals over a render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct RenderStats {
    /// Primary rays traced.
    pub rays: u64,
    /// Rays that hit the surface.
    pub hits: u64,
    /// Field evaluations (values, gradients, colours and slope bounds).
    pub field_evals: u64,
    /// Segment-tracing steps.
    pub steps: u64,
}

/// Renders `field` with `settings`; `progress` is called with the number of
/// finished rows (from worker threads).
pub fn render<F: Field + ?Sized>(
    field: &F,
    settings: &RenderSettings,
    progress: &(dyn Fn(usize) + Sync),
) -> (Frame, RenderStats) {
    let (w, h) = (settings.width, settings.height);
    let done = AtomicUsize::new(0);
    let samples: Vec<PixelSample> = (0..h)
        .into_par_iter()
        .flat_map_iter(|y| {
            let row: Vec<PixelSample> = (0..w).map(|x| trace_pixel(field, settings, x, y)).collect();
            progress(done.fetch_add(1, Ordering::Relaxed) + 1);
            row
        })
        .collect();
    assemble(samples, settings)
}

fn trace_pixel<F: Field + ?Sized>(field: &F, s: &RenderSettings, x: u32, y: u32) -> PixelSample {
    let ray = s.camera.ray(x, y, s.width, s.height);
    let r = trace_ray(field, &ray, &s.trace);
    let mut sample =
        PixelSample { color: s.background, depth: f32::INFINITY, normal: Vec3::ZERO, steps: r.steps, evals: r.evals };
    if let Some(t) = r.hit {
        let p = ray.at(t);
        let normal = outward_normal(field.gradient(p), ray.dir);
        let albedo = field.color(p);
        sample.color = s.lighting.shade(&s.camera, ray.dir, normal, albedo);
        sample.depth = t;
        sample.normal = normal.into();
        sample.evals += 2;
    }
    sample
}

/// The unit outward normal `-∇f / |∇f|`; where the gradient vanishes (a flat
/// spot of the field), the normal faces the viewer.
#[must_use]
pub fn outward_normal(gradient: Vec3A, dir: Vec3A) -> Vec3A {
    (-gradient).try_normalize().unwrap_or(-dir)
}

fn assemble(samples: Vec<PixelSample>, s: &RenderSettings) -> (Frame, RenderStats) {
    let mut frame = Frame::new(s.width, s.height, s.background);
    let mut stats = RenderStats { rays: samples.len() as u64, ..Default::default() };
    let mut steps = Vec::with_capacity(samples.len());
    let mut evals = Vec::with_capacity(samples.len());
    for (i, p) in samples.iter().enumerate() {
        frame.color[i] = p.color;
        frame.depth[i] = p.depth;
        frame.normal[i] = p.normal;
        if p.depth.is_finite() {
            frame.alpha[i] = 1.0;
            stats.hits += 1;
        }
        steps.push(p.steps as f32);
        evals.push(p.evals as f32);
        stats.steps += u64::from(p.steps);
        stats.field_evals += u64::from(p.evals);
    }
    frame.extra.push(("steps.Y".into(), steps));
    frame.extra.push(("evals.Y".into(), evals));
    (frame, stats)
}
