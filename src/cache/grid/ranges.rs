//! Ranges of the reconstructed value over a box: the range of the samples
//! the value filter reads there when all are held, else the subtree's.

use glam::IVec3;

use super::CacheGrid;
use crate::cache::pool::{SamplePool, UNSET};
use crate::geom::{Aabb, Interval};

/// Most samples a value range over a box reads before asking the subtree instead.
const MAX_HELD_RANGE_SAMPLES: i64 = 512;

impl CacheGrid {
    /// The lattice points `lo..=hi` the value filter reads for points of `b`,
    /// exactly: its first sample moves monotonically with the query point.
    fn value_reach(&self, b: &Aabb) -> (IVec3, IVec3) {
        let filter = self.spec.value;
        let (lo, _) = filter.footprint(b.min * self.inv_cell);
        let (first_hi, taps) = filter.footprint(b.max * self.inv_cell);
        (lo, first_hi + IVec3::splat(taps as i32 - 1))
    }

    /// The box of [`Self::value_reach`]'s lattice points (samples sit at
    /// exactly these positions: see `sample`).
    pub(super) fn value_reach_box(&self, b: &Aabb) -> Aabb {
        let (lo, hi) = self.value_reach(b);
        Aabb::new(lo.as_vec3a() * self.cell, hi.as_vec3a() * self.cell)
    }

    /// Bounds of the reconstructed value over `b`: the range of the samples
    /// the value filter reads there when all are held (the reconstruction, a
    /// weighted mean of them, stays within it), else `child_range`, the
    /// subtree's range over the box of those samples, widened by the samples'
    /// rounding in storage.
    pub fn interval(&self, b: &Aabb, pool: &SamplePool, child_range: &impl Fn(&Aabb) -> Interval) -> Interval {
        let (lo, hi) = self.value_reach(b);
        if let Some(held) = self.held_range(lo, hi, pool) {
            return held;
        }
        let r = child_range(&self.value_reach_box(b));
        let e = self.spec.storage.rounding_error(r.lo.abs().max(r.hi.abs()));
        Interval::new(r.lo - e, r.hi + e)
    }

    /// The range of the samples at the lattice points `lo..=hi`, if every one
    /// is held (points outside the subtree's bounds are zero); `None` as soon
    /// as one is not, or when there are more than [`MAX_HELD_RANGE_SAMPLES`].
    /// Evaluates nothing; reading a block counts as a use of it, as a
    /// lookup's does.
    fn held_range(&self, lo: IVec3, hi: IVec3, pool: &SamplePool) -> Option<Interval> {
        let count = (hi - lo + IVec3::ONE).max(IVec3::ZERO).as_i64vec3().element_product();
        if count == 0 || count > MAX_HELD_RANGE_SAMPLES {
            return None;
        }
        let (mut min, mut max) = (f32::INFINITY, f32::NEG_INFINITY);
        let (b0, b1) = (self.block_of(lo), self.block_of(hi));
        let block_cells = self.block_cells();
        for bz in b0.z..=b1.z {
            for by in b0.y..=b1.y {
                for bx in b0.x..=b1.x {
                    let block = IVec3::new(bx, by, bz);
                    let part = (lo.max(block * block_cells), hi.min((block + IVec3::ONE) * block_cells - IVec3::ONE));
                    let (part_min, part_max) = self.held_part_range(block, part, pool)?;
                    (min, max) = (min.min(part_min), max.max(part_max));
                }
            }
        }
        Some(Interval::new(min, max))
    }

    /// [`Self::held_range`] over the lattice points `lo..=hi` of one block.
    fn held_part_range(&self, block: IVec3, (lo, hi): (IVec3, IVec3), pool: &SamplePool) -> Option<(f32, f32)> {
        let (mut min, mut max) = (f32::INFINITY, f32::NEG_INFINITY);
        let (mut at, mut halves, mut count) = ([0u16; 64], [0u8; 64], 0);
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    let i = IVec3::new(x, y, z);
                    if !self.child_bounds.contains(i.as_vec3a() * self.cell) || self.part_known_zero(block, i) {
                        // Never stored: the subtree is zero there.
                        (min, max) = (min.min(0.0), max.max(0.0));
                        continue;
                    }
                    let (w, h) = self.word_of(i);
                    (at[count], halves[count]) = (w as u16, h as u8);
                    count += 1;
                    if count == at.len() {
                        let (lo_v, hi_v) = self.held_words_range(block, &at[..count], &halves[..count], pool)?;
                        (min, max) = (min.min(lo_v), max.max(hi_v));
                        count = 0;
                    }
                }
            }
        }
        if count > 0 {
            let (lo_v, hi_v) = self.held_words_range(block, &at[..count], &halves[..count], pool)?;
            (min, max) = (min.min(lo_v), max.max(hi_v));
        }
        Some((min, max))
    }

    /// The range of the samples at words `at` (halves `halves`) of `block`,
    /// read in one consistent section; `None` if one is not held.
    fn held_words_range(&self, block: IVec3, at: &[u16], halves: &[u8], pool: &SamplePool) -> Option<(f32, f32)> {
        let mut words = [UNSET; 64];
        if !self.read_block(block, at, &mut words[..at.len()], pool) {
            return None;
        }
        let (mut min, mut max) = (f32::INFINITY, f32::NEG_INFINITY);
        for (&word, &half) in words.iter().zip(halves) {
            let v = self.spec.storage.decode(word, u32::from(half))?;
            (min, max) = (min.min(v), max.max(v));
        }
        Some((min, max))
    }
}
