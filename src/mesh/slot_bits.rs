//! Bit sets of held slots: which points of a brick of corner values, or
//! cells of a brick of visited cells, hold something.

/// Whether slot `slot` is held.
#[inline]
pub(super) fn is_held(held: &[u64], slot: usize) -> bool {
    held[slot / 64] >> (slot % 64) & 1 == 1
}

/// Marks slot `slot` held.
#[inline]
pub(super) fn hold(held: &mut [u64], slot: usize) {
    held[slot / 64] |= 1 << (slot % 64);
}

/// Marks slot `slot` free.
#[inline]
pub(super) fn release(held: &mut [u64], slot: usize) {
    held[slot / 64] &= !(1 << (slot % 64));
}

/// Whether no slot is held.
pub(super) fn none_held(held: &[u64]) -> bool {
    held.iter().all(|&w| w == 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slots_are_held_and_released_one_by_one() {
        let mut held = [0u64; 3];
        assert!(none_held(&held));
        for slot in [0, 63, 64, 130] {
            hold(&mut held, slot);
        }
        assert!([0, 63, 64, 130].iter().all(|&s| is_held(&held, s)));
        assert!(!is_held(&held, 1) && !is_held(&held, 129));
        for slot in [0, 63, 64, 130] {
            release(&mut held, slot);
        }
        assert!(none_held(&held));
    }
}
