//! A uniform grid over the leaves of a wide blend, so that evaluating the sum
//! touches only the leaves whose supports can contain the query point.
//!
//! Blends nest (a component is a blend of splines, each a blend of points), and
//! sums are associative, so the index flattens a whole cluster of nested blends
//! into one list of leaves. Each cell also stores a Lipschitz bound, a
//! curvature bound and a value range of the sum over the cell, precomputed
//! from the leaves that reach it: a long segment's or a large box's bounds
//! then cost one grid walk, not a sum. (Short regions may still sum their
//! leaves, where the cells would be too loose: see `field::eval`.)

use glam::{Mat4, UVec3, Vec3, Vec3A, Vec4};
use std::sync::OnceLock;

use rayon::prelude::*;

use super::eight_wide_sums::{self, Chunk};
use super::kernel::Kernel;
use super::node_id::NodeId;
use super::primitive::Primitive;
use crate::geom::{Aabb, Interval, Region, UniformGrid};

/// Fewest leaves for which a blend gets an index: below this a plain loop is as fast.
pub const MIN_INDEXED_LEAVES: usize = 8;

/// Cell edge as a fraction of the median leaf size. Segment tracing bounds its
/// steps by the cells' precomputed slopes, which tighten as cells shrink: on
/// Medusa an eighth renders 1.5× faster than a quarter (8× the cells, 50 MB),
/// and a sixteenth costs 400 MB and seconds of building for 15% more.
const CELL_PER_LEAF_SIZE: f32 = 0.125;

/// A primitive is listed in the cells within this multiple of its support radius.
const SUPPORT_SLACK: f32 = 1.001;

/// Most cells a grid may have, whatever the leaf count.
const MAX_CELLS: usize = 1 << 22;

/// A leaf of a blend cluster: a primitive stored inline, or any other node.
#[derive(Clone, Debug, PartialEq)]
pub enum Leaf {
    /// A primitive, copied so the hot loop needs no arena lookup.
    Primitive(Primitive),
    /// Any non-blend node (an operator, transform, …).
    Node(NodeId),
}

/// A leaf with the colour it inherits from the nearest coloured blend above it.
#[derive(Clone, Debug, PartialEq)]
pub struct IndexedLeaf {
    /// The leaf.
    pub leaf: Leaf,
    /// Its bounds.
    pub bounds: Aabb,
    /// The leaf's own colour, or that of the nearest coloured ancestor in the cluster.
    pub color: Option<Vec3>,
}

/// The grid: leaves bucketed per cell (sorted by leaf order), plus per-cell bounds.
#[derive(Clone, Debug)]
pub struct BlendIndex {
    /// The leaves of the cluster, in depth-first scene order.
    pub leaves: Vec<IndexedLeaf>,
    grid: UniformGrid,
    offsets: Vec<u32>,
    items: Vec<u32>,
    /// The leaves reaching each block of `BLOCK_CELLS³` cells, for boxes
    /// meeting many cells: far fewer listings to pass over than the cells'.
    blocks: Lists,
    cell_lipschitz: Vec<f32>,
    cell_curvature: Vec<f32>,
    cell_range: Vec<Interval>,
    has_node_leaves: bool,
    /// The leaves packed for a four-wide sum, when all are Wyvill points.
    points: Option<PackedPoints>,
}

/// Cells per side of a block of [`BlendIndex`]'s block lists.
const BLOCK_CELLS: u32 = 4;
/// A box meeting more cells than this takes its leaves from the block lists.
const MAX_CELLS_FOR_CELL_LISTS: usize = 8;

/// Leaves listed per cell of a grid (offsets into one array of leaf indices).
#[derive(Clone, Debug)]
struct Lists {
    grid: UniformGrid,
    offsets: Vec<u32>,
    items: Vec<u32>,
}

impl Lists {
    /// The leaves reaching each cell of `grid`, in leaf order (a counting sort
    /// of (cell, leaf) pairs; the cells each leaf reaches are found in parallel).
    fn bucket(grid: UniformGrid, leaves: &[IndexedLeaf]) -> Self {
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

    fn cell(&self, c: usize) -> &[u32] {
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

/// Point leaves reduced to what their values need: centre and `1/R²` in one
/// 16-byte load, weights apart (a sixth of a leaf's size, so the leaves of a
/// dense model stay in cache); and where the eight-wide sums run, each
/// cell's list packed for them.
#[derive(Clone, Debug)]
struct PackedPoints {
    terms: Vec<Vec4>,
    weights: Vec<f32>,
    /// Each cell's list packed eight points to a chunk (see [`Self::packed`]).
    cells: Option<Vec<OnceLock<Box<[Chunk]>>>>,
}

impl PackedPoints {
    fn pack(leaves: &[IndexedLeaf], cells: usize) -> Option<Self> {
        let (terms, weights) = leaves
            .iter()
            .map(|l| match &l.leaf {
                Leaf::Primitive(p) => p.wyvill_point(),
                Leaf::Node(_) => None,
            })
            .collect::<Option<Vec<_>>>()?
            .into_iter()
            .unzip();
        let cells = eight_wide_sums::available().then(|| (0..cells).map(|_| OnceLock::new()).collect());
        Some(Self { terms, weights, cells })
    }

    /// The sum of cell `c`'s points' values at `p`, in double precision;
    /// `items` lists them (read only where the cell's packed list is not
    /// there yet, or the eight-wide sums do not run).
    #[inline]
    fn sum<'a>(&'a self, c: usize, items: impl Fn() -> &'a [u32], p: Vec3A) -> f64 {
        if let Some(sum) = self.packed(c, &items).and_then(|chunks| eight_wide_sums::sum(chunks, p)) {
            return sum;
        }
        let mut acc = glam::DVec4::ZERO;
        self.for_each_quad(items(), p, |lanes| acc += lanes.values());
        sum_lanes(acc)
    }

    /// [`Self::sum`] and the sum of the gradients in one pass, the value to the same bits.
    #[inline]
    fn sum_and_gradient<'a>(&'a self, c: usize, items: impl Fn() -> &'a [u32], p: Vec3A) -> (f64, Vec3A) {
        if let Some(both) = self.packed(c, &items).and_then(|chunks| eight_wide_sums::sum_and_gradient(chunks, p)) {
            return both;
        }
        let (mut values, mut gradients) = (glam::DVec4::ZERO, [Vec4::ZERO; 3]);
        self.for_each_quad(items(), p, |lanes| {
            values += lanes.values();
            add_axes(&mut gradients, lanes.gradients());
        });
        (sum_lanes(values), sum_axes(gradients))
    }

    /// Cell `c`'s list, `items`, packed for the eight-wide sums where they
    /// run. A cell is packed on its first sum, so that only the cells where
    /// the field is evaluated take the memory: packed, a list takes five
    /// times the bytes (all of Medusa's would take 160 MB; a render packs
    /// about 100 MB of them).
    #[inline]
    fn packed<'a>(&'a self, c: usize, items: impl Fn() -> &'a [u32]) -> Option<&'a [Chunk]> {
        let list = self.cells.as_ref()?.get(c)?;
        Some(list.get_or_init(|| eight_wide_sums::pack(&self.terms, &self.weights, items()).collect()))
    }

    /// Point `i`'s value at the nearest point of box `lo..hi`, in the
    /// operations of the eight-wide [`eight_wide_sums::interval`], so that it is zero
    /// exactly where that bound's lane for `i` is.
    fn value_at_nearest(&self, i: usize, lo: Vec3A, hi: Vec3A) -> f32 {
        let t = self.terms[i];
        let c = t.truncate();
        let near = (lo - Vec3A::from(c)).max(Vec3A::from(c) - hi).max(Vec3A::ZERO);
        let d2 = near.z.mul_add(near.z, near.y.mul_add(near.y, near.x * near.x));
        let s = (-d2).mul_add(t.w, 1.0).max(0.0);
        s * s * s * self.weights[i]
    }

    /// The slope, curvature and value bounds over `cell` of the points
    /// `items` (a cell's list), eight at a time, packed into the scratch
    /// `chunks`: the per-cell bounds of an index of points, each rounded
    /// outwards from its sum in double precision. `None` where the
    /// eight-wide sums do not run.
    fn cell_bounds(&self, items: &[u32], cell: &Aabb, chunks: &mut Vec<Chunk>) -> Option<(f32, f32, Interval)> {
        chunks.clear();
        chunks.extend(eight_wide_sums::pack(&self.terms, &self.weights, items));
        let (slope, bend) = eight_wide_sums::slope_bounds(chunks, cell.min, cell.max)?;
        let (low, high) = eight_wide_sums::interval(chunks, cell.min, cell.max)?;
        Some((outward(slope, slope).hi, outward(bend, bend).hi, outward(low, high)))
    }

    /// Calls `f` with the listed points four at a time, laid out by lane.
    /// The tail repeats a listed point with its weight masked to zero.
    #[inline]
    fn for_each_quad(&self, items: &[u32], p: Vec3A, mut f: impl FnMut(Quad)) {
        let quad = |q: [u32; 4], mask: Vec4| {
            let [a, b, c, d] = q.map(|i| i as usize);
            let t = &self.terms;
            // Columns are points; transposed, rows are x, y, z and 1/R².
            let m = Mat4::from_cols(t[a], t[b], t[c], t[d]).transpose();
            let to_center = [m.x_axis - Vec4::splat(p.x), m.y_axis - Vec4::splat(p.y), m.z_axis - Vec4::splat(p.z)];
            let [dx, dy, dz] = to_center;
            let w = &self.weights;
            Quad {
                d2: dx * dx + dy * dy + dz * dz,
                inv_r2: m.w_axis,
                weight: Vec4::new(w[a], w[b], w[c], w[d]) * mask,
                to_center,
            }
        };
        let mut chunks = items.chunks_exact(4);
        for q in &mut chunks {
            f(quad([q[0], q[1], q[2], q[3]], Vec4::ONE));
        }
        let rest = chunks.remainder();
        if let Some(&first) = rest.first() {
            let at = |k: usize| rest.get(k).copied().unwrap_or(first);
            let mask = Vec4::new(1.0, f32::from(rest.len() > 1), f32::from(rest.len() > 2), 0.0);
            f(quad([at(0), at(1), at(2), first], mask));
        }
    }
}

/// Four points seen from a query point, one per lane.
struct Quad {
    /// Squared distances.
    d2: Vec4,
    /// `1/R²`.
    inv_r2: Vec4,
    /// Weights (zero in masked lanes).
    weight: Vec4,
    /// `centre - p`, per axis.
    to_center: [Vec4; 3],
}

impl Quad {
    /// The four points' values, in double precision.
    #[inline]
    fn values(&self) -> glam::DVec4 {
        (Kernel::wyvill4(self.d2, self.inv_r2) * self.weight).as_dvec4()
    }

    /// The four points' gradients, per axis.
    #[inline]
    fn gradients(&self) -> [Vec4; 3] {
        // Towards the centres: the gradient of g(|p - c|²) is 2 g' (p - c), g' <= 0.
        let k = Kernel::wyvill4_pull(self.d2, self.inv_r2) * self.weight;
        self.to_center.map(|axis| axis * k)
    }
}

/// Adds four lanes of gradients, per axis.
#[inline]
fn add_axes(acc: &mut [Vec4; 3], g: [Vec4; 3]) {
    for (a, g) in acc.iter_mut().zip(g) {
        *a += g;
    }
}

/// The total of four lanes of values, summed in pairs.
#[inline]
fn sum_lanes(v: glam::DVec4) -> f64 {
    (v.x + v.y) + (v.z + v.w)
}

/// The total of four lanes of gradients.
#[inline]
fn sum_axes([x, y, z]: [Vec4; 3]) -> Vec3A {
    Vec3A::new(x.element_sum(), y.element_sum(), z.element_sum())
}

impl BlendIndex {
    /// Buckets `leaves` into a grid over `bounds`. `interval` and `lipschitz` give a
    /// leaf's value range and gradient bound over a cell box.
    pub fn build(
        bounds: Aabb,
        leaves: Vec<IndexedLeaf>,
        interval: impl Fn(&IndexedLeaf, &Aabb) -> Interval + Sync,
        lipschitz: impl Fn(&IndexedLeaf, &Region) -> f32 + Sync,
    ) -> Self {
        let cell = choose_cell_size(&bounds, &leaves);
        let has_node_leaves = leaves.iter().any(|l| matches!(l.leaf, Leaf::Node(_)));
        let dims = (bounds.size() / cell).ceil().as_uvec3();
        let grid = UniformGrid::new(bounds.min, cell, dims);
        let points = PackedPoints::pack(&leaves, grid.cell_count());
        let Lists { offsets, items, .. } = Lists::bucket(grid, &leaves);
        let block_dims = (dims + UVec3::splat(BLOCK_CELLS - 1)) / BLOCK_CELLS;
        let blocks = Lists::bucket(UniformGrid::new(bounds.min, cell * BLOCK_CELLS as f32, block_dims), &leaves);
        let mut index = Self {
            leaves,
            grid,
            offsets,
            items,
            blocks,
            cell_lipschitz: vec![],
            cell_curvature: vec![],
            cell_range: vec![],
            has_node_leaves,
            points,
        };
        index.precompute_cell_bounds(interval, lipschitz);
        index
    }

    fn precompute_cell_bounds(
        &mut self,
        interval: impl Fn(&IndexedLeaf, &Aabb) -> Interval + Sync,
        lipschitz: impl Fn(&IndexedLeaf, &Region) -> f32 + Sync,
    ) {
        let bounds: Vec<(f32, f32, Interval)> = (0..self.grid.cell_count())
            .into_par_iter()
            .map_init(Vec::new, |chunks, c| {
                let cell_box = self.grid.cell_box(c);
                let packed = self.points.as_ref().and_then(|p| p.cell_bounds(self.cell_items(c), &cell_box, chunks));
                if let Some(bounds) = packed {
                    return bounds;
                }
                let region = Region::Box(cell_box);
                let (mut l, mut m, mut range) = (0.0, 0.0, Interval::ZERO);
                for &i in self.cell_items(c) {
                    let leaf = &self.leaves[i as usize];
                    l += lipschitz(leaf, &region);
                    m += match &leaf.leaf {
                        Leaf::Primitive(p) => p.curvature_over(&region),
                        // A node's gradient need not even be continuous (a union's crease).
                        Leaf::Node(_) => f32::INFINITY,
                    };
                    range = range + interval(leaf, &cell_box);
                }
                (l, m, range)
            })
            .collect();
        self.cell_lipschitz = bounds.iter().map(|b| b.0).collect();
        self.cell_curvature = bounds.iter().map(|b| b.1).collect();
        self.cell_range = bounds.into_iter().map(|b| b.2).collect();
    }

    /// Where evaluation through this index may differ, even in its last
    /// bits, from evaluation through `old`: the cells and blocks whose leaf
    /// lists changed, or all either covers when their grids or their ways of
    /// summing differ. A point's sum runs over its cell's list in order,
    /// several lanes at a time, so a leaf joining or leaving a list changes
    /// the rounding at every point of the cell, inside the leaf's support or
    /// not.
    #[must_use]
    pub fn changed_since(&self, old: &BlendIndex) -> Aabb {
        // A node among the leaves sends every point down the general
        // per-leaf sum instead of the packed point sums, and back.
        let path_changed = self.points.is_some() != old.points.is_some();
        if path_changed || self.grid != old.grid || self.blocks.grid != old.blocks.grid {
            return self.grid.bounds().union(&old.grid.bounds());
        }
        let cells = (&self.offsets[..], &self.items[..], &old.offsets[..], &old.items[..]);
        let blocks = (&self.blocks.offsets[..], &self.blocks.items[..], &old.blocks.offsets[..], &old.blocks.items[..]);
        let mut changed = Aabb::EMPTY;
        for (grid, (offsets, items, old_offsets, old_items)) in [(self.grid, cells), (self.blocks.grid, blocks)] {
            for c in 0..grid.cell_count() {
                let list = &items[offsets[c] as usize..offsets[c + 1] as usize];
                let old_list = &old_items[old_offsets[c] as usize..old_offsets[c + 1] as usize];
                let same = list.len() == old_list.len()
                    && list.iter().zip(old_list).all(|(&i, &j)| self.leaves[i as usize] == old.leaves[j as usize]);
                if !same {
                    changed = changed.union(&grid.cell_box(c));
                }
            }
        }
        changed
    }

    /// The box the index's grid covers.
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        self.grid.bounds()
    }

    fn cell_items(&self, c: usize) -> &[u32] {
        &self.items[self.offsets[c] as usize..self.offsets[c + 1] as usize]
    }

    /// The blend's gradient at `p` when all its leaves are points (`None` otherwise).
    #[inline]
    #[must_use]
    pub fn point_gradient(&self, p: Vec3A) -> Option<Vec3A> {
        self.point_sum_and_gradient(p).map(|(_, gradient)| gradient)
    }

    /// The blend's value at `p` when all its leaves are points (`None` otherwise).
    #[inline]
    #[must_use]
    pub fn point_sum(&self, p: Vec3A) -> Option<f64> {
        let points = self.points.as_ref()?;
        Some(self.grid.cell_of(p).map_or(0.0, |c| points.sum(c, || self.cell_items(c), p)))
    }

    /// The blend's value and gradient at `p` when all its leaves are points:
    /// [`Self::point_sum`] and [`Self::point_gradient`] in one pass.
    #[inline]
    #[must_use]
    pub fn point_sum_and_gradient(&self, p: Vec3A) -> Option<(f64, Vec3A)> {
        let points = self.points.as_ref()?;
        let cell = self.grid.cell_of(p);
        Some(cell.map_or((0.0, Vec3A::ZERO), |c| points.sum_and_gradient(c, || self.cell_items(c), p)))
    }

    /// Bounds of the blend's value over box `b` when all its leaves are
    /// points and the eight-wide sums run (`None` otherwise): the hull, over
    /// the cells `b` meets, of the sum of each cell's points over the part of
    /// `b` in that cell. Every point of `b` lies in one of those cells, where
    /// only the cell's points reach it, so the hull holds the field there;
    /// and it is no looser than the points' own bounds over all of `b`
    /// summed, with no point to count once across cells.
    #[must_use]
    pub fn point_interval(&self, b: &Aabb) -> Option<Interval> {
        let points = self.points.as_ref().filter(|p| p.cells.is_some())?;
        let mut hull: Option<Interval> = None;
        let outside = self.visit_clipped_cells(b, |c, items, from, to| {
            let range = if items.is_empty() {
                Some(Interval::ZERO)
            } else {
                let chunks = points.packed(c, || items);
                chunks
                    .and_then(|chunks| eight_wide_sums::interval(chunks, from, to))
                    .map(|(low, high)| outward(low, high))
            };
            let Some(r) = range else { return false };
            hull = Some(hull.map_or(r, |h| h.join(r)));
            true
        })?;
        let hull = hull.unwrap_or(Interval::ZERO);
        Some(if outside { hull.join(Interval::ZERO) } else { hull })
    }

    /// Whether [`Self::point_interval`] over `b` is zero because no point
    /// reaches `b` (`None` where that bound is not taken): each listed
    /// point's value at the nearest point of the part of `b` in its cell, in
    /// the eight-wide bound's own operations, is zero. It asks no more than
    /// that, and packs no cell: a cold cache asks this of every part of its
    /// blocks, most of them in cells where no value is ever summed, and
    /// packing those lists costs more than the rest of its work when the
    /// mesh is coarse.
    #[must_use]
    pub fn points_miss(&self, b: &Aabb) -> Option<bool> {
        let points = self.points.as_ref().filter(|p| p.cells.is_some())?;
        let visited = self.visit_clipped_cells(b, |_, items, from, to| {
            items.iter().all(|&i| points.value_at_nearest(i as usize, from, to) == 0.0)
        });
        Some(visited.is_some())
    }

    /// Calls `f(cell, list, from, to)` for each grid cell `b` meets, with its
    /// linear index, its list and the part `from..to` of `b` inside it, while
    /// `f` returns true. Returns whether part of `b` lies outside the grid,
    /// or `None` where `f` stopped the visit. (Plain loops: as an iterator of
    /// nested ranges, bounding boxes for the empty-space grid took 4% more
    /// instructions.)
    fn visit_clipped_cells(&self, b: &Aabb, mut f: impl FnMut(usize, &[u32], Vec3A, Vec3A) -> bool) -> Option<bool> {
        let g = &self.grid;
        let Some((lo, hi, outside)) = g.cell_range_of(b) else { return Some(true) };
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    let i = UVec3::new(x, y, z);
                    let (c, cell) = (g.linear(i), g.box_at(i));
                    if !f(c, self.cell_items(c), b.min.max(cell.min), b.max.min(cell.max)) {
                        return None;
                    }
                }
            }
        }
        Some(outside)
    }

    /// True when some leaf is a node rather than a primitive.
    #[must_use]
    pub fn has_node_leaves(&self) -> bool {
        self.has_node_leaves
    }

    /// Leaves whose bounds overlap the cell holding `p` (empty outside the grid).
    #[inline]
    #[must_use]
    pub fn candidates(&self, p: Vec3A) -> &[u32] {
        self.grid.cell_of(p).map_or(&[], |c| self.cell_items(c))
    }

    /// Number of cells a box overlaps (clipped to the grid).
    #[must_use]
    pub fn cells_overlapped(&self, b: &Aabb) -> usize {
        self.grid.cells_overlapped(b)
    }

    /// A bound on the blend's gradient over a region from the precomputed cell
    /// bounds: the largest bound of the cells it passes through. Every point of
    /// the region lies in one of those (closed) cells, where `|∇f|` is at most
    /// that cell's bound.
    #[must_use]
    pub fn cell_lipschitz(&self, region: &Region) -> f32 {
        self.largest_over(region, &self.cell_lipschitz)
    }

    /// An upper bound on the blend's second derivative along lines through a
    /// region from the precomputed cell bounds, as [`Self::cell_lipschitz`]
    /// bounds its slope; never below zero (the field is zero past the grid).
    #[must_use]
    pub fn cell_curvature(&self, region: &Region) -> f32 {
        self.largest_over(region, &self.cell_curvature)
    }

    /// The largest of the per-cell `values` over the cells a region meets, and zero.
    fn largest_over(&self, region: &Region, values: &[f32]) -> f32 {
        let mut largest = 0.0f32;
        self.for_each_cell_in(region, |c| largest = largest.max(values[c]));
        largest
    }

    /// The leaves listed in cell `c`.
    #[must_use]
    pub fn leaves_in(&self, c: usize) -> &[u32] {
        self.cell_items(c)
    }

    /// Calls `f` with lists of leaves that together hold every leaf reaching
    /// `b` (and some that do not; each may be listed more than once): the
    /// lists of the cells `b` meets, or of the blocks when it meets many cells.
    pub fn for_each_list_over(&self, b: &Aabb, mut f: impl FnMut(&[u32])) {
        if self.grid.cells_overlapped(b) > MAX_CELLS_FOR_CELL_LISTS {
            self.blocks.grid.for_each_cell(b, |c| f(self.blocks.cell(c)));
        } else {
            self.grid.for_each_cell(b, |c| f(self.cell_items(c)));
        }
    }

    /// Visits the cells a region meets: those a segment passes through
    /// (Amanatides–Woo walk), or those a box overlaps.
    pub fn for_each_cell_in(&self, region: &Region, f: impl FnMut(usize)) {
        match region {
            Region::Segment(a, b) => self.grid.walk_segment(*a, *b, f),
            Region::Box(b) => self.grid.for_each_cell(b, f),
        }
    }

    /// Bounds of the blend's value over a box: the hull of the cells it meets.
    #[must_use]
    pub fn interval(&self, b: &Aabb) -> Interval {
        let Some((_, _, outside)) = self.grid.cell_range_of(b) else {
            return Interval::ZERO;
        };
        let mut acc: Option<Interval> = outside.then_some(Interval::ZERO);
        self.grid.for_each_cell(b, |c| {
            let r = self.cell_range[c];
            acc = Some(acc.map_or(r, |a| a.join(r)));
        });
        acc.unwrap_or(Interval::ZERO)
    }
}

/// The interval `low..high` rounded outwards to single precision.
fn outward(low: f64, high: f64) -> Interval {
    let (mut lo, mut hi) = (low as f32, high as f32);
    if f64::from(lo) > low {
        lo = lo.next_down();
    }
    if f64::from(hi) < high {
        hi = hi.next_up();
    }
    Interval::new(lo, hi)
}

/// Half the median leaf size, so a leaf spans about three cells per axis and a
/// cell lists few leaves that cannot reach the query; grown if the grid gets too big.
fn choose_cell_size(bounds: &Aabb, leaves: &[IndexedLeaf]) -> f32 {
    let mut sizes: Vec<f32> = leaves.iter().map(|l| l.bounds.size().max_element()).collect();
    sizes.sort_by(f32::total_cmp);
    let median = sizes.get(sizes.len() / 2).copied().unwrap_or(1.0);
    let extent = bounds.size().max(Vec3A::splat(1e-6));
    let mut cell = (CELL_PER_LEAF_SIZE * median).max(extent.max_element() / 512.0);
    let limit = MAX_CELLS.min(512 * leaves.len() + 4096) as f32;
    let count = |c: f32| (extent / c).ceil().max(Vec3A::ONE).element_product();
    while count(cell) > limit {
        cell *= (count(cell) / limit).cbrt().max(1.01);
    }
    cell
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::Skeleton;

    /// Eleven points of different radii and weights in a cluster, indexed.
    fn cluster() -> BlendIndex {
        let leaves: Vec<IndexedLeaf> = (0..11)
            .map(|i| {
                let f = i as f32;
                let center = Vec3A::new((f * 0.37).sin(), (f * 0.71).cos(), (f * 0.23).sin() * 0.5);
                let p = Primitive::new(Skeleton::Point { center }, 0.4 + 0.05 * f, 1.0 + 0.1 * f, Kernel::Wyvill);
                IndexedLeaf { bounds: p.bounds(), leaf: Leaf::Primitive(p), color: None }
            })
            .collect();
        let bounds = leaves.iter().fold(Aabb::EMPTY, |b, l| b.union(&l.bounds));
        let prim = |l: &IndexedLeaf| match &l.leaf {
            Leaf::Primitive(p) => *p,
            Leaf::Node(_) => unreachable!("the cluster holds primitives only"),
        };
        BlendIndex::build(bounds, leaves, |l, b| prim(l).interval(b), |l, _| prim(l).kernel.slope(0.0, prim(l).radius))
    }

    #[test]
    fn cells_list_every_leaf_reaching_them_and_the_packed_sums_match_the_plain_ones() {
        let ix = cluster();
        let prim = |i: usize| match &ix.leaves[i].leaf {
            Leaf::Primitive(p) => *p,
            Leaf::Node(_) => unreachable!(),
        };
        let mut checked = 0;
        for i in 0..ix.leaves.len() {
            let (p, Skeleton::Point { center }) = (prim(i), prim(i).skeleton) else { unreachable!() };
            // Just inside each support, in many directions: the cells there
            // are the ones a culling test could wrongly drop the leaf from.
            for k in 0..200 {
                let (a, b) = (k as f32 * 2.399, (k as f32 / 100.0) - 1.0);
                let dir = Vec3A::new(a.cos() * (1.0 - b * b).sqrt(), a.sin() * (1.0 - b * b).sqrt(), b);
                let q = center + dir * p.radius * 0.9999;
                if p.value(q) > 0.0 {
                    assert!(ix.candidates(q).contains(&(i as u32)), "leaf {i} missing at {q}");
                    checked += 1;
                }
                let plain: f64 = (0..ix.leaves.len()).map(|j| f64::from(prim(j).value(q))).sum();
                let packed = ix.point_sum(q).expect("all leaves are points");
                assert!((packed - plain).abs() <= 1e-6, "at {q}: packed {packed} vs plain {plain}");
                let plain = (0..ix.leaves.len()).fold(Vec3A::ZERO, |g, j| g + prim(j).gradient(q));
                let packed = ix.point_gradient(q).expect("all leaves are points");
                assert!((packed - plain).length() <= 1e-5 * (1.0 + plain.length()), "at {q}: {packed} vs {plain}");
            }
        }
        assert!(checked > 1000, "only {checked} points near support boundaries were checked");
    }

    #[test]
    fn the_cells_packed_bounds_are_the_leaves_bounds_summed() {
        // One negative weight among the points, for the curvature's other branch.
        let mut ix = cluster();
        if let Leaf::Primitive(p) = &mut ix.leaves[4].leaf {
            p.weight = -0.6;
        }
        let points = PackedPoints::pack(&ix.leaves, ix.grid.cell_count()).expect("all leaves are points");
        let (mut scratch, mut compared) = (vec![], 0);
        for c in 0..ix.grid.cell_count() {
            let cell = ix.grid.cell_box(c);
            let Some((slope, bend, range)) = points.cell_bounds(ix.cell_items(c), &cell, &mut scratch) else {
                eprintln!("this processor lacks AVX2 or FMA: the leaves' own bounds serve");
                return;
            };
            let region = Region::Box(cell);
            let prims = ix.cell_items(c).iter().map(|&i| match &ix.leaves[i as usize].leaf {
                Leaf::Primitive(p) => *p,
                Leaf::Node(_) => unreachable!("the cluster holds primitives only"),
            });
            let (mut plain_slope, mut plain_bend, mut plain_range) = (0.0f32, 0.0f32, Interval::ZERO);
            // Terms of either sign, each rounding by up to its profile's
            // largest value (8·|w|/R²) times a rounding of `d²/R²`.
            let mut sizes = 0.0f32;
            for p in prims {
                plain_slope += p.lipschitz_over(&region);
                let b = p.curvature_over(&region);
                (plain_bend, sizes) = (plain_bend + b, sizes + 8.0 * p.weight.abs() / (p.radius * p.radius));
                plain_range = plain_range + p.interval(&cell);
            }
            let near = |a: f32, b: f32, size: f32| (a - b).abs() <= 1e-5 * (1.0 + size);
            assert!(near(slope, plain_slope, plain_slope), "cell {c}: slope {slope} against {plain_slope}");
            assert!(near(bend, plain_bend, sizes), "cell {c}: curvature {bend} against {plain_bend}");
            let ends = near(range.lo, plain_range.lo, plain_range.hi) && near(range.hi, plain_range.hi, plain_range.hi);
            assert!(ends, "cell {c}: {range:?} against {plain_range:?}");
            compared += usize::from(plain_slope > 0.0 && plain_bend != 0.0);
        }
        assert!(compared > 100, "{compared} cells with points reaching them");
    }

    #[test]
    fn a_cell_is_packed_by_its_first_sum_and_no_other_cell_is() {
        let ix = cluster();
        let points = ix.points.as_ref().expect("all leaves are points");
        let Some(cells) = &points.cells else {
            eprintln!("this processor lacks AVX2 or FMA: no cell is ever packed");
            return;
        };
        let packed = || cells.iter().filter(|c| c.get().is_some()).count();
        assert_eq!(packed(), 0, "packed before any sum");
        let q = Vec3A::new(0.1, 0.2, 0.05);
        let c = ix.grid.cell_of(q).expect("inside the cluster");
        let (value, gradient) = ix.point_sum_and_gradient(q).expect("all leaves are points");
        assert_eq!(packed(), 1);
        // Eight points to a chunk, the list's own points in its order.
        let chunks = cells[c].get().expect("the cell summed in is packed");
        assert_eq!(chunks.len(), ix.cell_items(c).len().div_ceil(8));
        // Sums in the packed cell repeat the first to the bit.
        assert_eq!(ix.point_sum(q).map(f64::to_bits), Some(value.to_bits()));
        assert_eq!(ix.point_gradient(q), Some(gradient));
        assert_eq!(packed(), 1);
    }
    #[test]
    fn the_lists_over_a_box_hold_every_leaf_reaching_it() {
        let ix = cluster();
        let (mut by_blocks, mut by_cells) = (0, 0);
        for k in 0..400 {
            let f = k as f32;
            let center = Vec3A::new((f * 0.61).sin(), (f * 0.37).cos(), (f * 0.83).sin() * 0.6);
            // From a fraction of a cell to most of the cluster.
            let b = Aabb::around(center, ix.grid.cell * (0.2 + 0.05 * (k % 60) as f32));
            let mut listed = vec![false; ix.leaves.len()];
            ix.for_each_list_over(&b, |items| items.iter().for_each(|&i| listed[i as usize] = true));
            for (i, leaf) in ix.leaves.iter().enumerate() {
                let Leaf::Primitive(p) = &leaf.leaf else { unreachable!("the cluster holds primitives only") };
                assert!(listed[i] || !p.support_reaches(&b, 1.0), "leaf {i} reaches {b:?} but is not listed");
            }
            if ix.grid.cells_overlapped(&b) > MAX_CELLS_FOR_CELL_LISTS {
                by_blocks += 1;
            } else {
                by_cells += 1;
            }
        }
        assert!(by_blocks > 100 && by_cells > 20, "{by_blocks} boxes by blocks, {by_cells} by cells");
    }

    #[test]
    fn the_cells_sums_over_a_box_hold_the_field_and_are_no_looser_than_the_leaves_bounds() {
        let ix = cluster();
        if ix.point_interval(&Aabb::around(Vec3A::ZERO, 0.1)).is_none() {
            eprintln!("this processor lacks AVX2 or FMA: boxes take the leaves' bounds");
            return;
        }
        let prims: Vec<Primitive> = ix
            .leaves
            .iter()
            .map(|l| match &l.leaf {
                Leaf::Primitive(p) => *p,
                Leaf::Node(_) => unreachable!("the cluster holds primitives only"),
            })
            .collect();
        let (mut tighter, mut zero) = (0, 0);
        for k in 0..300 {
            let f = k as f32;
            let center = Vec3A::new((f * 0.61).sin(), (f * 0.37).cos(), (f * 0.83).sin() * 0.6) * 1.6;
            let b = Aabb::around(center, ix.grid.cell * (0.1 + 0.04 * (k % 50) as f32));
            let range = ix.point_interval(&b).expect("the eight-wide sums run");
            let leaves = prims.iter().fold(Interval::ZERO, |s, p| s + p.interval(&b));
            assert!(range.hi <= leaves.hi * (1.0 + 1e-6) + 1e-7, "{b:?}: {range:?} looser than {leaves:?}");
            tighter += usize::from(range.hi < leaves.hi * 0.99);
            zero += usize::from(range == Interval::ZERO);
            // Every sampled value lies inside, corners and faces included.
            for s in 0..64 {
                let t = Vec3A::new((s & 3) as f32 / 3.0, ((s >> 2) & 3) as f32 / 3.0, (s >> 4) as f32 / 3.0);
                let q = b.min + t * b.size();
                let v: f32 = prims.iter().map(|p| p.value(q)).sum();
                assert!(range.lo - 1e-6 <= v && v <= range.hi + 1e-6, "{v} at {q} outside {range:?}");
            }
        }
        assert!(tighter > 30 && zero > 5, "{tighter} boxes bounded tighter, {zero} found zero");
    }

    #[test]
    fn a_box_is_missed_exactly_where_its_cells_bound_is_zero_and_asking_packs_nothing() {
        let ix = cluster();
        let Some(cells) = ix.points.as_ref().and_then(|p| p.cells.as_ref()) else {
            eprintln!("this processor lacks AVX2 or FMA: boxes take the leaves' bounds");
            return;
        };
        // Boxes whose nearest corner sits within a few ulps of a support's
        // edge, inside and out, and boxes anywhere.
        let mut boxes = vec![];
        for leaf in &ix.leaves {
            let Leaf::Primitive(p) = &leaf.leaf else { unreachable!("the cluster holds primitives only") };
            let Skeleton::Point { center } = p.skeleton else { unreachable!("the cluster holds points only") };
            for (axis, sign) in (0..3).flat_map(|axis| [(axis, -1.0f32), (axis, 1.0)]) {
                for ulps in -12i32..=12 {
                    let mut corner = center;
                    corner[axis] += sign * p.radius;
                    for _ in 0..ulps.unsigned_abs() {
                        corner[axis] = if ulps < 0 { corner[axis].next_down() } else { corner[axis].next_up() };
                    }
                    let mut far = corner;
                    far[axis] += sign * ix.grid.cell * 0.3;
                    boxes.push(Aabb::new(corner.min(far), corner.max(far)));
                }
            }
        }
        for k in 0..200 {
            let f = k as f32;
            let center = Vec3A::new((f * 0.29).sin(), (f * 0.53).cos(), (f * 0.97).sin()) * 1.8;
            boxes.push(Aabb::around(center, ix.grid.cell * (0.05 + 0.02 * (k % 40) as f32)));
        }
        let misses: Vec<bool> = boxes.iter().map(|b| ix.points_miss(b).expect("the eight-wide bounds run")).collect();
        assert!(cells.iter().all(|c| c.get().is_none()), "asking whether a box is missed packed a cell");
        let (mut missed, mut reached) = (0, 0);
        for (b, miss) in boxes.iter().zip(misses) {
            let zero = ix.point_interval(b).expect("the eight-wide bounds run") == Interval::ZERO;
            assert_eq!(miss, zero, "{b:?}");
            (missed, reached) = (missed + usize::from(miss), reached + usize::from(!miss));
        }
        assert!(missed > 100 && reached > 100, "{missed} boxes missed, {reached} reached");
    }

    #[test]
    fn cells_list_fewer_leaves_than_their_boxes_overlap() {
        let ix = cluster();
        let listed = ix.items.len();
        let overlapped: usize = ix.leaves.iter().map(|l| ix.grid.cells_overlapped(&l.bounds)).sum();
        assert!(listed * 10 < overlapped * 8, "{listed} listings against {overlapped} overlapped cells");
    }
}
