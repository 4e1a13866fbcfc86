//! What an edit clears: the samples inside the changed box, the slope bounds
//! that read them, and where the reconstruction may change as a result.

use std::sync::atomic::Ordering;

use glam::IVec3;

use super::CacheGrid;
use super::slopes::UNSET_SLOPE;
use crate::cache::filter::MAX_SUPPORT_CELLS;
use crate::cache::memo::GatherId;
use crate::cache::pool::block_key;
use crate::geom::Aabb;

impl CacheGrid {
    /// A box holding every sample either filter may read for points of `b`:
    /// where an edit inside `b` can change the reconstruction or its gradient.
    #[must_use]
    pub fn sample_reach(&self, b: &Aabb) -> Aabb {
        b.padded(self.sample_reach_distance())
    }

    /// How far, along each axis, [`Self::sample_reach`] grows a region.
    #[must_use]
    pub fn sample_reach_distance(&self) -> f32 {
        MAX_SUPPORT_CELLS * self.cell
    }

    /// Clears the samples at lattice points inside `b` (cache frame) and the
    /// slope summaries that read them; returns how many held samples were cleared.
    pub fn invalidate(&mut self, b: &Aabb) -> u64 {
        self.gather_id = GatherId::fresh();
        let lo = (b.min * self.inv_cell).ceil().as_ivec3();
        let hi = (b.max * self.inv_cell).floor().as_ivec3();
        let mut cleared = 0;
        if lo.cmple(hi).all() && !b.is_empty() {
            for z in lo.z..=hi.z {
                for y in lo.y..=hi.y {
                    for x in lo.x..=hi.x {
                        cleared += u64::from(self.clear_sample(IVec3::new(x, y, z)));
                    }
                }
            }
            self.clear_cell_slopes(lo, hi);
        }
        self.forget_zero_parts(b);
        let reach = self.sample_reach(b);
        let slopes = &self.slopes;
        self.summary.for_each_cell(&reach, |c| slopes[c].store(UNSET_SLOPE, Ordering::Relaxed));
        cleared
    }

    fn clear_sample(&self, i: IVec3) -> bool {
        let block = self.block_of(i);
        let Some(t) = self.table_index(block) else { return false };
        // SAFETY: as in `sample`; invalidation has exclusive access to the cache.
        let Some(slot) = (unsafe { self.table[t].load(Ordering::Relaxed).as_ref() }) else { return false };
        if slot.owner() != block_key(self.serial, block) {
            return false;
        }
        let (w, half) = self.word_of(i);
        let word = slot.word(w);
        let held = self.spec.storage.decode(word, half).is_some();
        if held {
            slot.set_word(w, self.spec.storage.clear(word, half));
        }
        held
    }
}
