//! The mesh ray caster's acceleration structure: an obvhs compressed wide BVH
//! (CWBVH) over a [`Mesh`]'s triangles, the closest-hit query the renderer
//! needs, and a brute-force loop that tests check it against.

mod dynamic;
mod mesh_render;
mod traverse;

use std::time::{Duration, Instant};

use glam::{Vec2, Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::triangle::Triangle;

pub use dynamic::{BvhUpdate, DynamicMesh};
pub use mesh_render::{
    MeshRenderStats, blank_mesh_frame, refine_mesh, render_mesh, render_mesh_into, rerender_mesh, surface_at,
};

use crate::geom::Ray;
use crate::mesh::Mesh;
use traverse::closest_hit;

/// The closest intersection of a ray with a mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshHit {
    /// Distance along the (unit) ray.
    pub t: f32,
    /// The mesh triangle hit.
    pub triangle: u32,
    /// Barycentric weights of the triangle's second and third vertex.
    pub uv: Vec2,
}

/// What a primary ray sees on a triangle surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceHit {
    /// Distance along the unit ray.
    pub t: f32,
    /// Which triangle (an index for AOVs).
    pub triangle: u32,
    /// Unit shading normal.
    pub normal: Vec3A,
    /// Linear RGB albedo.
    pub albedo: Vec3,
}

/// A triangle surface a ray can be cast against.
pub trait RayTarget: Sync {
    /// The nearest hit along `ray`, and the number of triangles tested.
    fn hit(&self, ray: &Ray) -> (Option<SurfaceHit>, u32);
}

/// A static mesh with its CWBVH.
#[derive(Clone, Copy)]
pub struct StaticMesh<'a> {
    /// The mesh.
    pub mesh: &'a Mesh,
    /// Its BVH.
    pub bvh: &'a MeshBvh,
}

impl RayTarget for StaticMesh<'_> {
    fn hit(&self, ray: &Ray) -> (Option<SurfaceHit>, u32) {
        let (hit, tests) = self.bvh.intersect(ray);
        let surface = hit.map(|h| {
            let ids = self.mesh.triangles[h.triangle as usize];
            let attr = |v: &[Vec3]| ids.map(|i| v[i as usize]);
            let colors = self.mesh.colors.as_deref().map(attr);
            let (normal, albedo) =
                surface_at(attr(&self.mesh.positions), attr(&self.mesh.normals), colors, h.uv, ray.dir);
            SurfaceHit { t: h.t, triangle: h.triangle, normal, albedo }
        });
        (surface, tests)
    }
}

/// A CWBVH over a mesh's triangles, the triangles stored in the BVH's order.
pub struct MeshBvh {
    bvh: CwBvh,
    /// Triangles in BVH leaf order (`bvh.primitive_indices` already applied).
    triangles: Vec<Triangle>,
    /// Mesh triangle index of each stored triangle.
    mesh_index: Vec<u32>,
    /// Seconds spent building.
    pub build_seconds: f64,
}

impl MeshBvh {
    /// Builds the BVH over `mesh` with obvhs's medium preset (a good balance of
    /// build time and ray speed for meshes of 10⁵–10⁶ triangles).
    #[must_use]
    pub fn build(mesh: &Mesh) -> Self {
        let start = Instant::now();
        let tris = obvhs_triangles(mesh);
        if tris.is_empty() {
            return Self { bvh: CwBvh::default(), triangles: vec![], mesh_index: vec![], build_seconds: 0.0 };
        }
        let bvh = build_cwbvh_from_tris(&tris, BvhBuildParams::medium_build(), &mut Duration::default());
        let mesh_index = bvh.primitive_indices.clone();
        let triangles = mesh_index.iter().map(|&i| tris[i as usize]).collect();
        Self { bvh, triangles, mesh_index, build_seconds: start.elapsed().as_secs_f64() }
    }

    /// The nearest hit along `ray` with `t > 0`, and the number of triangles tested.
    #[must_use]
    pub fn intersect(&self, ray: &Ray) -> (Option<MeshHit>, u32) {
        if self.triangles.is_empty() {
            return (None, 0);
        }
        let (hit, tests) = closest_hit(&self.bvh, ray, |leaf| &self.triangles[leaf]);
        let hit = hit.map(|h| MeshHit { t: h.t, triangle: self.mesh_index[h.leaf], uv: h.uv });
        (hit, tests)
    }

    /// Checks the BVH's structure with obvhs's validator: every triangle
    /// reachable once, every node's box enclosing its children.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        if self.triangles.is_empty() {
            return true;
        }
        let v = self.bvh.validate(&self.triangles, true);
        v.discovered_primitives.len() == self.triangles.len() && v.prim_count == self.triangles.len()
    }
}

/// The mesh's triangles as obvhs triangles.
fn obvhs_triangles(mesh: &Mesh) -> Vec<Triangle> {
    (0..mesh.triangles.len())
        .map(|t| {
            let [v0, v1, v2] = mesh.corners(t).map(Vec3A::from);
            Triangle { v0, v1, v2 }
        })
        .collect()
}

/// The nearest hit along `ray` by testing every triangle: the reference for tests.
#[must_use]
pub fn brute_force_intersect(mesh: &Mesh, ray: &Ray) -> Option<MeshHit> {
    let r = obvhs::ray::Ray::new_inf(ray.origin, ray.dir);
    let mut best: Option<MeshHit> = None;
    for (t, tri) in obvhs_triangles(mesh).iter().enumerate() {
        let d = tri.intersect(&r);
        if d.is_finite() && best.is_none_or(|b| d < b.t) {
            best = Some(MeshHit { t: d, triangle: t as u32, uv: barycentric(tri, ray.at(d)) });
        }
    }
    best
}

/// The weights of `v1` and `v2` of the point `p` in the triangle's plane.
pub(crate) fn barycentric(tri: &Triangle, p: Vec3A) -> Vec2 {
    let (e1, e2, q) = (tri.v1 - tri.v0, tri.v2 - tri.v0, p - tri.v0);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (q1, q2) = (q.dot(e1), q.dot(e2));
    let det = d11 * d22 - d12 * d12;
    if det <= 0.0 {
        return Vec2::ZERO;
    }
    Vec2::new(d22 * q1 - d12 * q2, d11 * q2 - d12 * q1) / det
}
