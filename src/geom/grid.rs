//! A uniform grid of cubic cells over a box: cell lookup, box overlap and the
//! Amanatides–Woo walk along a segment. The blend index and the cache's block
//! summaries both stand on it.

use glam::{IVec3, UVec3, Vec3A};

use super::{Aabb, Support};

/// `dims` cubic cells of edge `cell`, the first with its minimum corner at `origin`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UniformGrid {
    /// Minimum corner of cell (0, 0, 0).
    pub origin: Vec3A,
    /// Cell edge length.
    pub cell: f32,
    /// `1 / cell`.
    pub inv_cell: f32,
    /// Cells per axis (each at least 1).
    pub dims: UVec3,
}

impl UniformGrid {
    /// A grid of `dims` cells of edge `cell` from `origin`.
    #[must_use]
    pub fn new(origin: Vec3A, cell: f32, dims: UVec3) -> Self {
        Self { origin, cell, inv_cell: 1.0 / cell, dims: dims.max(UVec3::ONE) }
    }

    /// Number of cells.
    #[must_use]
    pub fn cell_count(&self) -> usize {
        self.dims.as_usizevec3().element_product()
    }

    /// The box the whole grid covers.
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        Aabb::new(self.origin, self.origin + self.dims.as_vec3a() * self.cell)
    }

    /// Linear index of cell `i` (x fastest).
    #[inline]
    #[must_use]
    pub fn linear(&self, i: UVec3) -> usize {
        linear_index(i, self.dims)
    }

    /// Coordinates of the cell with linear index `c`.
    #[must_use]
    pub fn coords(&self, c: usize) -> UVec3 {
        cell_coords(c, self.dims)
    }

    /// The box of the cell with linear index `c`.
    #[must_use]
    pub fn cell_box(&self, c: usize) -> Aabb {
        self.box_at(self.coords(c))
    }

    /// The box of the cell at coordinates `i`.
    #[inline]
    #[must_use]
    pub fn box_at(&self, i: UVec3) -> Aabb {
        let min = self.origin + i.as_vec3a() * self.cell;
        Aabb::new(min, min + Vec3A::splat(self.cell))
    }

    /// The cell holding `p`, or `None` outside the grid.
    #[inline]
    #[must_use]
    pub fn cell_of(&self, p: Vec3A) -> Option<usize> {
        let f = (p - self.origin) * self.inv_cell;
        if f.cmplt(Vec3A::ZERO).any() {
            return None;
        }
        let i = f.as_uvec3();
        if i.cmpge(self.dims).any() {
            return None;
        }
        Some(self.linear(i))
    }

    /// The range of cell coordinates a box overlaps, clipped to the grid, and
    /// whether the box reaches outside the grid.
    #[must_use]
    pub fn cell_range_of(&self, b: &Aabb) -> Option<(UVec3, UVec3, bool)> {
        let lo = ((b.min - self.origin) * self.inv_cell).floor();
        let hi = ((b.max - self.origin) * self.inv_cell).floor();
        let top = self.dims.as_vec3a() - Vec3A::ONE;
        if hi.cmplt(Vec3A::ZERO).any() || lo.cmpgt(top).any() || b.is_empty() {
            return None;
        }
        let outside = lo.cmplt(Vec3A::ZERO).any() || hi.cmpgt(top).any();
        Some((lo.max(Vec3A::ZERO).as_uvec3(), hi.min(top).as_uvec3(), outside))
    }

    /// Number of cells a box overlaps (clipped to the grid).
    #[must_use]
    pub fn cells_overlapped(&self, b: &Aabb) -> usize {
        self.cell_range_of(b).map_or(0, |(lo, hi, _)| (hi - lo + UVec3::ONE).as_usizevec3().element_product())
    }

    /// Visits every cell a box overlaps.
    pub fn for_each_cell(&self, b: &Aabb, mut f: impl FnMut(usize)) {
        self.for_each_cell_at(b, |_, c| f(c));
    }

    /// Visits every cell a box overlaps, with its coordinates and linear index.
    /// Inlined into its callers, an index's build puts each leaf in its cells'
    /// lists as plain loops; left to the compiler, loading Medusa took 14%
    /// more instructions.
    #[inline]
    pub fn for_each_cell_at(&self, b: &Aabb, mut f: impl FnMut(UVec3, usize)) {
        if let Some((lo, hi, _)) = self.cell_range_of(b) {
            for z in lo.z..=hi.z {
                for y in lo.y..=hi.y {
                    for x in lo.x..=hi.x {
                        let i = UVec3::new(x, y, z);
                        f(i, self.linear(i));
                    }
                }
            }
        }
    }

    /// Visits the cells a box overlaps as runs of consecutive linear indices
    /// (one per row along x), for filling per-cell arrays a row at a time.
    pub fn for_each_row(&self, b: &Aabb, mut f: impl FnMut(std::ops::Range<usize>)) {
        if let Some((lo, hi, _)) = self.cell_range_of(b) {
            for z in lo.z..=hi.z {
                for y in lo.y..=hi.y {
                    let first = self.linear(UVec3::new(lo.x, y, z));
                    f(first..first + (hi.x - lo.x) as usize + 1);
                }
            }
        }
    }

    /// Visits the cells `region` meets as runs along x, as
    /// [`Self::for_each_row`] visits a box's (every cell of a row whose slab
    /// the region meets, between the ends of the region's stretch there).
    pub fn for_each_row_meeting(&self, region: &Support, mut f: impl FnMut(std::ops::Range<usize>)) {
        let Support::Ball { .. } = region else {
            return self.for_each_row(&region.bounds(), f);
        };
        let Some((lo, hi, _)) = self.cell_range_of(&region.bounds()) else { return };
        // Truncation floors the non-negative offsets (a library call spared per row).
        let x_cell = |x: f32| (((x - self.origin.x) * self.inv_cell).max(0.0) as u32).clamp(lo.x, hi.x);
        for z in lo.z..=hi.z {
            let z0 = self.origin.z + z as f32 * self.cell;
            for y in lo.y..=hi.y {
                let y0 = self.origin.y + y as f32 * self.cell;
                let Some((x0, x1)) = region.slab_span((y0, y0 + self.cell), (z0, z0 + self.cell)) else {
                    continue;
                };
                let (from, to) = (x_cell(x0), x_cell(x1));
                let first = self.linear(UVec3::new(from, y, z));
                f(first..first + (to - from) as usize + 1);
            }
        }
    }

    /// Visits the cells the segment `a..b` passes through, in order (Amanatides–Woo walk).
    pub fn walk_segment(&self, a: Vec3A, b: Vec3A, mut f: impl FnMut(usize)) {
        self.walk_segment_while(a, b, |c, _| {
            f(c);
            true
        });
    }

    /// Visits the coordinates of the cells the segment `a..b` passes through,
    /// in order: for callers that need them, which a linear index would give
    /// only through a division per axis.
    pub fn walk_segment_coords(&self, a: Vec3A, b: Vec3A, mut f: impl FnMut(UVec3)) {
        self.walk_cells_while(a, b, |cell, _| {
            f(cell);
            true
        });
    }

    /// Walks the cells the segment `a..b` passes through, in order, while `f`
    /// returns true; `f` gets each cell and the segment parameter (0 at `a`,
    /// 1 at `b`) where the walk leaves it.
    pub fn walk_segment_while(&self, a: Vec3A, b: Vec3A, mut f: impl FnMut(usize, f32) -> bool) {
        self.walk_cells_while(a, b, |cell, exit| f(self.linear(cell), exit));
    }

    /// [`Self::walk_segment_while`], giving each cell's coordinates.
    fn walk_cells_while(&self, a: Vec3A, b: Vec3A, mut f: impl FnMut(UVec3, f32) -> bool) {
        for (cell, _, exit) in CellWalk::new(self, a, b - a, (0.0, 1.0)) {
            if !f(cell, exit) {
                return;
            }
        }
    }
}

/// The cells of a grid that the line `origin + t·dir` passes through for
/// `t` in a range, in order (Amanatides–Woo), each with the `t` where the
/// walk enters it and where it leaves (the range's ends at the first and
/// last). A walk that can pause between cells, as a caller gathering what
/// the cells list only as far as it needs.
#[derive(Clone, Debug)]
pub struct CellWalk {
    cell: IVec3,
    step: IVec3,
    top: IVec3,
    /// The parameter of the next face crossing on each axis, kept in plain
    /// scalars: a vector indexed by the axis chosen went through memory (a
    /// store and a reload of the whole vector) every cell.
    next: (f32, f32, f32),
    delta: Vec3A,
    /// Where the walk enters the next cell, and where it stops.
    entry: f32,
    end: f32,
    done: bool,
}

impl CellWalk {
    /// The walk through `grid` along `origin + t·dir` for `t` in `range`
    /// (empty where the line misses the grid there).
    #[must_use]
    pub fn new(grid: &UniformGrid, origin: Vec3A, dir: Vec3A, range: (f32, f32)) -> Self {
        let top = grid.dims.as_ivec3() - IVec3::ONE;
        let step = IVec3::new(sign(dir.x), sign(dir.y), sign(dir.z));
        let inv = dir.recip();
        let Some((t0, t1)) = grid.bounds().clip_ray(origin, inv, range.0, range.1) else {
            let (next, delta) = ((0.0, 0.0, 0.0), Vec3A::ZERO);
            return Self { cell: IVec3::ZERO, step, top, next, delta, entry: 0.0, end: 0.0, done: true };
        };
        let start = (origin + dir * t0 - grid.origin) * grid.inv_cell;
        let cell = start.floor().as_ivec3().clamp(IVec3::ZERO, top);
        let next_face = (cell + step.max(IVec3::ZERO)).as_vec3a() * grid.cell + grid.origin;
        // Infinite along axes the line does not move on.
        let still = dir.cmpeq(Vec3A::ZERO);
        let t_max = Vec3A::select(still, Vec3A::INFINITY, (next_face - origin) * inv);
        let delta = Vec3A::select(still, Vec3A::INFINITY, (grid.cell * inv).abs());
        Self { cell, step, top, next: (t_max.x, t_max.y, t_max.z), delta, entry: t0, end: t1, done: false }
    }
}

impl Iterator for CellWalk {
    /// A cell's coordinates, and where the walk enters and leaves it.
    type Item = (UVec3, f32, f32);

    #[inline]
    fn next(&mut self) -> Option<Self::Item> {
        if self.done {
            return None;
        }
        let (tx, ty, tz) = self.next;
        let (axis, t_cross) = if tx <= ty && tx <= tz {
            (0, tx)
        } else if ty <= tz {
            (1, ty)
        } else {
            (2, tz)
        };
        let item = (self.cell.as_uvec3(), self.entry, t_cross.min(self.end));
        self.entry = item.2;
        // An axis the line does not move along is chosen only when the
        // crossings are NaN (a degenerate grid): stop rather than spin.
        let inside = match axis {
            0 => advance(&mut self.cell.x, &mut self.next.0, (self.step.x, self.top.x), self.delta.x),
            1 => advance(&mut self.cell.y, &mut self.next.1, (self.step.y, self.top.y), self.delta.y),
            _ => advance(&mut self.cell.z, &mut self.next.2, (self.step.z, self.top.z), self.delta.z),
        };
        self.done = t_cross > self.end || !inside;
        Some(item)
    }
}

/// One cell of a walk along an axis: the cell coordinate moves by `step`
/// and the next crossing by `t_delta`. False when the walk leaves the grid
/// (past cell `last`) or does not move along the axis.
#[inline(always)]
fn advance(cell: &mut i32, t_next: &mut f32, (step, last): (i32, i32), t_delta: f32) -> bool {
    *cell += step;
    *t_next += t_delta;
    step != 0 && (0..=last).contains(cell)
}

/// The linear index (x fastest) of cell `i` in a block of `dims` cells.
#[inline]
#[must_use]
pub fn linear_index(i: UVec3, dims: UVec3) -> usize {
    (i.x + dims.x * (i.y + dims.y * i.z)) as usize
}

/// The cell coordinates of linear index `c` in a block of `dims` cells.
#[must_use]
pub fn cell_coords(c: usize, dims: UVec3) -> UVec3 {
    let (nx, ny) = (dims.x as usize, dims.y as usize);
    UVec3::new((c % nx) as u32, ((c / nx) % ny) as u32, (c / (nx * ny)) as u32)
}

fn sign(v: f32) -> i32 {
    if v > 0.0 {
        1
    } else if v < 0.0 {
        -1
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn walk_visits_the_cells_a_dense_march_visits() {
        let g = UniformGrid::new(Vec3A::new(-1.0, -2.0, 0.5), 0.37, UVec3::new(9, 7, 5));
        let (a, b) = (Vec3A::new(-1.5, -1.1, 0.7), Vec3A::new(2.9, 0.3, 2.2));
        let mut walked = Vec::new();
        g.walk_segment(a, b, |c| walked.push(c));
        let mut marched: Vec<usize> =
            (0..=20000).filter_map(|i| g.cell_of(a + (b - a) * (i as f32 / 20000.0))).collect();
        marched.dedup();
        for c in &marched {
            assert!(walked.contains(c), "cell {c} missed");
        }
        assert!(walked.len() <= marched.len() + 2, "{} walked vs {} marched", walked.len(), marched.len());
    }
}
