//! The block table of a cache's lattice: which block holds each lattice
//! point's sample, and where in it, and how the table is laid, and grown or
//! laid anew, as the subtree's bounds change (paper section 4.5).

use std::sync::OnceLock;
use std::sync::atomic::{AtomicPtr, AtomicU16, AtomicU32, Ordering};

use glam::{IVec3, UVec3, Vec3A};

use super::slopes::UNSET_SLOPE;
use super::zero_parts::PART_UNKNOWN;
use super::{BLOCK_SHIFT, CacheGrid, PAD_CELLS};
use crate::cache::Storage;
use crate::cache::memo::GatherId;
use crate::cache::pool::{SamplePool, Slot};
use crate::geom::{Aabb, UniformGrid, cell_coords, linear_index};

/// What [`CacheGrid::fit`] did when the subtree's bounds changed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refit {
    /// The cell size still fits: samples kept (the block table may have grown).
    Kept,
    /// The cell size left `[c/2, 2c]`, or the subtree moved so far that a
    /// table over its old and new places would be mostly empty: every sample
    /// was dropped and the lattice rebuilt.
    Rebuilt,
}

impl CacheGrid {
    /// The cell size the resolution asks for over `bounds`: longest side / res.
    fn cell_for(&self, bounds: &Aabb) -> f32 {
        let side = if bounds.is_empty() { 0.0 } else { bounds.size().max_element() };
        if side > 0.0 { side / self.spec.res as f32 } else { 1.0 }
    }

    /// Follows the subtree's new bounds (paper section 4.5): keeps the lattice
    /// while the cell size the resolution asks for stays within `[c/2, 2c]`,
    /// growing the block table if needed; otherwise drops everything and rebuilds.
    pub fn fit(&mut self, child_bounds: Aabb, pool: &SamplePool) -> Refit {
        // The bounds decide which samples read as zero unasked.
        self.gather_id = GatherId::fresh();
        let ratio = self.cell_for(&child_bounds) / self.cell;
        if !(0.5..=2.0).contains(&ratio) {
            self.rebuild(child_bounds, pool);
            return Refit::Rebuilt;
        }
        self.child_bounds = child_bounds;
        if child_bounds.is_empty() {
            // The subtree's field is zero everywhere: no sample is read.
            return Refit::Kept;
        }
        let (lo, hi) = self.block_range(&child_bounds);
        if self.table.is_empty() {
            self.resize_table(lo, hi);
            return Refit::Kept;
        }
        let (old_lo, old_hi) = (self.table_lo, self.table_lo + self.table_dims.as_ivec3() - IVec3::ONE);
        if lo.cmplt(old_lo).any() || hi.cmpgt(old_hi).any() {
            let (wide_lo, wide_hi) = (lo.min(old_lo), hi.max(old_hi));
            // A subtree moved far within the cache would stretch the table
            // over the space between its old and new places: start afresh.
            if block_count(wide_lo, wide_hi) > MAX_TABLE_STRETCH * block_count(lo, hi) {
                self.rebuild(child_bounds, pool);
                return Refit::Rebuilt;
            }
            self.resize_table(wide_lo, wide_hi);
        }
        Refit::Kept
    }

    /// An upper bound on the bytes of the block table (and the per-block
    /// slope words and summaries beside it) a cache of resolution `res`
    /// allocates up front, before it holds any sample.
    #[must_use]
    pub fn table_bytes_at(res: u32) -> u64 {
        let per_block = std::mem::size_of::<AtomicPtr<Slot>>()
            + std::mem::size_of::<OnceLock<Box<[AtomicU16]>>>()
            + std::mem::size_of::<AtomicU32>()
            + std::mem::size_of::<AtomicU16>();
        // The padded bounds span `res` cells plus the pad on each side, in blocks, and one more for alignment.
        let blocks = (u64::from(res) + 2 * (PAD_CELLS as u64 + 1)).div_ceil(1 << BLOCK_SHIFT) + 1;
        blocks.pow(3) * per_block as u64
    }

    /// Drops every sample and lays a fresh lattice over `child_bounds`.
    pub(super) fn rebuild(&mut self, child_bounds: Aabb, pool: &SamplePool) {
        pool.release(self.serial);
        self.cell = self.cell_for(&child_bounds);
        self.inv_cell = 1.0 / self.cell;
        self.child_bounds = child_bounds;
        self.table = Box::new([]);
        self.cell_slopes = Box::new([]);
        self.zero_parts = Box::new([]);
        self.table_dims = UVec3::ZERO;
        // A subtree with empty bounds reads no sample, but invalidation still
        // walks the slope summaries: one cell, with its slope, keeps them whole.
        self.lattice = UniformGrid::new(Vec3A::ZERO, self.cell, UVec3::ONE);
        self.summary = UniformGrid::new(Vec3A::ZERO, 8.0 * self.cell, UVec3::ONE);
        self.slopes = Box::new([AtomicU32::new(UNSET_SLOPE)]);
        if !child_bounds.is_empty() {
            let (lo, hi) = self.block_range(&child_bounds);
            self.resize_table(lo, hi);
        }
    }

    /// Block coordinates spanned by `bounds` padded by the filters' reach.
    fn block_range(&self, bounds: &Aabb) -> (IVec3, IVec3) {
        let padded = bounds.padded((PAD_CELLS + 1.0) * self.cell);
        let lo = (padded.min * self.inv_cell).floor().as_ivec3();
        let hi = (padded.max * self.inv_cell).ceil().as_ivec3();
        (self.block_of(lo), self.block_of(hi))
    }

    /// Re-lays the block table over blocks `lo..=hi`, keeping the slots held.
    pub(super) fn resize_table(&mut self, lo: IVec3, hi: IVec3) {
        let dims = (hi - lo + IVec3::ONE).max(IVec3::ONE).as_uvec3();
        let mut table: Vec<AtomicPtr<Slot>> =
            (0..dims.as_usizevec3().element_product()).map(|_| AtomicPtr::new(std::ptr::null_mut())).collect();
        let mut cell_slopes: Vec<OnceLock<Box<[AtomicU16]>>> = table.iter().map(|_| OnceLock::new()).collect();
        let zero_parts: Box<[AtomicU16]> = table.iter().map(|_| AtomicU16::new(PART_UNKNOWN)).collect();
        for (i, entry) in self.table.iter().enumerate() {
            let b = self.table_lo + cell_coords(i, self.table_dims).as_ivec3();
            let to = linear_index((b - lo).as_uvec3(), dims);
            table[to] = AtomicPtr::new(entry.load(Ordering::Relaxed));
            cell_slopes[to] = std::mem::take(&mut self.cell_slopes[i]);
            zero_parts[to].store(self.zero_parts[i].load(Ordering::Relaxed), Ordering::Relaxed);
        }
        self.table = table.into_boxed_slice();
        self.cell_slopes = cell_slopes.into_boxed_slice();
        self.zero_parts = zero_parts;
        self.table_lo = lo;
        self.table_dims = dims;
        // The cells over the same region, and slope summaries over cubes of 8
        // of them (blocks are multiples of 8 cells), all recomputed lazily.
        self.lattice_lo = lo * self.block_cells();
        let origin = self.lattice_lo.as_vec3a() * self.cell;
        let cells = (dims.as_ivec3() * self.block_cells()).as_uvec3();
        self.lattice = UniformGrid::new(origin, self.cell, cells);
        self.summary = UniformGrid::new(origin, 8.0 * self.cell, cells / 8);
        self.slopes = (0..self.summary.cell_count()).map(|_| AtomicU32::new(UNSET_SLOPE)).collect();
    }

    /// Block coordinates (floor division) of lattice point `i`.
    #[inline]
    pub(super) fn block_of(&self, i: IVec3) -> IVec3 {
        IVec3::new(i.x >> BLOCK_SHIFT, i.y >> BLOCK_SHIFT, i.z >> (BLOCK_SHIFT + self.spec.storage.z_extra_shift()))
    }

    /// Word and half of lattice point `i` within its block.
    #[inline]
    pub(super) fn word_of(&self, i: IVec3) -> (usize, u32) {
        let mask = (1 << BLOCK_SHIFT) - 1;
        let z_mask = (1 << (BLOCK_SHIFT + self.spec.storage.z_extra_shift())) - 1;
        let local = ((i.x & mask) | ((i.y & mask) << BLOCK_SHIFT) | ((i.z & z_mask) << (2 * BLOCK_SHIFT))) as usize;
        match self.spec.storage {
            Storage::F32 => (local, 0),
            Storage::F16 => (local >> 1, (local & 1) as u32),
        }
    }

    #[inline]
    pub(super) fn table_index(&self, block: IVec3) -> Option<usize> {
        let r = block - self.table_lo;
        if r.cmplt(IVec3::ZERO).any() || r.as_uvec3().cmpge(self.table_dims).any() {
            return None;
        }
        Some(linear_index(r.as_uvec3(), self.table_dims))
    }

    /// Lattice points per block along each axis.
    pub(super) fn block_cells(&self) -> IVec3 {
        IVec3::new(1, 1, 1 << self.spec.storage.z_extra_shift()) << BLOCK_SHIFT
    }

    /// Lattice points (and cells) per block.
    pub(super) fn block_volume(&self) -> usize {
        self.block_cells().as_usizevec3().element_product()
    }

    /// Cell `i`'s place in its block.
    #[inline]
    pub(super) fn cell_in_block(&self, i: IVec3) -> usize {
        let (mask, z_mask) = ((1 << BLOCK_SHIFT) - 1, (1 << (BLOCK_SHIFT + self.spec.storage.z_extra_shift())) - 1);
        ((i.x & mask) | ((i.y & mask) << BLOCK_SHIFT) | ((i.z & z_mask) << (2 * BLOCK_SHIFT))) as usize
    }
}

/// How many times the blocks the subtree's bounds need a table kept over
/// both old and new bounds may hold; beyond, the cache is laid anew.
const MAX_TABLE_STRETCH: u64 = 8;

/// Blocks in the inclusive range `lo..=hi`.
fn block_count(lo: IVec3, hi: IVec3) -> u64 {
    (hi - lo + IVec3::ONE).max(IVec3::ZERO).as_u64vec3().element_product()
}
