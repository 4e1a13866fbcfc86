//! Leaves listed per cell of a grid: one array of leaf indices and the
//! offsets of each cell's list in it, built by a counting sort.

use rayon::prelude::*;

use super::{IndexedLeaf, Leaf, SUPPORT_SLACK};
use crate::geom::UniformGrid;

/// Leaves listed per cell of a grid (offsets into one array of leaf indices).
#[derive(Clone, Debug)]
pub(super) struct Lists {
    pub(super) grid: UniformGrid,
    pub(super) offsets: Vec<u32>,
    pub(super) items: Vec<u32>,
}

impl Lists {
    /// The leaves reaching each cell of `grid`, in leaf order (a counting sort
    /// of (cell, leaf) pairs; the cells each leaf reaches are found in parallel).
    pub(super) fn bucket(grid: UniformGrid, leaves: &[IndexedLeaf]) -> Self {
        let reached: Vec<Vec<u32>> = leaves.par_iter().map(|leaf| reached_cells(&grid, leaf)).collect();
        let cells = grid.cell_count();
        let mut counts = vec![0u32; cells + 1];
        for &c in reached.iter().flatten() {
            counts[c as usize + 1] += 1;
        }
        for i in 0..cells {
            counts[i + 1] += counts[i];
        }
        let mut cursor = counts.clone();
        let mut items = vec![0u32; counts[cells] as usize];
        for (i, leaf_cells) in reached.iter().enumerate() {
            for &c in leaf_cells {
                items[cursor[c as usize] as usize] = i as u32;
                cursor[c as usize] += 1;
            }
        }
        Self { grid, offsets: counts, items }
    }

    pub(super) fn cell(&self, c: usize) -> &[u32] {
        &self.items[self.offsets[c] as usize..self.offsets[c + 1] as usize]
    }
}

/// The cells of `grid` where `leaf` can be non-zero: those its box overlaps,
/// less, for a primitive, those wholly outside its support (a ball's box holds
/// twice the ball, so a dense model's cells list about half as many leaves).
fn reached_cells(grid: &UniformGrid, leaf: &IndexedLeaf) -> Vec<u32> {
    let mut cells = Vec::with_capacity(grid.cells_overlapped(&leaf.bounds));
    grid.for_each_cell_at(&leaf.bounds, |i, c| {
        let reached = match &leaf.leaf {
            // A hair wider than the support, against rounding in the value.
            Leaf::Primitive(p) => p.support_reaches(&grid.box_at(i), SUPPORT_SLACK),
            Leaf::Node(_) => true,
        };
        if reached {
            cells.push(c as u32);
        }
    });
    cells
}
