//! Bounds of a node's field over a region: its value range over a box,
//! whether it is zero there, and bounds on its slope (Lipschitz), on its
//! derivative along a segment from below, and on its curvature, over a
//! segment or a box. Every node's field is zero outside its bounds, so a
//! child whose bounds miss the region adds nothing.

use std::cell::Cell;

use glam::Vec3A;

use super::EvalMode;
use super::index::{BlendIndex, IndexedLeaf, Leaf};
use super::model::Model;
use super::node::NodeKind;
use super::node_id::NodeId;
use super::primitive::Primitive;
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

impl Model {
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
            NodeKind::Points { index, .. } => self.indexed_interval(index, b, mode),
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
            NodeKind::Warp { warp, child } => self.node_interval(*child, &warp.inverse_box(b), mode),
            NodeKind::Cache { child, grid, .. } if self.answers_from_lattice(*grid, mode) => {
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
        let points_miss =
            |ix: &BlendIndex| (ix.cells_overlapped(b) <= MAX_CELLS_FOR_LEAF_BOUNDS).then(|| ix.points_miss(b));
        let miss = match &node.kind {
            NodeKind::Blend { index: Some(ix), .. } if mode.indexed() => points_miss(ix).flatten(),
            NodeKind::Points { index, .. } => points_miss(index).flatten(),
            // A sum of intervals is zero where each is (no field here is a
            // nonzero constant over a box, to cancel another).
            NodeKind::Blend { children, .. } => Some(children.iter().all(|&c| self.node_is_zero_over(c, b, mode))),
            NodeKind::Transform { placement, child } => {
                Some(self.node_is_zero_over(*child, &b.transformed(&placement.to_local), mode))
            }
            NodeKind::Warp { warp, child } => Some(self.node_is_zero_over(*child, &warp.inverse_box(b), mode)),
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
            NodeKind::Points { index, .. } => self.indexed_lipschitz(index, region, mode),
            NodeKind::Ricci { children, .. } => sum(children),
            NodeKind::Union(cs) | NodeKind::Intersection(cs) => max(cs),
            NodeKind::Difference(a, b) => max(&[*a, *b]),
            NodeKind::Transform { placement, child } => {
                placement.stretch * self.node_lipschitz(*child, &region.transformed(&placement.to_local), mode)
            }
            NodeKind::Warp { warp, child } => {
                // |∇f(p)| ≤ ‖∂q/∂p‖ · |∇f_child(q)|, with q in a box holding the warped region.
                let bounds = region.bounds();
                let child_bound = self.node_lipschitz(*child, &Region::Box(warp.inverse_box(&bounds)), mode);
                if child_bound == 0.0 {
                    return 0.0;
                }
                warp.stretch_over(&bounds, &self.node(*child).bounds) * child_bound
            }
            NodeKind::Cache { child, grid, .. } if self.answers_from_lattice(*grid, mode) => {
                self.cache(*grid).lipschitz(
                    region,
                    &|b| self.node_lipschitz(*child, &Region::Box(*b), mode),
                    &|b| self.node_interval(*child, b, mode),
                    (self.pool(), &self.sampled(*child, mode)),
                )
            }
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
                        let leaf = ix.leaves.get(i as usize);
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
            NodeKind::Cache { child, grid, .. } if self.answers_from_lattice(*grid, mode) => {
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
            NodeKind::Points { index, .. } => self.indexed_curvature(index, region, mode),
            NodeKind::Transform { placement, child } => {
                // A unit step is between `least_stretch` and `stretch` long in
                // the child's frame: a convex child's bound grows by the most,
                // a concave child's stays below zero by the least.
                let child = self.node_curvature(*child, &region.transformed(&placement.to_local), mode);
                let stretch = if child > 0.0 { placement.stretch } else { placement.least_stretch };
                stretch * stretch * child
            }
            NodeKind::Cache { grid, .. } if self.answers_from_lattice(*grid, mode) => f32::INFINITY,
            NodeKind::Named { child, .. } | NodeKind::Cache { child, .. } => self.node_curvature(*child, region, mode),
            NodeKind::Warp { warp, child } => {
                // A warp bends straight lines: the second derivative along one is
                // the child's along the bent path, stretched, plus its slope times
                // the path's turning (see `Warp::acceleration_over`).
                let bounds = region.bounds();
                let accel = warp.acceleration_over(&bounds);
                if !accel.is_finite() {
                    return f32::INFINITY;
                }
                let inner = Region::Box(warp.inverse_box(&bounds));
                let stretch = warp.stretch_over(&bounds, &self.node(*child).bounds);
                let curvature = self.node_curvature(*child, &inner, mode).max(0.0);
                stretch * stretch * curvature + self.node_lipschitz(*child, &inner, mode) * accel
            }
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
        for_each_unique_leaf(ix, region, |i| total += self.leaf_lipschitz(&ix.leaves.get(i as usize), region, mode));
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
        for_each_unique_leaf(ix, region, |i| total += self.leaf_curvature(&ix.leaves.get(i as usize), region, mode));
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
            total = total + self.leaf_interval(&ix.leaves.get(i as usize), b, mode)
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

/// True when a bound of `ix` over a region should sum its leaves one by one:
/// some are nodes, and the region meets few enough cells for the walk to be cheap.
fn sums_node_leaves(ix: &BlendIndex, region: &Region) -> bool {
    ix.has_node_leaves() && ix.cells_overlapped(&region.bounds()) <= MAX_CELLS_FOR_LEAF_BOUNDS
}
