//! Vertices on the crossed edges, with their normals and colours: placed in
//! parallel, in the order of the edges' lattice positions.

use glam::{Vec3, Vec3A};
use rayon::prelude::*;

use super::{MIN_PARALLEL_ITEMS, Polygonizer};
use crate::field::{DEFAULT_COLOR, Field};
use crate::mesh::edge_vertices::EdgeVertex;
use crate::mesh::lattice::{Cell, LatticePoint, edge_key, sort_key};
use crate::mesh::vertex::{VertexPlacement, place_on_edge};

impl Polygonizer {
    /// Places a vertex, with its normal and colour, on every crossed edge of
    /// `crossed_cells` that has none yet; in parallel.
    pub(super) fn place_vertices<F: Field + ?Sized>(&mut self, field: &F, crossed_cells: &[(Cell, u8)]) {
        let shape = self.options.cells;
        let known = &self.vertices;
        // A first polygonization has no vertex to look up.
        let none_known = known.len() == 0;
        const CELLS_PER_TASK: usize = 1024;
        let parts: Vec<Vec<[LatticePoint; 2]>> = crossed_cells
            .par_chunks(CELLS_PER_TASK)
            .map(|chunk| {
                let mut crossed = Vec::with_capacity(chunk.len() * 2);
                for &(cell, mask) in chunk {
                    shape.crossed_edges(cell, mask, &mut crossed);
                }
                if !none_known {
                    crossed.retain(|&[a, b]| !known.contains(edge_key(a, b)));
                }
                crossed
            })
            .collect();
        let mut edges = parts.concat();
        // The cells come brick by brick, so each edge reads the corners (and
        // a cached field the sample blocks) the edges before it just read.
        // Tetrahedra list an edge once per cell around it: sorting brings
        // the copies together.
        if !shape.lists_each_edge_once() {
            edges.par_sort_unstable_by_key(|&[a, b]| sort_key(edge_key(a, b)));
            edges.dedup();
        }
        let (lattice, placement, with_colors) = (self.lattice, self.options.vertex, self.with_colors);
        let corners = &self.corners;
        let (placed, evals): (Vec<EdgeVertex>, Vec<u32>) = edges
            .par_iter()
            .with_min_len(MIN_PARALLEL_ITEMS)
            .map_init(
                || corners.cursor(),
                |cursor, &[a, b]| {
                    let mut ends = |q: LatticePoint| (lattice.position(q), cursor.value(q));
                    let (a, b) = (ends(a), ends(b));
                    let (p, evals) = place_on_edge(field, a, b, placement);
                    let (gradient, color) = match (placement, with_colors) {
                        // A preview spends nothing on normals: the mesh's face normals stand in.
                        (VertexPlacement::Linear, true) => (Vec3A::ZERO, field.color(p)),
                        (VertexPlacement::Linear, false) => (Vec3A::ZERO, DEFAULT_COLOR),
                        (VertexPlacement::Root { .. }, true) => field.gradient_and_color(p),
                        (VertexPlacement::Root { .. }, false) => (field.gradient(p), DEFAULT_COLOR),
                    };
                    let normal = Vec3::from(-gradient).normalize_or_zero();
                    (EdgeVertex { position: p.into(), normal, color }, evals)
                },
            )
            .unzip();
        if placement != VertexPlacement::Linear {
            self.stats.gradient_evals += placed.len() as u64;
        }
        if with_colors {
            self.stats.color_evals += placed.len() as u64;
        }
        self.stats.root_evals += evals.iter().map(|&e| u64::from(e)).sum::<u64>();
        self.vertices.insert_new(edges.iter().map(|&[a, b]| edge_key(a, b)), placed);
    }
}
