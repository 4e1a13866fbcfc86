//! The mesh ray caster: the field renderer's camera, shading and AOVs, with
//! the surface taken from a triangle mesh, so the two images differ only where
//! the geometry does.

use glam::Vec3A;

use super::{MeshBvh, interpolate};
use crate::field::DEFAULT_COLOR;
use crate::frame::Frame;
use crate::mesh::Mesh;
use crate::trace::{PixelSample, RenderSettings, assemble, render_pixels};

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

/// Names of the extra channels: triangle tests per ray, and the triangle hit (index + 1, 0 on a miss).
const MESH_COUNTERS: [&str; 2] = ["tests.Y", "triangle.Y"];

/// Renders `mesh` through its `bvh` with `settings`; `progress` gets finished rows.
pub fn render_mesh(
    mesh: &Mesh,
    bvh: &MeshBvh,
    settings: &RenderSettings,
    progress: &(dyn Fn(usize) + Sync),
) -> (Frame, MeshRenderStats) {
    let samples = render_pixels(settings, progress, |x, y| shade_pixel(mesh, bvh, settings, x, y));
    let mut stats = MeshRenderStats { rays: samples.len() as u64, ..Default::default() };
    for p in &samples {
        stats.hits += u64::from(p.depth.is_finite());
        stats.triangle_tests += u64::from(p.counts[0]);
    }
    (assemble(&samples, settings, MESH_COUNTERS), stats)
}

fn shade_pixel(mesh: &Mesh, bvh: &MeshBvh, s: &RenderSettings, x: u32, y: u32) -> PixelSample {
    let ray = s.camera.ray(x, y, s.width, s.height);
    let (hit, tests) = bvh.intersect(&ray);
    let Some(hit) = hit else {
        return PixelSample::miss(s.background, [tests, 0]);
    };
    let normal = smooth_normal(mesh, &hit).unwrap_or_else(|| geometric_normal(mesh, hit.triangle, ray.dir));
    let albedo = mesh.colors.as_deref().map_or(DEFAULT_COLOR, |c| interpolate(mesh, c, &hit));
    PixelSample {
        color: s.lighting.shade(&s.camera, ray.dir, normal, albedo),
        depth: hit.t,
        normal: normal.into(),
        counts: [tests, hit.triangle + 1],
    }
}

/// The vertex normals interpolated at the hit, if they do not cancel.
fn smooth_normal(mesh: &Mesh, hit: &super::MeshHit) -> Option<Vec3A> {
    Vec3A::from(interpolate(mesh, &mesh.normals, hit)).try_normalize()
}

/// The triangle's own normal (outward by the mesh's winding), or one facing
/// the viewer for a degenerate triangle.
fn geometric_normal(mesh: &Mesh, t: u32, dir: Vec3A) -> Vec3A {
    let [a, b, c] = mesh.corners(t as usize);
    Vec3A::from((b - a).cross(c - a)).try_normalize().unwrap_or(-dir)
}

