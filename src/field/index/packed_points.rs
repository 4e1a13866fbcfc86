//! An index whose leaves are all Wyvill points: the points packed for sums
//! four at a time (and eight at a time where [`eight_wide_sums`] run), and
//! the index's values, gradients and value ranges taken from them.

use std::sync::Arc;

use once_cell::race::OnceBox;

use glam::{Mat4, UVec3, Vec3A, Vec4};

use super::{BlendIndex, Leaf, Leaves};
use crate::field::eight_wide_sums::{self, Chunk};
use crate::field::kernel::Kernel;
use crate::field::point_set::PointSet;
use crate::geom::{Aabb, Interval};

/// Point leaves reduced to what their values need: centre and `1/R²` in one
/// 16-byte load, weights apart (a sixth of a leaf's size, so the leaves of a
/// dense model stay in cache); and where the eight-wide sums run, each
/// cell's list packed for them.
#[derive(Clone)]
pub(super) struct PackedPoints {
    /// The points: a `Points` node's own set, or one made of the leaves.
    set: Arc<PointSet>,
    /// Each cell's list packed eight points to a chunk (see [`Self::packed`]).
    /// A cell's slot is one pointer, set once (by whichever thread packs it
    /// first): 8 bytes a cell where a `OnceLock` took 24, 32 MB less for
    /// the 2 M cells of a million sparse points.
    pub(super) cells: Option<Vec<OnceBox<Box<[Chunk]>>>>,
}

/// The set and which cells are packed (not where: a slot's pointer is no
/// part of what the index is).
impl std::fmt::Debug for PackedPoints {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let packed = self.cells.as_ref().map(|cells| cells.iter().map(|c| c.get().is_some()).collect::<Vec<_>>());
        f.debug_struct("PackedPoints").field("set", &self.set).field("packed", &packed).finish()
    }
}

impl PackedPoints {
    pub(super) fn pack(leaves: &Leaves, cells: usize) -> Option<Self> {
        let set = match leaves {
            Leaves::Points(set) if set.kernel() == Kernel::Wyvill => Arc::clone(set),
            Leaves::Points(_) => return None,
            Leaves::Listed(leaves) => Arc::new(PointSet::of_wyvill_points(leaves.iter().map(|l| match &l.leaf {
                Leaf::Primitive(p) => Some(p),
                Leaf::Node(_) => None,
            }))?),
        };
        let cells = eight_wide_sums::available().then(|| (0..cells).map(|_| OnceBox::new()).collect());
        Some(Self { set, cells })
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
        Some(
            list.get_or_init(|| {
                Box::new(eight_wide_sums::pack(self.set.terms(), self.set.weights(), items()).collect())
            }),
        )
    }

    /// Point `i`'s value at the nearest point of box `lo..hi`, in the
    /// operations of the eight-wide [`eight_wide_sums::interval`], so that it is zero
    /// exactly where that bound's lane for `i` is.
    fn value_at_nearest(&self, i: usize, lo: Vec3A, hi: Vec3A) -> f32 {
        let t = self.set.terms()[i];
        let c = t.truncate();
        let near = (lo - Vec3A::from(c)).max(Vec3A::from(c) - hi).max(Vec3A::ZERO);
        let d2 = near.z.mul_add(near.z, near.y.mul_add(near.y, near.x * near.x));
        let s = (-d2).mul_add(t.w, 1.0).max(0.0);
        s * s * s * self.set.weights()[i]
    }

    /// The slope, curvature and value bounds over `cell` of the points
    /// `items` (a cell's list), eight at a time, packed into the scratch
    /// `chunks`: the per-cell bounds of an index of points, each rounded
    /// outwards from its sum in double precision. `None` where the
    /// eight-wide sums do not run.
    pub(super) fn cell_bounds(
        &self,
        items: &[u32],
        cell: &Aabb,
        chunks: &mut Vec<Chunk>,
    ) -> Option<(f32, f32, Interval)> {
        chunks.clear();
        chunks.extend(eight_wide_sums::pack(self.set.terms(), self.set.weights(), items));
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
            let t = self.set.terms();
            // Columns are points; transposed, rows are x, y, z and 1/R².
            let m = Mat4::from_cols(t[a], t[b], t[c], t[d]).transpose();
            let to_center = [m.x_axis - Vec4::splat(p.x), m.y_axis - Vec4::splat(p.y), m.z_axis - Vec4::splat(p.z)];
            let [dx, dy, dz] = to_center;
            let w = self.set.weights();
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

impl BlendIndex {
    /// The Wyvill points this index sums, in its leaves' order (for a blend,
    /// its descendants through nested blends, depth first), when every leaf
    /// is one (`None` otherwise).
    #[must_use]
    pub fn wyvill_points(&self) -> Option<&Arc<PointSet>> {
        self.points.as_ref().map(|p| &p.set)
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
