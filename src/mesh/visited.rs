//! The cells continuation has visited and their inside masks, kept in bricks
//! of 8³ cubes.
//!
//! Growth asks about a visited cell's neighbours far more often than it
//! visits one: a cell keyed map scattered them over memory (at res 512 some
//! 330 000 cells, and two million lookups in the serial part of each growth
//! wave, nearly all of them cache misses). A brick holds a cube's cells next
//! to its neighbours', so consecutive lookups land in a brick just read.

use glam::IVec3;
use rayon::prelude::*;
use rustc_hash::FxHashMap;

use super::lattice::Cell;
use super::slot_bits;

/// Cubes along each side of a brick, as a power of two: the polygonizer's
/// blocks (growth, vertices and assembly go brick by brick).
pub(super) const BRICK_SHIFT: i32 = 3;
/// Cubes in a brick.
pub(super) const BRICK_CUBES: usize = 1 << (3 * BRICK_SHIFT);

/// One brick's cells: which are visited, and their masks.
#[derive(Clone, Debug)]
pub(super) struct Brick {
    visited: Box<[u64]>,
    masks: Box<[u8]>,
}

impl Brick {
    fn new(slots: usize) -> Self {
        Self { visited: vec![0; slots.div_ceil(64)].into_boxed_slice(), masks: vec![0; slots].into_boxed_slice() }
    }

    /// The mask of the cell in `slot`, if visited.
    #[inline]
    pub fn get(&self, slot: usize) -> Option<u8> {
        slot_bits::is_held(&self.visited, slot).then(|| self.masks[slot])
    }

    /// Marks the cell in `slot` visited with `mask`.
    #[inline]
    pub fn set(&mut self, slot: usize, mask: u8) {
        slot_bits::hold(&mut self.visited, slot);
        self.masks[slot] = mask;
    }

    fn forget(&mut self, slot: usize) {
        slot_bits::release(&mut self.visited, slot);
    }

    /// The visited slots with their masks, in slot order.
    pub fn visited(&self) -> impl Iterator<Item = (usize, u8)> + '_ {
        self.visited.iter().enumerate().flat_map(move |(w, &word)| {
            let mut bits = word;
            std::iter::from_fn(move || {
                (bits != 0).then(|| {
                    let slot = w * 64 + bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    (slot, self.masks[slot])
                })
            })
        })
    }

    fn is_empty(&self) -> bool {
        slot_bits::none_held(&self.visited)
    }
}

/// Visited cells with their masks, by cell. The cells of one cube (one for
/// cubes, twelve tetrahedra for BCC) sit side by side.
#[derive(Clone, Debug)]
pub(super) struct VisitedCells {
    cells_per_cube: usize,
    bricks: FxHashMap<IVec3, Brick>,
}

impl VisitedCells {
    /// No cell visited, for cubes holding `cells_per_cube` cells each.
    pub fn new(cells_per_cube: usize) -> Self {
        Self { cells_per_cube, bricks: FxHashMap::default() }
    }

    /// Where cell `c` lives: its brick and its slot there.
    #[inline]
    fn locate(&self, c: Cell) -> (IVec3, usize) {
        (c.cube >> BRICK_SHIFT, cube_slot(c.cube) * self.cells_per_cube + usize::from(c.sub))
    }

    /// The mask of cell `c`, if visited.
    #[inline]
    pub fn get(&self, c: Cell) -> Option<u8> {
        let (brick, slot) = self.locate(c);
        self.bricks.get(&brick).and_then(|b| b.get(slot))
    }

    /// Cell `c`'s brick, made if it has none yet, and its slot there.
    #[inline]
    fn brick_for(&mut self, c: Cell) -> (&mut Brick, usize) {
        let (brick, slot) = self.locate(c);
        let slots = BRICK_CUBES * self.cells_per_cube;
        (self.bricks.entry(brick).or_insert_with(|| Brick::new(slots)), slot)
    }

    /// Marks `c` visited with `mask` if it was not; true if it was not.
    #[inline]
    pub fn insert_new(&mut self, c: Cell, mask: u8) -> bool {
        let (b, slot) = self.brick_for(c);
        let new = b.get(slot).is_none();
        if new {
            b.set(slot, mask);
        }
        new
    }

    /// The brick holding `c` and `c`'s slot in it.
    #[inline]
    pub fn brick_and_slot(&self, c: Cell) -> (IVec3, usize) {
        self.locate(c)
    }

    /// Takes out the brick `b` (an empty one where none was) for one thread to own.
    pub fn take(&mut self, b: IVec3) -> Brick {
        self.bricks.remove(&b).unwrap_or_else(|| Brick::new(BRICK_CUBES * self.cells_per_cube))
    }

    /// Puts a brick taken out back (nothing, if it is empty).
    pub fn put(&mut self, b: IVec3, brick: Brick) {
        if !brick.is_empty() {
            self.bricks.insert(b, brick);
        }
    }

    /// Brick `b`, if it holds visited cells.
    #[inline]
    pub fn brick(&self, b: IVec3) -> Option<&Brick> {
        self.bricks.get(&b)
    }

    /// Cells per cube.
    pub fn cells_per_cube(&self) -> usize {
        self.cells_per_cube
    }

    /// The bricks, in the canonical order of [`Self::in_order`].
    pub fn bricks_in_order(&self) -> Vec<(IVec3, &Brick)> {
        let mut bricks: Vec<(IVec3, &Brick)> = self.bricks.iter().map(|(&b, brick)| (b, brick)).collect();
        bricks.sort_unstable_by_key(|(b, _)| Cell { cube: *b, sub: 0 }.order_key());
        bricks
    }

    /// The visited cells whose masks pass `keep`, with their masks, in a
    /// canonical order: bricks by z, y, x, and cells in a brick by z, y, x
    /// and sub-cell. Gathered in parallel, brick by brick.
    pub fn in_order(&self, keep: impl Fn(u8) -> bool + Sync + Send) -> Vec<(Cell, u8)> {
        let per_cube = self.cells_per_cube;
        self.bricks_in_order()
            .par_iter()
            .flat_map_iter(|&(brick, b)| {
                let keep = &keep;
                b.visited().filter(move |&(_, m)| keep(m)).map(move |(slot, m)| (cell_of(per_cube, brick, slot), m))
            })
            .collect()
    }

    /// Every visited cell with its mask, brick by brick.
    pub fn iter(&self) -> impl Iterator<Item = (Cell, u8)> + '_ {
        self.bricks.iter().flat_map(move |(&brick, b)| {
            (0..b.masks.len())
                .filter_map(move |slot| b.get(slot).map(|m| (cell_of(self.cells_per_cube, brick, slot), m)))
        })
    }

    /// Drops the cells for which `keep` fails among those of the bricks
    /// meeting the cubes `lo..=hi` (it sees each of them once); every other
    /// cell is kept unread, as a local update's hole leaves most of them.
    pub fn retain_near(&mut self, (lo, hi): (IVec3, IVec3), mut keep: impl FnMut(Cell, u8) -> bool) {
        let per_cube = self.cells_per_cube;
        let (first, last) = (lo >> BRICK_SHIFT, hi >> BRICK_SHIFT);
        self.bricks.retain(|&brick, b| {
            if brick.cmplt(first).any() || brick.cmpgt(last).any() {
                return true;
            }
            for slot in 0..b.masks.len() {
                if let Some(m) = b.get(slot)
                    && !keep(cell_of(per_cube, brick, slot), m)
                {
                    b.forget(slot);
                }
            }
            !b.is_empty()
        });
    }
}

/// The place of cube `cube` among its brick's cubes, x fastest.
#[inline]
pub(super) fn cube_slot(cube: IVec3) -> usize {
    let within = cube & IVec3::splat((1 << BRICK_SHIFT) - 1);
    (within.x | within.y << BRICK_SHIFT | within.z << (2 * BRICK_SHIFT)) as usize
}

/// The cube in place `slot` of brick `brick` (see [`cube_slot`]).
pub(super) fn cube_at(brick: IVec3, slot: usize) -> IVec3 {
    let (slot, side) = (slot as i32, (1 << BRICK_SHIFT) - 1);
    let within = IVec3::new(slot & side, (slot >> BRICK_SHIFT) & side, slot >> (2 * BRICK_SHIFT));
    (brick << BRICK_SHIFT) + within
}

/// The cell in slot `slot` of brick `brick`, its cubes holding `per_cube` cells each.
pub(super) fn cell_of(per_cube: usize, brick: IVec3, slot: usize) -> Cell {
    Cell { cube: cube_at(brick, slot / per_cube), sub: (slot % per_cube) as u8 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_are_found_again_as_kept_and_forgotten_as_asked() {
        for per_cube in [1usize, 12] {
            let mut visited = VisitedCells::new(per_cube);
            let cells: Vec<Cell> = (0..200)
                .map(|k: i32| Cell {
                    cube: IVec3::new(k % 13 - 6, (k * 7) % 17 - 8, k / 9 - 11),
                    sub: (k as usize % per_cube) as u8,
                })
                .collect();
            for (k, &c) in cells.iter().enumerate() {
                assert!(visited.insert_new(c, k as u8), "{c:?} was new");
                assert!(!visited.insert_new(c, 0), "{c:?} is known now");
            }
            for (k, &c) in cells.iter().enumerate() {
                assert_eq!(visited.get(c), Some(k as u8));
            }
            let mut listed: Vec<(Cell, u8)> = visited.iter().collect();
            listed.sort_by_key(|&(c, _)| c.order_key());
            let mut expected: Vec<(Cell, u8)> = cells.iter().enumerate().map(|(k, &c)| (c, k as u8)).collect();
            expected.sort_by_key(|&(c, _)| c.order_key());
            assert_eq!(listed, expected);
            // In order: brick by brick, and by lattice position within one.
            let ordered = visited.in_order(|m| m % 2 == 1);
            let brick_then_cell = |c: &Cell| (Cell { cube: c.cube >> BRICK_SHIFT, sub: 0 }.order_key(), c.order_key());
            assert!(ordered.windows(2).all(|w| brick_then_cell(&w[0].0) < brick_then_cell(&w[1].0)));
            assert_eq!(ordered.len(), expected.iter().filter(|(_, m)| m % 2 == 1).count());
            // Bricks below z = -8 are not asked about; the others keep what has z < 0.
            visited.retain_near((IVec3::splat(-8), IVec3::splat(100)), |c, _| c.cube.z < 0);
            for &c in &cells {
                assert_eq!(visited.get(c).is_some(), c.cube.z < 0, "{c:?}");
            }
            visited.retain_near((IVec3::splat(-100), IVec3::new(100, 100, -9)), |_, _| false);
            for &c in &cells {
                assert_eq!(visited.get(c).is_some(), (-8..0).contains(&c.cube.z), "{c:?}");
            }
            assert_eq!(visited.get(Cell { cube: IVec3::new(100, 0, 0), sub: 0 }), None);
        }
    }
}
