//! The mesh ray caster: the field renderer's camera, shading and AOVs, with
//! the surface taken from a triangle mesh, so the two images differ only where
//! the geometry does.

use glam::{Vec2, Vec3, Vec3A};

use super::RayTarget;
use crate::field::DEFAULT_COLOR;
use crate::frame::Frame;
use crate::trace::{
    CENTRE, PixelRect, PixelSample, PixelTotals, Refinement, RenderSettings, Retrace, blank_frame, render_pixels,
    rerender_pixels, retrace_listed,
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
    /// The mesh caster's totals, whose first counter is triangle tests.
    fn of(t: PixelTotals) -> Self {
        MeshRenderStats { rays: t.rays, hits: t.hits, triangle_tests: t.counts[0] }
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
    render_mesh_into(blank_mesh_frame(settings), target, settings, progress)
}

/// [`render_mesh`] into `frame`, a blank frame of the settings' (see
/// [`blank_mesh_frame`]) made beforehand, as a caller timing the casting
/// alone makes it.
pub fn render_mesh_into(
    frame: Frame,
    target: &impl RayTarget,
    settings: &RenderSettings,
    progress: &(dyn Fn(usize) + Sync),
) -> (Frame, MeshRenderStats) {
    let (frame, totals) =
        render_pixels(frame, settings, progress, |x, y, at| shade_pixel(target, settings, (x, y, at)));
    (frame, MeshRenderStats::of(totals))
}

/// A frame of `settings`' size showing the background, with the mesh
/// caster's counter channels at zero: the start of a progressive render
/// (see [`refine_mesh`]).
#[must_use]
pub fn blank_mesh_frame(settings: &RenderSettings) -> Frame {
    blank_frame(settings, MESH_COUNTERS)
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
        Some(Retrace::Changed(shade_pixel(target, settings, (x, y, CENTRE))))
    });
    MeshRenderStats::of(PixelTotals::of(&done.changed, 1))
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
        Some(Retrace::Changed(shade_pixel(target, settings, (x, y, CENTRE))))
    });
    refinement.finish(&batch);
    MeshRenderStats::of(PixelTotals::of(&done.changed, 1))
}

/// Casts the ray through point `at` of pixel (`x`, `y`).
fn shade_pixel(target: &impl RayTarget, s: &RenderSettings, (x, y, at): (u32, u32, Vec2)) -> PixelSample {
    let ray = s.camera.ray_at(x as f32 + at.x, y as f32 + at.y, s.width, s.height);
    let (hit, tests) = target.hit(&ray);
    let Some(hit) = hit else {
        return PixelSample::miss(s.background, [tests, 0]);
    };
    PixelSample {
        color: s.lighting.shade(&s.camera, ray.dir, hit.normal, hit.albedo),
        depth: hit.t,
        normal: hit.normal.into(),
        alpha: 1.0,
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
