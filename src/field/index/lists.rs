//! Leaves listed per cell of a grid: one array of leaf indices and the
//! offsets of each cell's list in it, built by a counting sort.

use rayon::prelude::*;

use super::{IndexedLeaf, Leaf, Leaves, SUPPORT_SLACK};
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
    /// of (cell, leaf) pairs; the cells each leaf reaches are found in
    /// parallel, a run of leaves into one flat list, not one list a leaf).
    pub(super) fn bucket(grid: UniformGrid, leaves: &Leaves) -> Self {
        let runs: Vec<Run> = (0..leaves.len().div_ceil(RUN))
            .into_par_iter()
            .map(|r| reached_by_run(&grid, leaves, r * RUN..leaves.len().min((r + 1) * RUN)))
            .collect();
        let cells = grid.cell_count();
        let mut counts = vec![0u32; cells + 1];
        for run in &runs {
            for &c in &run.cells {
                counts[c as usize + 1] += 1;
            }
        }
        for i in 0..cells {
            counts[i + 1] += counts[i];
        }
        let mut cursor = counts.clone();
        let mut items = vec![0u32; counts[cells] as usize];
        for (r, run) in runs.iter().enumerate() {
            let mut start = 0;
            for (k, &end) in run.ends.iter().enumerate() {
                let leaf = (r * RUN + k) as u32;
                for &c in &run.cells[start..end as usize] {
                    items[cursor[c as usize] as usize] = leaf;
                    cursor[c as usize] += 1;
                }
                start = end as usize;
            }
        }
        Self { grid, offsets: counts, items }
    }

    pub(super) fn cell(&self, c: usize) -> &[u32] {
        &self.items[self.offsets[c] as usize..self.offsets[c + 1] as usize]
    }
}

/// Leaves whose reached cells one task lists together.
const RUN: usize = 4096;

/// The cells a run of leaves reaches: each leaf's in turn, in one list,
/// and where each leaf's end.
struct Run {
    cells: Vec<u32>,
    ends: Vec<u32>,
}

fn reached_by_run(grid: &UniformGrid, leaves: &Leaves, run: std::ops::Range<usize>) -> Run {
    let mut cells = vec![];
    let ends = run
        .map(|i| {
            reached_cells(grid, &leaves.get(i), &mut cells);
            cells.len() as u32
        })
        .collect();
    Run { cells, ends }
}

/// Adds to `cells` the cells of `grid` where `leaf` can be non-zero: those
/// its box overlaps, less, for a primitive, those wholly outside its support
/// (a ball's box holds twice the ball, so a dense model's cells list about
/// half as many leaves).
fn reached_cells(grid: &UniformGrid, leaf: &IndexedLeaf, cells: &mut Vec<u32>) {
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
}
