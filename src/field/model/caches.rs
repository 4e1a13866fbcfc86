//! The lattices of a model's `Cache` nodes and the pool behind them: made or
//! refitted as bounds change, emptied under a new budget, and cleared where
//! an edit changed the field beneath them.

use super::Model;
use crate::cache::{CacheGrid, CacheSpec, CacheStats, Refit, SLOT_BYTES, SamplePool};
use crate::field::node::NodeKind;
use crate::field::node_id::NodeId;
use crate::geom::Aabb;

impl Model {
    /// Makes or refits cache `grid` for its subtree's new bounds; returns the
    /// cache's bounds and what the refit did (a new cache keeps nothing).
    pub(super) fn fit_cache(&mut self, grid: usize, spec: CacheSpec, child_bounds: Aabb) -> (Aabb, Refit) {
        match &mut self.grids[grid] {
            Some(g) => {
                let refit = g.fit(child_bounds, &self.pool);
                (g.bounds(), refit)
            }
            slot @ None => (slot.insert(CacheGrid::new(spec, child_bounds, &self.pool)).bounds(), Refit::Kept),
        }
    }

    /// The lattice of cache `grid`.
    #[inline]
    #[must_use]
    pub fn cache(&self, grid: usize) -> &CacheGrid {
        self.grids[grid].as_ref().expect("every cache gets its lattice when the model is sealed")
    }

    /// The memory pool behind the caches.
    #[inline]
    #[must_use]
    pub fn pool(&self) -> &SamplePool {
        &self.pool
    }

    /// Caps the caches' sample storage at `bytes` (unbounded for `None`),
    /// evicting least-recently-used blocks beyond it. Empties every cache.
    pub fn set_cache_budget(&mut self, bytes: Option<usize>) {
        self.empty_caches(SamplePool::new(bytes.map(|b| b / SLOT_BYTES)));
    }

    /// Replaces the pool by `pool` and lays fresh, empty lattices on every cache.
    fn empty_caches(&mut self, pool: SamplePool) {
        self.pool = pool;
        self.grids.iter_mut().for_each(|g| *g = None);
        self.update_bounds(self.root);
    }

    /// Every cache: its node, the nearest name above it, and its statistics.
    #[must_use]
    pub fn cache_stats(&self) -> Vec<(NodeId, String, CacheStats)> {
        let mut out = Vec::new();
        for (id, node) in self.nodes.iter().enumerate() {
            if let NodeKind::Cache { grid, .. } = node.kind {
                let name = self.name_above(id as NodeId).unwrap_or_else(|| format!("cache{}", grid));
                out.push((id as NodeId, name, self.cache(grid).stats(&self.pool)));
            }
        }
        out
    }

    /// Clears the samples inside `region` (in `id`'s own frame) in `id` if it
    /// is a cache, then in every cache above.
    pub(super) fn invalidate_from(&mut self, id: NodeId, mut region: Aabb) -> u64 {
        let own = match self.nodes[id as usize].kind {
            NodeKind::Cache { grid, .. } => self.invalidate_cache(grid, &mut region),
            _ => 0,
        };
        own + self.invalidate_above(id, region)
    }

    /// Clears the samples of cache `grid` inside `region` and widens `region`
    /// to where its reconstruction changed: by its filters' reach, since a
    /// cache above samples that reconstruction, not the field beneath it.
    fn invalidate_cache(&mut self, grid: usize, region: &mut Aabb) -> u64 {
        self.grids[grid].as_mut().map_or(0, |g| {
            let cleared = g.invalidate(region);
            *region = g.sample_reach(region);
            cleared
        })
    }

    /// Clears, in every cache above node `id`, the samples inside `changed` (a
    /// box in the frame `id`'s parent sees), carrying the box up through the
    /// transforms on the way and widening it by each cache's filter reach
    /// (an outer cache samples the inner one's reconstruction). Returns how
    /// many held samples were cleared.
    pub fn invalidate_above(&mut self, id: NodeId, changed: Aabb) -> u64 {
        let (mut at, mut region, mut cleared) = (id, changed, 0);
        while let Some(parent) = self.node(at).parent {
            match &self.node(parent).kind {
                NodeKind::Transform { placement, .. } => region = region.transformed(&placement.to_world),
                NodeKind::Warp { warp, .. } => region = warp.forward_box(&region),
                NodeKind::Cache { grid, .. } => {
                    let grid = *grid;
                    cleared += self.invalidate_cache(grid, &mut region);
                }
                _ => {}
            }
            at = parent;
        }
        cleared
    }
}
