//! The continuation polygonizer.
//!
//! Starting from cells found by marching from every skeleton, it grows across
//! the faces the surface crosses, block by block: each block of 8³ cubes is
//! grown on one thread with the corner bricks it owns, blocks of one parity
//! class at a time, and the cells reached in other blocks become their work.
//! Corner values (in bricks of lattice points, see [`super::corners`]),
//! visited cells and edge vertices are keyed by integer lattice coordinates,
//! so each corner is evaluated once and each crossed edge gets one vertex,
//! shared by every cell around it.
//!
//! Everything the polygonizer keeps is a pure function of the field and the
//! lattice, so [`Polygonizer::repolygonize`] can drop what lies near an edit,
//! grow again from the boundary of the hole, and end with exactly the cells,
//! corners and vertices a fresh polygonization of the edited field would have.
//!
//! - `cell_shape`: cubes or tetrahedra, and what each asks of a cell;
//! - `seeding`: the first cells, marched to from the skeletons;
//! - `growth`: continuation across crossed faces, block by block;
//! - `hole`: the local update, which drops what lies near an edit and grows back;
//! - `placement`: vertices on the crossed edges;
//! - `assemble`: the mesh, and the triangles of one cell, from what was found;
//! - `stats`: the work done, by kind of evaluation.

mod assemble;
mod cell_shape;
mod growth;
mod hole;
mod placement;
mod seeding;
mod stats;

use rayon::prelude::*;
use rustc_hash::FxHashMap;

use super::corners::CornerValues;
use super::edge_vertices::EdgeVertices;
use super::lattice::{Lattice, LatticePoint, sort_key};
use super::seeds::{Evaluated, Seed, SeedStarts};
use super::vertex::VertexPlacement;
use super::visited::VisitedCells;
use crate::field::Field;
use crate::progress::{Progress, Silent, stage};

pub use cell_shape::CellShape;
use cell_shape::crossed;
pub use hole::Repolygonized;
pub use stats::PolygonizeStats;

/// The polygonizer's knobs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PolygonizeOptions {
    /// Cell decomposition.
    pub cells: CellShape,
    /// Vertex placement on crossed edges.
    pub vertex: VertexPlacement,
}

/// The mask value of a visited cell whose corners are not known yet.
const PENDING: u8 = 0;

/// A continuation polygonizer with its lattice and everything it has learned
/// about one field.
#[derive(Clone, Debug)]
pub struct Polygonizer {
    lattice: Lattice,
    options: PolygonizeOptions,
    /// Field values at the corners evaluated.
    corners: CornerValues,
    /// Visited cells and their inside masks.
    cells: VisitedCells,
    vertices: EdgeVertices,
    /// For each lattice row seeds marched along (by `y` and `z`), the spans
    /// of `x` whose values decided what its marches found (see [`SeedMarch::row`]).
    row_spans: FxHashMap<(i32, i32), Vec<(i32, i32)>>,
    /// The seeds' starts, sorted, from the last polygonization or update.
    starts: SeedStarts,
    with_colors: bool,
    threshold: f32,
    stats: PolygonizeStats,
}

impl Polygonizer {
    /// An empty polygonizer on `lattice`.
    #[must_use]
    pub fn new(lattice: Lattice, options: PolygonizeOptions) -> Self {
        Self {
            lattice,
            options,
            corners: CornerValues::default(),
            cells: VisitedCells::new(options.cells.cells_per_cube()),
            vertices: EdgeVertices::new(options.cells == CellShape::Bcc),
            row_spans: FxHashMap::default(),
            starts: SeedStarts::default(),
            with_colors: false,
            threshold: 0.0,
            stats: PolygonizeStats::default(),
        }
    }

    /// The lattice.
    #[must_use]
    pub fn lattice(&self) -> Lattice {
        self.lattice
    }

    /// Evaluations and cells so far.
    #[must_use]
    pub fn stats(&self) -> PolygonizeStats {
        self.stats
    }

    /// Cells the surface crosses.
    #[must_use]
    pub fn crossed_cells(&self) -> usize {
        self.cells.iter().filter(|&(_, m)| crossed(m, self.options.cells)).count()
    }

    /// Polygonizes the surface of `field` reachable from the `seeds` (points on
    /// skeletons, see [`super::skeleton_seeds`]).
    pub fn polygonize<F: Field + ?Sized>(&mut self, field: &F, seeds: &[Seed]) {
        self.polygonize_reporting(field, seeds, &Silent);
    }

    /// [`Self::polygonize`], reporting each stage (seeding, growth, vertex
    /// placement) to `progress` as it starts and ends.
    pub fn polygonize_reporting<F: Field + ?Sized>(&mut self, field: &F, seeds: &[Seed], progress: &dyn Progress) {
        self.with_colors = field.varies_in_color();
        self.threshold = field.threshold();
        let frontier = stage(progress, "seeding the mesh", || self.seed(field, seeds, None));
        stage(progress, "growing the mesh", || self.grow(field, frontier, false));
        stage(progress, "placing vertices", || self.place_all_vertices(field));
    }

    /// Polygonizes on this polygonizer's lattice, which must be `coarse`'s refined
    /// `2^k` times, starting from the coarse surface instead of the skeletons
    /// (the second paper's coarse-controlled fine mesh): every crossed edge of a
    /// coarse crossed cell is walked on the fine lattice to its sign change, and
    /// continuation grows from there. Coarse corner values are reused.
    pub fn refine<F: Field + ?Sized>(&mut self, field: &F, coarse: &Polygonizer, k: u32) {
        self.with_colors = field.varies_in_color();
        self.threshold = field.threshold();
        let scale = 1i32 << k;
        self.corners.extend(coarse.corners.iter().map(|(q, v)| (q * scale, v)));
        let shape = self.options.cells;
        let mut edges: Vec<[LatticePoint; 2]> = vec![];
        for (cell, mask) in coarse.cells.iter() {
            if crossed(mask, shape) {
                shape.polygons(cell, mask, &mut |polygon| {
                    edges.extend(polygon.iter().map(|&[a, b]| [a * scale, b * scale]))
                });
            }
        }
        edges.sort_unstable_by_key(|&[a, b]| (sort_key(a), sort_key(b)));
        edges.dedup();
        let seeds = self.fine_crossings(field, &edges, scale);
        let mut around = vec![];
        for [a, b] in seeds {
            shape.cells_around_edge(a, b, &mut around);
        }
        let frontier = self.claim(around);
        self.grow(field, frontier, false);
        self.place_all_vertices(field);
    }

    /// For each coarse edge (in fine coordinates, `scale` fine steps long), the
    /// first fine edge along it whose ends differ in sign; in parallel.
    fn fine_crossings<F: Field + ?Sized>(
        &mut self,
        field: &F,
        edges: &[[LatticePoint; 2]],
        scale: i32,
    ) -> Vec<[LatticePoint; 2]> {
        let (lattice, t, known) = (self.lattice, self.threshold, &self.corners);
        let walked: Vec<(Option<[LatticePoint; 2]>, Evaluated)> = edges
            .par_iter()
            .map(|&[a, b]| {
                let step = (b - a) / scale;
                let mut fresh = vec![];
                let mut value = |q: LatticePoint| {
                    known.get(q).unwrap_or_else(|| {
                        let v = field.value(lattice.position(q));
                        fresh.push((q, v));
                        v
                    })
                };
                let inside = value(a) > t;
                let crossing = (0..scale).map(|i| a + step * i).find(|&q| (value(q + step) > t) != inside);
                (crossing.map(|q| [q, q + step]), fresh)
            })
            .collect();
        let mut crossings = vec![];
        for (crossing, fresh) in walked {
            self.stats.corner_evals += fresh.len() as u64;
            self.corners.extend(fresh);
            crossings.extend(crossing);
        }
        crossings
    }
}
