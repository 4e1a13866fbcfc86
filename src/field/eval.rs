//! Evaluation of a node: value, analytic gradient, colour, value range over a
//! box and slope bound over a region. Every node's field is zero outside its
//! bounds, which is what makes the per-node box rejection exact.

use std::cell::Cell;

use glam::{Vec3, Vec3A};

use super::index::{BlendIndex, IndexedLeaf, Leaf};
use super::model::Model;
use super::node::NodeKind;
use super::node_id::NodeId;
use super::primitive::Primitive;
use super::{DEFAULT_COLOR, EvalMode};
use crate::cache::grid::Sampled;
use crate::geom::{Aabb, Interval, Region};

/// Above this many index cells, a region's bounds come from the per-cell
/// bounds; at or below it they may sum the leaves listed there one by one.
const MAX_CELLS_FOR_LEAF_BOUNDS: usize = 64;

thread_local! {
    /// Per-thread marks of the leaves already summed in the current query.
    static SEEN: Cell<SeenLeaves> = const { Cell::new(SeenLeaves { stamp: Vec::new(), generation: 0 }) };
}

/// Generation-stamped marks: clearing costs nothing between queries.
#[derive(Default)]
struct SeenLeaves {
    stamp: Vec<u32>,
    generation: u32,
}

impl SeenLeaves {
    /// Calls `f(leaf)` once for each distinct leaf listed in the cells a region meets.
    fn for_each_unique(&mut self, ix: &BlendIndex, region: &Region, mut f: impl FnMut(u32)) {
        if self.stamp.len() < ix.leaves.len() {
            self.stamp.resize(ix.leaves.len(), 0);
        }
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            self.stamp.fill(0);
            self.generation = 1;
        }
        let mut unseen = |items: &[u32]| {
            for &i in items {
                let mark = &mut self.stamp[i as usize];
                if *mark != self.generation {
                    *mark = self.generation;
                    f(i);
                }
            }
        };
        match region {
            Region::Box(b) => ix.for_each_list_over(b, unseen),
            Region::Segment(..) => ix.for_each_cell_in(region, |c| unseen(ix.leaves_in(c))),
        }
    }
}

/// Calls `f(leaf)` once for each distinct leaf of `ix` listed in the cells a
/// region meets, with this thread's scratch marks.
fn for_each_unique_leaf(ix: &BlendIndex, region: &Region, f: impl FnMut(u32)) {
    SEEN.with(|cell| {
        // Taken out while in use, so a nested index gets its own scratch.
        let mut seen = cell.take();
        seen.for_each_unique(ix, region, f);
        cell.set(seen);
    });
}

/// A cache's subtree as its lattice samples it: values, and the intervals
/// that show a region of the lattice to be zero.
struct CachedSubtree<'m> {
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
    fn sampled(&self, child: NodeId, mode: EvalMode) -> CachedSubtree<'_> {
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
                (m, Some(ix)) if m.indexed() => {
                    let sum = ix.point_sum(p).unwrap_or_else(|| {
                        let leaves = &ix.leaves;
                        ix.candidates(p)
                            .iter()
                            .fold(0.0f64, |s, &i| s + f64::from(self.leaf_value(&leaves[i as usize], p, mode)))
                    });
                    sum as f32
                }
                _ => self.nested_blend_sum(children, p, mode) as f32,
            },
            NodeKind::Union(cs) => cs.iter().map(|&c| self.node_value(c, p, mode)).fold(f32::MIN, f32::max),
            NodeKind::Intersection(cs) => cs.iter().map(|&c| self.node_value(c, p, mode)).fold(f32::MAX, f32::min),
            NodeKind::Difference(a, b) => {
                let (a, b) = (self.node_value(*a, p, mode), self.node_value(*b, p, mode));
                a.min(2.0 * t - b).max(0.0)
            }
            NodeKind::Ricci { n, children } => {
                let s: f32 = children.iter().map(|&c| self.node_value(c, p, mode).max(0.0).powf(*n)).sum();
                s.powf(1.0 / n)
            }
            NodeKind::Transform { placement, child } => self.node_value(*child, placement.local(p), mode),
            NodeKind::Cache { child, grid, .. } if mode == EvalMode::Cached => {
                self.cache(*grid).value(p, self.pool(), &self.sampled(*child, mode))
            }
            NodeKind::Named { child, .. } | NodeKind::Cache { child, .. } => self.node_value(*child, p, mode),
        }
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
                NodeKind::Cache { child, .. } if mode != EvalMode::Cached => id = *child,
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
                let (v, g) =
                    ix.point_sum_and_gradient(p).unwrap_or_else(|| self.leaves_value_and_gradient(ix, p, mode));
                return (v as f32, g);
            }
            NodeKind::Blend { children, index } if index.is_none() || !mode.indexed() => {
                let (v, g) = self.nested_blend_value_and_gradient(children, p, mode);
                return (v as f32, g);
            }
            NodeKind::Transform { placement, child } => {
                let (v, g) = self.node_value_and_gradient(*child, placement.local(p), mode);
                return (v, placement.gradient_map * g);
            }
            NodeKind::Cache { child, grid, .. } if mode == EvalMode::Cached => {
                return self.cache(*grid).value_and_gradient(p, self.pool(), &self.sampled(*child, mode));
            }
            NodeKind::Named { child, .. } | NodeKind::Cache { child, .. } => {
                return self.node_value_and_gradient(*child, p, mode);
            }
            _ => {}
        }
        (self.node_value(id, p, mode), self.node_gradient(id, p, mode))
    }

    /// The sum of the values and of the gradients of the leaves listed around
    /// `p`, in the order (and so to the bits) of [`Self::node_value`] and
    /// [`Self::node_gradient`] apart, each leaf visited once: a leaf that is a
    /// blend of points sums its values and gradients in one pass.
    fn leaves_value_and_gradient(&self, ix: &BlendIndex, p: Vec3A, mode: EvalMode) -> (f64, Vec3A) {
        ix.candidates(p).iter().fold((0.0f64, Vec3A::ZERO), |(sum, gradient), &i| {
            let (v, g) = match &ix.leaves[i as usize].leaf {
                Leaf::Primitive(prim) => (prim.value(p), prim.gradient(p)),
                Leaf::Node(id) => self.node_value_and_gradient(*id, p, mode),
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
                (m, Some(ix)) if m.indexed() => ix.point_gradient(p).unwrap_or_else(|| {
                    ix.candidates(p).iter().fold(Vec3A::ZERO, |s, &i| {
                        s + match &ix.leaves[i as usize].leaf {
                            Leaf::Primitive(prim) => prim.gradient(p),
                            Leaf::Node(id) => self.node_gradient(*id, p, mode),
                        }
                    })
                }),
                _ => children.iter().fold(Vec3A::ZERO, |s, &c| s + self.node_gradient(c, p, mode)),
            },
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
            NodeKind::Cache { child, grid, .. } if mode == EvalMode::Cached => {
                self.cache(*grid).gradient(p, self.pool(), &self.sampled(*child, mode))
            }
            NodeKind::Named { child, .. } | NodeKind::Cache { child, .. } => self.node_gradient(*child, p, mode),
        }
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
                (m, Some(ix)) if m.indexed() => mix(ix.candidates(p).iter().map(|&i| {
                    let leaf = &ix.leaves[i as usize];
                    let w = self.leaf_value(leaf, p, mode);
                    (w, move || leaf.color.unwrap_or_else(|| self.leaf_color(leaf, p, mode)))
                })),
                _ => mix(children.iter().map(|&c| (self.node_value(c, p, mode), move || self.node_color(c, p, mode)))),
            },
            NodeKind::Ricci { n, children } => mix(children
                .iter()
                .map(|&c| (self.node_value(c, p, mode).max(0.0).powf(*n), move || self.node_color(c, p, mode)))),
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
            NodeKind::Named { child, .. } | NodeKind::Cache { child, .. } => self.node_color(*child, p, mode),
        }
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
                NodeKind::Cache { .. } if mode == EvalMode::Cached => {}
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

    /// Conservative bounds of node `id`'s value over a box.
    pub fn node_interval(&self, id: NodeId, b: &Aabb, mode: EvalMode) -> Interval {
        let node = self.node(self.past_pass_throughs(id, mode));
        if !node.bounds.overlaps(b) {
            return Interval::ZERO;
        }
        let t = self.threshold();
        let sum = |cs: &[NodeId]| cs.iter().fold(Interval::ZERO, |s, &c| s + self.node_interval(c, b, mode));
        let reduce = |cs: &[NodeId], f: fn(Interval, Interval) -> Interval| {
            cs[1..].iter().fold(self.node_interval(cs[0], b, mode), |s, &c| f(s, self.node_interval(c, b, mode)))
        };
        match &node.kind {
            NodeKind::Primitive(prim) => prim.interval(b),
            NodeKind::Blend { children, index } => match (mode, index) {
                (m, Some(ix)) if m.indexed() => self.indexed_interval(ix, b, mode),
                _ => sum(children),
            },
            NodeKind::Union(cs) => reduce(cs, Interval::max),
            NodeKind::Intersection(cs) => reduce(cs, Interval::min),
            NodeKind::Difference(a, c) => {
                let carved =
                    self.node_interval(*a, b, mode).min(self.node_interval(*c, b, mode).subtracted_from(2.0 * t));
                Interval::new(carved.lo.max(0.0), carved.hi.max(0.0))
            }
            NodeKind::Ricci { n, children } => {
                let (lo, hi) = children.iter().fold((0.0f32, 0.0f32), |(lo, hi), &c| {
                    let r = self.node_interval(c, b, mode);
                    (lo + r.lo.max(0.0).powf(*n), hi + r.hi.max(0.0).powf(*n))
                });
                Interval::new(lo.powf(1.0 / n), hi.powf(1.0 / n))
            }
            NodeKind::Transform { placement, child } => {
                self.node_interval(*child, &b.transformed(&placement.to_local), mode)
            }
            NodeKind::Cache { child, grid, .. } if mode == EvalMode::Cached => {
                self.cache(*grid).interval(b, self.pool(), &|r| self.node_interval(*child, r, mode))
            }
            NodeKind::Named { child, .. } | NodeKind::Cache { child, .. } => self.node_interval(*child, b, mode),
        }
    }

    /// Whether node `id`'s [`Self::node_interval`] over `b` is zero. Blends
    /// and moves answer for their parts, and a blend of points indexed asks
    /// only whether a point reaches `b` ([`BlendIndex::points_miss`]), which
    /// sums nothing and packs no cell.
    pub fn node_is_zero_over(&self, id: NodeId, b: &Aabb, mode: EvalMode) -> bool {
        let node = self.node(self.past_pass_throughs(id, mode));
        if !node.bounds.overlaps(b) {
            return true;
        }
        let miss = match &node.kind {
            NodeKind::Blend { index: Some(ix), .. } if mode.indexed() => {
                (ix.cells_overlapped(b) <= MAX_CELLS_FOR_LEAF_BOUNDS).then(|| ix.points_miss(b)).flatten()
            }
            // A sum of intervals is zero where each is (no field here is a
            // nonzero constant over a box, to cancel another).
            NodeKind::Blend { children, .. } => Some(children.iter().all(|&c| self.node_is_zero_over(c, b, mode))),
            NodeKind::Transform { placement, child } => {
                Some(self.node_is_zero_over(*child, &b.transformed(&placement.to_local), mode))
            }
            _ => None,
        };
        miss.unwrap_or_else(|| self.node_interval(id, b, mode) == Interval::ZERO)
    }

    pub(super) fn leaf_interval(&self, leaf: &IndexedLeaf, b: &Aabb, mode: EvalMode) -> Interval {
        match &leaf.leaf {
            Leaf::Primitive(prim) => {
                if leaf.bounds.overlaps(b) {
                    prim.interval(b)
                } else {
                    Interval::ZERO
                }
            }
            Leaf::Node(id) => self.node_interval(*id, b, mode),
        }
    }

    /// A bound on `|∇f|` of node `id` over a region (segment or box).
    ///
    /// Sums add their children's bounds, min/max take the largest, a transform
    /// multiplies by its inverse's norm; children whose support misses the
    /// region are constant (zero) there and add nothing.
    pub fn node_lipschitz(&self, id: NodeId, region: &Region, mode: EvalMode) -> f32 {
        let id = self.past_pass_throughs(id, mode);
        if !region.meets(&self.node(id).bounds) {
            return 0.0;
        }
        self.met_node_lipschitz(id, region, mode)
    }

    /// [`Self::node_lipschitz`] of a node that is no pass-through and whose bounds `region` meets.
    pub(super) fn met_node_lipschitz(&self, id: NodeId, region: &Region, mode: EvalMode) -> f32 {
        let node = self.node(id);
        let sum = |cs: &[NodeId]| cs.iter().map(|&c| self.node_lipschitz(c, region, mode)).sum::<f32>();
        let max = |cs: &[NodeId]| cs.iter().map(|&c| self.node_lipschitz(c, region, mode)).fold(0.0, f32::max);
        match &node.kind {
            NodeKind::Primitive(prim) => prim.lipschitz_over(region),
            NodeKind::Blend { children, index } => match (mode, index) {
                (m, Some(ix)) if m.indexed() => self.indexed_lipschitz(ix, region, mode),
                _ => sum(children),
            },
            NodeKind::Ricci { children, .. } => sum(children),
            NodeKind::Union(cs) | NodeKind::Intersection(cs) => max(cs),
            NodeKind::Difference(a, b) => max(&[*a, *b]),
            NodeKind::Transform { placement, child } => {
                placement.stretch * self.node_lipschitz(*child, &region.transformed(&placement.to_local), mode)
            }
            NodeKind::Cache { child, grid, .. } if mode == EvalMode::Cached => self.cache(*grid).lipschitz(
                region,
                &|b| self.node_lipschitz(*child, &Region::Box(*b), mode),
                &|b| self.node_interval(*child, b, mode),
                (self.pool(), &self.sampled(*child, mode)),
            ),
            NodeKind::Named { child, .. } | NodeKind::Cache { child, .. } => self.node_lipschitz(*child, region, mode),
        }
    }

    /// A lower bound on the derivative of node `id`'s value along the
    /// segment `a..b` (in the node's frame) per unit of distance along the
    /// world ray, which moves at velocity `u` in this frame: `∇f(p)·u >= floor`
    /// at every `p` of the segment. Known where the field is a sum of cached
    /// lattices (each cell's derivative lies between its samples'
    /// differences); `None` elsewhere, where exact fields have curvature bounds.
    pub fn node_slope_floor(&self, id: NodeId, (a, b): (Vec3A, Vec3A), u: Vec3A, mode: EvalMode) -> Option<f32> {
        let node = self.node(id);
        let segment = Region::Segment(a, b);
        if !segment.meets(&node.bounds) {
            return Some(0.0);
        }
        match &node.kind {
            NodeKind::Blend { children, index } => match (mode, index) {
                (m, Some(ix)) if m.indexed() => {
                    let mut total = Some(0.0);
                    for_each_unique_leaf(ix, &segment, |i| {
                        let leaf = &ix.leaves[i as usize];
                        let floor = match &leaf.leaf {
                            Leaf::Node(id) => self.node_slope_floor(*id, (a, b), u, mode),
                            Leaf::Primitive(_) if !segment.meets(&leaf.bounds) => Some(0.0),
                            Leaf::Primitive(_) => None,
                        };
                        total = total.zip(floor).map(|(t, f)| t + f);
                    });
                    total
                }
                _ => children.iter().try_fold(0.0, |t, &c| Some(t + self.node_slope_floor(c, (a, b), u, mode)?)),
            },
            NodeKind::Transform { placement, child } => {
                let l = &placement.to_local;
                self.node_slope_floor(
                    *child,
                    (l.transform_point3a(a), l.transform_point3a(b)),
                    l.transform_vector3a(u),
                    mode,
                )
            }
            NodeKind::Cache { child, grid, .. } if mode == EvalMode::Cached => {
                Some(self.cache(*grid).slope_floor((a, b), u, self.pool(), &self.sampled(*child, mode)))
            }
            NodeKind::Named { child, .. } | NodeKind::Cache { child, .. } => {
                self.node_slope_floor(*child, (a, b), u, mode)
            }
            _ => None,
        }
    }

    /// An upper bound on node `id`'s second derivative along any line
    /// through a region (it may be negative where the field is concave),
    /// infinite where the gradient may jump (the creases of unions,
    /// intersections and differences, a cache's cell faces).
    pub fn node_curvature(&self, id: NodeId, region: &Region, mode: EvalMode) -> f32 {
        let id = self.past_pass_throughs(id, mode);
        if !region.meets(&self.node(id).bounds) {
            return 0.0;
        }
        self.met_node_curvature(id, region, mode)
    }

    /// [`Self::node_curvature`] of a node that is no pass-through and whose bounds `region` meets.
    pub(super) fn met_node_curvature(&self, id: NodeId, region: &Region, mode: EvalMode) -> f32 {
        let node = self.node(id);
        match &node.kind {
            NodeKind::Primitive(prim) => prim.curvature_over(region),
            NodeKind::Blend { children, index } => match (mode, index) {
                (m, Some(ix)) if m.indexed() => self.indexed_curvature(ix, region, mode),
                _ => children.iter().map(|&c| self.node_curvature(c, region, mode)).sum(),
            },
            NodeKind::Transform { placement, child } => {
                // A unit step is at most `stretch` long in the child's frame,
                // and a concave child stays concave.
                let stretch = placement.stretch;
                let child = self.node_curvature(*child, &region.transformed(&placement.to_local), mode);
                stretch * stretch * child.max(0.0)
            }
            NodeKind::Cache { .. } if mode == EvalMode::Cached => f32::INFINITY,
            NodeKind::Named { child, .. } | NodeKind::Cache { child, .. } => self.node_curvature(*child, region, mode),
            NodeKind::Union(_) | NodeKind::Intersection(_) | NodeKind::Difference(..) | NodeKind::Ricci { .. } => {
                f32::INFINITY
            }
        }
    }

    /// Slope bound of an indexed blend over a region: the largest per-cell
    /// bound along it, or, for a short segment through an index with node
    /// leaves, Galin's sum of the local bounds of the leaves listed in the
    /// cells it crosses (each leaf once).
    fn indexed_lipschitz(&self, ix: &BlendIndex, region: &Region, mode: EvalMode) -> f32 {
        // The per-cell bounds cost one grid walk. Summing the leaves' own
        // bounds is tighter but visits every leaf listed in every cell crossed:
        // on Medusa it takes 1.5× fewer steps at 3× the cost each. Node leaves
        // (a cache with its sampled slopes, say) can be far tighter along a
        // short segment than over whole cells, so those keep the sum.
        if !matches!(region, Region::Segment(..)) || !sums_node_leaves(ix, region) {
            return ix.cell_lipschitz(region);
        }
        let mut total = 0.0;
        for_each_unique_leaf(ix, region, |i| total += self.leaf_lipschitz(&ix.leaves[i as usize], region, mode));
        total
    }

    /// Curvature bound of an indexed blend along a region, as
    /// [`Self::indexed_lipschitz`] bounds its slope. The per-cell bounds are
    /// infinite where a node leaf reaches (they must hold for cached
    /// evaluation too, where a cache's gradient jumps at its cell faces); the
    /// sum over the leaves asks each node in the mode at hand.
    fn indexed_curvature(&self, ix: &BlendIndex, region: &Region, mode: EvalMode) -> f32 {
        if !sums_node_leaves(ix, region) {
            return ix.cell_curvature(region);
        }
        let mut total = 0.0;
        for_each_unique_leaf(ix, region, |i| total += self.leaf_curvature(&ix.leaves[i as usize], region, mode));
        total
    }

    /// Value range of an indexed blend over a box. A box meeting few cells
    /// sums its leaves one by one, each answering for the box itself: the hull
    /// of the precomputed cell ranges is loose where the cells stick out past
    /// the box (an empty-space cell is smaller than an index cell on Medusa).
    /// Larger boxes take that hull.
    fn indexed_interval(&self, ix: &BlendIndex, b: &Aabb, mode: EvalMode) -> Interval {
        if ix.cells_overlapped(b) > MAX_CELLS_FOR_LEAF_BOUNDS {
            return ix.interval(b);
        }
        if let Some(range) = ix.point_interval(b) {
            return range;
        }
        let mut total = Interval::ZERO;
        for_each_unique_leaf(ix, &Region::Box(*b), |i| {
            total = total + self.leaf_interval(&ix.leaves[i as usize], b, mode)
        });
        total
    }

    fn leaf_curvature(&self, leaf: &IndexedLeaf, region: &Region, mode: EvalMode) -> f32 {
        self.leaf_bound(leaf, region, Primitive::curvature_over, |id| self.node_curvature(id, region, mode))
    }

    pub(super) fn leaf_lipschitz(&self, leaf: &IndexedLeaf, region: &Region, mode: EvalMode) -> f32 {
        self.leaf_bound(leaf, region, Primitive::lipschitz_over, |id| self.node_lipschitz(id, region, mode))
    }

    /// A leaf's bound over a region: a primitive's own (zero where its box
    /// misses the region), a node's from the tree.
    fn leaf_bound(
        &self,
        leaf: &IndexedLeaf,
        region: &Region,
        primitive: fn(&Primitive, &Region) -> f32,
        node: impl Fn(NodeId) -> f32,
    ) -> f32 {
        match &leaf.leaf {
            Leaf::Primitive(prim) if region.meets(&leaf.bounds) => primitive(prim, region),
            Leaf::Primitive(_) => 0.0,
            Leaf::Node(id) => node(*id),
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

/// True when a bound of `ix` over a region should sum its leaves one by one:
/// some are nodes, and the region meets few enough cells for the walk to be cheap.
fn sums_node_leaves(ix: &BlendIndex, region: &Region) -> bool {
    ix.has_node_leaves() && ix.cells_overlapped(&region.bounds()) <= MAX_CELLS_FOR_LEAF_BOUNDS
}
