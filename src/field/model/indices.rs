//! The blend indices of a model: one over the leaves of each cluster of
//! nested blends that has enough of them, rebuilt along the path of an edit.

use std::sync::Arc;

use glam::Vec3;

use super::Model;
use crate::field::EvalMode;
use crate::field::index::{BlendIndex, IndexedLeaf, Leaf, Leaves, MIN_INDEXED_LEAVES};
use crate::field::node::NodeKind;
use crate::field::node_id::NodeId;
use crate::geom::{Aabb, Interval, Region};

impl Model {
    /// Indexes the top blend of every cluster of nested blends that has enough leaves.
    pub(super) fn build_indices(&mut self, id: NodeId) {
        for c in self.nodes[id as usize].kind.children() {
            self.build_indices(c);
        }
        self.build_index_at(id);
    }

    /// Rebuilds the index of node `id` if it is the top blend of a cluster;
    /// returns where evaluation through it may now differ (in the frame its
    /// parent sees), empty where nothing did.
    pub(super) fn build_index_at(&mut self, id: NodeId) -> Aabb {
        let is_cluster_top = matches!(self.nodes[id as usize].kind, NodeKind::Blend { .. })
            && !self.nodes[id as usize]
                .parent
                .is_some_and(|p| matches!(self.nodes[p as usize].kind, NodeKind::Blend { .. }));
        if !is_cluster_top {
            return Aabb::EMPTY;
        }
        let mut leaves = Vec::with_capacity(self.count_leaves(id));
        self.collect_leaves(id, None, &mut leaves);
        let index = (leaves.len() >= MIN_INDEXED_LEAVES).then(|| {
            let bounds = self.nodes[id as usize].bounds;
            Arc::new(BlendIndex::build(
                bounds,
                Leaves::Listed(leaves),
                // Per-cell bounds must hold for exact and cached evaluation alike.
                |leaf, b| in_every_mode(leaf, |m| self.leaf_interval(leaf, b, m), Interval::join),
                |leaf, r: &Region| in_every_mode(leaf, |m| self.leaf_lipschitz(leaf, r, m), f32::max),
            ))
        });
        let bounds = self.nodes[id as usize].bounds;
        let NodeKind::Blend { index: slot, .. } = &mut self.nodes[id as usize].kind else { return Aabb::EMPTY };
        let changed = match (&*slot, &index) {
            (Some(old), Some(new)) => new.changed_since(old),
            // Summed in child order instead of index order, or the reverse.
            (Some(ix), None) | (None, Some(ix)) => bounds.union(&ix.bounds()),
            (None, None) => Aabb::EMPTY,
        };
        *slot = index;
        changed
    }

    /// How many leaves [`Self::collect_leaves`] finds under `id`, so their
    /// list is made at its size (a million leaves of 112 bytes would
    /// otherwise take up to twice that while the list doubles).
    fn count_leaves(&self, id: NodeId) -> usize {
        match &self.node(id).kind {
            NodeKind::Blend { children, .. } => children.iter().map(|&c| self.count_leaves(c)).sum(),
            _ => 1,
        }
    }

    /// The non-blend descendants reached through nested blends, in scene order.
    fn collect_leaves(&self, id: NodeId, inherited: Option<Vec3>, out: &mut Vec<IndexedLeaf>) {
        let node = self.node(id);
        let color = node.color.or(inherited);
        match &node.kind {
            NodeKind::Blend { children, .. } => {
                for &c in children {
                    self.collect_leaves(c, color, out);
                }
            }
            NodeKind::Primitive(p) => out.push(IndexedLeaf { leaf: Leaf::Primitive(*p), bounds: node.bounds, color }),
            _ => out.push(IndexedLeaf { leaf: Leaf::Node(id), bounds: node.bounds, color }),
        }
    }
}

/// A bound on `leaf` that holds in every evaluation mode, the `widest` of its
/// exact and cached `bound`s: only a node leaf can hold a cache and answer
/// differently; a primitive answers alike in all.
fn in_every_mode<T>(leaf: &IndexedLeaf, bound: impl Fn(EvalMode) -> T, widest: impl Fn(T, T) -> T) -> T {
    match leaf.leaf {
        Leaf::Primitive(_) => bound(EvalMode::Naive),
        Leaf::Node(_) => widest(bound(EvalMode::Naive), bound(EvalMode::Cached)),
    }
}
