//! Whether a cache pays: a cost model that counts work, not time, so the
//! decision is a pure function of the scene — the same on every run and
//! machine, and so the same image.
//!
//! The unit is one point's term in a sum (`w·(1 − d²/R²)³`, as the index sums
//! them). An exact evaluation of a subtree costs the terms it sums on average
//! — for an indexed blend the mean of its cells' listings — plus the nodes it
//! passes through; a cached one costs a reconstruction from the lattice and
//! what caching costs a render on top of it. The lookup's constant is
//! calibrated by `cargo bench --bench cache_cost`, which times lookups and
//! exact evaluations of every bundled cache and prints the fit in the same
//! unit; the render overhead by whole renders (see [`RENDER_OVERHEAD`]).

use super::index::Leaf;
use super::model::Model;
use super::node::NodeKind;
use super::node_id::NodeId;
use super::primitive::{Primitive, Skeleton};
use crate::cache::CacheUse;

/// A tri-linear reconstruction from a warm lattice, in point terms
/// (`cargo bench --bench cache_cost` fits 96 on the bundled scenes' caches).
pub const LOOKUP_COST: f32 = 96.0;
/// What one lattice answer costs a render, in warm lookups: the cold
/// samples it fills and the tracer's curvature bounds it gives up (a
/// lattice's gradient jumps at its cell faces) come on top of the lookup.
/// Measured on Medusa at 640×480, its head and body answering from their
/// lattices (estimated at 272 and 275 point terms exactly) render in
/// 0.58–0.61 s against 0.37–0.41 s exact: an answer costs a render more
/// than 275 / 96 ≈ 2.9 lookups, and 3 is the least whole multiple that agrees.
pub const RENDER_OVERHEAD: f32 = 3.0;
/// What a lattice answer costs a render, in point terms: a cache pays where
/// an exact answer of its subtree costs more.
pub const LATTICE_COST: f32 = LOOKUP_COST * RENDER_OVERHEAD;
/// Visiting an operator node (its box test and combination), in point terms.
pub const NODE_COST: f32 = 1.0;
/// An affine transform of the point, in point terms.
pub const TRANSFORM_COST: f32 = 1.5;
/// A warp (sines, cosines, an arc tangent), in point terms: the spring of
/// `scenes/warps.ron` (a transform, a twist, a segment) takes 37 ns exactly
/// where a point term takes about 0.7 ns.
pub const WARP_COST: f32 = 40.0;
/// A power `xⁿ` of a Ricci blend (each child not zero at the point, and the
/// sum's root), in point terms.
pub const POWER_COST: f32 = 25.0;
/// How many more tracing steps a subtree takes exactly than from a lattice
/// where its exact bounds are loose: through a warp the slope bound is
/// stretched by the warp's largest `‖J‖` over a box, and Ricci blends and
/// CSG have no curvature bound. Measured on `scenes/crown.ron`: 4.05 M steps
/// exactly against 1.33 M from the lattice (`blobtrace bench cache`).
pub const LOOSE_BOUND_STEPS: f32 = 3.0;
/// A segment primitive (a projection onto the segment), in point terms.
pub const SEGMENT_COST: f32 = 1.5;
/// A circle primitive (a square root for the distance to the ring), in point terms.
pub const CIRCLE_COST: f32 = 3.0;

/// The decision about one cache and the estimate behind it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CacheDecision {
    /// The cache node.
    pub node: NodeId,
    /// The nearest name above it.
    pub name: String,
    /// Its resolution.
    pub res: u32,
    /// Estimated work of one exact evaluation of its subtree, in point terms.
    pub value_cost: f32,
    /// How many times the lattice's steps the tracer takes exactly
    /// (1, or [`LOOSE_BOUND_STEPS`] where the subtree's exact bounds are loose).
    pub steps: f32,
    /// What an exact answer costs a render: `value_cost · steps`.
    pub exact_cost: f32,
    /// Estimated work of a cached answer, in point terms.
    pub lattice_cost: f32,
    /// True when the cache answers from its lattice in auto mode.
    pub uses_lattice: bool,
    /// Why: `pinned` by the scene's `use:`, or `estimated`.
    pub reason: &'static str,
}

impl Model {
    /// Each cache's decision for auto mode, deepest first (an outer cache's
    /// estimate counts the inner ones as decided).
    #[must_use]
    pub fn cache_decisions(&self) -> Vec<CacheDecision> {
        let mut decided: Vec<Option<bool>> = vec![None; self.grid_count()];
        let mut out = vec![];
        for id in self.post_order() {
            let NodeKind::Cache { spec, child, grid } = self.node(id).kind else { continue };
            let value_cost = self.exact_cost(child, &decided);
            let steps = if self.has_loose_bounds(child, &decided) { LOOSE_BOUND_STEPS } else { 1.0 };
            let exact_cost = value_cost * steps;
            let lattice_cost = LATTICE_COST;
            let (uses_lattice, reason) = match spec.usage {
                CacheUse::Always => (true, "pinned"),
                CacheUse::Never => (false, "pinned"),
                CacheUse::Auto => (exact_cost > lattice_cost, "estimated"),
            };
            decided[grid] = Some(uses_lattice);
            let name = self.name_above(id).unwrap_or_else(|| format!("cache{grid}"));
            out.push(CacheDecision {
                node: id,
                name,
                res: spec.res,
                value_cost,
                steps,
                exact_cost,
                lattice_cost,
                uses_lattice,
                reason,
            });
        }
        out
    }

    /// What an exact answer of node `id` costs a render, in point terms, as
    /// [`Self::cache_decisions`] weighs a cache over it: the value's work
    /// and the steps factor (every cache below it answering exactly).
    #[must_use]
    pub fn exact_answer_cost(&self, id: NodeId) -> (f32, f32) {
        let undecided = vec![None; self.grid_count()];
        let steps = if self.has_loose_bounds(id, &undecided) { LOOSE_BOUND_STEPS } else { 1.0 };
        (self.exact_cost(id, &undecided), steps)
    }

    /// Estimated work of an exact evaluation of node `id` at a point inside
    /// its bounds, caches answering as `decided` says (undecided: exactly).
    fn exact_cost(&self, id: NodeId, decided: &[Option<bool>]) -> f32 {
        let node = self.node(id);
        let inside = |c: NodeId| {
            // A child is evaluated where the point lies in its box.
            let (outer, inner) = (node.bounds.volume(), self.node(c).bounds.volume());
            if outer > 0.0 { (inner / outer).min(1.0) } else { 1.0 }
        };
        let children = |cs: &[NodeId]| cs.iter().map(|&c| inside(c) * self.exact_cost(c, decided)).sum::<f32>();
        match &node.kind {
            NodeKind::Primitive(p) => primitive_cost(p),
            NodeKind::Blend { index: Some(ix), .. } | NodeKind::Points { index: ix, .. } => {
                NODE_COST
                    + ix.mean_listing(|leaf| match &leaf.leaf {
                        Leaf::Primitive(p) => primitive_cost(p),
                        Leaf::Node(n) => self.exact_cost(*n, decided),
                    })
            }
            NodeKind::Blend { children: cs, .. } | NodeKind::Union(cs) | NodeKind::Intersection(cs) => {
                NODE_COST + children(cs)
            }
            NodeKind::Ricci { children: cs, .. } => {
                let powers = cs.iter().map(|&c| inside(c)).sum::<f32>() + 1.0;
                NODE_COST + children(cs) + POWER_COST * powers
            }
            NodeKind::Difference(a, b) => NODE_COST + children(&[*a, *b]),
            NodeKind::Transform { child, .. } => TRANSFORM_COST + self.exact_cost(*child, decided),
            NodeKind::Warp { child, .. } => WARP_COST + self.exact_cost(*child, decided),
            NodeKind::Named { child, .. } => self.exact_cost(*child, decided),
            NodeKind::Cache { child, grid, .. } => match decided[*grid] {
                Some(true) => LATTICE_COST,
                _ => self.exact_cost(*child, decided),
            },
        }
    }

    /// True when exact tracing through node `id` takes loose bounds: it
    /// holds a warp, a Ricci blend or CSG not behind a cache that answers.
    fn has_loose_bounds(&self, id: NodeId, decided: &[Option<bool>]) -> bool {
        match &self.node(id).kind {
            NodeKind::Warp { .. }
            | NodeKind::Ricci { .. }
            | NodeKind::Union(_)
            | NodeKind::Intersection(_)
            | NodeKind::Difference(..) => true,
            NodeKind::Cache { grid, .. } if decided[*grid] == Some(true) => false,
            kind => kind.children().into_iter().any(|c| self.has_loose_bounds(c, decided)),
        }
    }

    /// Node ids, children before parents.
    fn post_order(&self) -> Vec<NodeId> {
        let (mut out, mut stack) = (vec![], vec![(self.root(), false)]);
        while let Some((id, expanded)) = stack.pop() {
            if expanded {
                out.push(id);
            } else {
                stack.push((id, true));
                stack.extend(self.node(id).kind.children().into_iter().rev().map(|c| (c, false)));
            }
        }
        out
    }
}

fn primitive_cost(p: &Primitive) -> f32 {
    match p.skeleton {
        Skeleton::Point { .. } => 1.0,
        Skeleton::Segment { .. } => SEGMENT_COST,
        Skeleton::Circle { .. } => CIRCLE_COST,
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::Scene;

    fn decisions(model: &str) -> Vec<bool> {
        let text = format!(
            "Scene(camera: Camera(eye: (0.0, 0.0, 9.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (8, 8), model: {model})"
        );
        Scene::parse(&text, "t").unwrap().model.cache_decisions().iter().map(|d| d.uses_lattice).collect()
    }

    #[test]
    fn a_cache_pays_over_an_expensive_subtree_only() {
        assert_eq!(decisions("Cache(res: 16, child: Point(center: (0.0, 0.0, 0.0), radius: 1.0))"), [false]);
        // Six hundred points all overlapping: every evaluation sums them all.
        let crowd: String =
            (0..600).map(|i| format!("Point(center: ({:.3}, 0.0, 0.0), radius: 2.0),", i as f32 * 1e-3)).collect();
        assert_eq!(decisions(&format!("Cache(res: 16, child: Blend([{crowd}]))")), [true]);
        // Warps and transforms add their work; the decision is the same on every call.
        let warped = format!("Cache(res: 16, child: Twist(rate: 1.0, child: Blend([{crowd}])))");
        assert_eq!(decisions(&warped), [true]);
        assert_eq!(decisions(&warped), decisions(&warped));
        // An inner cache decided for its lattice counts as a lookup in the outer one's estimate.
        let nested = format!(
            "Cache(res: 16, child: Blend([Cache(res: 16, child: Blend([{crowd}])), Point(center: (0.0, 0.0, 0.0), radius: 1.0)]))"
        );
        let text = format!(
            "Scene(camera: Camera(eye: (0.0, 0.0, 9.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (8, 8), model: {nested})"
        );
        let costs: Vec<f32> =
            Scene::parse(&text, "t").unwrap().model.cache_decisions().iter().map(|d| d.exact_cost).collect();
        let lattice = super::LOOKUP_COST * super::RENDER_OVERHEAD;
        assert!(costs[0] > 500.0 && costs[1] > lattice && costs[1] < lattice + 5.0, "{costs:?}");
    }
}
