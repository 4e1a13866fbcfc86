//! The memory behind every cache of a model: fixed-size slots of atomic words,
//! handed to cache blocks on first touch and, under a budget, taken back from
//! the least recently used block.
//!
//! Reads and sample writes never lock. A slot carries a generation that is odd
//! while the slot changes hands (a seqlock): a reader that sees the same even
//! generation before and after its read, and its own block as the owner, read
//! a sample of its own block. Writers announce themselves in `writers`, so the
//! slot's new owner never receives a stale writer's sample. Every sample is a
//! pure function of its lattice point, so a reader that loses a race simply
//! evaluates the sample itself: results never depend on timing.

use std::collections::HashMap;
use std::sync::Mutex;
use std::sync::atomic::{AtomicPtr, AtomicU32, AtomicU64, Ordering, fence};

/// Words per slot (one block of samples).
pub const SLOT_WORDS: usize = 512;
/// Bytes of sample storage per slot.
pub const SLOT_BYTES: usize = SLOT_WORDS * 4;
/// The smallest budget accepted: enough slots that concurrent lookups cannot
/// keep evicting each other's blocks.
pub const MIN_BUDGET_SLOTS: usize = 64;

/// A word no sample encodes to: every sample of a fresh slot holds it.
pub const UNSET: u32 = 0x7fff_7fff;
/// The owner of a slot no block holds.
const FREE: u64 = u64::MAX;

/// One block's worth of samples, and who holds it.
///
/// The words live inline, after the header: a reader's loads of the
/// generation and of its words then depend only on the slot's address, and
/// go to memory together rather than one after the other.
#[repr(C)]
pub struct Slot {
    /// Even while the owner is stable; odd while the slot is reassigned.
    generation: AtomicU32,
    /// Pool clock at the last use, for least-recently-used eviction.
    last_used: AtomicU32,
    /// The block key (cache serial and block coordinates) that holds the slot.
    owner: AtomicU64,
    words: [AtomicU32; SLOT_WORDS],
    /// Writers between their generation check and their store. Last, away
    /// from the header every read loads: each store counts itself in and out
    /// here, which would otherwise take the header's line from the other
    /// threads reading the slot.
    writers: AtomicU32,
}

/// The outcome of reading one word of a slot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Read {
    /// The word, read consistently for this block.
    Word(u32),
    /// The slot belongs to another block now (or is being reassigned).
    Stale,
}

impl Slot {
    fn new() -> Self {
        Self {
            generation: AtomicU32::new(0),
            writers: AtomicU32::new(0),
            owner: AtomicU64::new(FREE),
            last_used: AtomicU32::new(0),
            words: [const { AtomicU32::new(UNSET) }; SLOT_WORDS],
        }
    }

    /// Reads word `w` as block `key`; returns the generation it was read under.
    #[inline]
    pub fn read(&self, key: u64, w: usize) -> (Read, u32) {
        let g = self.generation.load(Ordering::Acquire);
        if g & 1 == 1 || self.owner.load(Ordering::Relaxed) != key {
            return (Read::Stale, g);
        }
        let word = self.words[w].load(Ordering::Relaxed);
        fence(Ordering::Acquire);
        if self.generation.load(Ordering::Relaxed) != g {
            return (Read::Stale, g);
        }
        (Read::Word(word), g)
    }

    /// Opens a read section as block `key`: the generation its words are
    /// read under, or `None` if the slot belongs to another block. Words
    /// [`Self::peek`]ed after it are the block's if [`Self::still`] holds
    /// after them: a reader of several blocks opens each once.
    #[inline]
    pub fn open(&self, key: u64) -> Option<u32> {
        let g = self.generation.load(Ordering::Acquire);
        (g & 1 == 0 && self.owner.load(Ordering::Relaxed) == key).then_some(g)
    }

    /// Word `w`, to be confirmed by [`Self::still`].
    #[inline]
    pub fn peek(&self, w: usize) -> u32 {
        self.words[w].load(Ordering::Relaxed)
    }

    /// Whether the words peeked since [`Self::open`] returned `g` were the block's.
    #[inline]
    pub fn still(&self, g: u32) -> bool {
        fence(Ordering::Acquire);
        self.generation.load(Ordering::Relaxed) == g
    }

    /// Stores `update(old)` into word `w` if the slot still has generation `g`.
    /// `update` returns `None` to leave the word alone (another writer was first).
    pub fn write(&self, g: u32, w: usize, update: impl Fn(u32) -> Option<u32>) {
        self.writers.fetch_add(1, Ordering::SeqCst);
        if self.generation.load(Ordering::SeqCst) == g {
            let _ = self.words[w].fetch_update(Ordering::Release, Ordering::Relaxed, &update);
        }
        self.writers.fetch_sub(1, Ordering::Release);
    }

    /// Hands the slot to `key` with every word unset. Called under the pool lock.
    fn reassign(&self, key: u64) {
        let g = self.generation.load(Ordering::Relaxed);
        self.generation.store(g.wrapping_add(1), Ordering::SeqCst);
        // A writer that saw the old generation may still be storing: let it finish.
        while self.writers.load(Ordering::SeqCst) != 0 {
            std::hint::spin_loop();
        }
        for w in self.words.iter() {
            w.store(UNSET, Ordering::Relaxed);
        }
        self.owner.store(key, Ordering::Relaxed);
        self.generation.store(g.wrapping_add(2), Ordering::Release);
    }

    /// Word `w`, read with exclusive access (no concurrent writers).
    #[must_use]
    pub fn word(&self, w: usize) -> u32 {
        self.words[w].load(Ordering::Relaxed)
    }

    /// Sets word `w`, with exclusive access (invalidation between renders).
    pub fn set_word(&self, w: usize, v: u32) {
        self.words[w].store(v, Ordering::Relaxed);
    }

    /// The block key holding this slot.
    #[must_use]
    pub fn owner(&self) -> u64 {
        self.owner.load(Ordering::Relaxed)
    }
}

/// Slots for all the caches of one model, with an optional byte budget.
pub struct SamplePool {
    state: Mutex<PoolState>,
    /// Advances once per slot handed out: the LRU clock.
    clock: AtomicU32,
    /// At most this many slots, if bounded.
    budget_slots: Option<usize>,
    evictions: AtomicU64,
}

#[derive(Default)]
struct PoolState {
    /// Every slot ever made; boxed so their addresses never move when the
    /// vector grows (table entries point at them).
    #[allow(clippy::vec_box)]
    slots: Vec<Box<Slot>>,
    /// Indices of slots no block holds.
    free: Vec<usize>,
    /// Slots held per cache serial.
    held: HashMap<u16, usize>,
    next_serial: u16,
}

impl Default for SamplePool {
    fn default() -> Self {
        Self::new(None)
    }
}

impl std::fmt::Debug for SamplePool {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SamplePool").field("slots", &self.slot_count()).field("budget", &self.budget_slots).finish()
    }
}

impl SamplePool {
    /// A pool of at most `budget_slots` slots (unbounded for `None`).
    #[must_use]
    pub fn new(budget_slots: Option<usize>) -> Self {
        Self {
            state: Mutex::new(PoolState::default()),
            clock: AtomicU32::new(1),
            budget_slots: budget_slots.map(|n| n.max(MIN_BUDGET_SLOTS)),
            evictions: AtomicU64::new(0),
        }
    }

    /// A fresh serial for a new cache, distinct from every live cache's.
    pub fn new_serial(&self) -> u16 {
        let mut s = self.lock();
        s.next_serial = s.next_serial.wrapping_add(1);
        s.next_serial
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, PoolState> {
        // A panic while holding the lock leaves only plain bookkeeping behind.
        self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Stores `update(old)` into word `w` of `slot`, read under generation `g`
    /// (see [`Slot::write`]). Without a budget no slot changes hands while
    /// caches are read (only edits, with exclusive access, free slots), so the
    /// store skips the writer count: two threads filling one block would
    /// otherwise trade the cache line of its generation with every sample,
    /// and every reader of the block would miss on it.
    #[inline]
    pub fn store(&self, slot: &Slot, g: u32, w: usize, update: impl Fn(u32) -> Option<u32>) {
        if self.budget_slots.is_some() {
            slot.write(g, w, update);
        } else {
            let _ = slot.words[w].fetch_update(Ordering::Release, Ordering::Relaxed, update);
        }
    }

    /// Marks `slot` as used now, so eviction passes it over (only under a budget).
    #[inline]
    pub fn touch(&self, slot: &Slot) {
        if self.budget_slots.is_some() {
            let now = self.clock.load(Ordering::Relaxed);
            if slot.last_used.load(Ordering::Relaxed) != now {
                slot.last_used.store(now, Ordering::Relaxed);
            }
        }
    }

    /// The slot for block `key`, attaching one to `entry` (the block's table
    /// entry) if the entry is empty or its slot went to another block.
    pub fn attach(&self, entry: &AtomicPtr<Slot>, key: u64) -> &Slot {
        let mut s = self.lock();
        let current = entry.load(Ordering::Acquire);
        // SAFETY: table entries only ever hold pointers to slots of this pool,
        // which live (boxed, never moved) until the pool is dropped.
        if let Some(slot) = unsafe { current.as_ref() }
            && slot.owner() == key
        {
            return slot;
        }
        let i = self.take_slot(&mut s);
        let ptr: *const Slot = &*s.slots[i];
        // SAFETY: as above.
        let slot = unsafe { &*ptr };
        let old = slot.owner();
        if old != FREE {
            self.evictions.fetch_add(1, Ordering::Relaxed);
            if let Some(n) = s.held.get_mut(&serial_of(old)) {
                *n -= 1;
            }
        }
        slot.reassign(key);
        slot.last_used.store(self.clock.fetch_add(1, Ordering::Relaxed) + 1, Ordering::Relaxed);
        *s.held.entry(serial_of(key)).or_default() += 1;
        entry.store(ptr.cast_mut(), Ordering::Release);
        slot
    }

    /// A free slot, a new one while under budget, or the least recently used.
    fn take_slot(&self, s: &mut PoolState) -> usize {
        if let Some(i) = s.free.pop() {
            return i;
        }
        if self.budget_slots.is_none_or(|b| s.slots.len() < b) {
            s.slots.push(Box::new(Slot::new()));
            return s.slots.len() - 1;
        }
        (0..s.slots.len()).min_by_key(|&i| s.slots[i].last_used.load(Ordering::Relaxed)).unwrap_or(0)
    }

    /// Frees every slot held by cache `serial` (with exclusive access to the cache).
    pub fn release(&self, serial: u16) {
        let mut s = self.lock();
        let mut freed = Vec::new();
        for (i, slot) in s.slots.iter().enumerate() {
            let owner = slot.owner();
            if owner != FREE && serial_of(owner) == serial {
                slot.reassign(FREE);
                freed.push(i);
            }
        }
        s.free.extend(freed);
        s.held.remove(&serial);
    }

    /// Slots currently held by cache `serial`.
    #[must_use]
    pub fn held(&self, serial: u16) -> usize {
        self.lock().held.get(&serial).copied().unwrap_or(0)
    }

    /// Slots allocated in all.
    #[must_use]
    pub fn slot_count(&self) -> usize {
        self.lock().slots.len()
    }

    /// Bytes of sample storage allocated in all.
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.slot_count() * SLOT_BYTES
    }

    /// The budget in slots, if any.
    #[must_use]
    pub fn budget_slots(&self) -> Option<usize> {
        self.budget_slots
    }

    /// Blocks evicted so far.
    #[must_use]
    pub fn evictions(&self) -> u64 {
        self.evictions.load(Ordering::Relaxed)
    }
}

/// The key of a block: cache serial and block coordinates, 16 bits each.
#[must_use]
pub fn block_key(serial: u16, block: glam::IVec3) -> u64 {
    let c = |v: i32| u64::from(v as i16 as u16);
    (u64::from(serial) << 48) | (c(block.x) << 32) | (c(block.y) << 16) | c(block.z)
}

fn serial_of(key: u64) -> u16 {
    (key >> 48) as u16
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_reassigned_slot_reads_stale_for_its_old_owner() {
        let pool = SamplePool::new(None);
        let entry = AtomicPtr::new(std::ptr::null_mut());
        let a = block_key(1, glam::IVec3::new(0, -1, 2));
        let slot = pool.attach(&entry, a);
        let (r, g) = slot.read(a, 5);
        assert_eq!(r, Read::Word(UNSET));
        slot.write(g, 5, |old| (old == UNSET).then_some(42));
        assert_eq!(slot.read(a, 5).0, Read::Word(42));
        pool.release(1);
        assert_eq!(slot.read(a, 5).0, Read::Stale);
        // A write under the old generation is dropped.
        slot.write(g, 5, |_| Some(7));
        assert_eq!(slot.word(5), UNSET);
    }

    #[test]
    fn a_budget_reuses_the_least_recently_used_slot() {
        let pool = SamplePool::new(Some(MIN_BUDGET_SLOTS));
        let entries: Vec<AtomicPtr<Slot>> =
            (0..MIN_BUDGET_SLOTS + 1).map(|_| AtomicPtr::new(std::ptr::null_mut())).collect();
        let key = |i: usize| block_key(3, glam::IVec3::new(i as i32, 0, 0));
        for (i, e) in entries.iter().enumerate().take(MIN_BUDGET_SLOTS) {
            pool.attach(e, key(i));
        }
        assert_eq!(pool.slot_count(), MIN_BUDGET_SLOTS);
        pool.attach(&entries[MIN_BUDGET_SLOTS], key(MIN_BUDGET_SLOTS));
        assert_eq!(pool.slot_count(), MIN_BUDGET_SLOTS);
        assert_eq!(pool.evictions(), 1);
        // Block 0 was the oldest: its slot now answers for the newest block.
        let first = unsafe { &*entries[0].load(Ordering::Acquire) };
        assert_eq!(first.read(key(0), 0).0, Read::Stale);
        assert_eq!(pool.held(3), MIN_BUDGET_SLOTS);
    }
}
