//! Empty-space skipping: a coarse grid over a field's bounds marking the
//! cells where the field's interval bound stays below the threshold (by the
//! margin of [`super::outside_margin`], against rounding), so the
//! surface cannot be there. A ray crosses a run of such cells in one jump
//! instead of a segment-tracing step per doubling of its segment.
//!
//! The marks are a function of the field alone, so a march that jumps over
//! empty cells finds the same snapped hit as one that steps through them.
//! After an edit, the blocks of cells over the changed boxes are marked
//! again, each when a ray first reaches it: the rays traced again after an
//! edit reach the front of what changed, not all of its boxes.
//!
//! The marks live in `field`, not beside their siblings `trace::coverage`
//! and `trace::changed_space`, because [`super::ModelField::skipping`] holds
//! them to answer [`super::Field::skip_empty`]: moved into `trace`, they
//! would make the field import the tracer, and the way round that — a field
//! in `trace` wrapping `ModelField` with the marks — would forward every
//! method of [`super::Field`] by hand for one of them.

use std::sync::atomic::{AtomicU8, Ordering};

use glam::{UVec3, Vec3A};
use rayon::prelude::*;

use super::Field;
use crate::geom::{Aabb, Ray, UniformGrid};

/// Cells along the longest side of the bounds. With rays starting at their
/// coverage (`trace::Coverage`), on Medusa at 640×480 96 cells take 31 ms to
/// mark and trace in 110 ms, against 21 ms and 133 ms for 64 cells; 128 take
/// 54 ms to mark for a few percent more (and the previewer marks once, then
/// traces frame after frame).
const CELLS_ALONG_LONGEST_SIDE: f32 = 96.0;

/// Cells per block edge in the first, coarse pass of marking.
const BLOCK: u32 = 4;

/// A cell's mark: the field's range over it is below the threshold.
const EMPTY: u8 = 1;
/// A cell's mark: the surface may be in it.
const OCCUPIED: u8 = 0;
/// A flag on a cell's mark: an edit changed the field over the cell's block
/// since it was marked, so the block is marked again before the mark is
/// read. The mark under it still guides that marking.
const STALE: u8 = 2;

/// The empty cells of a field, over the field's bounds when built.
#[derive(Debug)]
pub struct EmptySpace {
    grid: UniformGrid,
    /// Blocks of `BLOCK³` cells, the unit of marking.
    blocks: UniformGrid,
    /// [`EMPTY`] or [`OCCUPIED`] per cell, maybe flagged [`STALE`]. Rays
    /// mark blocks concurrently: two that mark one block at once write
    /// marks of the same field, each cell's in one store.
    marks: Vec<AtomicU8>,
    /// The field's bounds when the grid was laid over them.
    built_over: Aabb,
}

impl EmptySpace {
    /// Marks the cells of a grid over `field`'s bounds.
    pub fn build<F: Field + ?Sized>(field: &F) -> Self {
        // A field that is zero everywhere still gets a grid, over a unit box,
        // for edits to mark once the field reaches it.
        let built_over = field.bounds();
        let bounds = Some(built_over).filter(|b| !b.is_empty()).unwrap_or(Aabb::around(Vec3A::ZERO, 0.5));
        let extent = bounds.size().max(Vec3A::splat(1e-6));
        let cell = extent.max_element() / CELLS_ALONG_LONGEST_SIDE;
        let grid = UniformGrid::new(bounds.min, cell, (extent / cell).ceil().as_uvec3());
        let blocks =
            UniformGrid::new(grid.origin, grid.cell * BLOCK as f32, (grid.dims + UVec3::splat(BLOCK - 1)) / BLOCK);
        let marks = (0..grid.cell_count()).map(|_| AtomicU8::new(OCCUPIED)).collect();
        let space = Self { marks, grid, blocks, built_over };
        // Before a first render, point values at the coarse cells' corners
        // would fill cache samples that no ray reads (a cold cached render of
        // Medusa took ~5% longer with them).
        let order = if field.fills_caches_on_read() { Order::RangesOnly } else { Order::ValuesFirst };
        (0..space.blocks.cell_count()).into_par_iter().for_each(|b| space.mark_block(field, b, order));
        space
    }

    /// Flags stale the marks of the blocks overlapping `changed`, after the
    /// field changed inside those boxes only: [`Self::skip`] marks such a
    /// block again when a ray first reaches it. Space the grid does not cover
    /// is never skipped.
    pub fn update(&mut self, changed: &[Aabb]) {
        // Boxes go onto the blocks first: an edit's boxes (one per primitive
        // moved) overlap by the thousand.
        let mut touched = vec![false; self.blocks.cell_count()];
        for b in changed {
            self.blocks.for_each_row(b, |row| touched[row].fill(true));
        }
        for block in (0..touched.len()).filter(|&b| touched[b]) {
            let first = self.blocks.coords(block) * BLOCK;
            for i in cells_between(first, (first + UVec3::splat(BLOCK)).min(self.grid.dims)) {
                *self.marks[self.grid.linear(i)].get_mut() |= STALE;
            }
        }
    }

    /// The field's bounds when the grid was laid: a space built for a field
    /// whose bounds are now otherwise has another grid than a fresh one.
    #[must_use]
    pub fn built_over(&self) -> Aabb {
        self.built_over
    }

    /// Whether some marks wait to be marked again since an edit (see [`Self::update`]).
    #[must_use]
    pub fn has_stale(&self) -> bool {
        self.marks.iter().any(|m| m.load(Ordering::Relaxed) & STALE != 0)
    }

    /// Marks every stale block again now, from `field` (the field this space
    /// was built from, with every edit since told to [`Self::update`]): the
    /// marks are then those a space built afresh over the same grid has.
    pub fn refresh<F: Field + ?Sized>(&self, field: &F) {
        let stale: Vec<usize> = (0..self.blocks.cell_count())
            .filter(|&b| {
                let first = self.blocks.coords(b) * BLOCK;
                cells_between(first, (first + UVec3::splat(BLOCK)).min(self.grid.dims))
                    .any(|i| self.marks[self.grid.linear(i)].load(Ordering::Relaxed) & STALE != 0)
            })
            .collect();
        stale.into_par_iter().for_each(|b| self.mark_block(field, b, Order::Guided(&self.marks)));
    }

    /// Marks the cells of block `b`, in `order`.
    fn mark_block<F: Field + ?Sized>(&self, field: &F, b: usize, order: Order) {
        let first = self.blocks.coords(b) * BLOCK;
        let mut marker = BlockMarker::new(field, &self.grid, first, order);
        marker.descend(first, (first + UVec3::splat(BLOCK)).min(self.grid.dims));
        for (c, e) in marker.marks {
            self.marks[c].store(if e { EMPTY } else { OCCUPIED }, Ordering::Relaxed);
        }
    }

    /// Whether cell `c` is empty, marking its block first if an edit left it stale.
    fn is_empty<F: Field + ?Sized>(&self, field: &F, c: usize) -> bool {
        let mark = self.marks[c].load(Ordering::Relaxed);
        if mark & STALE == 0 {
            return mark == EMPTY;
        }
        // The samples around an edit are read again by the rays traced
        // there; most cells keep their marks, so the old ones pick the order.
        self.mark_block(field, self.blocks.linear(self.grid.coords(c) / BLOCK), Order::Guided(&self.marks));
        self.marks[c].load(Ordering::Relaxed) == EMPTY
    }

    /// The boxes of the cells the surface may be in: runs of cells along x
    /// not marked empty (a stale mark counts as not empty), plus the parts of
    /// `bounds` (the field's bounds now) outside the grid, which an edit may
    /// have reached. Outside these boxes the field is below the threshold.
    #[must_use]
    pub fn occupied_boxes(&self, bounds: &Aabb) -> Vec<Aabb> {
        let dims = self.grid.dims;
        let mut boxes = vec![];
        for z in 0..dims.z {
            for y in 0..dims.y {
                let row = self.grid.linear(UVec3::new(0, y, z));
                let occupied = |x: u32| self.marks[row + x as usize].load(Ordering::Relaxed) != EMPTY;
                let mut x = 0;
                while x < dims.x {
                    if !occupied(x) {
                        x += 1;
                        continue;
                    }
                    let first = x;
                    while x < dims.x && occupied(x) {
                        x += 1;
                    }
                    let (lo, hi) =
                        (self.grid.box_at(UVec3::new(first, y, z)), self.grid.box_at(UVec3::new(x - 1, y, z)));
                    boxes.push(lo.union(&hi));
                }
            }
        }
        boxes.extend(outside(bounds, &self.grid.bounds()));
        boxes
    }

    /// Fraction of the cells marked empty (as last marked, where an edit left
    /// cells stale).
    #[must_use]
    pub fn empty_fraction(&self) -> f64 {
        self.marks.iter().filter(|m| m.load(Ordering::Relaxed) & EMPTY != 0).count() as f64 / self.marks.len() as f64
    }

    /// Where the run of empty cells holding `ray.at(t)` ends along the ray,
    /// at most `t_end`; `None` when the point is not in an empty cell. The
    /// field is below the threshold on the whole of `[t, returned]`, up to
    /// the rounding of the cell faces' crossings. Stale blocks the walk
    /// reaches are marked first, from `field`: the field this space was built
    /// from, with every edit since told to [`Self::update`].
    #[must_use]
    pub fn skip<F: Field + ?Sized>(&self, field: &F, ray: &Ray, t: f32, t_end: f32) -> Option<f32> {
        let (a, b) = (ray.at(t), ray.at(t_end));
        // Most steps start in an occupied cell: answer those without a walk.
        if !self.grid.cell_of(a).is_some_and(|c| self.is_empty(field, c)) {
            return None;
        }
        let mut end = None;
        self.grid.walk_segment_while(a, b, |c, exit| {
            let empty = self.is_empty(field, c);
            if empty {
                end = Some(exit);
            }
            empty
        });
        Some(t + end? * (t_end - t))
    }
}

/// Boxes covering the part of `bounds` outside `grid`: for each axis, the
/// slabs of `bounds` below and above the grid's extent.
fn outside(bounds: &Aabb, grid: &Aabb) -> Vec<Aabb> {
    if bounds.is_empty() {
        return vec![];
    }
    let mut slabs = vec![];
    for axis in 0..3 {
        if bounds.min[axis] < grid.min[axis] {
            let mut below = *bounds;
            below.max[axis] = grid.min[axis].min(bounds.max[axis]);
            slabs.push(below);
        }
        if bounds.max[axis] > grid.max[axis] {
            let mut above = *bounds;
            above.min[axis] = grid.max[axis].max(bounds.min[axis]);
            slabs.push(above);
        }
    }
    slabs
}

/// Which questions settle a part of a block first. Each cell's mark is its
/// range against the threshold whatever the order (a point value at or above
/// it puts the range there too); the order only saves work.
#[derive(Clone, Copy)]
enum Order<'a> {
    /// Ranges only: before a first cached render, point values would fill
    /// cache samples that no ray reads.
    RangesOnly,
    /// Whole blocks by their range, smaller parts by point values first.
    ValuesFirst,
    /// After an edit, by the marks before it (indexed by cell): a part all
    /// empty before asks its range first, and a block not all empty before
    /// goes straight to its parts, whose values settle most of it.
    Guided(&'a [AtomicU8]),
}

/// Marks the cells of one block, from the whole block down to single
/// cells. Most of a model's bounds (and of an edit's boxes) is whole blocks
/// whose range stays below the threshold, answered by one range query. Below
/// a block, the field's values at the corners and centres of the cells
/// settle most occupied parts with no range query at all: a part holding a
/// point at or above the threshold cannot be empty, and point values cost a
/// small fraction of a range query over a box near many leaves. The marks
/// are still each cell's range against the threshold, whatever the order.
struct BlockMarker<'a, F: ?Sized> {
    field: &'a F,
    grid: &'a UniformGrid,
    /// Ranges below this leave a cell empty: the threshold less [`super::outside_margin`].
    level: f32,
    /// Which questions to ask first.
    order: Order<'a>,
    /// Lattice point (0, 0, 0) of the block's corner values.
    first: UVec3,
    /// Whether the field reaches the threshold at each lattice point of the
    /// block at doubled resolution (cell corners at even, centres at odd
    /// coordinates), computed when first asked.
    reached: [Option<bool>; PROBES * PROBES * PROBES],
    marks: Vec<(usize, bool)>,
}

/// Points per axis of a block's doubled lattice.
const PROBES: usize = 2 * BLOCK as usize + 1;

impl<'a, F: Field + ?Sized> BlockMarker<'a, F> {
    fn new(field: &'a F, grid: &'a UniformGrid, first: UVec3, order: Order<'a>) -> Self {
        let iso = field.threshold();
        let level = iso - super::outside_margin(iso);
        Self { field, grid, level, order, first, reached: [None; PROBES * PROBES * PROBES], marks: vec![] }
    }

    /// Marks the cells in `lo..hi`.
    fn descend(&mut self, lo: UVec3, hi: UVec3) {
        let cells: Vec<usize> = cells_between(lo, hi).map(|i| self.grid.linear(i)).collect();
        let whole_block = hi - lo == UVec3::splat(BLOCK);
        let single = hi - lo == UVec3::ONE;
        let (values_first, straight_down) = match self.order {
            Order::RangesOnly => (false, false),
            // A whole block is mostly empty space: ask its range first.
            Order::ValuesFirst => (!whole_block, false),
            Order::Guided(before) => {
                let was_empty = cells.iter().all(|&c| before[c].load(Ordering::Relaxed) & EMPTY != 0);
                (!whole_block && !was_empty, whole_block && !was_empty)
            }
        };
        if straight_down {
            self.split(lo, hi);
            return;
        }
        if values_first && self.reaches_threshold(lo, hi) {
            if single {
                self.marks.push((cells[0], false));
            } else {
                self.split(lo, hi);
            }
            return;
        }
        let range = self.field.interval(&self.cells_box(lo, hi));
        if range.hi < self.level {
            self.marks.extend(cells.into_iter().map(|c| (c, true)));
        } else if single {
            self.marks.push((cells[0], false));
        } else {
            self.split(lo, hi);
        }
    }

    /// Descends into the halves of `lo..hi` along every axis longer than a
    /// cell; without point values, straight into its cells, since a range
    /// query over half a block seldom spares the queries over its cells.
    fn split(&mut self, lo: UVec3, hi: UVec3) {
        if matches!(self.order, Order::RangesOnly) {
            for i in cells_between(lo, hi) {
                self.descend(i, i + UVec3::ONE);
            }
            return;
        }
        let mid = lo + (hi - lo + UVec3::ONE) / 2;
        for k in 0..8 {
            let pick = |bit: u32, axis: usize| if k & bit == 0 { (lo[axis], mid[axis]) } else { (mid[axis], hi[axis]) };
            let ((x0, x1), (y0, y1), (z0, z1)) = (pick(1, 0), pick(2, 1), pick(4, 2));
            if x0 < x1 && y0 < y1 && z0 < z1 {
                self.descend(UVec3::new(x0, y0, z0), UVec3::new(x1, y1, z1));
            }
        }
    }

    /// True when the field reaches the marking level at a corner or centre of a cell in `lo..hi`.
    fn reaches_threshold(&mut self, lo: UVec3, hi: UVec3) -> bool {
        let (a, b) = (2 * (lo - self.first), 2 * (hi - self.first));
        (a.z..=b.z).any(|z| (a.y..=b.y).any(|y| (a.x..=b.x).any(|x| self.reached_at(UVec3::new(x, y, z)))))
    }

    /// Whether the field reaches the marking level at doubled-lattice point `i`
    /// of the block; odd–even mixes (face and edge midpoints) are skipped.
    fn reached_at(&mut self, i: UVec3) -> bool {
        let odd = i % 2;
        if odd.element_sum() != 0 && odd.element_sum() != 3 {
            return false;
        }
        let k = (i.z as usize * PROBES + i.y as usize) * PROBES + i.x as usize;
        *self.reached[k].get_or_insert_with(|| {
            let p = self.grid.origin + (self.first.as_vec3a() + i.as_vec3a() * 0.5) * self.grid.cell;
            self.field.value(p) >= self.level
        })
    }

    fn cells_box(&self, lo: UVec3, hi: UVec3) -> Aabb {
        let g = self.grid;
        Aabb::new(g.origin + lo.as_vec3a() * g.cell, g.origin + hi.as_vec3a() * g.cell)
    }
}

/// The cell coordinates in `lo..hi`, x fastest.
fn cells_between(lo: UVec3, hi: UVec3) -> impl Iterator<Item = UVec3> {
    (lo.z..hi.z).flat_map(move |z| (lo.y..hi.y).flat_map(move |y| (lo.x..hi.x).map(move |x| UVec3::new(x, y, z))))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Interval;

    /// A ball of radius 1 around `centre`, `f = 1 - |p - centre|²` inside,
    /// and the bounds it claims.
    struct Ball {
        bounds: Aabb,
        centre: Vec3A,
    }

    /// The ball at the origin inside bounds of ±2.
    const BALL: Ball = Ball { bounds: Aabb { min: Vec3A::splat(-2.0), max: Vec3A::splat(2.0) }, centre: Vec3A::ZERO };

    impl Field for Ball {
        fn value(&self, p: Vec3A) -> f32 {
            (1.0 - (p - self.centre).length_squared()).max(0.0)
        }
        fn gradient(&self, p: Vec3A) -> Vec3A {
            -2.0 * (p - self.centre)
        }
        fn color(&self, _: Vec3A) -> glam::Vec3 {
            glam::Vec3::ONE
        }
        fn interval(&self, b: &Aabb) -> Interval {
            Interval::new(0.0, (1.0 - b.distance_squared(self.centre)).max(0.0))
        }
        fn lipschitz(&self, _: &crate::geom::Region) -> f32 {
            4.0
        }
        fn bounds(&self) -> Aabb {
            self.bounds
        }
        fn threshold(&self) -> f32 {
            0.5
        }
    }

    impl EmptySpace {
        /// Every cell's mark as it stands.
        fn marked(&self) -> Vec<bool> {
            self.marks.iter().map(|m| m.load(Ordering::Relaxed) & EMPTY != 0).collect()
        }

        /// Every cell's mark, marking the stale blocks first.
        fn resolved<F: Field>(&self, field: &F) -> Vec<bool> {
            (0..self.marks.len()).map(|c| self.is_empty(field, c)).collect()
        }

        fn stale_cells(&self) -> usize {
            self.marks.iter().filter(|m| m.load(Ordering::Relaxed) & STALE != 0).count()
        }
    }

    /// Each cell's range against the threshold, one query per cell.
    fn direct<F: Field>(space: &EmptySpace, field: &F) -> Vec<bool> {
        // Below the threshold by the margin against rounding, as the marks are.
        let level = 0.5 - crate::field::outside_margin(0.5);
        (0..space.grid.cell_count()).map(|c| field.interval(&space.grid.cell_box(c)).hi < level).collect()
    }

    #[test]
    fn a_skip_stops_before_the_surface_and_never_starts_inside_it() {
        let space = EmptySpace::build(&BALL);
        let surface = 0.5f32.sqrt();
        for k in 0..50 {
            let y = -0.9 + 1.8 * k as f32 / 49.0;
            let ray = Ray::new(Vec3A::new(-3.0, y, 0.1), Vec3A::X);
            let Some(t) = space.skip(&BALL, &ray, 1.0, 5.0) else { panic!("ray at y = {y} starts in empty space") };
            let to_surface = (surface * surface - y * y - 0.01).max(0.0).sqrt();
            if y.abs() < surface - 0.05 {
                assert!(t < 3.0 - to_surface, "ray at y = {y} skipped to {t}, past the surface");
                assert!(t > 3.0 - to_surface - 0.3, "ray at y = {y} stopped at {t}, far before the surface");
            }
        }
        assert!(space.skip(&BALL, &Ray::new(Vec3A::ZERO, Vec3A::X), 0.0, 1.0).is_none(), "skipped inside");
    }

    #[test]
    fn marking_by_blocks_equals_marking_every_cell() {
        // Whole blocks only, then bounds cutting the ball and the last blocks short.
        let cut = Ball { bounds: Aabb::new(Vec3A::new(-2.0, -1.3, -0.9), Vec3A::new(1.7, 1.1, 0.35)), ..BALL };
        for (ball, empty_at_least) in [(BALL, 0.9), (cut, 0.3)] {
            let space = EmptySpace::build(&ball);
            let direct = direct(&space, &ball);
            assert_eq!(space.marked(), direct, "bounds {:?}, point values first", ball.bounds);
            assert!(space.empty_fraction() > empty_at_least && space.empty_fraction() < 1.0);
            space.marks.iter().for_each(|m| m.store(OCCUPIED, Ordering::Relaxed));
            (0..space.blocks.cell_count()).for_each(|b| space.mark_block(&ball, b, Order::RangesOnly));
            assert_eq!(space.marked(), direct, "bounds {:?}, ranges only", ball.bounds);
        }
    }

    #[test]
    fn an_update_marks_the_changed_blocks_when_reached_as_marking_every_cell_would() {
        let mut space = EmptySpace::build(&BALL);
        let moved = Ball { centre: Vec3A::new(0.3, -0.25, 0.1), ..BALL };
        space.update(&[Aabb::around(Vec3A::ZERO, 1.0), Aabb::around(moved.centre, 1.0)]);
        let stale = space.stale_cells();
        assert!(stale > 0 && stale < space.grid.cell_count(), "{stale} stale cells");
        // A ray through the changed space (above the moved ball, so all of it
        // empty) marks the blocks it reaches, and no others.
        let ray = Ray::new(Vec3A::new(-1.9, 0.9, 0.0), Vec3A::X);
        assert!(space.skip(&moved, &ray, 0.0, 3.8).is_some_and(|t| t > 3.7), "the ray skips to its end");
        let after_ray = space.stale_cells();
        assert!(after_ray < stale && after_ray > 0, "{stale} stale cells, {after_ray} after the ray");
        let direct = direct(&space, &moved);
        assert_eq!(space.resolved(&moved), direct);
        assert_eq!(space.stale_cells(), 0);
        let was_empty = EmptySpace::build(&BALL).marked();
        let changed = direct.iter().zip(&was_empty).filter(|(a, b)| a != b).count();
        assert!(changed > 100, "the move changed {changed} marks");
    }

    #[test]
    fn an_update_marks_the_changed_cells_again() {
        let mut space = EmptySpace::build(&BALL);
        let before = space.empty_fraction();
        let centre = space.grid.cell_of(Vec3A::ZERO).unwrap();
        space.marks[centre].store(EMPTY, Ordering::Relaxed);
        space.update(&[Aabb::around(Vec3A::ZERO, 0.01)]);
        assert!(!space.is_empty(&BALL, centre), "the centre cell holds the surface's inside");
        assert_eq!(space.empty_fraction(), before);
    }
}
