//! Bounds on the reconstruction's slope: per lattice cell from the samples
//! themselves (kept in half precision per block), floors on its derivative
//! along a segment, and per 8-cell cube from the subtree's own bounds.

use std::sync::atomic::{AtomicU16, Ordering};

use glam::{IVec3, Vec3A};

use super::{CacheGrid, Sampled};
use crate::cache::Storage;
use crate::cache::filter::Filter;
use crate::cache::pool::SamplePool;
use crate::geom::{Aabb, Interval, Region};

/// Segments up to this many cells long take their slope bound from the samples.
const MAX_SAMPLED_SEGMENT_CELLS: f32 = 8.0;
/// Summary cells a slope query may visit before falling back to one bound over its box.
const MAX_SUMMARY_CELLS: usize = 64;
/// A bound on each gradient component is a bound on the norm divided by √3.
const SQRT_3: f32 = 1.732_050_8;
/// The word of a slope summary not yet computed.
pub(super) const UNSET_SLOPE: u32 = u32::MAX;
/// The half-precision word of a cell slope not yet computed (a NaN).
const UNSET_CELL_SLOPE: u16 = u16::MAX;

impl CacheGrid {
    /// A bound on the reconstruction's slope over the lattice cell with minimum
    /// corner `i`, from the samples themselves: each axis derivative is a convex
    /// combination of the differences along that axis between the samples the
    /// filter reads anywhere in the cell (2 per axis for tri-linear, 4 for the
    /// quadratic), so the largest such difference bounds it. Tight where the
    /// tracer needs it most: next to the surface.
    fn cell_slope(&self, i: IVec3, pool: &SamplePool, eval: &impl Sampled) -> f32 {
        let (lo, hi) = self.cell_differences(i, pool, eval);
        lo.abs().max(hi.abs()).length() * self.inv_cell
    }

    /// The least and the greatest difference along each axis between
    /// neighbouring samples the value filter reads in the lattice cell with
    /// minimum corner `i`.
    pub(super) fn cell_differences(&self, i: IVec3, pool: &SamplePool, eval: &impl Sampled) -> (Vec3A, Vec3A) {
        let reach: usize = match self.spec.value {
            Filter::Trilinear => 0,
            Filter::Triquadratic => 1,
        };
        let n = 2 + 2 * reach;
        let mut s = [0.0f32; 64];
        self.gather_cube(i - IVec3::splat(reach as i32), n, &mut s, pool, eval);
        let (mut lo, mut hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
        for (at, v) in s.iter().enumerate().take(n * n * n) {
            let (x, y, z) = (at % n, (at / n) % n, at / (n * n));
            let mut difference = |axis: usize, next: usize| {
                let d = s[next] - v;
                lo[axis] = lo[axis].min(d);
                hi[axis] = hi[axis].max(d);
            };
            if x + 1 < n {
                difference(0, at + 1);
            }
            if y + 1 < n {
                difference(1, at + n);
            }
            if z + 1 < n {
                difference(2, at + n * n);
            }
        }
        (lo, hi)
    }

    /// A lower bound on `∇f·u` for the reconstructed value along the segment
    /// `a..b` (cache frame). In each lattice cell the segment crosses, each
    /// axis derivative of the value filter is a convex combination of the
    /// differences along that axis between the samples it reads there (see
    /// `cell_slope`), so it lies between the least and the greatest.
    /// Off the lattice the reconstruction is zero, and so is its derivative.
    pub fn slope_floor(&self, (a, b): (Vec3A, Vec3A), u: Vec3A, pool: &SamplePool, eval: &impl Sampled) -> f32 {
        let on_lattice = self.lattice.bounds();
        let mut floor = if on_lattice.contains(a) && on_lattice.contains(b) { f32::INFINITY } else { 0.0 };
        self.lattice.walk_segment_coords(a, b, |c| {
            let i = self.lattice_lo + c.as_ivec3();
            floor = floor.min(self.cell_slope_floor(i, u, pool, eval));
        });
        if floor.is_finite() { floor } else { 0.0 }
    }

    /// [`Self::slope_floor`] over the lattice cell with minimum corner `i`.
    fn cell_slope_floor(&self, i: IVec3, u: Vec3A, pool: &SamplePool, eval: &impl Sampled) -> f32 {
        let (lo, hi) = self.cell_differences(i, pool, eval);
        (u * lo).min(u * hi).element_sum() * self.inv_cell
    }

    /// A bound on the reconstructed value's slope over `region`. Each axis
    /// derivative of the value filter is a convex combination of differences
    /// along that axis between the samples it reads, each at most the
    /// subtree's slope over their box (`child_slope`) plus twice the storage
    /// rounding over one cell; √3 times that bounds the gradient's norm.
    /// Bounds per 8-cell cube are computed once and kept; long regions take
    /// one bound over their box.
    pub fn lipschitz(
        &self,
        region: &Region,
        child_slope: &impl Fn(&Aabb) -> f32,
        child_range: &impl Fn(&Aabb) -> Interval,
        sample: (&SamplePool, &impl Sampled),
    ) -> f32 {
        if let Region::Segment(a, b) = *region
            && (b - a).length() * self.inv_cell <= MAX_SAMPLED_SEGMENT_CELLS
        {
            return self.segment_slope_from_samples(a, b, sample.0, sample.1);
        }
        let reach = region.bounds();
        if self.summary.cells_overlapped(&reach) > MAX_SUMMARY_CELLS {
            return self.slope_over(&reach, child_slope, child_range);
        }
        let mut l = 0.0f32;
        let mut visit = |c: usize| l = l.max(self.summary_slope(c, child_slope, child_range));
        match region {
            Region::Segment(a, b) => self.summary.walk_segment(*a, *b, &mut visit),
            Region::Box(b) => self.summary.for_each_cell(b, &mut visit),
        }
        l
    }

    /// The largest sampled cell bound along `a..b`. Kept bounds are half
    /// bits, which for the non-negative slopes order as their values do: the
    /// walk keeps the largest bits (passing over NaNs, as `f32::max` does)
    /// and converts them once, and looks each block's bounds up once.
    fn segment_slope_from_samples(&self, a: Vec3A, b: Vec3A, pool: &SamplePool, eval: &impl Sampled) -> f32 {
        const INFINITY_BITS: u16 = 0x7c00;
        let mut largest = 0u16;
        let mut last_block: Option<(IVec3, Option<&[AtomicU16]>)> = None;
        self.lattice.walk_segment_coords(a, b, |c| {
            let i = self.lattice_lo + c.as_ivec3();
            let block = self.block_of(i);
            let words = match last_block {
                Some((b, words)) if b == block => words,
                _ => {
                    let words = self.cell_slopes_of_block(block, pool);
                    last_block = Some((block, words));
                    words
                }
            };
            let bits = self.kept_slope_bits(words, i, pool, eval);
            if bits <= INFINITY_BITS {
                largest = largest.max(bits);
            }
        });
        half::f16::from_bits(largest).to_f32()
    }

    /// The kept slope bounds of `block`'s cells, allocated on first use;
    /// `None` off the table, and under a budget, where nothing is kept, so
    /// the budget bounds all the memory the cache holds.
    #[inline]
    fn cell_slopes_of_block(&self, block: IVec3, pool: &SamplePool) -> Option<&[AtomicU16]> {
        let t = self.table_index(block).filter(|_| pool.budget_slots().is_none())?;
        Some(
            self.cell_slopes[t]
                .get_or_init(|| (0..self.block_volume()).map(|_| AtomicU16::new(UNSET_CELL_SLOPE)).collect()),
        )
    }

    /// [`Self::cell_slope`] of cell `i` in half precision, rounded up, from
    /// `words`, its block's kept bounds (computed and kept there if unset):
    /// kept or not, the same bound.
    #[inline]
    fn kept_slope_bits(&self, words: Option<&[AtomicU16]>, i: IVec3, pool: &SamplePool, eval: &impl Sampled) -> u16 {
        let Some(words) = words else { return half_up(self.cell_slope(i, pool, eval)) };
        let word = &words[self.cell_in_block(i)];
        let mut bits = word.load(Ordering::Relaxed);
        if bits == UNSET_CELL_SLOPE {
            bits = half_up(self.cell_slope(i, pool, eval));
            word.store(bits, Ordering::Relaxed);
        }
        bits
    }

    /// The table entry of cell `i`'s block and the cell's place in it.
    fn cell_slope_word(&self, i: IVec3) -> Option<(usize, usize)> {
        Some((self.table_index(self.block_of(i))?, self.cell_in_block(i)))
    }

    /// Forgets the kept slope bounds of every cell reading a sample in `lo..=hi`.
    pub(super) fn clear_cell_slopes(&self, lo: IVec3, hi: IVec3) {
        // Cell `i` reads samples `i - 1 ..= i + 2` at most (the quadratic filter).
        for z in lo.z - 2..=hi.z + 1 {
            for y in lo.y - 2..=hi.y + 1 {
                for x in lo.x - 2..=hi.x + 1 {
                    let Some((t, w)) = self.cell_slope_word(IVec3::new(x, y, z)) else { continue };
                    if let Some(words) = self.cell_slopes[t].get() {
                        words[w].store(UNSET_CELL_SLOPE, Ordering::Relaxed);
                    }
                }
            }
        }
    }

    fn slope_over(
        &self,
        b: &Aabb,
        child_slope: &impl Fn(&Aabb) -> f32,
        child_range: &impl Fn(&Aabb) -> Interval,
    ) -> f32 {
        let reach = self.value_reach_box(b);
        let rounding = match self.spec.storage {
            Storage::F32 => 0.0,
            Storage::F16 => {
                let r = child_range(&reach);
                2.0 * self.spec.storage.rounding_error(r.lo.abs().max(r.hi.abs())) * self.inv_cell
            }
        };
        SQRT_3 * (child_slope(&reach) + rounding)
    }

    fn summary_slope(
        &self,
        c: usize,
        child_slope: &impl Fn(&Aabb) -> f32,
        child_range: &impl Fn(&Aabb) -> Interval,
    ) -> f32 {
        let bits = self.slopes[c].load(Ordering::Relaxed);
        if bits != UNSET_SLOPE {
            return f32::from_bits(bits);
        }
        let l = self.slope_over(&self.summary.cell_box(c), child_slope, child_range);
        self.slopes[c].store(l.to_bits(), Ordering::Relaxed);
        l
    }
}

/// The bits of the smallest half-precision number at least `x` (`x ≥ 0`;
/// infinity above the half range), a bound that stays a bound.
fn half_up(x: f32) -> u16 {
    let h = half::f16::from_f32(x);
    if h.to_f32() >= x { h.to_bits() } else { h.to_bits() + 1 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_bits_of_slopes_order_nans_above_infinity() {
        // The slope walk compares half bits up to infinity's (0x7c00) and
        // passes over anything above, as `f32::max` passes over NaNs.
        let (nan, inf) = (half::f16::NAN.to_bits(), half::f16::INFINITY.to_bits());
        assert_eq!(inf, 0x7c00);
        assert!(nan > inf && half_up(f32::INFINITY) == inf && half_up(f32::NAN) > inf);
    }

    #[test]
    fn half_up_never_rounds_a_slope_down() {
        for i in 0..100_000 {
            let x = (i as f32 * 0.731).powf(1.7) * 1e-3;
            let h = half::f16::from_bits(half_up(x)).to_f32();
            assert!(h >= x, "{x} -> {h}");
            if x < 65_000.0 {
                assert!(h - x <= x * 1e-3 + 1e-7, "{x} -> {h}");
            }
        }
        assert_eq!(half::f16::from_bits(half_up(70_000.0)).to_f32(), f32::INFINITY);
    }
}
