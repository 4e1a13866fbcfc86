//! Evaluation of a node at a point: value, analytic gradient and colour.
//! Every node's field is zero outside its bounds, which is what makes the
//! per-node box rejection exact. (Ranges and bounds over a region are in
//! `region_bounds`.)

use glam::{Vec3, Vec3A};

use super::index::{BlendIndex, IndexedLeaf, Leaf};
use super::model::Model;
use super::node::NodeKind;
use super::node_id::NodeId;
use super::{DEFAULT_COLOR, EvalMode};
use crate::cache::grid::Sampled;
use crate::geom::Aabb;

/// A cache's subtree as its lattice samples it: values, and the intervals
/// that show a region of the lattice to be zero.
pub(super) struct CachedSubtree<'m> {
    model: &'m Model,
    child: NodeId,
    mode: EvalMode,
}

impl Sampled for CachedSubtree<'_> {
    fn value(&self, p: Vec3A) -> f32 {
        self.model.node_value(self.child, p, self.mode)
    }

    fn is_zero_over(&self, b: &Aabb) -> bool {
        self.model.node_is_zero_over(self.child, b, self.mode)
    }
}

impl Model {
    /// Cache node `child`'s subtree, for its grid.
    pub(super) fn sampled(&self, child: NodeId, mode: EvalMode) -> CachedSubtree<'_> {
        CachedSubtree { model: self, child, mode }
    }

    /// Field value of node `id` at `p`.
    pub fn node_value(&self, id: NodeId, p: Vec3A, mode: EvalMode) -> f32 {
        let node = self.node(self.past_pass_throughs(id, mode));
        if !node.bounds.contains(p) {
            return 0.0;
        }
        let t = self.threshold();
        match &node.kind {
            NodeKind::Primitive(prim) => prim.value(p),
            NodeKind::Blend { children, index } => match (mode, index) {
                (m, Some(ix)) if m.indexed() => self.indexed_sum(ix, p, mode) as f32,
                _ => self.nested_blend_sum(children, p, mode) as f32,
            },
            // A point set has no other form than its index, in every mode.
            NodeKind::Points { index, .. } => self.indexed_sum(index, p, mode) as f32,
            NodeKind::Union(cs) => cs.iter().map(|&c| self.node_value(c, p, mode)).fold(f32::MIN, f32::max),
            NodeKind::Intersection(cs) => cs.iter().map(|&c| self.node_value(c, p, mode)).fold(f32::MAX, f32::min),
            NodeKind::Difference(a, b) => {
                let (a, b) = (self.node_value(*a, p, mode), self.node_value(*b, p, mode));
                a.min(2.0 * t - b).max(0.0)
            }
            NodeKind::Ricci { n, children } => {
                let s: f32 = children.iter().map(|&c| ricci_term(self.node_value(c, p, mode), *n)).sum();
                if s > 0.0 { s.powf(1.0 / n) } else { 0.0 }
            }
            NodeKind::Transform { placement, child } => self.node_value(*child, placement.local(p), mode),
            NodeKind::Warp { warp, child } => self.node_value(*child, warp.inverse(p), mode),
            NodeKind::Cache { child, grid, .. } if self.answers_from_lattice(*grid, mode) => {
                self.cache(*grid).value(p, self.pool(), &self.sampled(*child, mode))
            }
            NodeKind::Named { child, .. } | NodeKind::Cache { child, .. } => self.node_value(*child, p, mode),
        }
    }

    /// The sum of the leaves of index `ix` at `p`.
    #[inline]
    fn indexed_sum(&self, ix: &BlendIndex, p: Vec3A, mode: EvalMode) -> f64 {
        ix.point_sum(p).unwrap_or_else(|| {
            ix.candidates(p)
                .iter()
                .fold(0.0f64, |s, &i| s + f64::from(self.leaf_value(&ix.leaves.get(i as usize), p, mode)))
        })
    }

    /// The first node at or below `id` that is not a pass-through in `mode`
    /// (a name, a cache evaluated exactly, a transform that moves nothing, as
    /// one that only colours does). Its bounds are theirs, so evaluations
    /// test them once, there, and not at every level above (four times for
    /// each of Medusa's components).
    #[inline]
    pub(super) fn past_pass_throughs(&self, mut id: NodeId, mode: EvalMode) -> NodeId {
        loop {
            match &self.node(id).kind {
                NodeKind::Named { child, .. } => id = *child,
                NodeKind::Cache { child, grid, .. } if !self.answers_from_lattice(*grid, mode) => id = *child,
                NodeKind::Transform { placement, child } if placement.is_identity() => id = *child,
                _ => return id,
            }
        }
    }

    /// The sum over a blend's children, descending into nested blends without
    /// rounding: summed in `f64` and rounded once, it equals the flattened
    /// indexed sum to the last bit but for rare ties.
    fn nested_blend_sum(&self, children: &[NodeId], p: Vec3A, mode: EvalMode) -> f64 {
        children.iter().fold(0.0f64, |s, &c| {
            let node = self.node(c);
            s + match &node.kind {
                NodeKind::Blend { children, .. } => {
                    if node.bounds.contains(p) {
                        self.nested_blend_sum(children, p, mode)
                    } else {
                        0.0
                    }
                }
                _ => f64::from(self.node_value(c, p, mode)),
            }
        })
    }

    /// [`Self::node_value`] and [`Self::node_gradient`] together, to the same
    /// bits, in one pass where they share work: sums of points in an index,
    /// and the blends and frames above them. Other nodes evaluate the two apart.
    pub fn node_value_and_gradient(&self, id: NodeId, p: Vec3A, mode: EvalMode) -> (f32, Vec3A) {
        let node = self.node(self.past_pass_throughs(id, mode));
        if !node.bounds.contains(p) {
            return (0.0, Vec3A::ZERO);
        }
        match &node.kind {
            NodeKind::Blend { index: Some(ix), .. } if mode.indexed() => {
                return self.indexed_value_and_gradient(ix, p, mode);
            }
            NodeKind::Points { index, .. } => return self.indexed_value_and_gradient(index, p, mode),
            NodeKind::Blend { children, index } if index.is_none() || !mode.indexed() => {
                let (v, g) = self.nested_blend_value_and_gradient(children, p, mode);
                return (v as f32, g);
            }
            NodeKind::Transform { placement, child } => {
                let (v, g) = self.node_value_and_gradient(*child, placement.local(p), mode);
                return (v, placement.gradient_map * g);
            }
            NodeKind::Warp { warp, child } => {
                let (v, g) = self.node_value_and_gradient(*child, warp.inverse(p), mode);
                return (v, warp.gradient(p, g));
            }
            NodeKind::Cache { child, grid, .. } if self.answers_from_lattice(*grid, mode) => {
                return self.cache(*grid).value_and_gradient(p, self.pool(), &self.sampled(*child, mode));
            }
            NodeKind::Named { child, .. } | NodeKind::Cache { child, .. } => {
                return self.node_value_and_gradient(*child, p, mode);
            }
            _ => {}
        }
        (self.node_value(id, p, mode), self.node_gradient(id, p, mode))
    }

    /// The sum of the leaves of index `ix` at `p` and of their gradients, in one pass.
    fn indexed_value_and_gradient(&self, ix: &BlendIndex, p: Vec3A, mode: EvalMode) -> (f32, Vec3A) {
        let (v, g) = ix.point_sum_and_gradient(p).unwrap_or_else(|| self.leaves_value_and_gradient(ix, p, mode));
        (v as f32, g)
    }

    /// The sum of the values and of the gradients of the leaves listed around
    /// `p`, in the order (and so to the bits) of [`Self::node_value`] and
    /// [`Self::node_gradient`] apart, each leaf visited once: a leaf that is a
    /// blend of points sums its values and gradients in one pass.
    fn leaves_value_and_gradient(&self, ix: &BlendIndex, p: Vec3A, mode: EvalMode) -> (f64, Vec3A) {
        ix.candidates(p).iter().fold((0.0f64, Vec3A::ZERO), |(sum, gradient), &i| {
            let (v, g) = match ix.leaves.get(i as usize).leaf {
                Leaf::Primitive(prim) => (prim.value(p), prim.gradient(p)),
                Leaf::Node(id) => self.node_value_and_gradient(id, p, mode),
            };
            (sum + f64::from(v), gradient + g)
        })
    }

    /// [`Self::nested_blend_sum`] with the children's gradients summed as
    /// [`Self::node_gradient`] sums them.
    fn nested_blend_value_and_gradient(&self, children: &[NodeId], p: Vec3A, mode: EvalMode) -> (f64, Vec3A) {
        children.iter().fold((0.0f64, Vec3A::ZERO), |(sum, gradient), &c| {
            let node = self.node(c);
            let (v, g) = match &node.kind {
                NodeKind::Blend { children, .. } if node.bounds.contains(p) => {
                    self.nested_blend_value_and_gradient(children, p, mode)
                }
                NodeKind::Blend { .. } => (0.0, Vec3A::ZERO),
                _ => {
                    let (v, g) = self.node_value_and_gradient(c, p, mode);
                    (f64::from(v), g)
                }
            };
            (sum + v, gradient + g)
        })
    }

    #[inline]
    fn leaf_value(&self, leaf: &IndexedLeaf, p: Vec3A, mode: EvalMode) -> f32 {
        match &leaf.leaf {
            Leaf::Primitive(prim) => prim.value(p),
            Leaf::Node(id) => self.node_value(*id, p, mode),
        }
    }

    /// Analytic gradient of node `id` at `p`.
    pub fn node_gradient(&self, id: NodeId, p: Vec3A, mode: EvalMode) -> Vec3A {
        let node = self.node(self.past_pass_throughs(id, mode));
        if !node.bounds.contains(p) {
            return Vec3A::ZERO;
        }
        let t = self.threshold();
        match &node.kind {
            NodeKind::Primitive(prim) => prim.gradient(p),
            NodeKind::Blend { children, index } => match (mode, index) {
                (m, Some(ix)) if m.indexed() => self.indexed_gradient(ix, p, mode),
                _ => children.iter().fold(Vec3A::ZERO, |s, &c| s + self.node_gradient(c, p, mode)),
            },
            NodeKind::Points { index, .. } => self.indexed_gradient(index, p, mode),
            NodeKind::Union(cs) => self.node_gradient(self.extreme_child(cs, p, mode, true), p, mode),
            NodeKind::Intersection(cs) => self.node_gradient(self.extreme_child(cs, p, mode, false), p, mode),
            NodeKind::Difference(a, b) => {
                let (va, vb) = (self.node_value(*a, p, mode), self.node_value(*b, p, mode));
                if va.min(2.0 * t - vb) <= 0.0 {
                    Vec3A::ZERO
                } else if va <= 2.0 * t - vb {
                    self.node_gradient(*a, p, mode)
                } else {
                    -self.node_gradient(*b, p, mode)
                }
            }
            NodeKind::Ricci { n, children } => {
                // ∇(Σ v_i^n)^(1/n) = f^(1-n) Σ v_i^(n-1) ∇v_i
                let f = self.node_value(id, p, mode);
                if f <= 0.0 {
                    return Vec3A::ZERO;
                }
                let sum = children.iter().fold(Vec3A::ZERO, |s, &c| {
                    let v = self.node_value(c, p, mode);
                    if v <= 0.0 { s } else { s + self.node_gradient(c, p, mode) * v.powf(n - 1.0) }
                });
                sum * f.powf(1.0 - n)
            }
            NodeKind::Transform { placement, child } => {
                placement.gradient_map * self.node_gradient(*child, placement.local(p), mode)
            }
            NodeKind::Warp { warp, child } => warp.gradient(p, self.node_gradient(*child, warp.inverse(p), mode)),
            NodeKind::Cache { child, grid, .. } if self.answers_from_lattice(*grid, mode) => {
                self.cache(*grid).gradient(p, self.pool(), &self.sampled(*child, mode))
            }
            NodeKind::Named { child, .. } | NodeKind::Cache { child, .. } => self.node_gradient(*child, p, mode),
        }
    }

    /// The sum of the gradients of the leaves of index `ix` at `p`.
    fn indexed_gradient(&self, ix: &BlendIndex, p: Vec3A, mode: EvalMode) -> Vec3A {
        ix.point_gradient(p).unwrap_or_else(|| {
            ix.candidates(p).iter().fold(Vec3A::ZERO, |s, &i| {
                s + match ix.leaves.get(i as usize).leaf {
                    Leaf::Primitive(prim) => prim.gradient(p),
                    Leaf::Node(id) => self.node_gradient(id, p, mode),
                }
            })
        })
    }

    /// The child with the largest (`max`) or smallest value at `p`; the first on ties.
    fn extreme_child(&self, cs: &[NodeId], p: Vec3A, mode: EvalMode, max: bool) -> NodeId {
        let mut best = cs[0];
        let mut best_v = self.node_value(best, p, mode);
        for &c in &cs[1..] {
            let v = self.node_value(c, p, mode);
            if (max && v > best_v) || (!max && v < best_v) {
                best = c;
                best_v = v;
            }
        }
        best
    }

    /// Surface colour of node `id` at `p`: a node's own colour wins; blends mix
    /// their children's colours weighted by their field contributions.
    pub fn node_color(&self, id: NodeId, p: Vec3A, mode: EvalMode) -> Vec3 {
        let node = self.node(id);
        if let Some(c) = node.color {
            return c;
        }
        let t = self.threshold();
        match &node.kind {
            NodeKind::Primitive(_) => DEFAULT_COLOR,
            NodeKind::Blend { children, index } => match (mode, index) {
                (m, Some(ix)) if m.indexed() => self.indexed_color(ix, p, mode),
                _ => mix(children.iter().map(|&c| (self.node_value(c, p, mode), move || self.node_color(c, p, mode)))),
            },
            NodeKind::Points { index, .. } => self.indexed_color(index, p, mode),
            NodeKind::Ricci { n, children } => mix(children
                .iter()
                .map(|&c| (ricci_term(self.node_value(c, p, mode), *n), move || self.node_color(c, p, mode)))),
            NodeKind::Union(cs) => self.node_color(self.extreme_child(cs, p, mode, true), p, mode),
            NodeKind::Intersection(cs) => self.node_color(self.extreme_child(cs, p, mode, false), p, mode),
            NodeKind::Difference(a, b) => {
                // The carved face takes the cutter's colour.
                if self.node_value(*a, p, mode) <= 2.0 * t - self.node_value(*b, p, mode) {
                    self.node_color(*a, p, mode)
                } else {
                    self.node_color(*b, p, mode)
                }
            }
            NodeKind::Transform { placement, child } => self.node_color(*child, placement.local(p), mode),
            NodeKind::Warp { warp, child } => self.node_color(*child, warp.inverse(p), mode),
            NodeKind::Named { child, .. } | NodeKind::Cache { child, .. } => self.node_color(*child, p, mode),
        }
    }

    /// The colours of the leaves of index `ix` mixed at `p` (see [`mix`]).
    fn indexed_color(&self, ix: &BlendIndex, p: Vec3A, mode: EvalMode) -> Vec3 {
        mix(ix.candidates(p).iter().map(|&i| {
            let leaf = ix.leaves.get(i as usize);
            let w = self.leaf_value(&leaf, p, mode);
            (w, move || leaf.color.unwrap_or_else(|| self.leaf_color(&leaf, p, mode)))
        }))
    }

    /// [`Self::node_gradient`] and [`Self::node_color`] at `p` together, to the
    /// same bits. A blend weighs its children's colours by their values, so
    /// where it sums their gradients too each child is evaluated once for both
    /// (a blend of points in one pass over them): a shaded hit or a coloured
    /// vertex costs one evaluation of the model instead of two.
    pub fn node_gradient_and_color(&self, id: NodeId, p: Vec3A, mode: EvalMode) -> (Vec3A, Vec3) {
        let node = self.node(id);
        if node.color.is_none() && node.bounds.contains(p) {
            match &node.kind {
                NodeKind::Blend { children, index } if index.is_none() || !mode.indexed() => {
                    return self.blend_gradient_and_color(children, p, mode);
                }
                NodeKind::Transform { placement, child } => {
                    let (g, color) = self.node_gradient_and_color(*child, placement.local(p), mode);
                    return (placement.gradient_map * g, color);
                }
                NodeKind::Warp { warp, child } => {
                    let (g, color) = self.node_gradient_and_color(*child, warp.inverse(p), mode);
                    return (warp.gradient(p, g), color);
                }
                NodeKind::Cache { grid, .. } if self.answers_from_lattice(*grid, mode) => {}
                NodeKind::Named { child, .. } | NodeKind::Cache { child, .. } => {
                    return self.node_gradient_and_color(*child, p, mode);
                }
                _ => {}
            }
        }
        (self.node_gradient(id, p, mode), self.node_color(id, p, mode))
    }

    /// The gradient of a blend without an index and its colour (see
    /// [`mix`]), each child's value and gradient taken together.
    fn blend_gradient_and_color(&self, children: &[NodeId], p: Vec3A, mode: EvalMode) -> (Vec3A, Vec3) {
        self.mixed_gradient_and_color(children.iter().map(|&c| (c, c)), p, mode)
    }

    /// The summed gradient of some of a blend's children and their colours'
    /// mix, given each child as the node that answers for its value and the
    /// node that colours it (the child itself, or past its pass-throughs and
    /// itself: see [`super::root`]).
    pub(super) fn mixed_gradient_and_color(
        &self,
        children: impl Iterator<Item = (NodeId, NodeId)>,
        p: Vec3A,
        mode: EvalMode,
    ) -> (Vec3A, Vec3) {
        let (mut gradient, mut acc, mut total) = (Vec3A::ZERO, Vec3::ZERO, 0.0f32);
        for (valued, colored) in children {
            let (v, g) = self.node_value_and_gradient(valued, p, mode);
            gradient += g;
            if v > 0.0 {
                acc += self.node_color(colored, p, mode) * v;
                total += v;
            }
        }
        (gradient, if total > 0.0 { acc / total } else { DEFAULT_COLOR })
    }

    fn leaf_color(&self, leaf: &IndexedLeaf, p: Vec3A, mode: EvalMode) -> Vec3 {
        match &leaf.leaf {
            Leaf::Primitive(_) => DEFAULT_COLOR,
            Leaf::Node(id) => self.node_color(*id, p, mode),
        }
    }
}

/// Weighted mean of colours; weights `<= 0` are skipped, and colours are only
/// computed for the parts that contribute.
fn mix<F: FnOnce() -> Vec3>(parts: impl Iterator<Item = (f32, F)>) -> Vec3 {
    let (mut acc, mut total) = (Vec3::ZERO, 0.0f32);
    for (w, color) in parts {
        if w > 0.0 {
            acc += color() * w;
            total += w;
        }
    }
    if total > 0.0 { acc / total } else { DEFAULT_COLOR }
}

/// A child's term `max(v, 0)ⁿ` in Ricci's blend. Most children are zero at
/// most points (outside their support), and `0ⁿ = 0` needs no power: the
/// same bits as `powf`, without its cost.
#[inline]
fn ricci_term(v: f32, n: f32) -> f32 {
    if v > 0.0 { v.powf(n) } else { 0.0 }
}
