//! The nodes of the BlobTree arena.

use glam::{Affine3A, Mat3A, Vec3, Vec3A};

use super::index::BlendIndex;
use super::node_id::NodeId;
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
        index: Option<Box<BlendIndex>>,
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
        /// The map and its derived forms.
        placement: Placement,
        /// The transformed subtree.
        child: NodeId,
    },
    /// The child seen through a warp: `f(p) = f_child(W⁻¹(p))`.
    Warp {
        /// The warp and its parameters.
        warp: Warp,
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
    /// Spectral norm of `M⁻¹`'s linear part: how much the map steepens the field.
    pub stretch: f32,
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
            // M⁻¹ = S⁻¹ R⁻¹, so its largest singular value is 1 / min |s_i|.
            stretch: 1.0 / scale.abs().min_element(),
        })
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

impl NodeKind {
    /// The children of this node, in order.
    #[must_use]
    pub fn children(&self) -> Vec<NodeId> {
        match self {
            NodeKind::Primitive(_) => vec![],
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
            NodeKind::Union(_) => "Union",
            NodeKind::Intersection(_) => "Intersection",
            NodeKind::Difference(..) => "Difference",
            NodeKind::Ricci { .. } => "Ricci",
            NodeKind::Transform { .. } => "Transform",
            NodeKind::Warp { warp, .. } => match warp {
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
}
