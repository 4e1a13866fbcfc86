//! Leaves listed per cell of a grid: one array of leaf indices and the
//! offsets of each cell's list in it, built by a counting sort.

use rayon::prelude::*;

use glam::{UVec3, Vec3A};

use super::{IndexedLeaf, Leaf, Leaves, SUPPORT_SLACK};
use crate::field::{Primitive, Skeleton};
use crate::geom::UniformGrid;

/// Leaves listed per cell of a grid (offsets into one array of leaf indices).
#[derive(Clone, Debug)]
pub(super) struct Lists {
    pub(super) grid: UniformGrid,
    pub(super) offsets: Vec<u32>,
    pub(super) items: Vec<u32>,
}

impl Lists {
    /// The leaves reaching each cell of `grid`, in leaf order: a counting
    /// sort, one layer of cells (constant z, a contiguous run of cell
    /// numbers) at a time and the layers in parallel. Each layer counts its
    /// cells' listings, then, once every layer knows where its lists start,
    /// finds them again and writes them in place. A layer's counters stay in
    /// cache; one sort over the whole grid wrote each of a million points'
    /// 25 listings to a random place, serially, and took half the load.
    pub(super) fn bucket(grid: UniformGrid, leaves: &Leaves) -> Self {
        let layers = leaves_by_layer(&grid, leaves);
        let layer_cells = (grid.dims.x * grid.dims.y) as usize;
        let mut counts = vec![0u32; grid.cell_count() + 1];
        counts[1..].par_chunks_mut(layer_cells).zip(layers.par_iter()).enumerate().for_each(|(z, (counts, layer))| {
            let first = z * layer_cells;
            for &i in layer {
                reached_in_layer(&grid, leaves, i as usize, z as u32, |c| counts[c - first] += 1);
            }
        });
        for i in 0..grid.cell_count() {
            counts[i + 1] += counts[i];
        }
        let mut items = vec![0u32; counts[grid.cell_count()] as usize];
        let mut slices = Vec::with_capacity(layers.len());
        let mut rest = &mut items[..];
        for z in 0..layers.len() {
            let len = (counts[(z + 1) * layer_cells] - counts[z * layer_cells]) as usize;
            let (slice, tail) = rest.split_at_mut(len);
            slices.push(slice);
            rest = tail;
        }
        slices.into_par_iter().zip(layers.par_iter()).enumerate().for_each(|(z, (slice, layer))| {
            let (first, start) = (z * layer_cells, counts[z * layer_cells]);
            let mut cursor: Vec<u32> = counts[first..first + layer_cells].iter().map(|&o| o - start).collect();
            for &i in layer {
                reached_in_layer(&grid, leaves, i as usize, z as u32, |c| {
                    slice[cursor[c - first] as usize] = i;
                    cursor[c - first] += 1;
                });
            }
        });
        Self { grid, offsets: counts, items }
    }

    pub(super) fn cell(&self, c: usize) -> &[u32] {
        &self.items[self.offsets[c] as usize..self.offsets[c + 1] as usize]
    }
}

/// The leaves whose boxes reach each layer of cells (constant z), in leaf order.
fn leaves_by_layer(grid: &UniformGrid, leaves: &Leaves) -> Vec<Vec<u32>> {
    let ranges: Vec<Option<(u32, u32)>> = (0..leaves.len())
        .into_par_iter()
        .map(|i| grid.cell_range_of(&leaves.bounds(i)).map(|(lo, hi, _)| (lo.z, hi.z)))
        .collect();
    let mut layers = vec![Vec::new(); grid.dims.z as usize];
    for (i, range) in ranges.into_iter().enumerate() {
        if let Some((lo, hi)) = range {
            for z in lo..=hi {
                layers[z as usize].push(i as u32);
            }
        }
    }
    layers
}

/// Calls `f` with each cell of layer `z` of `grid` where leaf `i` can be
/// non-zero: those its box overlaps, less, for a primitive, those wholly
/// outside its support (a ball's box holds twice the ball, so a dense
/// model's cells list about half as many leaves).
fn reached_in_layer(grid: &UniformGrid, leaves: &Leaves, i: usize, z: u32, f: impl FnMut(usize)) {
    let ball = match leaves {
        // A point set's ball, without making the point a leaf.
        Leaves::Points(set) => set.ball(i),
        Leaves::Listed(listed) => match listed[i].leaf {
            Leaf::Primitive(Primitive { skeleton: Skeleton::Point { center }, radius, .. }) => (center, radius),
            _ => return reached_by_leaf(grid, &listed[i], z, f),
        },
    };
    let Some((lo, hi, _)) = grid.cell_range_of(&leaves.bounds(i)) else { return };
    // A hair wider than the support, against rounding in the value.
    let reach = ball.1 * SUPPORT_SLACK;
    ball_in_layer(grid, (ball.0, reach * reach), (lo, hi), z, f);
}

/// [`reached_in_layer`] for any leaf but a point.
fn reached_by_leaf(grid: &UniformGrid, leaf: &IndexedLeaf, z: u32, mut f: impl FnMut(usize)) {
    let Some((lo, hi, _)) = grid.cell_range_of(&leaf.bounds) else { return };
    for y in lo.y..=hi.y {
        for x in lo.x..=hi.x {
            let i = UVec3::new(x, y, z);
            let reached = match &leaf.leaf {
                Leaf::Primitive(p) => p.support_reaches(&grid.box_at(i), SUPPORT_SLACK),
                Leaf::Node(_) => true,
            };
            if reached {
                f(grid.linear(i));
            }
        }
    }
}

/// [`reached_in_layer`] for a ball (centre, squared reach) whose box spans
/// cells `lo..=hi`: the cells whose nearest point lies within reach, by
/// [`crate::geom::Aabb::distance_squared`]'s own operations on the cell's
/// box (`min = origin + i·cell`, `max = min + cell`; `(dx² + dy²) + dz²`),
/// so that the lists are the same to the leaf, but each axis's distance
/// found once per row or layer instead of once per cell.
fn ball_in_layer(
    grid: &UniformGrid,
    (c, reach2): (Vec3A, f32),
    (lo, hi): (UVec3, UVec3),
    z: u32,
    mut f: impl FnMut(usize),
) {
    let axis = |i: u32, origin: f32, p: f32| {
        let min = origin + i as f32 * grid.cell;
        let max = min + grid.cell;
        let d = (min - p).max(p - max).max(0.0);
        d * d
    };
    let dz2 = axis(z, grid.origin.z, c.z);
    for y in lo.y..=hi.y {
        let dy2 = axis(y, grid.origin.y, c.y);
        let row = grid.linear(UVec3::new(0, y, z));
        for x in lo.x..=hi.x {
            if (axis(x, grid.origin.x, c.x) + dy2) + dz2 < reach2 {
                f(row + x as usize);
            }
        }
    }
}
