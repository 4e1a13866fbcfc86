//! Footprints the caches gathered lately, kept per thread.
//!
//! Successive questions to a cache often read the same footprint: a root
//! found on a lattice edge shorter than the cache's cell asks two or three
//! points of one tri-linear cell, and the steps of a ray through a wide cell
//! ask the same eight samples again. A gathered footprint stays what it is
//! until the cache changes, and every change to a cache takes it by `&mut`
//! and gives it a new [`GatherId`]; so a footprint kept under the id it was
//! gathered with is the footprint a new gather would return, to the bit
//! (filling samples, evicting blocks and learning which block parts are zero
//! never change what a lattice point reads).

use std::cell::RefCell;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::IVec3;

/// Names one state of one cache: no two caches, and no two states of a
/// cache between changes, share one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GatherId(u64);

impl GatherId {
    /// A name no cache state has had.
    pub fn fresh() -> Self {
        static NEXT: AtomicU64 = AtomicU64::new(1);
        GatherId(NEXT.fetch_add(1, Ordering::Relaxed))
    }
}

/// Footprints kept per thread, in a table indexed by a hash of the cache
/// state, the footprint's first lattice point and its width; each holds the
/// last footprint that hashed to it. In a cold polygonization of Medusa at
/// res 512, where a cache cell spans one to three lattice cells, 256 of them
/// spared 12% of the instructions (a cube's neighbouring corners, and a
/// vertex's root and gradient, read footprints gathered a moment before), one
/// per cache and width 6%, and 1024 a further 1.4%.
const SLOT_BITS: u32 = 8;
const SLOTS: usize = 1 << SLOT_BITS;

#[derive(Clone, Copy)]
struct Kept {
    id: u64,
    first: IVec3,
    taps: usize,
    samples: [f32; 27],
}

const EMPTY: Kept = Kept { id: 0, first: IVec3::ZERO, taps: 0, samples: [0.0; 27] };

thread_local! {
    static KEPT: RefCell<[Kept; SLOTS]> = const { RefCell::new([EMPTY; SLOTS]) };
}

/// The table entry for a footprint: the top bits of a multiplicative hash.
fn slot(id: GatherId, first: IVec3, taps: usize) -> usize {
    let h = (id.0 as u32).wrapping_mul(0x9E37_79B9)
        ^ (first.x as u32).wrapping_mul(0x85EB_CA6B)
        ^ (first.y as u32).wrapping_mul(0xC2B2_AE35)
        ^ (first.z as u32).wrapping_mul(0x27D4_EB2F)
        ^ (taps as u32).wrapping_mul(0x1656_67B1);
    (h >> (32 - SLOT_BITS)) as usize
}

/// The footprint of `taps³` samples from `first` this thread last gathered
/// from the cache state `id`, if it is the one kept.
#[inline]
pub fn recall(id: GatherId, first: IVec3, taps: usize) -> Option<[f32; 27]> {
    KEPT.with_borrow(|kept| {
        let k = &kept[slot(id, first, taps)];
        (k.id == id.0 && k.first == first && k.taps == taps).then_some(k.samples)
    })
}

/// Keeps `samples`, the footprint of `taps³` samples from `first` of the cache state `id`.
#[inline]
pub fn keep(id: GatherId, first: IVec3, taps: usize, samples: &[f32; 27]) {
    KEPT.with_borrow_mut(|kept| kept[slot(id, first, taps)] = Kept { id: id.0, first, taps, samples: *samples });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_footprint_is_recalled_only_under_its_own_id_place_and_width() {
        let (a, b) = (GatherId::fresh(), GatherId::fresh());
        let first = IVec3::new(3, -2, 7);
        let mut samples = [0.0; 27];
        samples[5] = 1.5;
        keep(a, first, 2, &samples);
        assert_eq!(recall(a, first, 2).map(|s| s[5]), Some(1.5));
        assert!(recall(b, first, 2).is_none(), "another cache state");
        assert!(recall(a, first + IVec3::X, 2).is_none(), "another footprint");
        assert!(recall(a, first, 3).is_none(), "another filter width");
        // Another width's footprint may take the entry, never answer for this one.
        keep(a, first, 3, &[2.0; 27]);
        assert!(recall(a, first, 2).is_none_or(|s| s[5] == 1.5));
        assert_eq!(recall(a, first, 3).map(|s| s[0]), Some(2.0));
        // Other threads keep their own.
        let elsewhere = std::thread::spawn(move || recall(a, first, 2).is_none()).join().unwrap();
        assert!(elsewhere);
    }
}
