//! Counts of what a cache holds and has done, and the per-thread counters
//! its lookups and fills are counted on.

use std::sync::atomic::{AtomicU64, Ordering};

use glam::Vec3A;

use super::CacheGrid;
use crate::cache::Storage;
use crate::cache::pool::{SLOT_WORDS, SamplePool, UNSET, block_key};
use crate::geom::cell_coords;

/// What a cache holds and has done.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct CacheStats {
    /// Lattice spacing `c`.
    pub cell: f32,
    /// Lattice points over the subtree's bounds (a dense grid's size).
    pub grid_points: u64,
    /// Samples evaluated from the subtree (again after an eviction).
    pub samples_evaluated: u64,
    /// Samples held now.
    pub samples_held: u64,
    /// `samples_held / grid_points`.
    pub touched_fraction: f64,
    /// Blocks held now.
    pub blocks: u64,
    /// Bytes of sample storage held now.
    pub bytes: u64,
    /// Bytes holding the kept per-cell slope bounds.
    pub slope_bytes: u64,
    /// Reconstructions asked of the cache (values and gradients).
    pub lookups: u64,
}

impl CacheGrid {
    /// Counts of what the cache holds and has done.
    #[must_use]
    pub fn stats(&self, pool: &SamplePool) -> CacheStats {
        let blocks = pool.held(self.serial) as u64;
        let grid_points = if self.child_bounds.is_empty() {
            0
        } else {
            ((self.child_bounds.size() * self.inv_cell).floor() + Vec3A::ONE).as_u64vec3().element_product()
        };
        let samples_held = self.samples_held();
        CacheStats {
            cell: self.cell,
            grid_points,
            samples_evaluated: self.evaluated.total(),
            samples_held,
            touched_fraction: samples_held as f64 / grid_points.max(1) as f64,
            blocks,
            bytes: blocks * (SLOT_WORDS * 4) as u64,
            slope_bytes: self.cell_slopes.iter().filter(|b| b.get().is_some()).count() as u64
                * (self.block_volume() * 2) as u64,
            lookups: self.lookups.total(),
        }
    }

    fn samples_held(&self) -> u64 {
        let mut n = 0;
        for (i, entry) in self.table.iter().enumerate() {
            let block = self.table_lo + cell_coords(i, self.table_dims).as_ivec3();
            // SAFETY: as in `sample`.
            let Some(slot) = (unsafe { entry.load(Ordering::Acquire).as_ref() }) else { continue };
            if slot.owner() != block_key(self.serial, block) {
                continue;
            }
            for w in 0..SLOT_WORDS {
                let word = slot.word(w);
                n += match self.spec.storage {
                    Storage::F32 => u64::from(word != UNSET),
                    Storage::F16 => (0..2).filter(|&h| self.spec.storage.decode(word, h).is_some()).count() as u64,
                };
            }
        }
        n
    }
}

/// A counter split over cache lines by worker thread, so counting every lookup
/// from every thread costs no contention.
#[derive(Default)]
pub(super) struct ShardedCounter {
    shards: [PaddedCounter; 16],
}

#[derive(Default)]
#[repr(align(128))]
struct PaddedCounter(AtomicU64);

impl ShardedCounter {
    #[inline]
    pub(super) fn add(&self, n: u64) {
        self.shard().fetch_add(n, Ordering::Relaxed);
    }

    /// Counts one, by a plain load and store: a tenth of a warm lookup's
    /// time less than [`Self::add`]. Each thread of a pool has a shard of its
    /// own; a thread outside the pool shares the first, and an increment it
    /// races there may be lost, which only a statistic would show.
    #[inline]
    pub(super) fn add_one_unsynchronized(&self) {
        let shard = self.shard();
        shard.store(shard.load(Ordering::Relaxed) + 1, Ordering::Relaxed);
    }

    #[inline]
    fn shard(&self) -> &AtomicU64 {
        &self.shards[rayon::current_thread_index().unwrap_or(0) % self.shards.len()].0
    }

    fn total(&self) -> u64 {
        self.shards.iter().map(|s| s.0.load(Ordering::Relaxed)).sum()
    }
}
