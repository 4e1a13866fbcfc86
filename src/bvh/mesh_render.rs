//! The mesh ray caster: the field renderer's camera, shading and AOVs, with
//! the surface taken from a triangle mesh, so the two images differ only where
//! the geometry does.

use glam::{Vec2, Vec3, Vec3A};

use super::RayTarget;
use crate::field::DEFAULT_COLOR;
use crate::frame::Frame;
use crate::trace::{
    PixelRect, PixelSample, Refinement, RenderSettings, Retrace, assemble, render_pixels, rerender_pixels,
    retrace_listed,
};

/// Totals over a mesh render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct MeshRenderStats {
    /// Primary rays traced.
    pub rays: u64,
    /// Rays that hit a triangle.
    pub hits: u64,
    /// Ray–triangle tests.
    pub triangle_tests: u64,
}

impl MeshRenderStats {
    /// The totals over cast `samples`, whose first counter is triangle tests.
    fn of(samples: &[PixelSample]) -> Self {
        let mut stats = MeshRenderStats { rays: samples.len() as u64, ..Default::default() };
        for p in samples {
            stats.hits += u64::from(p.depth.is_finite());
            stats.triangle_tests += u64::from(p.counts[0]);
        }
        stats
    }
}

/// Names of the extra channels: triangle tests per ray, and the triangle hit (index + 1, 0 on a miss).
const MESH_COUNTERS: [&str; 2] = ["tests.Y", "triangle.Y"];

/// Renders a triangle surface (a static mesh with its BVH, or a dynamic
/// mesh) with `settings`; `progress` gets finished rows.
pub fn render_mesh(
    target: &impl RayTarget,
    settings: &RenderSettings,
    progress: &(dyn Fn(usize) + Sync),
) -> (Frame, MeshRenderStats) {
    let samples = render_pixels(settings, progress, |x, y| shade_pixel(target, settings, x, y));
    (assemble(&samples, settings, MESH_COUNTERS), MeshRenderStats::of(&samples))
}

/// Re-casts the pixels inside `rects` (not overlapping) into `frame`, a render
/// of the surface before it changed; the rest is kept.
pub fn rerender_mesh(
    target: &impl RayTarget,
    settings: &RenderSettings,
    frame: &mut Frame,
    rects: &[PixelRect],
) -> MeshRenderStats {
    let done = rerender_pixels(frame, rects, MESH_COUNTERS, |x, y, _| {
        Some(Retrace::Changed(shade_pixel(target, settings, x, y)))
    });
    MeshRenderStats::of(&done.changed)
}

/// Casts the next batch of about `max_rays` stale pixels of `refinement`
/// into `frame`: once the refinement is done, `frame` equals a full render.
pub fn refine_mesh(
    target: &impl RayTarget,
    settings: &RenderSettings,
    frame: &mut Frame,
    refinement: &mut Refinement,
    max_rays: usize,
) -> MeshRenderStats {
    let batch = refinement.next_batch(max_rays);
    let done = retrace_listed(frame, &batch, MESH_COUNTERS, |x, y, _, _| {
        Some(Retrace::Changed(shade_pixel(target, settings, x, y)))
    });
    refinement.finish(&batch);
    MeshRenderStats::of(&done.changed)
}

fn shade_pixel(target: &impl RayTarget, s: &RenderSettings, x: u32, y: u32) -> PixelSample {
    let ray = s.camera.ray(x, y, s.width, s.height);
    let (hit, tests) = target.hit(&ray);
    let Some(hit) = hit else {
        return PixelSample::miss(s.background, [tests, 0]);
    };
    PixelSample {
        color: s.lighting.shade(&s.camera, ray.dir, hit.normal, hit.albedo),
        depth: hit.t,
        normal: hit.normal.into(),
        counts: [tests, hit.triangle + 1],
    }
}

/// Normal and albedo at barycentric `uv` of a triangle with per-vertex
/// normals and colours: the interpolated normal, or the triangle's own (by
/// its winding) where the vertex normals cancel, or one facing the viewer on
/// a degenerate triangle.
#[must_use]
pub fn surface_at(p: [Vec3; 3], n: [Vec3; 3], c: Option<[Vec3; 3]>, uv: Vec2, dir: Vec3A) -> (Vec3A, Vec3) {
    let w = [1.0 - uv.x - uv.y, uv.x, uv.y];
    let mix = |v: [Vec3; 3]| v[0] * w[0] + v[1] * w[1] + v[2] * w[2];
    let normal = Vec3A::from(mix(n))
        .try_normalize()
        .or_else(|| Vec3A::from((p[1] - p[0]).cross(p[2] - p[0])).try_normalize())
        .unwrap_or(-dir);
    (normal, c.map_or(DEFAULT_COLOR, mix))
}
