//! A uniform grid over the leaves of a wide blend, so that evaluating the sum
//! touches only the leaves whose supports can contain the query point.
//!
//! Blends nest (a component is a blend of splines, each a blend of points), and
//! sums are associative, so the index flattens a whole cluster of nested blends
//! into one list of leaves. Each cell also stores a Lipschitz bound, a
//! curvature bound and a value range of the sum over the cell, precomputed
//! from the leaves that reach it: a long segment's or a large box's bounds
//! then cost one grid walk, not a sum. (Short regions may still sum their
//! leaves, where the cells would be too loose: see `field::region_bounds`.)
//!
//! - `lists`: the leaves listed per cell of a grid;
//! - `packed_points`: an index of points alone, packed for sums four and
//!   eight at a time, and the values and bounds taken from them.

mod lists;
mod packed_points;
#[cfg(test)]
mod tests;

use std::borrow::Cow;
use std::sync::Arc;

use glam::{UVec3, Vec3, Vec3A};

use rayon::prelude::*;

use super::node_id::NodeId;
use super::point_set::PointSet;
use super::primitive::Primitive;
use crate::geom::{Aabb, CellWalk, Interval, Region, UniformGrid};
use lists::Lists;
use packed_points::PackedPoints;

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

/// Cells a grid of at most [`FREE_CELLS_UP_TO`] leaves may have, however
/// few its leaves: Medusa's grid, an eighth of a leaf wide, has 1.4 M.
const FREE_CELLS: usize = 1 << 21;

/// Most leaves a grid may have for [`FREE_CELLS`] to apply: every bundled
/// scene has fewer (Medusa 9,490), and keeps its grid. Larger models get
/// [`MAX_CELLS_PER_LEAF`] a leaf: a hundred thousand sparse points took the
/// 2 M free cells, 20 a point and 60 listings, and 0.13 s to index; at 2 a
/// point, 0.03 s, meshing as fast (the segment tracer renders them 20%
/// slower; the kernel tracer, which renders them, reads their tiles' lists).
const FREE_CELLS_UP_TO: usize = 1 << 14;

/// Cells a grid may have per leaf (beyond [`FREE_CELLS`], where those
/// apply). Each cell costs about 28 bytes (its list's offset, three bounds,
/// a packing slot) whether it lists anything or not, and the cells a leaf
/// reaches grow as the cells shrink: a million sparse points at 4 cells a
/// leaf took 4 M cells and 25 listings a point; at 2, 2 M cells and 16.5
/// listings, 0.27 s less to load and 175 MB less to hold. The kernel tracer's
/// rays walk these cells, about a support wide (see `trace::kernel`); the
/// segment tracer renders them 7% slower.
const MAX_CELLS_PER_LEAF: usize = 2;

/// Listings (a leaf in a cell's list) the cell lists may hold on average per
/// leaf, once they hold more than [`FREE_LISTINGS`] in all. Where supports
/// overlap many others (a dense particle cloud: each of a million supports
/// meets about 90 others) cells an eighth of a leaf wide list each leaf
/// about 380 times: 1.5 GB of lists for a million points. Wider cells there
/// list each leaf fewer times and each cell a few more leaves.
const MAX_LISTINGS_PER_LEAF: f32 = 48.0;

/// Listings any model may have before [`MAX_LISTINGS_PER_LEAF`] applies (64 MB
/// of lists), so models of thousands of leaves, Medusa's among them, keep
/// the finest cells.
const FREE_LISTINGS: f32 = (1 << 24) as f32;

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

/// The leaves of an index: each stored with its bounds and colour, or the
/// points of one set, made into leaves as they are asked for (a million
/// stored leaves would take 112 MB).
#[derive(Clone, Debug)]
pub enum Leaves {
    /// The leaves of a cluster of blends, in depth-first scene order.
    Listed(Vec<IndexedLeaf>),
    /// The points of a `Points` node, in the file's order.
    Points(Arc<PointSet>),
}

impl Leaves {
    /// Number of leaves.
    #[must_use]
    pub fn len(&self) -> usize {
        match self {
            Leaves::Listed(leaves) => leaves.len(),
            Leaves::Points(set) => set.len(),
        }
    }

    /// True when there is no leaf.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Leaf `i`.
    #[inline]
    #[must_use]
    pub fn get(&self, i: usize) -> Cow<'_, IndexedLeaf> {
        match self {
            Leaves::Listed(leaves) => Cow::Borrowed(&leaves[i]),
            Leaves::Points(set) => {
                let p = set.primitive(i);
                Cow::Owned(IndexedLeaf { leaf: Leaf::Primitive(p), bounds: p.bounds(), color: set.color(i) })
            }
        }
    }

    /// Leaf `i`'s bounds (a point's made as [`Primitive::bounds`] makes them).
    #[inline]
    #[must_use]
    pub fn bounds(&self, i: usize) -> Aabb {
        match self {
            Leaves::Listed(leaves) => leaves[i].bounds,
            Leaves::Points(set) => {
                let (center, radius) = set.ball(i);
                Aabb::around(center, radius)
            }
        }
    }

    /// True when leaf `i` of these and leaf `j` of `other` are the same.
    fn same(&self, i: usize, other: &Leaves, j: usize) -> bool {
        match (self, other) {
            (Leaves::Points(a), Leaves::Points(b)) if Arc::ptr_eq(a, b) => i == j,
            _ => self.get(i) == other.get(j),
        }
    }
}

/// The grid: leaves bucketed per cell (sorted by leaf order), plus per-cell bounds.
#[derive(Clone, Debug)]
pub struct BlendIndex {
    /// The leaves: of a cluster of blends, or of a point set.
    pub leaves: Leaves,
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

impl BlendIndex {
    /// Buckets `leaves` into a grid over `bounds`. `interval` and `lipschitz` give a
    /// leaf's value range and gradient bound over a cell box.
    pub fn build(
        bounds: Aabb,
        leaves: Leaves,
        interval: impl Fn(&IndexedLeaf, &Aabb) -> Interval + Sync,
        lipschitz: impl Fn(&IndexedLeaf, &Region) -> f32 + Sync,
    ) -> Self {
        let cell = choose_cell_size(&bounds, &leaves);
        let has_node_leaves = match &leaves {
            Leaves::Listed(leaves) => leaves.iter().any(|l| matches!(l.leaf, Leaf::Node(_))),
            Leaves::Points(_) => false,
        };
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
        // Unzipped as they are made: collected whole first, the triples took
        // 16 bytes a cell more at once (64 MB for 4 M cells).
        let (lipschitz_bounds, (curvature_bounds, ranges)): (Vec<f32>, (Vec<f32>, Vec<Interval>)) = (0..self
            .grid
            .cell_count())
            .into_par_iter()
            .map_init(Vec::new, |chunks, c| {
                // What the sums below give for no leaf, without their setup
                // (many cells of a sparse cloud's grid list nothing).
                if self.cell_items(c).is_empty() {
                    return (0.0, 0.0, Interval::ZERO);
                }
                let cell_box = self.grid.cell_box(c);
                let packed = self.points.as_ref().and_then(|p| p.cell_bounds(self.cell_items(c), &cell_box, chunks));
                if let Some(bounds) = packed {
                    return bounds;
                }
                let region = Region::Box(cell_box);
                let (mut l, mut m, mut range) = (0.0, 0.0, Interval::ZERO);
                for &i in self.cell_items(c) {
                    let leaf = &*self.leaves.get(i as usize);
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
            .map(|(l, m, range)| (l, (m, range)))
            .unzip();
        (self.cell_lipschitz, self.cell_curvature, self.cell_range) = (lipschitz_bounds, curvature_bounds, ranges);
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
                    && list.iter().zip(old_list).all(|(&i, &j)| self.leaves.same(i as usize, &old.leaves, j as usize));
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

    /// The summed `weight` of the leaves a cell lists, averaged over the
    /// cells with each cell counted once per leaf it lists: what an
    /// evaluation at a point in some leaf's support sums on average (points
    /// where supports crowd are where the field is asked about most).
    #[must_use]
    pub fn mean_listing(&self, weight: impl Fn(&IndexedLeaf) -> f32) -> f32 {
        let (mut total, mut listings) = (0.0f64, 0usize);
        for c in 0..self.offsets.len() - 1 {
            let items = self.cell_items(c);
            let cell: f64 = items.iter().map(|&i| f64::from(weight(&self.leaves.get(i as usize)))).sum();
            total += cell * items.len() as f64;
            listings += items.len();
        }
        (total / listings.max(1) as f64) as f32
    }

    fn cell_items(&self, c: usize) -> &[u32] {
        &self.items[self.offsets[c] as usize..self.offsets[c + 1] as usize]
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

    /// The lists of the cells the line `origin + t·dir` passes through for
    /// `t` in `range`, in order, each with the `t` where the line enters
    /// and leaves its cell: every leaf reaching a point of the line there
    /// is in the list of the cell holding it (see [`CellWalk`]).
    pub fn lists_along(
        &self,
        origin: Vec3A,
        dir: Vec3A,
        range: (f32, f32),
    ) -> impl Iterator<Item = (&[u32], f32, f32)> + '_ {
        CellWalk::new(&self.grid, origin, dir, range)
            .map(|(cell, entry, exit)| (self.cell_items(self.grid.linear(cell)), entry, exit))
    }

    /// The edge of the grid's cells.
    #[must_use]
    pub fn cell_size(&self) -> f32 {
        self.grid.cell
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

/// An eighth of the median leaf size, so a cell lists few leaves that cannot
/// reach the query; grown if the grid gets too big, or if its lists would
/// list each leaf too many times (see [`MAX_LISTINGS_PER_LEAF`]).
fn choose_cell_size(bounds: &Aabb, leaves: &Leaves) -> f32 {
    let mut sizes: Vec<f32> = (0..leaves.len()).map(|i| leaves.bounds(i).size().max_element()).collect();
    sizes.sort_by(f32::total_cmp);
    let median = sizes.get(sizes.len() / 2).copied().unwrap_or(1.0);
    let extent = bounds.size().max(Vec3A::splat(1e-6));
    let mut cell = (CELL_PER_LEAF_SIZE * median).max(extent.max_element() / 512.0);
    let free = if leaves.len() <= FREE_CELLS_UP_TO { FREE_CELLS } else { 0 };
    let per_leaf = free.max(MAX_CELLS_PER_LEAF * leaves.len());
    let limit = MAX_CELLS.min(512 * leaves.len() + 4096).min(per_leaf) as f32;
    let count = |c: f32| (extent / c).ceil().max(Vec3A::ONE).element_product();
    while count(cell) > limit {
        cell *= (count(cell) / limit).cbrt().max(1.01);
    }
    // A ball of radius r cells meets about 1 + 6r + 3πr² + 4πr³/3 cells: the
    // volume of the ball grown by a cell (Steiner's formula), in cells.
    let pi = std::f32::consts::PI;
    let listings = |c: f32| {
        let r = median / (2.0 * c);
        leaves.len() as f32 * (1.0 + 6.0 * r + 3.0 * pi * r * r + 4.0 / 3.0 * pi * r * r * r)
    };
    let budget = FREE_LISTINGS.max(MAX_LISTINGS_PER_LEAF * leaves.len() as f32);
    while listings(cell) > budget {
        cell *= 1.05;
    }
    cell
}
