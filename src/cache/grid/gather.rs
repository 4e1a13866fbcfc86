//! Gathering the samples of a footprint: held ones read straight from their
//! blocks, in one consistent read per block, and missing ones evaluated and
//! stored one at a time.

use std::sync::atomic::Ordering;

use glam::IVec3;

use super::{BLOCK_SHIFT, CacheGrid, Sampled};
use crate::cache::Storage;
use crate::cache::memo;
use crate::cache::pool::{Read, SamplePool, Slot, UNSET, block_key};
use crate::geom::Aabb;

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

impl CacheGrid {
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
    pub(super) fn gather(&self, (first, n): (IVec3, usize), pool: &SamplePool, eval: &impl Sampled) -> [f32; 27] {
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
    pub(super) fn gather_cube(&self, first: IVec3, n: usize, out: &mut [f32], pool: &SamplePool, eval: &impl Sampled) {
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
    pub(super) fn read_block(&self, block: IVec3, at: &[u16], words: &mut [u32], pool: &SamplePool) -> bool {
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
}
