//! What a scene's caches hold and did, totalled and per cache, for the
//! reports of cached renders and polygonizations.

use serde::Serialize;

use crate::cache::{CacheStats, SLOT_BYTES};
use crate::field::{Model, NodeKind};

/// Cache statistics of a cached render: totals, then each cache.
#[derive(Clone, Debug, Serialize)]
pub struct CacheReport {
    /// Samples evaluated from the subtrees (including re-evaluations after eviction).
    pub samples_evaluated: u64,
    /// Blocks held.
    pub blocks: u64,
    /// Bytes of sample storage held.
    pub bytes: u64,
    /// Lattice points over the caches' subtrees (what dense grids would hold).
    pub grid_points: u64,
    /// Samples held over lattice points.
    pub touched_fraction: f64,
    /// Reconstructions asked of the caches.
    pub lookups: u64,
    /// Blocks evicted to stay within the budget.
    pub evictions: u64,
    /// The budget in bytes, if any.
    pub budget_bytes: Option<u64>,
    /// Each cache, by the name above it.
    pub per_cache: Vec<NamedCacheStats>,
}

/// One cache's statistics.
#[derive(Clone, Debug, Serialize)]
pub struct NamedCacheStats {
    /// The nearest name above the cache.
    pub name: String,
    /// Its resolution.
    pub res: u32,
    /// What it holds and did.
    #[serde(flatten)]
    pub stats: CacheStats,
}

impl CacheReport {
    /// The statistics of every cache of `model`.
    #[must_use]
    pub fn of(model: &Model) -> Self {
        let per_cache: Vec<NamedCacheStats> = model
            .cache_stats()
            .into_iter()
            .map(|(id, name, stats)| {
                let res = match model.node(id).kind {
                    NodeKind::Cache { spec, .. } => spec.res,
                    _ => 0,
                };
                NamedCacheStats { name, res, stats }
            })
            .collect();
        let sum = |f: fn(&CacheStats) -> u64| per_cache.iter().map(|c| f(&c.stats)).sum::<u64>();
        let (held, grid_points) = (sum(|s| s.samples_held), sum(|s| s.grid_points));
        Self {
            samples_evaluated: sum(|s| s.samples_evaluated),
            blocks: sum(|s| s.blocks),
            bytes: sum(|s| s.bytes),
            grid_points,
            touched_fraction: held as f64 / grid_points.max(1) as f64,
            lookups: sum(|s| s.lookups),
            evictions: model.pool().evictions(),
            budget_bytes: model.pool().budget_slots().map(|n| (n * SLOT_BYTES) as u64),
            per_cache,
        }
    }
}
