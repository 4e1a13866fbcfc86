//! The nodes of the BlobTree arena.

use std::sync::Arc;

use glam::{Affine3A, Mat3A, Vec3, Vec3A};

use super::index::BlendIndex;
use super::node_id::NodeId;
use super::point_set::PointSet;
use super::primitive::Primitive;
use super::warp::Warp;
use crate::cache::CacheSpec;
use crate::geom::Aabb;

/// One node of the tree: what it computes, where its support lies, who owns it.
#[derive(Clone, Debug)]
pub struct Node {
    /// The operator or primitive.
    pub kind: NodeKind,
    /// The parent node; `None` for the root.
    pub parent: Option<NodeId>,
    /// A box holding the node's support: outside it the node's field is zero.
    pub bounds: Aabb,
    /// Whether the node's field may be negative somewhere (a negatively
    /// weighted primitive below that no clamp removes). An intersection
    /// reaches as far as such a child: its minimum is negative there.
    pub may_be_negative: bool,
    /// Surface colour (linear RGB) for this subtree, overriding its descendants'.
    pub color: Option<Vec3>,
}

/// What a node computes.
#[derive(Clone, Debug)]
pub enum NodeKind {
    /// A skeletal primitive (leaf).
    Primitive(Primitive),
    /// Sum of the children. Wide blends carry a spatial index over their leaves.
    Blend {
        /// Children, in scene order.
        children: Vec<NodeId>,
        /// Grid over the blend's leaves; built for wide blends.
        index: Option<Arc<BlendIndex>>,
    },
    /// The sum of a set of points (a particle file's): one node over packed
    /// arrays, with its own index over them.
    Points {
        /// The points.
        set: Arc<PointSet>,
        /// Grid over the points (see [`PointSet::indexed`]).
        index: Arc<BlendIndex>,
    },
    /// `max` of the children (CSG union).
    Union(Vec<NodeId>),
    /// `min` of the children (CSG intersection).
    Intersection(Vec<NodeId>),
    /// `max(0, min(a, 2T - b))`: `a` with `b` carved out. The clamp keeps the
    /// support inside `a`'s and leaves the iso-surface `f = T` unchanged.
    Difference(NodeId, NodeId),
    /// Ricci's blend `(Σ max(f_i, 0)^n)^(1/n)`: `n = 1` is the sum, `n → ∞` the union.
    Ricci {
        /// The exponent `n ≥ 1`.
        n: f32,
        /// Children.
        children: Vec<NodeId>,
    },
    /// The child seen through an affine map.
    Transform {
        /// The map and its derived forms (boxed: four matrices would make
        /// every node, a model's million points among them, as large).
        placement: Box<Placement>,
        /// The transformed subtree.
        child: NodeId,
    },
    /// The child seen through a warp: `f(p) = f_child(W⁻¹(p))`.
    Warp {
        /// The warp and its parameters (boxed, as a transform's placement).
        warp: Box<Warp>,
        /// The warped subtree.
        child: NodeId,
    },
    /// A name for edits; the field is the child's.
    Named {
        /// The name, unique in the model.
        name: String,
        /// The named subtree.
        child: NodeId,
    },
    /// The child's field sampled on a lattice and reconstructed (in cached
    /// evaluation; exact evaluation passes through to the child).
    Cache {
        /// Resolution, filters and storage.
        spec: CacheSpec,
        /// The cached subtree.
        child: NodeId,
        /// The cache's lattice: an index into the model's caches, set when the model is sealed.
        grid: usize,
    },
}

/// An affine placement `world = M · local`, with what evaluation needs precomputed.
#[derive(Clone, Copy, Debug)]
pub struct Placement {
    /// `M`: local to world.
    pub to_world: Affine3A,
    /// `M⁻¹`: world to local.
    pub to_local: Affine3A,
    /// `(M⁻¹)ᵀ` linear part: maps a local gradient to the world gradient.
    pub gradient_map: Mat3A,
    /// Spectral norm of `M⁻¹`'s linear part (its largest singular value):
    /// how much the map steepens the field.
    pub stretch: f32,
    /// The smallest singular value of `M⁻¹`'s linear part: how little a unit
    /// step in the world may be in the child's frame (1 for a rigid move),
    /// which keeps a concave child's curvature bound below zero.
    pub least_stretch: f32,
}

impl Placement {
    /// The placement `translate · rotate · scale`, rotation in degrees about X, then Y, then Z.
    ///
    /// Returns `None` when a scale factor is zero (the map would not be invertible).
    #[must_use]
    pub fn new(translate: Vec3, rotate_deg: Vec3, scale: Vec3) -> Option<Self> {
        if scale.abs().min_element() <= f32::EPSILON {
            return None;
        }
        let r = rotate_deg * (std::f32::consts::PI / 180.0);
        let rotation = glam::Quat::from_euler(glam::EulerRot::ZYX, r.z, r.y, r.x);
        let to_world = Affine3A::from_scale_rotation_translation(scale, rotation, translate);
        let to_local = to_world.inverse();
        Some(Self {
            to_world,
            to_local,
            gradient_map: to_local.matrix3.transpose(),
            // M⁻¹ = S⁻¹ R⁻¹, so its singular values are the 1 / |s_i|.
            stretch: 1.0 / scale.abs().min_element(),
            least_stretch: 1.0 / scale.abs().max_element(),
        })
    }

    /// The placement of an invertible affine map; `None` when it is singular.
    #[must_use]
    pub fn from_affine(to_world: Affine3A) -> Option<Self> {
        if to_world.matrix3.determinant().abs() <= f32::EPSILON || !to_world.is_finite() {
            return None;
        }
        let to_local = to_world.inverse();
        let (least_stretch, stretch) = singular_value_bounds(to_local.matrix3);
        Some(Self { to_world, to_local, gradient_map: to_local.matrix3.transpose(), stretch, least_stretch })
    }

    /// World point to local.
    #[inline]
    #[must_use]
    pub fn local(&self, p: Vec3A) -> Vec3A {
        self.to_local.transform_point3a(p)
    }

    /// True when the placement moves nothing: values, gradients and bounds
    /// through it are those of its child, to the bit.
    #[inline]
    #[must_use]
    pub fn is_identity(&self) -> bool {
        self.to_local == Affine3A::IDENTITY
    }
}

/// A lower bound on the smallest and an upper bound on the largest
/// singular value of `m`: the square roots of the extreme eigenvalues of
/// `mᵀm`, found in closed form (the trigonometric solution of its
/// characteristic cubic) in `f64` and widened past its rounding. A rigid map
/// gets `1` within a few units in the last place, where a norm like the
/// Frobenius one would say `√3` and shorten every step through it.
#[must_use]
pub fn singular_value_bounds(m: Mat3A) -> (f32, f32) {
    let cols = [m.x_axis, m.y_axis, m.z_axis].map(|c| [f64::from(c.x), f64::from(c.y), f64::from(c.z)]);
    let dot = |i: usize, j: usize| (0..3).map(|k| cols[i][k] * cols[j][k]).sum::<f64>();
    let a = [[dot(0, 0), dot(0, 1), dot(0, 2)], [dot(0, 1), dot(1, 1), dot(1, 2)], [dot(0, 2), dot(1, 2), dot(2, 2)]];
    let q = (a[0][0] + a[1][1] + a[2][2]) / 3.0;
    let off = a[0][1].powi(2) + a[0][2].powi(2) + a[1][2].powi(2);
    let p = (((a[0][0] - q).powi(2) + (a[1][1] - q).powi(2) + (a[2][2] - q).powi(2) + 2.0 * off) / 6.0).sqrt();
    let (lo, hi) = if p <= f64::EPSILON * q {
        (q, q)
    } else {
        let b = |i: usize, j: usize| (a[i][j] - if i == j { q } else { 0.0 }) / p;
        let det = b(0, 0) * (b(1, 1) * b(2, 2) - b(1, 2) * b(2, 1)) - b(0, 1) * (b(1, 0) * b(2, 2) - b(1, 2) * b(2, 0))
            + b(0, 2) * (b(1, 0) * b(2, 1) - b(1, 1) * b(2, 0));
        let phi = (det / 2.0).clamp(-1.0, 1.0).acos() / 3.0;
        let third = 2.0 * std::f64::consts::PI / 3.0;
        (q + 2.0 * p * (phi + third).cos(), q + 2.0 * p * phi.cos())
    };
    // The cubic's rounding is far below a millionth of the largest eigenvalue.
    let slack = 1e-9 * hi.abs();
    let (lo, hi) = ((lo - slack).max(0.0).sqrt(), (hi + slack).sqrt());
    ((lo * (1.0 - 1e-6)) as f32, (hi * (1.0 + 1e-6)) as f32)
}

impl NodeKind {
    /// A `Points` node over `set`, with its index; `None` for an empty set.
    #[must_use]
    pub fn points(set: PointSet) -> Option<Self> {
        if set.is_empty() {
            return None;
        }
        let set = Arc::new(set);
        let index = Arc::new(set.indexed());
        Some(NodeKind::Points { set, index })
    }

    /// The children of this node, in order.
    #[must_use]
    pub fn children(&self) -> Vec<NodeId> {
        match self {
            NodeKind::Primitive(_) | NodeKind::Points { .. } => vec![],
            NodeKind::Blend { children, .. }
            | NodeKind::Union(children)
            | NodeKind::Intersection(children)
            | NodeKind::Ricci { children, .. } => children.clone(),
            NodeKind::Difference(a, b) => vec![*a, *b],
            NodeKind::Transform { child, .. }
            | NodeKind::Warp { child, .. }
            | NodeKind::Named { child, .. }
            | NodeKind::Cache { child, .. } => vec![*child],
        }
    }

    /// A short name of the node type, for listings.
    #[must_use]
    pub fn type_name(&self) -> &'static str {
        match self {
            NodeKind::Primitive(p) => match p.skeleton {
                super::Skeleton::Point { .. } => "Point",
                super::Skeleton::Segment { .. } => "Segment",
                super::Skeleton::Circle { .. } => "Circle",
            },
            NodeKind::Blend { .. } => "Blend",
            NodeKind::Points { .. } => "Points",
            NodeKind::Union(_) => "Union",
            NodeKind::Intersection(_) => "Intersection",
            NodeKind::Difference(..) => "Difference",
            NodeKind::Ricci { .. } => "Ricci",
            NodeKind::Transform { .. } => "Transform",
            NodeKind::Warp { warp, .. } => match **warp {
                Warp::Twist { .. } => "Twist",
                Warp::Taper { .. } => "Taper",
                Warp::Bend { .. } => "Bend",
            },
            NodeKind::Named { .. } => "Named",
            NodeKind::Cache { .. } => "Cache",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stretch_is_the_inverse_norm() {
        let p = Placement::new(Vec3::ONE, Vec3::new(10.0, 20.0, 30.0), Vec3::new(2.0, 0.5, 4.0)).unwrap();
        // Largest stretch of M⁻¹ over many unit vectors approaches, never exceeds, 1/0.5.
        let mut best = 0.0f32;
        for i in 0..2000 {
            let a = i as f32 * 0.731;
            let b = i as f32 * 0.377;
            let v = Vec3A::new(a.cos() * b.sin(), a.sin() * b.sin(), b.cos());
            best = best.max(p.to_local.matrix3.mul_vec3a(v).length());
        }
        assert!(best <= p.stretch * 1.0001 && best > p.stretch * 0.95, "{best} vs {}", p.stretch);
        assert!(Placement::new(Vec3::ZERO, Vec3::ZERO, Vec3::new(1.0, 0.0, 1.0)).is_none());
    }

    /// The least and most `m` stretches any of many unit vectors.
    fn sampled_stretch(m: Mat3A) -> (f32, f32) {
        (0..20_000).fold((f32::MAX, 0.0f32), |(lo, hi), i| {
            let (a, z) = (i as f32 * 2.399_963, 1.0 - 2.0 * (i as f32 + 0.5) / 20_000.0);
            let r = (1.0 - z * z).sqrt();
            let len = m.mul_vec3a(Vec3A::new(r * a.cos(), r * a.sin(), z)).length();
            (lo.min(len), hi.max(len))
        })
    }

    #[test]
    fn an_edited_placement_bounds_its_singular_values_tightly() {
        let turn = glam::Quat::from_euler(glam::EulerRot::ZYX, 0.3, -1.1, 2.0);
        let shear = Mat3A::from_cols(Vec3A::new(1.0, 0.0, 0.0), Vec3A::new(0.7, 1.0, 0.0), Vec3A::new(-0.2, 0.4, 1.0));
        let maps = [
            Affine3A::from_translation(Vec3::new(1e-6, 0.0, 0.0)),
            Affine3A::from_rotation_translation(turn, Vec3::new(3.0, -1.0, 2.0)),
            Affine3A::from_scale_rotation_translation(Vec3::new(0.5, 2.0, 3.0), turn, Vec3::ONE),
            Affine3A { matrix3: shear * Mat3A::from_quat(turn), translation: Vec3A::ZERO },
        ];
        for (k, m) in maps.into_iter().enumerate() {
            let p = Placement::from_affine(m).unwrap();
            let (lo, hi) = sampled_stretch(p.to_local.matrix3);
            assert!(
                p.least_stretch <= lo && p.stretch >= hi,
                "map {k}: [{}, {}] holds [{lo}, {hi}]",
                p.least_stretch,
                p.stretch
            );
            assert!(
                p.least_stretch > lo * 0.99 && p.stretch < hi * 1.01,
                "map {k}: [{}, {}] near [{lo}, {hi}]",
                p.least_stretch,
                p.stretch
            );
        }
        let moved = Placement::from_affine(maps[0]).unwrap();
        assert!(
            (moved.stretch - 1.0).abs() < 1e-5 && (moved.least_stretch - 1.0).abs() < 1e-5,
            "a move stretches nothing"
        );
    }
}
