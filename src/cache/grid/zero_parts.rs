//! The parts of a block (its halves along each axis) known to hold only zero
//! samples: asked of the subtree once per part, and forgotten where an edit
//! may have changed its support.

use std::sync::atomic::Ordering;

use glam::IVec3;

use super::{BLOCK_SHIFT, CacheGrid, Sampled};
use crate::geom::Aabb;

/// A block's eight parts (halves along each axis): whether each is known to
/// hold only zero samples, two bits per part.
pub(super) const PART_UNKNOWN: u16 = 0;
const PART_ZERO: u16 = 1;
const PART_NONZERO: u16 = 2;

/// The first of part `part`'s two state bits in its block's word.
#[inline]
fn part_bit(part: IVec3) -> u32 {
    2 * (part.x & 1 | (part.y & 1) << 1 | (part.z & 1) << 2) as u32
}

impl CacheGrid {
    /// Lattice points per block part along each axis (half a block).
    fn part_cells(&self) -> IVec3 {
        self.block_cells() >> 1
    }

    /// Part coordinates (floor division) of lattice point `i`: a block's
    /// parts are its halves along each axis.
    #[inline]
    fn part_of(&self, i: IVec3) -> IVec3 {
        let z_shift = BLOCK_SHIFT - 1 + self.spec.storage.z_extra_shift();
        IVec3::new(i.x >> (BLOCK_SHIFT - 1), i.y >> (BLOCK_SHIFT - 1), i.z >> z_shift)
    }

    /// Whether every sample of lattice point `i`'s block part is zero: the
    /// subtree asked once per part (an interval over the part's box), its
    /// answer kept until an edit touches the block. A zero part stores no
    /// sample and costs no evaluation: most of a cache's bounds around a
    /// thin subtree (strands, chains of points) lie outside its support.
    #[inline]
    pub(super) fn part_is_zero(&self, t: usize, i: IVec3, subtree: &impl Sampled) -> bool {
        match self.part_state(t, i) {
            PART_ZERO => true,
            PART_UNKNOWN => {
                let part = self.part_of(i);
                let lo = part * self.part_cells();
                let hi = lo + self.part_cells() - IVec3::ONE;
                // A sliver of padding keeps the answer conservative against
                // rounding at the edge of a support.
                let b = Aabb::new(lo.as_vec3a() * self.cell, hi.as_vec3a() * self.cell).padded(0.01 * self.cell);
                let zero = subtree.is_zero_over(&b);
                // Threads racing here may disagree where the subtree's
                // bound rests on its own caches' held samples; both bits
                // set then read as nonzero, which reads the samples and is
                // never wrong (zero-part samples evaluate to zero).
                let state = if zero { PART_ZERO } else { PART_NONZERO };
                self.zero_parts[t].fetch_or(state << part_bit(part), Ordering::Relaxed);
                zero
            }
            _ => false,
        }
    }

    /// Whether lattice point `i` (of `block`) lies in a part already known
    /// to be zero; asks the subtree nothing.
    pub(super) fn part_known_zero(&self, block: IVec3, i: IVec3) -> bool {
        self.table_index(block).is_some_and(|t| self.part_state(t, i) == PART_ZERO)
    }

    /// The state bits of lattice point `i`'s part, in table block `t`.
    #[inline]
    fn part_state(&self, t: usize, i: IVec3) -> u16 {
        self.zero_parts[t].load(Ordering::Relaxed) >> part_bit(self.part_of(i)) & 3
    }

    /// Whether every sample of the lattice points `first..=last` lies in a
    /// zero part (see [`Self::part_is_zero`]).
    pub(super) fn parts_are_zero(&self, first: IVec3, last: IVec3, subtree: &impl Sampled) -> bool {
        let (p0, p1) = (self.part_of(first), self.part_of(last));
        let cells = self.part_cells();
        for z in p0.z..=p1.z {
            for y in p0.y..=p1.y {
                for x in p0.x..=p1.x {
                    // Any point of the part names it.
                    let i = IVec3::new(x, y, z) * cells;
                    let Some(t) = self.table_index(self.block_of(i)) else { return false };
                    if !self.part_is_zero(t, i, subtree) {
                        return false;
                    }
                }
            }
        }
        true
    }

    /// Forgets which parts are zero in every block within a cell of `b`,
    /// where an edit may have changed the subtree's support.
    pub(super) fn forget_zero_parts(&mut self, b: &Aabb) {
        if b.is_empty() || self.table.is_empty() {
            return;
        }
        let near = b.padded(self.cell);
        let lo = self.block_of((near.min * self.inv_cell).floor().as_ivec3()).max(self.table_lo);
        let table_hi = self.table_lo + self.table_dims.as_ivec3() - IVec3::ONE;
        let hi = self.block_of((near.max * self.inv_cell).ceil().as_ivec3()).min(table_hi);
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    if let Some(t) = self.table_index(IVec3::new(x, y, z)) {
                        self.zero_parts[t].store(PART_UNKNOWN, Ordering::Relaxed);
                    }
                }
            }
        }
    }
}
