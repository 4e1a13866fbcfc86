//! Continuation, block by block. The lattice's cubes fall into blocks of
//! 8³ (the bricks the visited cells are stored in). Each block with cells to
//! examine is grown on one thread, depth first and wholly inside the block:
//! its cells' corners are read and evaluated in a patch of corner bricks the
//! thread owns, and neighbours across crossed faces that lie in other blocks
//! are handed to those. Blocks run in eight alternating classes (by the
//! parity of their coordinates), so two blocks growing at once never share a
//! corner brick.
//!
//! The cells visited are those reachable from the frontier across crossed
//! faces, whatever the order, and each corner is evaluated once, by the one
//! thread owning it: the result and the evaluation count are the same for
//! any number of threads.

use glam::IVec3;
use rayon::prelude::*;
use rustc_hash::FxHashMap;

use super::{CellShape, PENDING, Polygonizer, crossed};
use crate::field::Field;
use crate::mesh::corners::CornerPatch;
use crate::mesh::lattice::{Cell, Lattice};
use crate::mesh::visited::{self, BRICK_SHIFT as BLOCK_SHIFT};

impl Polygonizer {
    /// Marks the cells not visited yet as visited and returns them, in order.
    pub(super) fn claim(&mut self, cells: Vec<Cell>) -> Vec<Cell> {
        cells.into_iter().filter(|&c| self.cells.insert_new(c, PENDING)).collect()
    }

    /// Continuation: examines the frontier (cells claimed, not examined yet)
    /// and every cell reachable from it across crossed faces. Returns the
    /// crossed cells found (in an order fixed by the frontier) if `listed`
    /// (a local update's new cells), none otherwise.
    pub(super) fn grow<F: Field + ?Sized>(&mut self, field: &F, frontier: Vec<Cell>, listed: bool) -> Vec<Cell> {
        let mut pending: FxHashMap<IVec3, Seeds> = FxHashMap::default();
        for cell in frontier {
            pending.entry(block_of(cell)).or_default().claimed.push(cell);
        }
        let mut found = vec![];
        let mut class = 0;
        while !pending.is_empty() {
            let mut batch: Vec<(IVec3, Seeds)> = vec![];
            pending.retain(|&block, cells| {
                let taken = parity_class(block) == class;
                if taken {
                    batch.push((block, std::mem::take(cells)));
                }
                !taken
            });
            class = (class + 1) % 8;
            // In a fixed order, so that the stores are filled the same way every run.
            batch.sort_unstable_by_key(|(block, _)| Cell { cube: *block, sub: 0 }.order_key());
            if !batch.is_empty() {
                self.grow_blocks(field, batch, listed.then_some(&mut found), &mut pending);
            }
        }
        found
    }

    /// Grows the blocks of one class in parallel, then files the cells they
    /// reached in other blocks as those blocks' work.
    fn grow_blocks<F: Field + ?Sized>(
        &mut self,
        field: &F,
        batch: Vec<(IVec3, Seeds)>,
        mut found: Option<&mut Vec<Cell>>,
        pending: &mut FxHashMap<IVec3, Seeds>,
    ) {
        let blocks: Vec<Block> = batch
            .into_iter()
            .map(|(base, seeds)| Block {
                base,
                corners: self.corners.take_patch(base),
                cells: self.cells.take(base),
                seeds,
            })
            .collect();
        let context = BlockContext {
            lattice: self.lattice,
            shape: self.options.cells,
            threshold: self.threshold,
            listed: found.is_some(),
        };
        let grown: Vec<Grown> = blocks.into_par_iter().map(|block| block.grow(field, &context, &self.cells)).collect();
        for g in grown {
            self.corners.put_patch(g.corners);
            self.cells.put(g.base, g.cells);
            self.stats.corner_evals += g.evaluated;
            self.stats.cells_visited += g.examined;
            if let Some(found) = found.as_deref_mut() {
                found.extend(g.crossed);
            }
            // One look at each block reached: cells it has visited already are passed over.
            for run in g.leaving.chunk_by(|a, b| block_of(*a) == block_of(*b)) {
                let block = block_of(run[0]);
                let brick = self.cells.brick(block);
                let new = |&&c: &&Cell| brick.is_none_or(|b| b.get(self.cells.brick_and_slot(c).1).is_none());
                let mut new = run.iter().filter(new).peekable();
                if new.peek().is_some() {
                    pending.entry(block).or_default().arrived.extend(new);
                }
            }
        }
    }

    /// Every crossed cell with its mask, in the canonical order of
    /// [`crate::mesh::visited::VisitedCells::in_order`].
    pub(super) fn crossed_with_masks(&self) -> Vec<(Cell, u8)> {
        let shape = self.options.cells;
        self.cells.in_order(|m| crossed(m, shape))
    }
}

/// The block of 8³ cubes holding `cell`.
fn block_of(cell: Cell) -> IVec3 {
    cell.cube >> BLOCK_SHIFT
}

/// One of eight classes: blocks of one class are two apart along some axis.
fn parity_class(block: IVec3) -> u8 {
    (block.x & 1 | (block.y & 1) << 1 | (block.z & 1) << 2) as u8
}

/// What every block's growth reads.
struct BlockContext {
    lattice: Lattice,
    shape: CellShape,
    threshold: f32,
    /// Whether the crossed cells examined are listed.
    listed: bool,
}

/// The cells of a block waiting to be examined.
#[derive(Default)]
struct Seeds {
    /// Cells already marked visited (claimed).
    claimed: Vec<Cell>,
    /// Cells reached from other blocks, to be examined unless the block
    /// has visited them by the time it grows (some may repeat).
    arrived: Vec<Cell>,
}

/// A block to grow, with the stores it owns while it grows.
struct Block {
    base: IVec3,
    corners: CornerPatch,
    cells: visited::Brick,
    seeds: Seeds,
}

/// A grown block: its stores to put back and what it found.
struct Grown {
    base: IVec3,
    corners: CornerPatch,
    cells: visited::Brick,
    /// Crossed cells examined (if the context lists them).
    crossed: Vec<Cell>,
    /// Neighbours across crossed faces in other blocks, block by block.
    leaving: Vec<Cell>,
    evaluated: u64,
    examined: u64,
}

impl Block {
    /// Examines the seeds and every cell of the block reachable from them
    /// across crossed faces, depth first. `all` locates cells in bricks.
    fn grow<F: Field + ?Sized>(mut self, field: &F, c: &BlockContext, all: &visited::VisitedCells) -> Grown {
        let mut grown = Grown {
            base: self.base,
            corners: self.corners,
            cells: self.cells,
            crossed: vec![],
            leaving: vec![],
            evaluated: 0,
            examined: 0,
        };
        let mut stack = std::mem::take(&mut self.seeds.claimed);
        for cell in std::mem::take(&mut self.seeds.arrived) {
            let slot = all.brick_and_slot(cell).1;
            if grown.cells.get(slot).is_none() {
                grown.cells.set(slot, PENDING);
                stack.push(cell);
            }
        }
        let mut neighbours = Vec::with_capacity(6);
        while let Some(cell) = stack.pop() {
            let mask = grown.mask(field, c, cell);
            grown.cells.set(all.brick_and_slot(cell).1, mask);
            grown.examined += 1;
            if !crossed(mask, c.shape) {
                continue;
            }
            if c.listed {
                grown.crossed.push(cell);
            }
            neighbours.clear();
            c.shape.neighbours(cell, mask, &mut neighbours);
            for &n in &neighbours {
                let (block, slot) = all.brick_and_slot(n);
                if block != self.base {
                    grown.leaving.push(n);
                } else if grown.cells.get(slot).is_none() {
                    grown.cells.set(slot, PENDING);
                    stack.push(n);
                }
            }
        }
        grown.leaving.sort_unstable_by_key(|&c| block_of(c).to_array());
        grown
    }
}

impl Grown {
    /// Bit `i` set when vertex `i` of `cell` is inside; vertices not known yet evaluated.
    fn mask<F: Field + ?Sized>(&mut self, field: &F, c: &BlockContext, cell: Cell) -> u8 {
        if c.shape == CellShape::Cubes {
            let (values, evaluated) = self.corners.cube_values(cell.cube * 2, |q| field.value(c.lattice.position(q)));
            self.evaluated += evaluated;
            return values.iter().enumerate().fold(0, |mask, (i, &v)| mask | u8::from(v > c.threshold) << i);
        }
        let (v, n) = c.shape.vertices(cell);
        let mut mask = 0;
        for (i, &q) in v[..n].iter().enumerate() {
            let value = self.corners.get(q).unwrap_or_else(|| {
                let value = field.value(c.lattice.position(q));
                self.corners.set(q, value);
                self.evaluated += 1;
                value
            });
            mask |= u8::from(value > c.threshold) << i;
        }
        mask
    }
}
