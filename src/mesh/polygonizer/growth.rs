//! Continuation: the cells of a frontier examined in parallel, their corners
//! evaluated first, and the unvisited neighbours across their crossed faces
//! taken as the next frontier, until none are left.

use glam::IVec3;
use rayon::prelude::*;

use super::{MIN_PARALLEL_ITEMS, PENDING, Polygonizer, crossed};
use crate::field::Field;
use crate::mesh::lattice::{Cell, LatticePoint, sort_key};

impl Polygonizer {
    /// Marks the cells not visited yet as visited and returns them, in order.
    pub(super) fn claim(&mut self, cells: Vec<Cell>) -> Vec<Cell> {
        cells.into_iter().filter(|&c| self.cells.insert_new(c, PENDING)).collect()
    }

    /// Continuation: examine the frontier, keep its crossed cells, and move on to
    /// their unvisited neighbours across crossed faces, until none are left.
    /// Returns the crossed cells found.
    pub(super) fn grow<F: Field + ?Sized>(&mut self, field: &F, mut frontier: Vec<Cell>) -> Vec<Cell> {
        let shape = self.options.cells;
        let mut found = vec![];
        while !frontier.is_empty() {
            self.evaluate_corners(field, &frontier);
            // Masks and neighbour lists in parallel; marking cells visited in order.
            let examined: Vec<(u8, Neighbours)> = frontier
                .par_iter()
                .with_min_len(MIN_PARALLEL_ITEMS)
                .map_init(Vec::new, |scratch, &cell| {
                    let mask = self.mask(cell);
                    scratch.clear();
                    if crossed(mask, shape) {
                        shape.neighbours(cell, mask, scratch);
                    }
                    (mask, Neighbours::from(scratch.as_slice()))
                })
                .collect();
            let mut next = vec![];
            for (&cell, (mask, neighbours)) in frontier.iter().zip(examined) {
                self.cells.insert(cell, mask);
                self.stats.cells_visited += 1;
                if crossed(mask, shape) {
                    found.push(cell);
                }
                for &n in neighbours.as_slice() {
                    if self.cells.insert_new(n, PENDING) {
                        next.push(n);
                    }
                }
            }
            frontier = next;
        }
        found
    }

    /// Evaluates, in parallel, the corners of `cells` not known yet.
    fn evaluate_corners<F: Field + ?Sized>(&mut self, field: &F, cells: &[Cell]) {
        let shape = self.options.cells;
        let corners = &self.corners;
        let mut missing: Vec<LatticePoint> = cells
            .par_iter()
            .with_min_len(MIN_PARALLEL_ITEMS)
            .flat_map_iter(|&cell| {
                let (v, n) = shape.vertices(cell);
                (0..n).map(move |i| v[i]).filter(|&q| !corners.contains(q))
            })
            .collect();
        missing.par_sort_unstable_by_key(|&q| sort_key(q));
        missing.dedup();
        let lattice = self.lattice;
        let values: Vec<f32> =
            missing.par_iter().with_min_len(MIN_PARALLEL_ITEMS).map(|&q| field.value(lattice.position(q))).collect();
        self.stats.corner_evals += missing.len() as u64;
        self.corners.extend(missing.into_iter().zip(values));
    }

    /// Bit `i` set when vertex `i` of `cell` is inside.
    fn mask(&self, cell: Cell) -> u8 {
        let t = self.threshold;
        let (v, n) = self.options.cells.vertices(cell);
        (0..n).filter(|&i| self.corners.value(v[i]) > t).fold(0u8, |m, i| m | 1 << i)
    }

    /// Every crossed cell with its mask.
    pub(super) fn crossed_with_masks(&self) -> Vec<(Cell, u8)> {
        let shape = self.options.cells;
        self.cells.iter().filter(|&(_, m)| crossed(m, shape)).collect()
    }
}

/// The neighbours of one cell to visit (at most six, across the faces of a cube).
struct Neighbours {
    cells: [Cell; 6],
    len: u8,
}

impl Neighbours {
    fn as_slice(&self) -> &[Cell] {
        &self.cells[..usize::from(self.len)]
    }
}

impl From<&[Cell]> for Neighbours {
    fn from(found: &[Cell]) -> Self {
        let mut cells = [Cell { cube: IVec3::ZERO, sub: 0 }; 6];
        cells[..found.len()].copy_from_slice(found);
        Self { cells, len: found.len() as u8 }
    }
}
