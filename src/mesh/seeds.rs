//! Where continuation starts: points on every primitive's skeleton, in world
//! space. The polygonizer marches from each along +x to where it leaves the
//! surface, so every connected component that holds a skeleton is found, not
//! just the first, and the outside of a hollow whose skeletons lie in its
//! cavity too.

use glam::{Affine3A, Vec3A};

use crate::field::{Model, NodeId, NodeKind, Skeleton};

/// A point on a skeleton and how far its primitive's support reaches from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Seed {
    /// World position.
    pub point: Vec3A,
    /// A bound on the world distance from `point` to the edge of the support.
    pub reach: f32,
}

/// Seeds on the skeletons of the primitives under `id`, mapped to world space.
#[must_use]
pub fn skeleton_seeds(model: &Model, id: NodeId) -> Vec<Seed> {
    let mut out = vec![];
    collect(model, id, Affine3A::IDENTITY, &mut out);
    out
}

fn collect(model: &Model, id: NodeId, to_world: Affine3A, out: &mut Vec<Seed>) {
    match &model.node(id).kind {
        NodeKind::Primitive(p) => {
            // The Frobenius norm bounds how far the map stretches any length.
            let m = to_world.matrix3;
            let stretch = (m.x_axis.length_squared() + m.y_axis.length_squared() + m.z_axis.length_squared()).sqrt();
            let reach = p.radius * stretch;
            out.extend(skeleton_samples(&p.skeleton).map(|x| Seed { point: to_world.transform_point3a(x), reach }));
        }
        NodeKind::Transform { placement, child } => collect(model, *child, to_world * placement.to_world, out),
        kind => {
            for c in kind.children() {
                collect(model, c, to_world, out);
            }
        }
    }
}

/// A few points on a skeleton: the point, a segment's ends and middle, eight on a circle.
fn skeleton_samples(s: &Skeleton) -> impl Iterator<Item = Vec3A> {
    let points: Vec<Vec3A> = match *s {
        Skeleton::Point { center } => vec![center],
        Skeleton::Segment { a, b } => vec![a, (a + b) * 0.5, b],
        Skeleton::Circle { center, normal, ring } => {
            let u = normal.any_orthonormal_vector();
            let v = normal.cross(u);
            (0..8)
                .map(|i| {
                    let a = i as f32 * std::f32::consts::FRAC_PI_4;
                    center + (u * a.cos() + v * a.sin()) * ring
                })
                .collect()
        }
    };
    points.into_iter()
}
