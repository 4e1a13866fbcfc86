//! Vertices on the crossed edges, with their normals and colours, placed
//! block by block in parallel: each block of 8³ cubes takes the crossed
//! edges its cubes own and keeps their vertices in the order of the edges.

use glam::{IVec3, Vec3, Vec3A};
use rayon::prelude::*;

use super::{CellShape, Polygonizer, crossed};
use crate::field::{DEFAULT_COLOR, Field};
use crate::mesh::corners::CornerCursor;
use crate::mesh::cubes;
use crate::mesh::edge_vertices::{Channels, EdgeBlock, EdgeNumber, EdgeVertex, ends_of, key_at, locate};
use crate::mesh::lattice::{Cell, Lattice, LatticePoint, edge_key};
use crate::mesh::vertex::{VertexPlacement, place_on_edge};

/// What placing one vertex reads.
struct Placer<'a, F: ?Sized> {
    field: &'a F,
    lattice: Lattice,
    placement: VertexPlacement,
    with_colors: bool,
}

impl<F: Field + ?Sized> Placer<'_, F> {
    /// The vertex on the crossed edge `a`–`b` (lower end first), and the
    /// evaluations its root took.
    fn place(&self, corners: &mut CornerCursor<'_>, [a, b]: [LatticePoint; 2]) -> (EdgeVertex, u32) {
        let mut ends = |q: LatticePoint| (self.lattice.position(q), corners.value(q));
        let (a, b) = (ends(a), ends(b));
        let (p, evals) = place_on_edge(self.field, a, b, self.placement);
        let (gradient, color) = match (self.placement, self.with_colors) {
            // A preview spends nothing on normals: the mesh's face normals stand in.
            (VertexPlacement::Linear, true) => (Vec3A::ZERO, self.field.color(p)),
            (VertexPlacement::Linear, false) => (Vec3A::ZERO, DEFAULT_COLOR),
            (VertexPlacement::Root { .. }, true) => self.field.gradient_and_color(p),
            (VertexPlacement::Root { .. }, false) => (self.field.gradient(p), DEFAULT_COLOR),
        };
        let normal = Vec3::from(-gradient).normalize_or_zero();
        (EdgeVertex { position: p.into(), normal, color }, evals)
    }
}

/// A block's vertices to fill and the edges it is asked for, ascending.
struct Work {
    block: IVec3,
    vertices: EdgeBlock,
    wanted: Vec<EdgeNumber>,
}

impl Polygonizer {
    /// Places a vertex on every crossed edge of every crossed cell: for
    /// cubes, each block takes its own cubes' edges straight from its
    /// brick of visited cells.
    pub(super) fn place_all_vertices<F: Field + ?Sized>(&mut self, field: &F) {
        if self.options.cells != CellShape::Cubes {
            let crossed = self.crossed_with_masks();
            self.place_vertices(field, &crossed);
            return;
        }
        let bricks = self.cells.bricks_in_order();
        let kinds = self.vertices.kinds();
        // A cube's axis edges are its edge kinds 0, 1, 2 (see `edge_vertices`).
        let wanted: Vec<Vec<EdgeNumber>> = bricks
            .par_iter()
            .map(|(_, brick)| {
                let mut wanted = vec![];
                for (slot, mask) in brick.visited() {
                    if crossed(mask, CellShape::Cubes) {
                        wanted.extend(cubes::owned_crossed_axes(mask).map(|axis| (slot * kinds + axis) as EdgeNumber));
                    }
                }
                wanted
            })
            .collect();
        let blocks: Vec<IVec3> = bricks.into_iter().map(|(block, _)| block).collect();
        let work = blocks
            .into_iter()
            .zip(wanted)
            .map(|(block, wanted)| Work { block, vertices: self.vertices.take(block), wanted })
            .collect();
        self.fill(field, work);
    }

    /// Places a vertex on every crossed edge of `cells` that has none yet.
    pub(super) fn place_vertices<F: Field + ?Sized>(&mut self, field: &F, cells: &[(Cell, u8)]) {
        let (shape, kinds, known) = (self.options.cells, self.vertices.kinds(), &self.vertices);
        // A local update's cells keep most of their vertices; a first
        // polygonization has none to look up.
        let none_known = known.is_empty();
        const CELLS_PER_TASK: usize = 1024;
        let mut wanted: Vec<(u128, IVec3, EdgeNumber)> = cells
            .par_chunks(CELLS_PER_TASK)
            .flat_map_iter(|chunk| {
                let mut edges = Vec::with_capacity(chunk.len() * 2);
                for &(cell, mask) in chunk {
                    shape.crossed_edges(cell, mask, &mut edges);
                }
                edges
                    .into_iter()
                    .map(|[a, b]| edge_key(a, b))
                    .filter(move |&key| none_known || !known.contains(key))
                    .map(move |key| {
                        let (block, number) = locate(kinds, key);
                        (Cell { cube: block, sub: 0 }.order_key(), block, number)
                    })
            })
            .collect();
        wanted.par_sort_unstable_by_key(|&(order, _, number)| (order, number));
        wanted.dedup();
        let work: Vec<Work> = wanted
            .chunk_by(|a, b| a.1 == b.1)
            .map(|run| Work {
                block: run[0].1,
                vertices: self.vertices.take(run[0].1),
                wanted: run.iter().map(|&(_, _, number)| number).collect(),
            })
            .collect();
        self.fill(field, work);
    }

    /// The channels vertices keep: normals where they come from the field,
    /// colours where the model has more than one.
    fn channels(&self) -> Channels {
        Channels { normals: self.options.vertex != VertexPlacement::Linear, colors: self.with_colors }
    }

    /// Fills each block of `work` with the vertices it is asked for, in
    /// parallel, and puts the blocks back.
    fn fill<F: Field + ?Sized>(&mut self, field: &F, work: Vec<Work>) {
        let placer =
            Placer { field, lattice: self.lattice, placement: self.options.vertex, with_colors: self.with_colors };
        let (corners, kinds, channels) = (&self.corners, self.vertices.kinds(), self.channels());
        let filled: Vec<(IVec3, EdgeBlock, u64, u64)> = work
            .into_par_iter()
            .map_init(
                || corners.cursor(),
                |cursor, Work { block, mut vertices, wanted }| {
                    let (mut evals, mut placed) = (0u64, 0u64);
                    vertices.add(kinds, channels, wanted, |number| {
                        let (vertex, e) = placer.place(cursor, ends_of(key_at(kinds, block, number)));
                        evals += u64::from(e);
                        placed += 1;
                        vertex
                    });
                    (block, vertices, evals, placed)
                },
            )
            .collect();
        for (block, vertices, evals, placed) in filled {
            self.vertices.put(block, vertices);
            self.stats.root_evals += evals;
            if self.options.vertex != VertexPlacement::Linear {
                self.stats.gradient_evals += placed;
            }
            if self.with_colors {
                self.stats.color_evals += placed;
            }
        }
    }
}
