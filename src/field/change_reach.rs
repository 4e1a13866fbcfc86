//! Where a change reaches: the supports of a node's field (the regions
//! outside which it is zero), and the regions of the world a [`Change`] may
//! have changed the field in — carried up through the transforms and warps
//! above it and, for the cached field, widened by each cache's filters — so
//! caches, meshes and screens update there and nowhere else.

use super::model::{Change, Model};
use super::node::NodeKind;
use super::node_id::NodeId;
use crate::geom::{Aabb, Support};

impl Model {
    /// Appends regions holding the support of node `id`'s field, in the
    /// frame `id` is evaluated in: each primitive's (a point's ball, any
    /// other's box), through the transforms and, for the cached field,
    /// widened at each cache by its filters' reach. Every operator's field is
    /// zero outside its children's supports.
    pub fn supports(&self, id: NodeId, out: &mut Vec<Support>) {
        let first = out.len();
        match &self.node(id).kind {
            NodeKind::Primitive(p) => out.push(match p.skeleton {
                super::Skeleton::Point { center } => Support::ball(center, p.radius),
                _ => Support::Box(self.node(id).bounds),
            }),
            NodeKind::Points { set, .. } => out.extend((0..set.len()).map(|i| {
                let (center, radius) = set.ball(i);
                Support::ball(center, radius)
            })),
            NodeKind::Transform { placement, child } => {
                self.supports(*child, out);
                out[first..].iter_mut().for_each(|s| *s = s.transformed(&placement.to_world));
            }
            NodeKind::Cache { child, grid, .. } => {
                self.supports(*child, out);
                let reach = self.cache(*grid).sample_reach_distance();
                out[first..].iter_mut().for_each(|s| *s = s.padded(reach));
            }
            NodeKind::Difference(a, _) => self.supports(*a, out),
            // A warp bends its child's supports out of shape: its own bounds hold them.
            NodeKind::Warp { .. } => out.push(Support::Box(self.node(id).bounds)),
            kind => kind.children().into_iter().for_each(|c| self.supports(c, out)),
        }
    }

    /// Boxes in the world (the root's frame) holding everything `change` may
    /// have changed in the field evaluated in `cached` or exact mode: the
    /// bounds of [`Self::change_support_regions`].
    #[must_use]
    pub fn change_supports(&self, change: &Change, cached: bool) -> Vec<Aabb> {
        self.change_support_regions(change, cached).iter().map(Support::bounds).collect()
    }

    /// Regions in the world (the root's frame) holding everything `change`
    /// may have changed in the field evaluated in `cached` or exact mode: its
    /// supports carried up like [`Self::change_region`], or that region alone
    /// when the change does not know its supports.
    #[must_use]
    pub fn change_support_regions(&self, change: &Change, cached: bool) -> Vec<Support> {
        if change.supports.is_empty() {
            return vec![Support::Box(self.change_region(change, cached))];
        }
        let mut regions = change.supports.clone();
        self.carry_up(change.scope, &mut regions, cached);
        regions.extend(self.replaced_regions(change, cached).map(Support::Box));
        regions
    }

    /// The world box (the root's frame) holding everything `change` may have
    /// changed in the field evaluated in `cached` or exact mode: its old and new
    /// bounds carried up through the transforms above, and in cached mode
    /// widened, at each cache on the way, by the reach of its filters (and
    /// holding the whole of every cache the change rebuilt).
    #[must_use]
    pub fn change_region(&self, change: &Change, cached: bool) -> Aabb {
        let mut region = [Support::Box(change.old.union(&change.new))];
        self.carry_up(change.node, &mut region, cached);
        self.replaced_regions(change, cached).fold(region[0].bounds(), |u, b| u.union(&b))
    }

    /// The world boxes of the caches `change` rebuilt, whose cached field
    /// changed all over (none for exact evaluation, which passes caches by),
    /// and of the index cells whose lists it changed, where sums may differ
    /// in their last bits.
    fn replaced_regions<'a>(&'a self, change: &'a Change, cached: bool) -> impl Iterator<Item = Aabb> + 'a {
        let rebuilt = if cached { &change.rebuilt[..] } else { &[] };
        rebuilt.iter().chain(&change.reindexed).map(move |&(node, b)| {
            let mut region = [Support::Box(b)];
            self.carry_up(node, &mut region, cached);
            region[0].bounds()
        })
    }

    /// Carries `regions`, in the frame node `id`'s parent sees, up to the
    /// root's: through the transforms above, and in cached mode grown at each
    /// cache on the way by the reach of its filters.
    fn carry_up(&self, id: NodeId, regions: &mut [Support], cached: bool) {
        let mut at = id;
        while let Some(parent) = self.node(at).parent {
            match &self.node(parent).kind {
                NodeKind::Transform { placement, .. } => {
                    regions.iter_mut().for_each(|s| *s = s.transformed(&placement.to_world))
                }
                NodeKind::Warp { warp, .. } => {
                    regions.iter_mut().for_each(|s| *s = Support::Box(warp.forward_box(&s.bounds())))
                }
                NodeKind::Cache { grid, .. } if cached => {
                    let reach = self.cache(*grid).sample_reach_distance();
                    regions.iter_mut().for_each(|s| *s = s.padded(reach));
                }
                _ => {}
            }
            at = parent;
        }
    }
}
