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

use std::sync::OnceLock;
use std::sync::atomic::{AtomicPtr, AtomicU16, AtomicU32, AtomicU64, Ordering};

use glam::{IVec3, UVec3, Vec3A};

use super::filter::{Filter, MAX_SUPPORT_CELLS};
use super::memo::{self, GatherId};
use super::pool::{Read, SLOT_WORDS, SamplePool, Slot, UNSET, block_key};
use super::{CacheSpec, Storage};
use crate::geom::{Aabb, Interval, Region, UniformGrid, cell_coords, linear_index};

/// Lattice points per block edge along x and y (z doubles for two-byte storage).
const BLOCK_SHIFT: i32 = 3;
/// Cells of padding around the subtree's bounds: beyond the filters' support,
/// so every reconstruction inside the cache's bounds finds its samples here.
pub const PAD_CELLS: f32 = 2.0;
/// Segments up to this many cells long take their slope bound from the samples.
const MAX_SAMPLED_SEGMENT_CELLS: f32 = 8.0;
/// Most samples a value range over a box reads before asking the subtree instead.
const MAX_HELD_RANGE_SAMPLES: i64 = 512;
/// Summary cells a slope query may visit before falling back to one bound over its box.
const MAX_SUMMARY_CELLS: usize = 64;
/// A bound on each gradient component is a bound on the norm divided by √3.
const SQRT_3: f32 = 1.732_050_8;
/// The word of a slope summary not yet computed.
const UNSET_SLOPE: u32 = u32::MAX;
/// The half-precision word of a cell slope not yet computed (a NaN).
const UNSET_CELL_SLOPE: u16 = u16::MAX;

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

/// Word offsets within a block of the `N³ = M` samples of a cube, x fastest.
const fn cube_offsets<const N: usize, const M: usize>() -> [u16; M] {
    let mut offsets = [0; M];
    let mut m = 0;
    while m < M {
        let (x, y, z) = (m % N, (m / N) % N, m / (N * N));
        offsets[m] = (x | y << BLOCK_SHIFT | z << (2 * BLOCK_SHIFT)) as u16;
        m += 1;
    }
    offsets
}

/// The `M³` samples at `offset` within the `N³` samples `outer`, both x fastest.
#[inline]
fn inner_cube<const N: usize, const M: usize>(outer: &[f32; 27], offset: IVec3) -> [f32; 27] {
    let o = offset.as_uvec3();
    let (ox, oy, oz) = (o.x as usize, o.y as usize, o.z as usize);
    let mut sub = [0.0; 27];
    for z in 0..M {
        for y in 0..M {
            for x in 0..M {
                sub[(z * M + y) * M + x] = outer[((oz + z) * N + oy + y) * N + ox + x];
            }
        }
    }
    sub
}

/// A block's eight parts (halves along each axis): whether each is known to
/// hold only zero samples, two bits per part.
const PART_UNKNOWN: u16 = 0;
const PART_ZERO: u16 = 1;
const PART_NONZERO: u16 = 2;

/// The first of part `part`'s two state bits in its block's word.
#[inline]
fn part_bit(part: IVec3) -> u32 {
    2 * (part.x & 1 | (part.y & 1) << 1 | (part.z & 1) << 2) as u32
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

    /// The cell size the resolution asks for over `bounds`: longest side / res.
    fn cell_for(&self, bounds: &Aabb) -> f32 {
        let side = if bounds.is_empty() { 0.0 } else { bounds.size().max_element() };
        if side > 0.0 { side / self.spec.res as f32 } else { 1.0 }
    }

    /// The bounds of the reconstructed field: the subtree's, padded by the filters' reach.
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        if self.child_bounds.is_empty() { self.child_bounds } else { self.child_bounds.padded(PAD_CELLS * self.cell) }
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
    fn rebuild(&mut self, child_bounds: Aabb, pool: &SamplePool) {
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
    fn resize_table(&mut self, lo: IVec3, hi: IVec3) {
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
    fn block_of(&self, i: IVec3) -> IVec3 {
        IVec3::new(i.x >> BLOCK_SHIFT, i.y >> BLOCK_SHIFT, i.z >> (BLOCK_SHIFT + self.spec.storage.z_extra_shift()))
    }

    /// Word and half of lattice point `i` within its block.
    #[inline]
    fn word_of(&self, i: IVec3) -> (usize, u32) {
        let mask = (1 << BLOCK_SHIFT) - 1;
        let z_mask = (1 << (BLOCK_SHIFT + self.spec.storage.z_extra_shift())) - 1;
        let local = ((i.x & mask) | ((i.y & mask) << BLOCK_SHIFT) | ((i.z & z_mask) << (2 * BLOCK_SHIFT))) as usize;
        match self.spec.storage {
            Storage::F32 => (local, 0),
            Storage::F16 => (local >> 1, (local & 1) as u32),
        }
    }

    #[inline]
    fn table_index(&self, block: IVec3) -> Option<usize> {
        let r = block - self.table_lo;
        if r.cmplt(IVec3::ZERO).any() || r.as_uvec3().cmpge(self.table_dims).any() {
            return None;
        }
        Some(linear_index(r.as_uvec3(), self.table_dims))
    }

    /// Sample `i`: held, or evaluated now with `eval` (in the cache's frame) and stored.
    fn sample(&self, i: IVec3, pool: &SamplePool, eval: &impl Sampled) -> f32 {
        let p = i.as_vec3a() * self.cell;
        if !self.child_bounds.contains(p) {
            // The subtree's field is zero outside its bounds: nothing to store.
            return 0.0;
        }
        let block = self.block_of(i);
        let Some(t) = self.table_index(block) else {
            return self.spec.storage.round_trip(eval.value(p));
        };
        if self.part_is_zero(t, i, eval) {
            return 0.0;
        }
        let key = block_key(self.serial, block);
        let (w, half) = self.word_of(i);
        let storage = self.spec.storage;
        for _ in 0..4 {
            let entry = &self.table[t];
            // SAFETY: table entries hold null or slots of `pool`, which never move or die while it lives.
            let slot = match unsafe { entry.load(Ordering::Acquire).as_ref() } {
                Some(slot) => slot,
                None => pool.attach(entry, key),
            };
            let (Read::Word(word), g) = slot.read(key, w) else {
                pool.attach(entry, key);
                continue;
            };
            if let Some(v) = storage.decode(word, half) {
                pool.touch(slot);
                return v;
            }
            let v = storage.round_trip(eval.value(p));
            self.evaluated.add(1);
            let bits = storage.encode(v);
            pool.store(slot, g, w, |old| storage.store(old, half, bits));
            return v;
        }
        // The block kept changing hands under a tight budget: evaluate without storing.
        storage.round_trip(eval.value(p))
    }

    /// The samples of the footprint from lattice point `first`, `n` per axis, x fastest.
    fn gather(&self, (first, n): (IVec3, usize), pool: &SamplePool, eval: &impl Sampled) -> [f32; 27] {
        if let Some(s) = memo::recall(self.gather_id, first, n) {
            return s;
        }
        let mut s = [0.0; 27];
        self.gather_cube(first, n, &mut s, pool, eval);
        memo::keep(self.gather_id, first, n, &s);
        s
    }

    /// The warm lookup: the `N³ = M` samples from lattice point `first`, x
    /// fastest, when every one is held in 32-bit storage. A held sample is
    /// what every path returns for its point, so this asks nothing of the
    /// block parts that are zero: a cube whose samples are all held has
    /// none in a zero part.
    #[inline]
    fn held_cube<const N: usize, const M: usize>(&self, first: IVec3, pool: &SamplePool) -> Option<[f32; M]> {
        let last = first + IVec3::splat(N as i32 - 1);
        // Past the subtree's bounds `gather_cube` answers zeros unread, whatever a block holds.
        let reach = Aabb::new(first.as_vec3a() * self.cell, last.as_vec3a() * self.cell);
        if self.spec.storage != Storage::F32 || !reach.overlaps(&self.child_bounds) {
            return None;
        }
        let mut words = [UNSET; M];
        let block = self.block_of(first);
        if block == self.block_of(last) {
            let base = self.word_of(first).0 as u16;
            let at = cube_offsets::<N, M>().map(|o| base + o);
            if !self.read_block(block, &at, &mut words, pool) {
                return None;
            }
        } else if !self.read_across_blocks::<N, M>(first, &mut words, pool) {
            return None;
        }
        (!words.contains(&UNSET)).then(|| words.map(f32::from_bits))
    }

    /// Reads the `N³ = M` words from lattice point `first`, x fastest, where
    /// they span two blocks along some axis: each block's slot is found and
    /// opened once (at most eight), and the words read under the openings.
    /// False where a block holds no slot or a read raced a reassignment.
    fn read_across_blocks<const N: usize, const M: usize>(
        &self,
        first: IVec3,
        words: &mut [u32; M],
        pool: &SamplePool,
    ) -> bool {
        let origin = self.block_of(first);
        let mut opened: [Option<(&Slot, u32)>; 8] = [None; 8];
        for (m, word) in words.iter_mut().enumerate() {
            let i = first + IVec3::new((m % N) as i32, ((m / N) % N) as i32, (m / (N * N)) as i32);
            let block = self.block_of(i);
            let d = block - origin;
            let which = (d.x | d.y << 1 | d.z << 2) as usize;
            let slot = match opened[which] {
                Some((slot, _)) => slot,
                None => {
                    let Some(open) = self.open_block(block) else { return false };
                    opened[which] = Some(open);
                    open.0
                }
            };
            *word = slot.peek(self.word_of(i).0);
        }
        opened.iter().flatten().all(|&(slot, g)| {
            let held = slot.still(g);
            if held {
                pool.touch(slot);
            }
            held
        })
    }

    /// Block `block`'s slot, opened for reading (see [`Slot::open`]), if it has one.
    #[inline]
    fn open_block(&self, block: IVec3) -> Option<(&Slot, u32)> {
        let t = self.table_index(block)?;
        // SAFETY: as in `sample`.
        let slot = unsafe { self.table[t].load(Ordering::Acquire).as_ref() }?;
        Some((slot, slot.open(block_key(self.serial, block))?))
    }

    /// The `n³` samples from lattice point `first`, x fastest, into `out`:
    /// held ones first (see [`Self::held_cube`]). Otherwise the cube spans at
    /// most two blocks per axis; each block's part is fetched in one
    /// consistent read, and only samples not yet held go one by one.
    fn gather_cube(&self, first: IVec3, n: usize, out: &mut [f32], pool: &SamplePool, eval: &impl Sampled) {
        let held = match n {
            2 => self.held_cube::<2, 8>(first, pool).map(|c| out[..8].copy_from_slice(&c)),
            3 => self.held_cube::<3, 27>(first, pool).map(|c| out[..27].copy_from_slice(&c)),
            4 => self.held_cube::<4, 64>(first, pool).map(|c| out[..64].copy_from_slice(&c)),
            _ => None,
        };
        if held.is_some() {
            return;
        }
        let last = first + IVec3::splat(n as i32 - 1);
        let reach = Aabb::new(first.as_vec3a() * self.cell, last.as_vec3a() * self.cell);
        if !reach.overlaps(&self.child_bounds) {
            // Every sample lies outside the subtree's support.
            out[..n * n * n].fill(0.0);
            return;
        }
        if self.parts_are_zero(first, last, eval) {
            out[..n * n * n].fill(0.0);
            return;
        }
        let (b0, b1) = (self.block_of(first), self.block_of(last));
        if b0 == b1 && self.spec.storage == Storage::F32 {
            // A tri-linear cell's corners, the quadratic filter's three taps,
            // and the quadratic filter's reach over a whole cell (its slope
            // bounds); any other edge takes the general path below.
            match n {
                2 => return self.gather_in_block::<2, 8>(b0, first, out, pool, eval),
                3 => return self.gather_in_block::<3, 27>(b0, first, out, pool, eval),
                4 => return self.gather_in_block::<4, 64>(b0, first, out, pool, eval),
                _ => {}
            }
        }
        let block_cells = self.block_cells();
        for bz in b0.z..=b1.z {
            for by in b0.y..=b1.y {
                for bx in b0.x..=b1.x {
                    let block = IVec3::new(bx, by, bz);
                    let lo = first.max(block * block_cells);
                    let hi = last.min((block + IVec3::ONE) * block_cells - IVec3::ONE);
                    self.gather_part(block, (lo, hi), first, n, out, pool, eval);
                }
            }
        }
    }

    /// Lattice points per block along each axis.
    fn block_cells(&self) -> IVec3 {
        IVec3::new(1, 1, 1 << self.spec.storage.z_extra_shift()) << BLOCK_SHIFT
    }

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
    fn part_is_zero(&self, t: usize, i: IVec3, subtree: &impl Sampled) -> bool {
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
    fn part_known_zero(&self, block: IVec3, i: IVec3) -> bool {
        self.table_index(block).is_some_and(|t| self.part_state(t, i) == PART_ZERO)
    }

    /// The state bits of lattice point `i`'s part, in table block `t`.
    #[inline]
    fn part_state(&self, t: usize, i: IVec3) -> u16 {
        self.zero_parts[t].load(Ordering::Relaxed) >> part_bit(self.part_of(i)) & 3
    }

    /// Whether every sample of the lattice points `first..=last` lies in a
    /// zero part (see [`Self::part_is_zero`]).
    fn parts_are_zero(&self, first: IVec3, last: IVec3, subtree: &impl Sampled) -> bool {
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

    /// The samples of the cube from `first` (edge `n`) in the box `lo..=hi` of `block`.
    #[allow(clippy::too_many_arguments)]
    fn gather_part(
        &self,
        block: IVec3,
        (lo, hi): (IVec3, IVec3),
        first: IVec3,
        n: usize,
        out: &mut [f32],
        pool: &SamplePool,
        eval: &impl Sampled,
    ) {
        // Small index types keep these scratch arrays (and their clearing) cheap.
        let mut at = [0u16; 64];
        let mut halves = [0u8; 64];
        let mut dest = [0u8; 64];
        let mut count = 0;
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    let i = IVec3::new(x, y, z);
                    let o = (i - first).as_uvec3();
                    dest[count] = (o.x as usize + n * (o.y as usize + n * o.z as usize)) as u8;
                    let (w, h) = self.word_of(i);
                    (at[count], halves[count]) = (w as u16, h as u8);
                    count += 1;
                }
            }
        }
        let mut words = [UNSET; 64];
        let read = self.read_block(block, &at[..count], &mut words[..count], pool);
        let storage = self.spec.storage;
        for k in 0..count {
            let m = usize::from(dest[k]);
            out[m] = match storage.decode(words[k], u32::from(halves[k])) {
                Some(v) if read => v,
                _ => self.sample_at_offset(first, m, n, pool, eval),
            };
        }
    }

    /// The hot case of [`Self::gather_cube`]: the `N³ = M` samples (a
    /// tri-linear cell's corners, a tri-quadratic footprint) inside one block
    /// of 32-bit samples, at fixed offsets.
    fn gather_in_block<const N: usize, const M: usize>(
        &self,
        block: IVec3,
        first: IVec3,
        out: &mut [f32],
        pool: &SamplePool,
        eval: &impl Sampled,
    ) {
        let offsets = cube_offsets::<N, M>();
        let base = self.word_of(first).0 as u16;
        let at = offsets.map(|o| base + o);
        let mut words = [UNSET; M];
        let read = self.read_block(block, &at, &mut words, pool);
        for (m, &word) in words.iter().enumerate() {
            out[m] = match Storage::F32.decode(word, 0) {
                Some(v) if read => v,
                _ => self.sample_at_offset(first, m, N, pool, eval),
            };
        }
    }

    /// Reads the words `at` of `block` into `words` in one consistent read;
    /// false when the block holds no slot or the read raced a reassignment.
    #[inline]
    fn read_block(&self, block: IVec3, at: &[u16], words: &mut [u32], pool: &SamplePool) -> bool {
        let Some((slot, g)) = self.open_block(block) else { return false };
        for (word, &w) in words.iter_mut().zip(at) {
            *word = slot.peek(usize::from(w));
        }
        let held = slot.still(g);
        if held {
            pool.touch(slot);
        }
        held
    }

    /// The sample at position `m` (x fastest) of the cube of edge `n` from `first`.
    fn sample_at_offset(&self, first: IVec3, m: usize, n: usize, pool: &SamplePool, eval: &impl Sampled) -> f32 {
        let o = IVec3::new((m % n) as i32, ((m / n) % n) as i32, (m / (n * n)) as i32);
        self.sample(first + o, pool, eval)
    }

    /// The reconstructed value at `p` (cache frame), with the value filter.
    pub fn value(&self, p: Vec3A, pool: &SamplePool, eval: &impl Sampled) -> f32 {
        self.lookups.add_one_unsynchronized();
        let weights = self.spec.value.at(p * self.inv_cell);
        weights.value(&self.gather(weights.footprint(), pool, eval))
    }

    /// The reconstructed gradient at `p` (cache frame), with the gradient filter.
    pub fn gradient(&self, p: Vec3A, pool: &SamplePool, eval: &impl Sampled) -> Vec3A {
        self.lookups.add_one_unsynchronized();
        let weights = self.spec.gradient.at(p * self.inv_cell);
        weights.gradient(&self.gather(weights.footprint(), pool, eval)) * self.inv_cell
    }

    /// [`Self::value`] and [`Self::gradient`] at `p` together, to the same
    /// bits, from one gather: one filter's samples always hold the other's
    /// (the tri-linear cube lies in the tri-quadratic one around the same
    /// point). A shaded hit or a coloured vertex weighs a cache's colour by
    /// its value and takes its gradient there.
    pub fn value_and_gradient(&self, p: Vec3A, pool: &SamplePool, eval: &impl Sampled) -> (f32, Vec3A) {
        let u = p * self.inv_cell;
        let (value, gradient) = (self.spec.value.at(u), self.spec.gradient.at(u));
        let gradient_is_wide = gradient.footprint().1 >= value.footprint().1;
        let (wide, narrow) = if gradient_is_wide { (gradient, value) } else { (value, gradient) };
        let ((first, n), (inner, m)) = (wide.footprint(), narrow.footprint());
        let offset = inner - first;
        debug_assert!(offset.min_element() >= 0 && (offset + IVec3::splat(m as i32)).max_element() <= n as i32);
        self.lookups.add_one_unsynchronized();
        self.lookups.add_one_unsynchronized();
        let outer = self.gather((first, n), pool, eval);
        let sub = match (n, m) {
            (3, 2) => inner_cube::<3, 2>(&outer, offset),
            (3, 3) => inner_cube::<3, 3>(&outer, offset),
            _ => inner_cube::<2, 2>(&outer, offset),
        };
        let (value_samples, gradient_samples) = if gradient_is_wide { (&sub, &outer) } else { (&outer, &sub) };
        (value.value(value_samples), gradient.gradient(gradient_samples) * self.inv_cell)
    }

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
    fn value_reach_box(&self, b: &Aabb) -> Aabb {
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
    fn cell_differences(&self, i: IVec3, pool: &SamplePool, eval: &impl Sampled) -> (Vec3A, Vec3A) {
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
    /// [`Self::cell_slope`]), so it lies between the least and the greatest.
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

    /// Cell `i`'s place in its block.
    #[inline]
    fn cell_in_block(&self, i: IVec3) -> usize {
        let (mask, z_mask) = ((1 << BLOCK_SHIFT) - 1, (1 << (BLOCK_SHIFT + self.spec.storage.z_extra_shift())) - 1);
        ((i.x & mask) | ((i.y & mask) << BLOCK_SHIFT) | ((i.z & z_mask) << (2 * BLOCK_SHIFT))) as usize
    }

    /// Lattice points (and cells) per block.
    fn block_volume(&self) -> usize {
        self.block_cells().as_usizevec3().element_product()
    }

    /// Forgets the kept slope bounds of every cell reading a sample in `lo..=hi`.
    fn clear_cell_slopes(&self, lo: IVec3, hi: IVec3) {
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

    /// Forgets which parts are zero in every block within a cell of `b`,
    /// where an edit may have changed the subtree's support.
    fn forget_zero_parts(&mut self, b: &Aabb) {
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

/// The bits of the smallest half-precision number at least `x` (`x ≥ 0`;
/// infinity above the half range), a bound that stays a bound.
fn half_up(x: f32) -> u16 {
    let h = half::f16::from_f32(x);
    if h.to_f32() >= x { h.to_bits() } else { h.to_bits() + 1 }
}

/// How many times the blocks the subtree's bounds need a table kept over
/// both old and new bounds may hold; beyond, the cache is laid anew.
const MAX_TABLE_STRETCH: u64 = 8;

/// Blocks in the inclusive range `lo..=hi`.
fn block_count(lo: IVec3, hi: IVec3) -> u64 {
    (hi - lo + IVec3::ONE).max(IVec3::ZERO).as_u64vec3().element_product()
}

/// A counter split over cache lines by worker thread, so counting every lookup
/// from every thread costs no contention.
#[derive(Default)]
struct ShardedCounter {
    shards: [PaddedCounter; 16],
}

#[derive(Default)]
#[repr(align(128))]
struct PaddedCounter(AtomicU64);

impl ShardedCounter {
    #[inline]
    fn add(&self, n: u64) {
        self.shard().fetch_add(n, Ordering::Relaxed);
    }

    /// Counts one, by a plain load and store: a tenth of a warm lookup's
    /// time less than [`Self::add`]. Each thread of a pool has a shard of its
    /// own; a thread outside the pool shares the first, and an increment it
    /// races there may be lost, which only a statistic would show.
    #[inline]
    fn add_one_unsynchronized(&self) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cache::CacheSpec;

    /// Deterministic points in `[-r, r]³`.
    fn points(n: usize, r: f32) -> Vec<Vec3A> {
        crate::geom::scattered_points(n, r, 0x2545_f491_4f6c_dd1d)
    }

    /// A ball's field, zero outside it: cubes across block faces, in zero
    /// parts and past the subtree's bounds.
    fn ball(p: Vec3A) -> f32 {
        0.9 * (1.0 - p.length_squared()).max(0.0).powi(3)
    }

    /// An empty cache of [`ball`] at resolution 20 with `value` for values.
    fn ball_cache(value: Filter, pool: &SamplePool) -> CacheGrid {
        let spec = CacheSpec { res: 20, value, gradient: Filter::Triquadratic, storage: Storage::F32 };
        CacheGrid::new(spec, Aabb::new(Vec3A::splat(-1.0), Vec3A::splat(1.0)), pool)
    }

    /// [`CacheGrid::lipschitz`] over a segment short enough to be bounded from samples alone.
    fn sampled_slope(grid: &CacheGrid, (a, b): (Vec3A, Vec3A), pool: &SamplePool) -> f32 {
        let (no_slope, no_range) = (|_: &Aabb| f32::INFINITY, |_: &Aabb| Interval::new(0.0, 1.0));
        grid.lipschitz(&Region::Segment(a, b), &no_slope, &no_range, (pool, &ball))
    }

    /// Warm lookups read held samples straight from their blocks; cold ones
    /// gather part by part, asking which parts are zero. Each warm answer
    /// must equal, to the bit, what a fresh cache computes for that point alone.
    #[test]
    fn warm_lookups_and_slope_walks_read_what_a_fresh_cache_computes() {
        for value in [Filter::Trilinear, Filter::Triquadratic] {
            let pool = SamplePool::default();
            let warm = ball_cache(value, &pool);
            let answers = |grid: &CacheGrid, p: Vec3A| {
                let slope = sampled_slope(grid, (p, p + Vec3A::new(0.21, -0.13, 0.17)), &pool);
                let (v, g) = grid.value_and_gradient(p, &pool, &ball);
                [grid.value(p, &pool, &ball), slope, v, g.x, g.y, g.z].map(f32::to_bits)
            };
            let points = points(1500, 1.25);
            for &p in &points {
                answers(&warm, p);
            }
            for &p in &points {
                let fresh = ball_cache(value, &pool);
                assert_eq!(answers(&warm, p), answers(&fresh, p), "{value:?} at {p}");
            }
        }
    }

    /// The sampled slope bound over a short segment holds for the
    /// reconstruction along it, for both value filters (the quadratic one
    /// reads a 4×4×4 cube per cell, often inside one block), and so does
    /// the floor on its derivative along the segment.
    #[test]
    fn sampled_slope_bounds_hold_along_their_segments() {
        for value in [Filter::Trilinear, Filter::Triquadratic] {
            let pool = SamplePool::default();
            let grid = ball_cache(value, &pool);
            let ends = points(800, 1.1);
            for pair in ends.chunks(2) {
                let (a, b) = (pair[0], pair[0] + (pair[1] - pair[0]).normalize() * 0.25);
                let slope = sampled_slope(&grid, (a, b), &pool);
                let dir = (b - a).normalize();
                let floor = grid.slope_floor((a, b), dir, &pool, &ball);
                let steps = 400;
                let h = (b - a).length() / steps as f32;
                let at = |k: usize| grid.value(a + (b - a) * (k as f32 / steps as f32), &pool, &ball);
                for k in 0..steps {
                    let rise = at(k + 1) - at(k);
                    assert!(
                        rise.abs() <= slope * h * 1.001 + 1e-6,
                        "{value:?} {a}..{b}: rise {rise} over {h}, bound {slope}"
                    );
                    assert!(
                        rise >= floor * h * 1.001 - 1e-6,
                        "{value:?} {a}..{b}: rise {rise} over {h}, floor {floor}"
                    );
                }
            }
        }
    }

    /// A cell's sample differences are those of the samples its value
    /// filter reads (the quadratic filter's 4×4×4 cube around it), whether
    /// that cube lies inside one block or across several, cold or warm.
    #[test]
    fn cell_differences_are_those_of_the_cells_samples() {
        let pool = SamplePool::default();
        let grid = ball_cache(Filter::Triquadratic, &pool);
        let sample = |i: IVec3| {
            let p = i.as_vec3a() * grid.cell();
            if grid.child_bounds.contains(p) { ball(p) } else { 0.0 }
        };
        for round in 0..2 {
            for p in points(300, 1.0) {
                let i = (p / grid.cell()).floor().as_ivec3();
                let (mut lo, mut hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
                for o in (0..64).map(|m| IVec3::new(m % 4, m / 4 % 4, m / 16) - IVec3::ONE) {
                    for axis in 0..3 {
                        if o[axis] < 2 {
                            let d = sample(i + o + IVec3::AXES[axis]) - sample(i + o);
                            (lo[axis], hi[axis]) = (lo[axis].min(d), hi[axis].max(d));
                        }
                    }
                }
                let (got_lo, got_hi) = grid.cell_differences(i, &pool, &ball);
                assert_eq!((got_lo, got_hi), (lo, hi), "cell {i}, round {round}");
            }
        }
    }

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
