//! One cache's lattice: exact samples of its subtree at the points `c·(i, j, k)`
//! of its own frame, in blocks allocated on first touch and filled one sample
//! at a time when a reconstruction first needs it (paper sections 4.2–4.5).
//!
//! A block's parts (its halves along each axis) where the subtree's field is
//! zero throughout, by an interval over the part, hold no samples: lookups
//! there answer zero without reading a block, and a block only zero parts of
//! which are read is never stored.
//!
//! The lattice is anchored at the frame's origin, not at the subtree's bounds,
//! so a sample keeps its place when the bounds change: an edit clears only the
//! samples inside the changed box, and the grid only grows its block table.
//!
//! - `blocks`: the block table, the place of each lattice point's sample in
//!   it, and how the table follows the subtree's bounds;
//! - `gather`: reading, and filling, the samples a footprint needs;
//! - `reconstruct`: values and gradients from the samples gathered;
//! - `zero_parts`: the block parts known to hold only zeros;
//! - `ranges`: value ranges over boxes, from held samples where it can;
//! - `slopes`: slope bounds and floors from the samples, and per-region summaries;
//! - `invalidate`: what an edit clears;
//! - `stats`: counts of what the cache holds and has done.

mod blocks;
mod gather;
mod invalidate;
mod ranges;
mod reconstruct;
mod slopes;
mod stats;
#[cfg(test)]
mod tests;
mod zero_parts;

use std::sync::OnceLock;
use std::sync::atomic::{AtomicPtr, AtomicU16, AtomicU32};

use glam::{IVec3, UVec3, Vec3A};

use super::CacheSpec;
use super::memo::GatherId;
use super::pool::{SamplePool, Slot};
use crate::geom::{Aabb, UniformGrid};

pub use blocks::Refit;
pub use stats::CacheStats;
use stats::ShardedCounter;

/// Lattice points per block edge along x and y (z doubles for two-byte storage).
const BLOCK_SHIFT: i32 = 3;
/// Cells of padding around the subtree's bounds: beyond the filters' support,
/// so every reconstruction inside the cache's bounds finds its samples here.
pub const PAD_CELLS: f32 = 2.0;

/// The subtree a cache samples: its value at a point (in the cache's frame),
/// and whether its field is zero throughout a box.
pub trait Sampled {
    /// The subtree's value at `p`.
    fn value(&self, p: Vec3A) -> f32;
    /// True only where the subtree's field is zero at every point of `b`.
    fn is_zero_over(&self, b: &Aabb) -> bool;
}

/// A bare function knows no region where it is zero.
impl<F: Fn(Vec3A) -> f32> Sampled for F {
    fn value(&self, p: Vec3A) -> f32 {
        self(p)
    }

    fn is_zero_over(&self, _: &Aabb) -> bool {
        false
    }
}

/// The lattice, the block table and the per-region slope summaries of one cache.
pub struct CacheGrid {
    spec: CacheSpec,
    serial: u16,
    /// This state's name for the footprints kept per thread: renewed by
    /// every change (each takes `&mut self`).
    gather_id: GatherId,
    cell: f32,
    inv_cell: f32,
    /// Bounds of the cached subtree: outside them every sample is zero.
    child_bounds: Aabb,
    /// Block coordinates of table entry 0, and the table's extent in blocks.
    table_lo: IVec3,
    table_dims: UVec3,
    table: Box<[AtomicPtr<Slot>]>,
    /// The lattice's cells over the table's region, for walks along segments.
    lattice: UniformGrid,
    /// Lattice coordinates of the first point of `lattice`.
    lattice_lo: IVec3,
    /// Cubes of 8 cells over the table's region, each with a lazily computed slope bound.
    summary: UniformGrid,
    slopes: Box<[AtomicU32]>,
    /// Per block of the table, the sampled slope bound of each of its cells
    /// once computed (the tracer's hottest query). Samples are pure functions
    /// of their lattice points, so these stay valid when blocks are evicted;
    /// only invalidation clears them.
    cell_slopes: Box<[OnceLock<Box<[AtomicU16]>>]>,
    /// Per block of the table, which of its parts the subtree's field is
    /// known to be zero throughout (see [`Self::part_is_zero`]).
    zero_parts: Box<[AtomicU16]>,
    lookups: ShardedCounter,
    /// Samples evaluated, counted per thread: one shared counter bounced
    /// between the cores on every fill.
    evaluated: ShardedCounter,
}

impl std::fmt::Debug for CacheGrid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CacheGrid").field("spec", &self.spec).field("cell", &self.cell).finish_non_exhaustive()
    }
}

impl CacheGrid {
    /// An empty cache with `spec`, fitted to `child_bounds`, holding slots of `pool`.
    #[must_use]
    pub fn new(spec: CacheSpec, child_bounds: Aabb, pool: &SamplePool) -> Self {
        let mut grid = Self {
            spec,
            serial: pool.new_serial(),
            gather_id: GatherId::fresh(),
            cell: 1.0,
            inv_cell: 1.0,
            child_bounds: Aabb::EMPTY,
            table_lo: IVec3::ZERO,
            table_dims: UVec3::ZERO,
            table: Box::new([]),
            lattice: UniformGrid::new(Vec3A::ZERO, 1.0, UVec3::ONE),
            lattice_lo: IVec3::ZERO,
            summary: UniformGrid::new(Vec3A::ZERO, 1.0, UVec3::ONE),
            slopes: Box::new([]),
            cell_slopes: Box::new([]),
            zero_parts: Box::new([]),
            lookups: ShardedCounter::default(),
            evaluated: ShardedCounter::default(),
        };
        grid.rebuild(child_bounds, pool);
        grid
    }

    /// A cache on this one's lattice, over the same block table, holding no
    /// sample: its reconstruction is this one's exactly, filled afresh. (A
    /// new cache over the same bounds may lay another lattice: the resize
    /// rule keeps a cell size while the bounds drift.)
    #[must_use]
    pub fn cold_copy(&self, pool: &SamplePool) -> Self {
        let mut grid = Self::new(self.spec, Aabb::EMPTY, pool);
        (grid.cell, grid.inv_cell) = (self.cell, self.inv_cell);
        grid.lattice = UniformGrid::new(Vec3A::ZERO, self.cell, UVec3::ONE);
        grid.summary = UniformGrid::new(Vec3A::ZERO, 8.0 * self.cell, UVec3::ONE);
        if self.table_dims.cmpgt(UVec3::ZERO).all() {
            grid.resize_table(self.table_lo, self.table_lo + self.table_dims.as_ivec3() - IVec3::ONE);
        }
        grid.child_bounds = self.child_bounds;
        grid
    }

    /// The options the cache was made with.
    #[must_use]
    pub fn spec(&self) -> &CacheSpec {
        &self.spec
    }

    /// Lattice spacing `c`.
    #[must_use]
    pub fn cell(&self) -> f32 {
        self.cell
    }

    /// The bounds of the reconstructed field: the subtree's, padded by the filters' reach.
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        if self.child_bounds.is_empty() { self.child_bounds } else { self.child_bounds.padded(PAD_CELLS * self.cell) }
    }
}
