//! The closest-hit traversal both trees go through: the CWBVH of static
//! meshes and the BVH2 of [`super::DynamicMesh`] each have one in obvhs,
//! under the same name but no shared trait, so the wrapper around it (the
//! ray converted, the triangles tested counted, the hit's barycentric
//! weights) is written here once.

use glam::Vec2;
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::RayHit;
use obvhs::triangle::Triangle;

use super::barycentric;
use crate::geom::Ray;

/// An obvhs tree with a closest-hit traversal.
pub(super) trait ClosestHit {
    /// Traverses `ray`, calling `test` on each leaf reached; true on a hit, recorded in `hit`.
    fn traverse(
        &self,
        ray: obvhs::ray::Ray,
        hit: &mut RayHit,
        test: impl FnMut(&obvhs::ray::Ray, usize) -> f32,
    ) -> bool;
}

/// Puts a tree's own `ray_traverse` behind [`ClosestHit`].
macro_rules! closest_hit_by_ray_traverse {
    ($($tree:ty),*) => {$(
        impl ClosestHit for $tree {
            fn traverse(
                &self,
                ray: obvhs::ray::Ray,
                hit: &mut RayHit,
                test: impl FnMut(&obvhs::ray::Ray, usize) -> f32,
            ) -> bool {
                self.ray_traverse(ray, hit, test)
            }
        }
    )*};
}

closest_hit_by_ray_traverse!(CwBvh, Bvh2);

/// The leaf a ray hits first: its index in the tree, the distance and the
/// barycentric weights of its triangle's second and third vertex.
pub(super) struct LeafHit {
    pub leaf: usize,
    pub t: f32,
    pub uv: Vec2,
}

/// Casts `ray` through `bvh`, testing leaf `i` against `triangle(i)`: the
/// nearest hit with `t > 0`, and the number of triangles tested.
pub(super) fn closest_hit<'a>(
    bvh: &impl ClosestHit,
    ray: &Ray,
    triangle: impl Fn(usize) -> &'a Triangle,
) -> (Option<LeafHit>, u32) {
    let r = obvhs::ray::Ray::new_inf(ray.origin, ray.dir);
    let mut hit = RayHit::none();
    let mut tests = 0;
    let found = bvh.traverse(r, &mut hit, |r, leaf| {
        tests += 1;
        triangle(leaf).intersect(r)
    });
    let leaf = found.then(|| {
        let leaf = hit.primitive_id as usize;
        LeafHit { leaf, t: hit.t, uv: barycentric(triangle(leaf), ray.at(hit.t)) }
    });
    (leaf, tests)
}
