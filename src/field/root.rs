//! The components of a model's root: the children of a root blend without an
//! index (Medusa's seven), each past its names, exactly evaluated caches and
//! frames that move nothing, with their bounds side by side.
//!
//! Every question the tracer asks starts at the root. Through the tree, each
//! child's chain of nodes is walked to reach the bounds at its end and test
//! them there, seven times per question on Medusa; here the few boxes are
//! tested in one place, and only the components they admit are asked. Each
//! answer is summed in the order and precision of the root blend's own, so
//! it is the tree's to the bit: a component left out would have added zero.

use glam::Vec3A;

use super::node::{NodeId, NodeKind};
use super::{EvalMode, Model, Region};
use crate::geom::{Aabb, Interval};

/// Most children a root blend may have to be split into [`RootParts`].
const MAX_PARTS: usize = 8;

/// The children of a root blend without an index, past their pass-throughs.
#[derive(Clone, Copy, Debug)]
pub struct RootParts {
    len: usize,
    bounds: [Aabb; MAX_PARTS],
    ids: [NodeId; MAX_PARTS],
}

impl RootParts {
    /// The parts of `model`'s root in `mode`: `None` unless the root is a
    /// blend without an index of at most [`MAX_PARTS`] children, none of them
    /// a blend itself (the tree sums a nested blend's terms without rounding
    /// its total, which a part would).
    #[must_use]
    pub fn of(model: &Model, mode: EvalMode) -> Option<Self> {
        let root = model.node(model.past_pass_throughs(model.root(), mode));
        let NodeKind::Blend { children, index: None } = &root.kind else { return None };
        let nested = children.iter().any(|&c| matches!(model.node(c).kind, NodeKind::Blend { .. }));
        if children.len() > MAX_PARTS || nested {
            return None;
        }
        let mut parts = Self { len: children.len(), bounds: [Aabb::EMPTY; MAX_PARTS], ids: [0; MAX_PARTS] };
        for (k, &c) in children.iter().enumerate() {
            let id = model.past_pass_throughs(c, mode);
            (parts.bounds[k], parts.ids[k]) = (model.node(id).bounds, id);
        }
        Some(parts)
    }

    /// The parts whose bounds pass `admits`.
    #[inline]
    fn admitted<'s>(&'s self, admits: impl Fn(&Aabb) -> bool + 's) -> impl Iterator<Item = NodeId> + 's {
        let parts = self.bounds[..self.len].iter().zip(&self.ids[..self.len]);
        parts.filter(move |(b, _)| admits(b)).map(|(_, &id)| id)
    }

    /// The root's value at `p`.
    pub fn value(&self, model: &Model, p: Vec3A, mode: EvalMode) -> f32 {
        let sum = self.admitted(|b| b.contains(p)).fold(0.0f64, |s, id| s + f64::from(model.node_value(id, p, mode)));
        sum as f32
    }

    /// The root's gradient at `p`.
    pub fn gradient(&self, model: &Model, p: Vec3A, mode: EvalMode) -> Vec3A {
        self.admitted(|b| b.contains(p)).fold(Vec3A::ZERO, |s, id| s + model.node_gradient(id, p, mode))
    }

    /// The root's value and gradient at `p`, to the bits of each alone.
    pub fn value_and_gradient(&self, model: &Model, p: Vec3A, mode: EvalMode) -> (f32, Vec3A) {
        let (sum, gradient) = self.admitted(|b| b.contains(p)).fold((0.0f64, Vec3A::ZERO), |(s, g), id| {
            let (v, dv) = model.node_value_and_gradient(id, p, mode);
            (s + f64::from(v), g + dv)
        });
        (sum as f32, gradient)
    }

    /// The root's value range over `b`.
    pub fn interval(&self, model: &Model, b: &Aabb, mode: EvalMode) -> Interval {
        self.admitted(|part| part.overlaps(b)).fold(Interval::ZERO, |s, id| s + model.node_interval(id, b, mode))
    }

    /// The root's slope bound over `region`.
    pub fn lipschitz(&self, model: &Model, region: &Region, mode: EvalMode) -> f32 {
        let reach = region.bounds();
        let met = self.admitted(|b| b.overlaps(&reach) && region.meets(b));
        met.map(|id| model.met_node_lipschitz(id, region, mode)).sum()
    }

    /// The root's curvature bound over `region`.
    pub fn curvature(&self, model: &Model, region: &Region, mode: EvalMode) -> f32 {
        let reach = region.bounds();
        let met = self.admitted(|b| b.overlaps(&reach) && region.meets(b));
        met.map(|id| model.met_node_curvature(id, region, mode)).sum()
    }
}
