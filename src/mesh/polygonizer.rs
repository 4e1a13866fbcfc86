//! The continuation polygonizer.
//!
//! Starting from cells found by marching from every skeleton, it grows across
//! the faces the surface crosses, one wave at a time: the new corners of a
//! wave are evaluated in parallel, then the wave's crossed cells name the next.
//! Corner values (in bricks of lattice points, see [`super::corners`]),
//! visited cells and edge vertices are keyed by integer lattice coordinates,
//! so each corner is evaluated once and each crossed edge gets one vertex,
//! shared by every cell around it.
//!
//! Everything the polygonizer keeps is a pure function of the field and the
//! lattice, so [`Polygonizer::repolygonize`] can drop what lies near an edit,
//! grow again from the boundary of the hole, and end with exactly the cells,
//! corners and vertices a fresh polygonization of the edited field would have.

use glam::{IVec3, Vec3, Vec3A};
use rayon::prelude::*;
use rustc_hash::FxHashMap;

use super::corners::CornerValues;
use super::edge_vertices::{EdgeVertex, EdgeVertices};
use super::lattice::{Cell, EdgeKey, Lattice, LatticePoint, edge_key, ordered_edge, sort_key};
use super::seeds::{Evaluated, Marched, Rejoin, RowSpans, RowStarts, Seed, SeedMarch, SeedStarts, Start};
use super::vertex::{VertexPlacement, place_on_edge};
use super::visited::VisitedCells;
use super::{Mesh, bcc, cubes};
use crate::field::{DEFAULT_COLOR, Field};
use crate::geom::{Aabb, Support};

/// The fewest cells, corners or edges a parallel task takes on: a local
/// update grows through many small waves, which splitting among the threads
/// would slow down.
const MIN_PARALLEL_ITEMS: usize = 64;

/// How space is cut into cells.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CellShape {
    /// Cubes with a generated, watertight marching-cubes case table.
    #[default]
    Cubes,
    /// The body-centred-cubic tetrahedra of Levinski and Sourin.
    Bcc,
}

impl CellShape {
    /// The cell's vertices (8 for a cube, 4 for a tetrahedron) in half-cell coordinates.
    fn vertices(self, cell: Cell) -> ([LatticePoint; 8], usize) {
        match self {
            CellShape::Cubes => (cubes::vertices(cell), 8),
            CellShape::Bcc => {
                let v = bcc::vertices(cell);
                ([v[0], v[1], v[2], v[3], v[0], v[0], v[0], v[0]], 4)
            }
        }
    }

    fn cells_touching(self, corner: LatticePoint, out: &mut Vec<Cell>) {
        match self {
            CellShape::Cubes => cubes::cells_touching(corner, out),
            CellShape::Bcc => bcc::cells_touching(corner, out),
        }
    }

    /// Cells having the lattice edge `a`–`b` (plus, harmlessly, a few that
    /// only touch one of its ends).
    fn cells_around_edge(self, a: LatticePoint, b: LatticePoint, out: &mut Vec<Cell>) {
        let even = |p: LatticePoint| p.x & 1 == 0;
        match (self, even(a), even(b)) {
            (CellShape::Bcc, false, false) => bcc::cells_around_centre_edge(a, b, out),
            (_, true, _) => self.cells_touching(a, out),
            _ => self.cells_touching(b, out),
        }
    }

    /// Crossed edges of `cell` to place vertices on, lower end first (so a
    /// root never depends on which cell asked): for cubes only those the cell
    /// owns, which every crossed edge is for one crossed cube; for tetrahedra
    /// all of them, repeated across the cells that share them.
    fn crossed_edges(self, cell: Cell, mask: u8, out: &mut Vec<[LatticePoint; 2]>) {
        match self {
            CellShape::Cubes => cubes::owned_crossed_edges(cell, mask, out),
            CellShape::Bcc => {
                bcc::polygons(cell, mask, &mut |polygon| out.extend(polygon.iter().map(|&[a, b]| ordered_edge(a, b))))
            }
        }
    }

    /// True when [`Self::crossed_edges`] over all crossed cells lists each edge once.
    fn lists_each_edge_once(self) -> bool {
        self == CellShape::Cubes
    }

    fn neighbours(self, cell: Cell, mask: u8, out: &mut Vec<Cell>) {
        match self {
            CellShape::Cubes => cubes::neighbours(cell, mask, out),
            CellShape::Bcc => bcc::neighbours(cell, mask, out),
        }
    }

    fn polygons(self, cell: Cell, mask: u8, emit: &mut impl FnMut(&[[LatticePoint; 2]])) {
        match self {
            CellShape::Cubes => cubes::polygons(cell, mask, emit),
            CellShape::Bcc => bcc::polygons(cell, mask, emit),
        }
    }

    /// Cells per cube: the cube itself, or its twelve tetrahedra.
    fn cells_per_cube(self) -> usize {
        match self {
            CellShape::Cubes => 1,
            CellShape::Bcc => 12,
        }
    }

    /// The inside mask of a cell whose vertices are all inside.
    fn full_mask(self) -> u8 {
        match self {
            CellShape::Cubes => 0xff,
            CellShape::Bcc => 0x0f,
        }
    }
}

/// The polygonizer's knobs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PolygonizeOptions {
    /// Cell decomposition.
    pub cells: CellShape,
    /// Vertex placement on crossed edges.
    pub vertex: VertexPlacement,
}

/// Work done so far, by kind of evaluation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct PolygonizeStats {
    /// Field values at lattice corners (and body centres).
    pub corner_evals: u64,
    /// Field values spent placing vertices on edges.
    pub root_evals: u64,
    /// Gradients for vertex normals, and for the uphill walks of seeds
    /// starting outside the surface.
    pub gradient_evals: u64,
    /// Colour queries for vertex colours (none when the model has one colour).
    pub color_evals: u64,
    /// Cells examined.
    pub cells_visited: u64,
}

impl PolygonizeStats {
    /// The work of two runs together.
    #[must_use]
    pub fn plus(&self, o: &PolygonizeStats) -> PolygonizeStats {
        PolygonizeStats {
            corner_evals: self.corner_evals + o.corner_evals,
            root_evals: self.root_evals + o.root_evals,
            gradient_evals: self.gradient_evals + o.gradient_evals,
            color_evals: self.color_evals + o.color_evals,
            cells_visited: self.cells_visited + o.cells_visited,
        }
    }

    /// Every evaluation of the field: values, gradients and colours.
    #[must_use]
    pub fn field_evals(&self) -> u64 {
        self.corner_evals + self.root_evals + self.gradient_evals + self.color_evals
    }
}

/// What a local re-polygonization changed, cell by cell.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Repolygonized {
    /// Crossed cells dropped (their triangles are gone).
    pub removed: Vec<Cell>,
    /// Crossed cells grown back or newly found (their triangles are new).
    pub added: Vec<Cell>,
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
            vertices: EdgeVertices::default(),
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
        self.with_colors = field.varies_in_color();
        self.threshold = field.threshold();
        let frontier = self.seed(field, seeds, None);
        self.grow(field, frontier);
        self.place_vertices(field, &self.crossed_with_masks());
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
        self.grow(field, frontier);
        self.place_vertices(field, &self.crossed_with_masks());
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

    /// Re-polygonizes after the field changed inside `region` (and nowhere
    /// else): see [`Self::repolygonize_within`].
    pub fn repolygonize<F: Field + ?Sized>(&mut self, field: &F, region: &Aabb, seeds: &[Seed]) -> Repolygonized {
        self.repolygonize_within(field, &[Support::Box(*region)], seeds)
    }

    /// Re-polygonizes after the field changed inside the regions `changed`
    /// (and nowhere else): forgets every corner, vertex and cell within one
    /// cell of them, then grows back from the surface around the hole and
    /// from the `seeds`. The result equals a fresh polygonization of the
    /// changed field.
    pub fn repolygonize_within<F: Field + ?Sized>(
        &mut self,
        field: &F,
        changed: &[Support],
        seeds: &[Seed],
    ) -> Repolygonized {
        self.with_colors = field.varies_in_color();
        self.threshold = field.threshold();
        let cell = self.lattice.cell;
        let near = HoleShape::new(changed).padded(cell);
        let lattice = self.lattice;
        // An edge meeting `near` has its midpoint within one cell of it.
        let midpoints = near.padded(cell);
        // A cell with a vertex in `near` has its cube (or, for a tetrahedron, its
        // owning cube) within one cube of it.
        let dropped = near.padded(cell);
        let (lo, hi) = lattice.cubes_overlapping(&dropped.bounds);
        let meets = |cube: IVec3, margin: f32| {
            let min = cube.as_vec3a() * cell;
            dropped.meets(&Aabb::new(min, min + Vec3A::splat(cell)).padded(margin * cell))
        };
        // The three maps are dropped from in parallel, each in one pass.
        let (corners, vertices, cells) = (&mut self.corners, &mut self.vertices, &mut self.cells);
        let ((), ((), hole_cells)) = rayon::join(
            || corners.forget_within(&near.bounds, |q| lattice.position(q), |p| near.contains(p)),
            || {
                rayon::join(
                    || vertices.retain(|k| !midpoints.contains(lattice.position(k) * 0.5)),
                    || HoleCells::drop_from(cells, self.options.cells, (lo, hi), meets),
                )
            },
        );
        let HoleCells { removed, mut border, around } = hole_cells;
        let mut frontier = self.claim(around);
        // `dropped` holds every corner dropped (those in `near`).
        frontier.extend(self.seed(field, seeds, Some(&dropped)));
        let added = self.grow(field, frontier);
        // Every other crossed cell kept all its vertices.
        border.extend(added.iter().map(|&c| (c, self.cells.get(c).expect("a grown cell is visited"))));
        self.place_vertices(field, &border);
        Repolygonized { removed, added }
    }

    /// Marches from each seed along +x to the first sign change and returns
    /// the unvisited cells around it.
    ///
    /// Seeds start at their nearest lattice corner. Seeds starting outside the
    /// surface march no farther than their primitive's support reaches. Starts
    /// in one lattice row march in order, and a start lying on a stretch an
    /// earlier march crossed to a sign change is skipped, since it would find
    /// that same change; rows march in parallel. A start outside the surface
    /// then walks uphill to the first sign change within its reach (see
    /// [`super::seeds`]).
    ///
    /// With `hole`, a region holding every corner just dropped, only
    /// marches that can come within a cell of it run: every other march
    /// reads only corners kept from before and finds the crossings it found
    /// then, whose cells (all within a cell of the march) are kept and
    /// visited already.
    fn seed<F: Field + ?Sized>(&mut self, field: &F, seeds: &[Seed], hole: Option<&HoleShape>) -> Vec<Cell> {
        let lattice = self.lattice;
        // A cell on either side, and half a cell against rounding in positions.
        let near_hole = hole.map(|h| h.padded(1.5 * lattice.cell));
        // Marches past the hole find what they found, but which of them run
        // depends on the marches before them: rows keep their starts there.
        let in_row = |q: LatticePoint| {
            let p = lattice.position(q);
            near_hole.as_ref().is_none_or(|h| h.row_span(p.y, p.z).is_some())
        };
        // An uphill walk goes no farther than its reach (plus a cell, the
        // staircase's offset from its ray).
        let walks_near_hole = |q: LatticePoint, reach: i32| {
            near_hole.as_ref().is_none_or(|h| h.within(lattice.position(q), (reach + 1) as f32 * lattice.cell))
        };
        // Only starts that can come near the hole are kept (in a local update,
        // a few of thousands); neither test fails for a longer reach where it
        // passes for a shorter one.
        self.starts.update(lattice, seeds);
        let starts = self.starts.kept(|(q, reach)| in_row(q) || walks_near_hole(q, reach));
        let along_x: Vec<Start> = starts.iter().copied().filter(|&(q, _)| in_row(q)).collect();
        let rows: Vec<(&RowStarts, Option<Rejoin>)> = along_x
            .chunk_by(|a, b| (a.0.y, a.0.z) == (b.0.y, b.0.z))
            .filter_map(|row| match &near_hole {
                None => Some((row, None)),
                Some(near) => self.changed_part(row, near),
            })
            .collect();
        let marched: Vec<Marched> = rows
            .par_iter()
            .map(|&(row, rejoin)| SeedMarch::new(field, lattice, &self.corners).row(row, rejoin))
            .collect();
        let mut cells = vec![];
        self.take_marched(marched, &mut cells);
        // The second round sees the corners the first evaluated. A walk from a
        // corner known to be inside ends where it starts (most of them: 82% of
        // a point/hair update's).
        let known_inside = |q: LatticePoint| self.corners.get(q).is_some_and(|v| v > self.threshold);
        let marched: Vec<Marched> = starts
            .par_iter()
            .filter(|&&(q, reach)| walks_near_hole(q, reach) && !known_inside(q))
            .map(|&(q, reach)| SeedMarch::new(field, lattice, &self.corners).uphill(q, reach))
            .collect();
        self.take_marched(marched, &mut cells);
        self.claim(cells)
    }

    /// The starts of `row` (sorted by `x`) whose marches may find something
    /// new: from the first that lies near the hole, or that an earlier march
    /// whose span meets the hole started or skipped. Every march from before
    /// it read only values kept (the field changed only in the hole) and
    /// finds what it found; only starts of changed primitives are new, and
    /// those lie in the hole. Past the hole the marches may stop where they
    /// rejoin the ones recorded before. A row never marched before is
    /// marched whole.
    fn changed_part<'s>(
        &'s self,
        row: &'s RowStarts,
        near_hole: &HoleShape,
    ) -> Option<(&'s RowStarts, Option<Rejoin<'s>>)> {
        let (y, z) = (row[0].0.y, row[0].0.z);
        let Some(spans) = self.row_spans.get(&(y, z)) else {
            return Some((row, None));
        };
        let at = |x: i32| self.lattice.position(IVec3::new(x, y, z));
        // The stretch of the row the hole reaches: its values changed only there.
        let row_point = at(0);
        let (x0, x1) = near_hole.row_span(row_point.y, row_point.z)?;
        let near = |x: i32| (x0..=x1).contains(&at(x).x);
        let from_spans = spans.iter().filter(|&&(lo, hi)| at(lo).x <= x1 && at(hi).x >= x0).map(|s| s.0);
        let from_starts = row.iter().map(|&(q, _)| q.x).filter(|&x| near(x));
        let first = from_spans.chain(from_starts).min()?;
        // A lattice step (two half cells) past the corner nearest the stretch's end.
        let past = self.lattice.nearest_corner(Vec3A::new(x1, row_point.y, row_point.z)).x + 2;
        let part = &row[row.partition_point(|&(q, _)| q.x < first)..];
        (!part.is_empty()).then_some((part, Some(Rejoin { first, past, before: spans })))
    }

    /// Keeps the corners `marched` evaluated and lists the cells around its
    /// crossings; a row marched again from some start on keeps the spans of
    /// the marches before it and takes the new ones.
    fn take_marched(&mut self, marched: Vec<Marched>, cells: &mut Vec<Cell>) {
        for Marched { crossings, evaluated, gradients, row_spans } in marched {
            if let Some(RowSpans { row, spans: new, from, kept_from }) = row_spans {
                // Sorted by start: the spans before the marches, theirs (in
                // place of those of starts now gone or skipped), and those
                // they rejoined.
                let spans = self.row_spans.entry(row).or_default();
                let rejoined = kept_from.map_or(spans.len(), |x| spans.partition_point(|s| s.0 < x));
                let redone = spans.partition_point(|s| s.0 < from);
                spans.splice(redone..rejoined, new);
            }
            self.stats.corner_evals += evaluated.len() as u64;
            self.stats.gradient_evals += gradients;
            self.corners.extend(evaluated);
            for q in crossings {
                self.options.cells.cells_touching(q, cells);
            }
        }
    }

    /// Marks the cells not visited yet as visited and returns them, in order.
    fn claim(&mut self, cells: Vec<Cell>) -> Vec<Cell> {
        cells.into_iter().filter(|&c| self.cells.insert_new(c, PENDING)).collect()
    }

    /// Continuation: examine the frontier, keep its crossed cells, and move on to
    /// their unvisited neighbours across crossed faces, until none are left.
    /// Returns the crossed cells found.
    fn grow<F: Field + ?Sized>(&mut self, field: &F, mut frontier: Vec<Cell>) -> Vec<Cell> {
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
    fn crossed_with_masks(&self) -> Vec<(Cell, u8)> {
        let shape = self.options.cells;
        self.cells.iter().filter(|&(_, m)| crossed(m, shape)).collect()
    }

    /// Places a vertex, with its normal and colour, on every crossed edge of
    /// `crossed_cells` that has none yet; in parallel.
    fn place_vertices<F: Field + ?Sized>(&mut self, field: &F, crossed_cells: &[(Cell, u8)]) {
        let shape = self.options.cells;
        let known = &self.vertices;
        let mut edges: Vec<[LatticePoint; 2]> = crossed_cells
            .par_iter()
            .with_min_len(MIN_PARALLEL_ITEMS)
            .flat_map_iter(|&(cell, mask)| {
                let mut crossed = vec![];
                shape.crossed_edges(cell, mask, &mut crossed);
                crossed.retain(|&[a, b]| !known.contains(edge_key(a, b)));
                crossed
            })
            .collect();
        // Sorted by position, each edge reads cache samples from the blocks
        // the edges before it just read; in the cells' hash order nearly
        // every lookup missed the processor's caches (in a cached
        // polygonization at res 512, reaching sample blocks took an eighth
        // of the time). An edge's key names it alone, so the sort also
        // brings an edge listed twice together.
        edges.par_sort_unstable_by_key(|&[a, b]| sort_key(edge_key(a, b)));
        if !shape.lists_each_edge_once() {
            edges.dedup();
        }
        let (lattice, placement, with_colors) = (self.lattice, self.options.vertex, self.with_colors);
        let corners = &self.corners;
        let placed: Vec<(EdgeKey, EdgeVertex, u32)> = edges
            .par_iter()
            .with_min_len(MIN_PARALLEL_ITEMS)
            .map(|&[a, b]| {
                let ends = |q: LatticePoint| (lattice.position(q), corners.value(q));
                let (p, evals) = place_on_edge(field, ends(a), ends(b), placement);
                let (gradient, color) = match (placement, with_colors) {
                    // A preview spends nothing on normals: the mesh's face normals stand in.
                    (VertexPlacement::Linear, true) => (Vec3A::ZERO, field.color(p)),
                    (VertexPlacement::Linear, false) => (Vec3A::ZERO, DEFAULT_COLOR),
                    (VertexPlacement::Root { .. }, true) => field.gradient_and_color(p),
                    (VertexPlacement::Root { .. }, false) => (field.gradient(p), DEFAULT_COLOR),
                };
                let normal = Vec3::from(-gradient).normalize_or_zero();
                (edge_key(a, b), EdgeVertex { position: p.into(), normal, color }, evals)
            })
            .collect();
        if placement != VertexPlacement::Linear {
            self.stats.gradient_evals += placed.len() as u64;
        }
        if with_colors {
            self.stats.color_evals += placed.len() as u64;
        }
        for (key, vertex, evals) in placed {
            self.stats.root_evals += u64::from(evals);
            self.vertices.insert(key, vertex);
        }
    }

    /// The crossed cells, sorted by lattice position.
    #[must_use]
    pub fn crossed_cell_list(&self) -> Vec<Cell> {
        let mut cells: Vec<Cell> = self.crossed_with_masks().into_iter().map(|(c, _)| c).collect();
        cells.sort_unstable_by_key(Cell::order_key);
        cells
    }

    /// The triangles of one crossed cell (none for a cell not crossed), each
    /// as its three vertices, exactly as [`Polygonizer::mesh`] cuts them.
    #[must_use]
    pub fn cell_triangles(&self, cell: Cell) -> Vec<[EdgeVertex; 3]> {
        let mut out = vec![];
        let Some(mask) = self.cells.get(cell).filter(|&m| crossed(m, self.options.cells)) else {
            return out;
        };
        let mut local = Vec::with_capacity(12);
        self.options.cells.polygons(cell, mask, &mut |polygon| {
            let vertices: Vec<EdgeVertex> = polygon.iter().map(|&[a, b]| self.vertex(edge_key(a, b))).collect();
            let ids: Vec<u32> = (0..vertices.len() as u32).collect();
            local.clear();
            super::triangulate(&ids, |i| vertices[i as usize].position, &mut local);
            out.extend(local.iter().map(|t| t.map(|i| vertices[i as usize])));
        });
        out
    }

    /// The mesh of the crossed cells, in a canonical order (cells by lattice
    /// position, vertices by first use), so equal polygonizations give equal meshes.
    #[must_use]
    pub fn mesh(&self) -> Mesh {
        let mut crossed_cells = self.crossed_with_masks();
        crossed_cells.par_sort_unstable_by_key(|(c, _)| c.order_key());
        let loops = self.polygon_loops(&crossed_cells);
        // Numbering by first use is the one serial pass, over dense slot numbers.
        const UNNUMBERED: u32 = u32::MAX;
        let mut number = vec![UNNUMBERED; self.vertices.slot_count()];
        let mut used = Vec::with_capacity(self.vertices.len());
        let ids: Vec<u32> = loops
            .slots
            .iter()
            .map(|&slot| {
                let n = &mut number[slot as usize];
                if *n == UNNUMBERED {
                    *n = used.len() as u32;
                    used.push(slot);
                }
                *n
            })
            .collect();
        let vertices: Vec<EdgeVertex> = used.par_iter().map(|&slot| self.vertices.at(slot)).collect();
        let mut mesh = Mesh {
            positions: vertices.iter().map(|v| v.position).collect(),
            normals: vertices.iter().map(|v| v.normal).collect(),
            colors: (self.with_colors && !vertices.is_empty()).then(|| vertices.iter().map(|v| v.color).collect()),
            ..Mesh::default()
        };
        let mut first = 0;
        for &len in &loops.lengths {
            let end = first + usize::from(len);
            mesh.push_polygon(&ids[first..end]);
            first = end;
        }
        if self.options.vertex == VertexPlacement::Linear {
            mesh.set_normals_from_faces();
        }
        mesh
    }

    /// The slot of edge `key`'s vertex, which every crossed edge of a crossed cell has.
    fn vertex_slot(&self, key: EdgeKey) -> u32 {
        self.vertices.slot(key).unwrap_or_else(|| panic!("no vertex on the edge with key {key}"))
    }

    /// Edge `key`'s vertex, which every crossed edge of a crossed cell has.
    fn vertex(&self, key: EdgeKey) -> EdgeVertex {
        self.vertices.get(key).unwrap_or_else(|| panic!("no vertex on the edge with key {key}"))
    }

    /// The polygons of `cells`, in order, as loops of their vertices' slots; in parallel.
    fn polygon_loops(&self, cells: &[(Cell, u8)]) -> PolygonLoops {
        const CELLS_PER_TASK: usize = 4096;
        let shape = self.options.cells;
        let parts: Vec<PolygonLoops> = cells
            .par_chunks(CELLS_PER_TASK)
            .map(|chunk| {
                let mut part = PolygonLoops::default();
                for &(cell, mask) in chunk {
                    shape.polygons(cell, mask, &mut |polygon| {
                        part.slots.extend(polygon.iter().map(|&[a, b]| self.vertex_slot(edge_key(a, b))));
                        part.lengths.push(polygon.len() as u8);
                    });
                }
                part
            })
            .collect();
        let mut loops = PolygonLoops::default();
        for part in parts {
            loops.slots.extend(part.slots);
            loops.lengths.extend(part.lengths);
        }
        loops
    }
}

/// What dropping a local update's cells leaves to do.
struct HoleCells {
    /// The crossed cells dropped, whose triangles go.
    removed: Vec<Cell>,
    /// The crossed cells kept within two cubes of the dropped ones: growth
    /// restarts from their neighbours, and they may have lost vertices on
    /// the hole's faces.
    border: Vec<(Cell, u8)>,
    /// The border cells' neighbours across crossed faces.
    around: Vec<Cell>,
}

impl HoleCells {
    /// Drops from `cells` those whose cube lies in `lo..=hi` and meets the
    /// hole (`meets(cube, 0.0)`), in one pass; the border is the crossed
    /// cells kept within two cubes of it (`meets(cube, 2.0)`).
    fn drop_from(
        cells: &mut VisitedCells,
        shape: CellShape,
        (lo, hi): (IVec3, IVec3),
        meets: impl Fn(IVec3, f32) -> bool,
    ) -> Self {
        let inside =
            |c: IVec3, margin: i32| c.cmpge(lo - margin).all() && c.cmple(hi + margin).all() && meets(c, margin as f32);
        let mut hole = Self { removed: vec![], border: vec![], around: vec![] };
        // Only cells within two cubes of `lo..=hi` can be dropped or border the hole.
        cells.retain_near((lo - 2, hi + 2), |c, mask| {
            let keep = !inside(c.cube, 0);
            if crossed(mask, shape) {
                if !keep {
                    hole.removed.push(c);
                } else if inside(c.cube, 2) {
                    shape.neighbours(c, mask, &mut hole.around);
                    hole.border.push((c, mask));
                }
            }
            keep
        });
        hole
    }
}

/// Most supports a local update tests each cell against; past it, their
/// bounding box stands for them (every test tries every part, and a moved
/// subtree has hundreds: Medusa's head 1 400).
const MAX_HOLE_SUPPORTS: usize = 8;

/// The space a local update redoes: the changed supports, grown alike, and
/// a box holding them (which most tests need go no further than).
#[derive(Clone, Debug)]
struct HoleShape {
    parts: Vec<Support>,
    bounds: Aabb,
}

impl HoleShape {
    fn new(changed: &[Support]) -> Self {
        let parts: Vec<Support> = changed.iter().filter(|s| !s.bounds().is_empty()).copied().collect();
        let bounds = parts.iter().fold(Aabb::EMPTY, |u, s| u.union(&s.bounds()));
        let parts = if parts.len() > MAX_HOLE_SUPPORTS { vec![Support::Box(bounds)] } else { parts };
        Self { parts, bounds }
    }

    /// The shape grown by a cube of half-side `r`.
    fn padded(&self, r: f32) -> Self {
        Self { parts: self.parts.iter().map(|s| s.padded(r)).collect(), bounds: self.bounds.padded(r) }
    }

    fn contains(&self, p: Vec3A) -> bool {
        self.bounds.contains(p) && self.parts.iter().any(|s| s.contains(p))
    }

    /// Whether some point of the shape lies within `d` of `p`.
    fn within(&self, p: Vec3A, d: f32) -> bool {
        self.bounds.distance_squared(p) <= d * d && self.parts.iter().any(|s| s.within(p, d))
    }

    /// The stretch of the row through `(·, y, z)` holding every point it
    /// shares with the shape (see [`Support::row_span`]).
    fn row_span(&self, y: f32, z: f32) -> Option<(f32, f32)> {
        let spans = self.parts.iter().filter_map(|s| s.row_span(y, z));
        spans.reduce(|(a0, a1), (b0, b1)| (a0.min(b0), a1.max(b1)))
    }

    fn meets(&self, b: &Aabb) -> bool {
        self.bounds.overlaps(b) && self.parts.iter().any(|s| s.meets(b))
    }
}

/// Polygons as consecutive loops of their vertices' slots.
#[derive(Default)]
struct PolygonLoops {
    slots: Vec<u32>,
    lengths: Vec<u8>,
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

/// True when a cell's vertices differ in sign.
fn crossed(mask: u8, shape: CellShape) -> bool {
    mask != 0 && mask != shape.full_mask()
}

#[cfg(test)]
mod tests {
    use glam::Vec3A;

    use super::*;
    use crate::field::{EvalMode, ModelField};
    use crate::mesh::skeleton_seeds;
    use crate::scene::Scene;

    /// Two blobs on one lattice row: the left one's march ends near it, so a
    /// change around the right one marches the row only from the right
    /// one's start, a change around the left one marches it all, and a
    /// change between them, which no march reached, marches none of it.
    #[test]
    fn a_local_update_marches_a_row_from_where_its_spans_meet_the_hole() {
        let scene = Scene::parse(
            "Scene(camera: Camera(eye: (0.0, 0.0, 9.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (8, 8),
                   model: Blend([Point(center: (-2.0, 0.0, 0.0), radius: 0.8), Point(center: (2.0, 0.0, 0.0), radius: 0.8)]))",
            "two blobs",
        )
        .expect("test scene parses");
        let field = ModelField::new(&scene.model, EvalMode::Indexed);
        let lattice = Lattice { cell: 0.1 };
        let mut polygonizer = Polygonizer::new(lattice, PolygonizeOptions::default());
        let seeds = skeleton_seeds(&scene.model, scene.model.root());
        polygonizer.polygonize(&field, &seeds);
        let mut row: Vec<Start> = seeds.iter().map(|s| (lattice.nearest_corner(s.point), 9)).collect();
        row.sort_by_key(|(q, _)| q.x);
        let boxed = |x: f32| HoleShape::new(&[Support::Box(Aabb::around(Vec3A::new(x, 0.0, 0.0), 0.3))]);
        let ball = |x: f32| HoleShape::new(&[Support::ball(Vec3A::new(x, 0.0, 0.0), 0.3)]);
        for around in [&boxed as &dyn Fn(f32) -> HoleShape, &ball] {
            let part = |x: f32| polygonizer.changed_part(&row, &around(x)).map(|(part, _)| part);
            assert_eq!(part(2.0), Some(&row[1..]));
            assert_eq!(part(-2.0), Some(&row[..]));
            assert_eq!(part(0.0), None);
        }
    }

    /// Three blobs on one lattice row, the middle one moved a little: the
    /// local update marches the row from the middle blob's start, and the
    /// marches past the hole, which read only values kept, must keep their
    /// spans, so that later updates see where they reached. The records then
    /// equal a fresh polygonization's.
    #[test]
    fn a_local_update_keeps_the_spans_of_the_marches_past_the_hole() {
        let mut scene = Scene::parse(
            "Scene(camera: Camera(eye: (0.0, 0.0, 9.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (8, 8),
                   model: Blend([Point(center: (-3.0, 0.0, 0.0), radius: 0.8),
                                 Named(\"mid\", Point(center: (0.0, 0.0, 0.0), radius: 0.8)),
                                 Point(center: (3.0, 0.0, 0.0), radius: 0.8), Point(center: (3.5, 0.0, 0.0), radius: 0.8)]))",
            "three blobs",
        )
        .expect("test scene parses");
        let lattice = Lattice { cell: 0.1 };
        let mut local = Polygonizer::new(lattice, PolygonizeOptions::default());
        local.polygonize(
            &ModelField::new(&scene.model, EvalMode::Indexed),
            &skeleton_seeds(&scene.model, scene.model.root()),
        );
        let mut within_balls = local.clone();
        for by in [Vec3A::new(0.0, 0.0, 0.03), Vec3A::new(0.45, 0.0, -0.03)] {
            let change =
                scene.model.apply(&crate::field::Edit::Translate { node: "mid".into(), by: by.into() }).unwrap();
            let region = scene.model.change_region(&change, false);
            let field = ModelField::new(&scene.model, EvalMode::Indexed);
            let seeds = skeleton_seeds(&scene.model, scene.model.root());
            local.repolygonize(&field, &region, &seeds);
            within_balls.repolygonize_within(&field, &scene.model.change_support_regions(&change, false), &seeds);
            let mut fresh = Polygonizer::new(lattice, PolygonizeOptions::default());
            fresh.polygonize(&field, &seeds);
            let row = |p: &Polygonizer| {
                p.row_spans.get(&(0, 0)).cloned().map(|mut s| {
                    s.sort_unstable();
                    s
                })
            };
            assert!(fresh.row_spans[&(0, 0)].len() >= 3, "{:?}", fresh.row_spans[&(0, 0)]);
            assert_eq!(row(&local), row(&fresh), "moved by {by}");
            assert_eq!(row(&within_balls), row(&fresh), "moved by {by}, within the balls");
        }
    }
}
