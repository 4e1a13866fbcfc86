//! The kernel supports of a model: every Wyvill point and segment it sums,
//! flattened out of its blends, names, exact caches and affine transforms,
//! and where a ray crosses each.
//!
//! Along a ray `p(t) = o + t·d` seen in a support's own frame (`o'`, `d'`
//! after its placement's inverse), the squared distance to a point is
//! `|d'|² (t - t_m)² + h²`, so Wyvill's `s = 1 - r²/R²` is the quadratic
//! `a₀ - k (t - t_m)²` with `a₀ = 1 - h²/R²`, `k = |d'|²/R²`, and the field
//! `w·s³` a polynomial of degree 6 between the roots of `s`. A segment's
//! distance is a point's beyond either end and the line's in between, where
//! the projection onto the axis (linear in `t`) lies on the segment: up to
//! three such quadratics, each on its own stretch of the ray.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::{Affine3A, Vec3A};
use rayon::prelude::*;

use crate::field::{BlendIndex, EvalMode, Kernel, Model, NodeId, NodeKind, PointSet, Primitive, Skeleton};
use crate::geom::{Aabb, Ray};

/// Why a model is not a sum of polynomial kernels, for `info` and errors.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NotKernel(pub String);

impl std::fmt::Display for NotKernel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// A skeleton in its placement's frame.
#[derive(Clone, Copy, Debug)]
enum Shape {
    Point {
        center: Vec3A,
    },
    /// From `a` along the unit `axis` for `length`.
    Segment {
        a: Vec3A,
        axis: Vec3A,
        length: f32,
    },
}

/// One primitive of the sum.
#[derive(Clone, Copy, Debug)]
struct Support {
    shape: Shape,
    /// The primitive itself, for its value at a point exactly as the field
    /// computes it, and its radius and weight.
    primitive: Primitive,
    /// Index into [`KernelSupports::placements`].
    placement: u32,
}

/// Every kernel primitive of a model, numbered in the tree's order (which
/// fixes the order a ray's crossings are summed in, so a ray's sum does not
/// depend on how the supports were found). Primitives of the tree are
/// copied here; the points of a point set are read from the set itself, as
/// its node's grid reads them (a million points would take 184 MB copied).
#[derive(Clone, Debug, Default)]
pub struct KernelSupports {
    /// Where each run of consecutive support numbers is kept, by first number.
    runs: Vec<Run>,
    /// The primitives copied from the tree.
    listed: Vec<Support>,
    /// World-to-local maps; the first is the identity.
    placements: Vec<Affine3A>,
    /// The world box of each listed support, for binning onto the screen.
    boxes: Vec<Aabb>,
    /// A world sphere (centre, radius) holding each listed support, for the
    /// cone test each ray makes before it solves for a crossing.
    spheres: Vec<(Vec3A, f32)>,
    /// Supports in all.
    len: usize,
}

/// A model's supports where they are the points of one set: the set, the
/// index over it (in the set's own frame) and the map from the world there.
#[derive(Clone, Copy, Debug)]
pub struct IndexedSet<'a> {
    /// The index, whose cells list the points by number.
    pub index: &'a BlendIndex,
    /// The points.
    pub set: &'a PointSet,
    /// World to the set's frame.
    pub to_local: &'a Affine3A,
}

/// A run of consecutive support numbers from `first`.
#[derive(Clone, Debug)]
struct Run {
    first: usize,
    kept: Kept,
}

/// Where a run's supports are kept.
#[derive(Clone, Debug)]
enum Kept {
    /// In [`KernelSupports::listed`] from this index.
    Listed(usize),
    /// The points of a set, in order, under one placement.
    Set(SetPlacement),
}

/// A point set and where it is placed.
#[derive(Clone, Debug)]
struct SetPlacement {
    set: Arc<PointSet>,
    /// Index into [`KernelSupports::placements`].
    placement: u32,
    /// Local-to-world map.
    to_world: Affine3A,
    /// How far the map stretches any direction at most.
    stretch: f32,
    /// The index over the points, where they have one: its cells list them by number.
    index: Option<Arc<BlendIndex>>,
}

/// Where a ray is inside one support: `w·(a₀ - k (t - t_m)²)³` on `[t_in, t_out]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    /// Where the ray enters the support (or the stretch of it).
    pub t_in: f32,
    /// Where it leaves.
    pub t_out: f32,
    /// `s` at its peak along the ray's line.
    pub a0: f32,
    /// The curvature of `s` along the ray, `|d'|²/R²`.
    pub k: f32,
    /// Where along the ray's line `s` peaks.
    pub tm: f32,
    /// The primitive's weight.
    pub weight: f32,
    /// Which support it crosses.
    pub support: u32,
    /// Whether the support is placed by a transform.
    pub placed: bool,
    /// A bound on how far `s` computed from the ray here may stray from
    /// `s` computed by the field at a point of the ray (see [`super::margin`]).
    pub err: f32,
}

impl Crossing {
    /// `s` at `t`.
    #[inline]
    #[must_use]
    pub fn s(&self, t: f32) -> f32 {
        let u = t - self.tm;
        self.a0 - self.k * u * u
    }

    /// The largest `s` over `[t0, t1]`.
    #[inline]
    #[must_use]
    pub fn s_max(&self, t0: f32, t1: f32) -> f32 {
        self.s(self.tm.clamp(t0, t1))
    }
}

impl KernelSupports {
    /// The supports of `model` evaluated in `mode`, or why its field is not
    /// a sum of Wyvill points and segments under blends, names, transforms
    /// and caches answering exactly.
    pub fn of(model: &Model, mode: EvalMode) -> Result<Self, NotKernel> {
        let mut out = Self { placements: vec![Affine3A::IDENTITY], ..Self::default() };
        out.gather(model, model.root(), mode, (0, Affine3A::IDENTITY, Affine3A::IDENTITY))?;
        Ok(out)
    }

    /// How many supports overlap a point inside the model, on average: the
    /// supports' total volume over the volume of the cells (as wide as the
    /// median support radius) that hold their centres. A ray through the
    /// model crosses about this many at a time, and the sweep's work per
    /// stretch grows with it.
    #[must_use]
    pub fn overlap(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let mut radii: Vec<f32> = (0..self.len).into_par_iter().map(|i| self.world_sphere(i).1).collect();
        let volume: f64 = radii.iter().map(|&r| 4.0 / 3.0 * std::f64::consts::PI * f64::from(r).powi(3)).sum();
        let mid = radii.len() / 2;
        let cell = *radii.select_nth_unstable_by(mid, f32::total_cmp).1;
        let cell_of = |i: usize| (self.world_sphere(i).0 / cell).floor();
        let (low, high) = (0..self.len)
            .into_par_iter()
            .map(|i| {
                let c = cell_of(i);
                (c, c)
            })
            .reduce(|| (Vec3A::INFINITY, Vec3A::NEG_INFINITY), |a, b| (a.0.min(b.0), a.1.max(b.1)));
        let occupied = occupied_cells(self.len, |i| cell_of(i) - low, high - low);
        (volume / (occupied as f64 * f64::from(cell).powi(3))) as f32
    }

    /// The set of points the supports are, where they are one set with an
    /// index: its cells list them by support number.
    #[must_use]
    pub fn indexed_set(&self) -> Option<IndexedSet<'_>> {
        let [Run { kept: Kept::Set(s), .. }] = &self.runs[..] else { return None };
        Some(IndexedSet { index: s.index.as_deref()?, set: &s.set, to_local: &self.placements[s.placement as usize] })
    }

    /// Number of primitives.
    #[must_use]
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when the model sums no primitive.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The world box of support `i`.
    #[must_use]
    pub fn world_box(&self, i: usize) -> Aabb {
        match self.run_of(i) {
            (Kept::Listed(at), k) => self.boxes[at + k],
            (Kept::Set(s), k) => s.set.primitive(k).bounds().transformed(&s.to_world),
        }
    }

    /// A world sphere (centre, radius) holding support `i`.
    #[must_use]
    pub fn world_sphere(&self, i: usize) -> (Vec3A, f32) {
        match self.run_of(i) {
            (Kept::Listed(at), k) => self.spheres[at + k],
            (Kept::Set(s), k) => {
                let (center, radius) = s.set.ball(k);
                world_sphere(Shape::Point { center }, radius, &s.to_world, s.stretch)
            }
        }
    }

    /// Appends what lies below node `id`, seen through placement
    /// `(index, to_local, to_world)`.
    fn gather(
        &mut self,
        model: &Model,
        id: NodeId,
        mode: EvalMode,
        frame: (u32, Affine3A, Affine3A),
    ) -> Result<(), NotKernel> {
        let refuse = |what: &str| {
            let place = model.name_above(id).map_or_else(String::new, |name| format!(" in \"{name}\""));
            Err(NotKernel(format!("{what}{place} is not a sum of polynomial kernels")))
        };
        match &model.node(id).kind {
            NodeKind::Primitive(p) => self.push(p, frame).or_else(|()| refuse("a circle")),
            NodeKind::Blend { children, index } => match index.as_deref().and_then(BlendIndex::wyvill_points) {
                // A wide blend of Wyvill points is read from the set its index
                // sums: the same points, in the same (depth-first) order.
                Some(set) => {
                    self.push_set(set, index.as_ref(), frame);
                    Ok(())
                }
                None => children.iter().try_for_each(|&c| self.gather(model, c, mode, frame)),
            },
            NodeKind::Points { set, index } => {
                self.push_set(set, Some(index), frame);
                Ok(())
            }
            NodeKind::Named { child, .. } => self.gather(model, *child, mode, frame),
            NodeKind::Cache { child, grid, .. } if !model.answers_from_lattice(*grid, mode) => {
                self.gather(model, *child, mode, frame)
            }
            NodeKind::Cache { .. } => refuse("a cache answering from its lattice"),
            NodeKind::Transform { placement, child } if placement.is_identity() => {
                self.gather(model, *child, mode, frame)
            }
            NodeKind::Transform { placement, child } => {
                let to_local = placement.to_local * frame.1;
                let to_world = frame.2 * placement.to_world;
                self.placements.push(to_local);
                let index = (self.placements.len() - 1) as u32;
                self.gather(model, *child, mode, (index, to_local, to_world))
            }
            NodeKind::Union(_) => refuse("a union"),
            NodeKind::Intersection(_) => refuse("an intersection"),
            NodeKind::Difference(..) => refuse("a difference"),
            NodeKind::Ricci { .. } => refuse("a Ricci blend"),
            NodeKind::Warp { .. } => refuse("a warp"),
        }
    }

    /// Appends the points of `set`, read from the set itself; `index` is
    /// the index over them, where they have one.
    fn push_set(
        &mut self,
        set: &Arc<PointSet>,
        index: Option<&Arc<BlendIndex>>,
        (placement, _, to_world): (u32, Affine3A, Affine3A),
    ) {
        let Kernel::Wyvill = set.kernel();
        let stretch = stretch_of(placement, &to_world);
        let run = SetPlacement { set: Arc::clone(set), placement, to_world, stretch, index: index.cloned() };
        self.runs.push(Run { first: self.len, kept: Kept::Set(run) });
        self.len += set.len();
    }

    /// Appends primitive `p`; `Err` for a skeleton no quadratic describes.
    fn push(&mut self, p: &Primitive, (placement, _, to_world): (u32, Affine3A, Affine3A)) -> Result<(), ()> {
        let Kernel::Wyvill = p.kernel;
        let shape = match p.skeleton {
            Skeleton::Point { center } => Shape::Point { center },
            Skeleton::Segment { a, b } => {
                let length = (b - a).length();
                if length > 0.0 {
                    Shape::Segment { a, axis: (b - a) / length, length }
                } else {
                    Shape::Point { center: a }
                }
            }
            Skeleton::Circle { .. } => return Err(()),
        };
        if !matches!(self.runs.last(), Some(Run { kept: Kept::Listed(_), .. })) {
            self.runs.push(Run { first: self.len, kept: Kept::Listed(self.listed.len()) });
        }
        self.listed.push(Support { shape, primitive: *p, placement });
        self.boxes.push(p.bounds().transformed(&to_world));
        self.spheres.push(world_sphere(shape, p.radius, &to_world, stretch_of(placement, &to_world)));
        self.len += 1;
        Ok(())
    }

    /// The run holding support `i`, and `i`'s place in it.
    #[inline]
    fn run_of(&self, i: usize) -> (&Kept, usize) {
        let run = &self.runs[self.runs.partition_point(|r| r.first <= i) - 1];
        (&run.kept, i - run.first)
    }

    /// Support `i`: copied from the tree, or made from its point set.
    #[inline]
    fn support(&self, i: usize) -> Support {
        match self.run_of(i) {
            (Kept::Listed(at), k) => self.listed[at + k],
            (Kept::Set(s), k) => Support {
                shape: Shape::Point { center: s.set.ball(k).0 },
                primitive: s.set.primitive(k),
                placement: s.placement,
            },
        }
    }

    /// Appends to `out` where `ray` crosses support `i` within `[t_min, t_max]`.
    /// `local` caches the ray seen in the last placement asked for.
    #[inline]
    pub fn crossings(&self, i: usize, ray: &Ray, local: &mut LocalRay, span: (f32, f32), out: &mut Vec<Crossing>) {
        let first = out.len();
        match self.run_of(i) {
            // A set's point read from its packed terms, its weight only where
            // the ray crosses it: most supports a ray is asked about it misses.
            (Kept::Set(s), k) => {
                let term = s.set.terms()[k];
                let center = Vec3A::from(term.truncate());
                let (o, d, scale) = local.get(self, s.placement, ray);
                if let Some(c) = point_quadratic(o - center, d, term.w, || scale + center.length()) {
                    let placed = s.placement != 0;
                    clip_push(Crossing { weight: s.set.weights()[k], placed, ..c }, span, out);
                }
            }
            (Kept::Listed(at), k) => {
                let s = &self.listed[at + k];
                let (o, d, scale) = local.get(self, s.placement, ray);
                match s.shape {
                    Shape::Point { center } => {
                        if let Some(c) =
                            point_quadratic(o - center, d, s.primitive.inv_r2(), || scale + center.length())
                        {
                            clip_push(s.weigh(c), span, out);
                        }
                    }
                    Shape::Segment { a, axis, length } => {
                        segment_crossings(s, (a, axis, length), (o, d, scale), span, out);
                    }
                }
            }
        }
        for c in &mut out[first..] {
            c.support = i as u32;
        }
    }

    /// The value of support `i` at world point `p`, as the field computes
    /// it (through a transform, by the composed map rather than each in turn).
    #[inline]
    #[must_use]
    pub fn value(&self, i: usize, p: Vec3A) -> f32 {
        let s = &self.support(i);
        let local = if s.placement == 0 { p } else { self.placements[s.placement as usize].transform_point3a(p) };
        s.primitive.value(local)
    }
}

/// How far `to_world` (placement number `placement`, 0 the identity)
/// stretches any direction at most: its Frobenius norm.
fn stretch_of(placement: u32, to_world: &Affine3A) -> f32 {
    if placement == 0 {
        return 1.0;
    }
    let m = to_world.matrix3;
    (m.x_axis.length_squared() + m.y_axis.length_squared() + m.z_axis.length_squared()).sqrt()
}

/// A world sphere holding a support of `shape` and support radius `radius`
/// placed by `to_world`, which stretches by at most `stretch`.
fn world_sphere(shape: Shape, radius: f32, to_world: &Affine3A, stretch: f32) -> (Vec3A, f32) {
    let (centre, radius) = match shape {
        Shape::Point { center } => (center, radius),
        Shape::Segment { a, axis, length } => (a + axis * (0.5 * length), 0.5 * length + radius),
    };
    (to_world.transform_point3a(centre), radius * stretch)
}

/// The largest cell coordinate [`occupied_cells`]'s keys hold.
const CELL_KEY_MAX: f32 = ((1 << 21) - 1) as f32;

/// Most cells [`occupied_cells`] marks in a bitmap (8 MB of it).
const MAX_MARKED_CELLS: f32 = (1u64 << 26) as f32;

/// How many cells hold some item, of the items `0..n` in cells `cell(i)`
/// (whole coordinates from zero up to `top`): marked in a bitmap of the
/// cells where it is small, as a million points' cells are (a sort of
/// their keys took most of the estimate); else by sorting their keys (a
/// model more than two million cells wide counts its farthest cells as
/// the edge's: the estimate only steers `auto`).
fn occupied_cells(n: usize, cell: impl Fn(usize) -> Vec3A + Sync, top: Vec3A) -> usize {
    let dims = top + Vec3A::ONE;
    if dims.element_product() <= MAX_MARKED_CELLS.min(64.0 * n as f32) {
        marked_cells(n, cell, dims)
    } else {
        sorted_cells(n, cell)
    }
}

/// [`occupied_cells`] by marking each item's cell in a bitmap of `dims` cells.
fn marked_cells(n: usize, cell: impl Fn(usize) -> Vec3A + Sync, dims: Vec3A) -> usize {
    let (dx, dy) = (dims.x as usize, dims.y as usize);
    let cells = dims.element_product() as usize;
    let words: Vec<AtomicU64> = std::iter::repeat_with(|| AtomicU64::new(0)).take(cells.div_ceil(64)).collect();
    (0..n).into_par_iter().for_each(|i| {
        let c = cell(i);
        let k = (c.z as usize * dy + c.y as usize) * dx + c.x as usize;
        words[k / 64].fetch_or(1 << (k % 64), Ordering::Relaxed);
    });
    words.iter().map(|w| w.load(Ordering::Relaxed).count_ones() as usize).sum()
}

/// [`occupied_cells`] by sorting the items' cells as 63-bit keys, 21 bits an axis.
fn sorted_cells(n: usize, cell: impl Fn(usize) -> Vec3A + Sync) -> usize {
    let key = |i: usize| {
        let c = cell(i).min(Vec3A::splat(CELL_KEY_MAX));
        (c.x as u64) << 42 | (c.y as u64) << 21 | c.z as u64
    };
    let mut keys: Vec<u64> = (0..n).into_par_iter().map(key).collect();
    keys.par_sort_unstable();
    keys.dedup();
    keys.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn occupied_cells_are_counted_alike_in_a_bitmap_and_by_sorting() {
        // Items scattered over a 40 × 30 × 20 box of cells, two by two in
        // the same cell; a bitmap and a sort must count the same.
        let cell = |i: usize| {
            let h = (i as u64 / 2 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 20;
            Vec3A::new((h % 40) as f32, (h / 40 % 30) as f32, (h / 1200 % 20) as f32)
        };
        let dims = Vec3A::new(40.0, 30.0, 20.0);
        for n in [1, 17, 500, 5000] {
            let marked = marked_cells(n, cell, dims);
            assert_eq!(marked, sorted_cells(n, cell), "{n} items");
            assert_eq!(marked, occupied_cells(n, cell, dims - Vec3A::ONE), "{n} items");
        }
        // 5,000 items in pairs, scattered over 24,000 cells.
        let count = sorted_cells(5000, cell);
        assert!((2000..=2500).contains(&count), "{count} cells");
    }
}

/// A ray seen in one placement's frame, kept while consecutive supports share it.
#[derive(Clone, Copy, Debug, Default)]
pub struct LocalRay {
    placement: Option<u32>,
    origin: Vec3A,
    dir: Vec3A,
    /// The farthest distance along the ray a crossing is looked for.
    reach: f32,
    /// `|o'| + reach·|d'|`: the largest magnitude of a local point of the
    /// ray, for rounding bounds.
    scale: f32,
}

impl LocalRay {
    /// A cache that holds nothing yet, for rays looked along up to distance `reach`.
    #[must_use]
    pub fn new(reach: f32) -> Self {
        Self { reach, ..Self::default() }
    }

    #[inline]
    fn get(&mut self, supports: &KernelSupports, placement: u32, ray: &Ray) -> (Vec3A, Vec3A, f32) {
        if self.placement != Some(placement) {
            let m = &supports.placements[placement as usize];
            self.origin = m.transform_point3a(ray.origin);
            self.dir = m.transform_vector3a(ray.dir);
            self.placement = Some(placement);
            self.scale = self.origin.length() + self.reach * self.dir.length();
        }
        (self.origin, self.dir, self.scale)
    }
}

/// The quadratic of a point support of `1/R²` `inv_r2` at offset `oc = o' - c`
/// from the ray's local origin, along local direction `d`, of no weight
/// yet; `None` where the ray's line misses the support. `scale` bounds the
/// magnitudes of the points involved (asked only where the ray crosses).
#[inline]
fn point_quadratic(oc: Vec3A, d: Vec3A, inv_r2: f32, scale: impl FnOnce() -> f32) -> Option<Crossing> {
    let (dd, tm, a0) = peak(oc, d, inv_r2);
    if a0 <= 0.0 {
        return None;
    }
    let k = dd * inv_r2;
    let half = (a0 / k).sqrt();
    Some(Crossing {
        t_in: tm - half,
        t_out: tm + half,
        a0,
        k,
        tm,
        weight: 0.0,
        support: 0,
        placed: false,
        err: rounding(scale(), inv_r2),
    })
}

/// Along the line `o' + t·d` with `oc = o' - c`, for a point support of
/// `1/R²` `inv_r2` at `c`: `|d|²`, where `s` peaks, and `s` there.
#[inline]
fn peak(oc: Vec3A, d: Vec3A, inv_r2: f32) -> (f32, f32, f32) {
    let dd = d.length_squared();
    let tm = -d.dot(oc) / dd;
    // The perpendicular offset directly, not |oc|² - (oc·d)²: that would
    // cancel to nothing for a support far from the eye.
    let perp = oc + d * tm;
    (dd, tm, 1.0 - perp.length_squared() * inv_r2)
}

/// False where the line `o + t·d`, a ray seen in `set`'s frame, misses
/// point `i` of the set, as [`KernelSupports::crossings`] finds it: a test
/// reading nothing but the point's packed term, for rays that meet many
/// supports' cells.
#[inline]
#[must_use]
pub fn line_meets_point(set: &PointSet, i: usize, (o, d): (Vec3A, Vec3A)) -> bool {
    let term = set.terms()[i];
    peak(o - Vec3A::from(term.truncate()), d, term.w).2 > 0.0
}

impl Support {
    /// Crossing `c` of this support, with its weight and placement.
    #[inline]
    fn weigh(&self, c: Crossing) -> Crossing {
        Crossing { weight: self.primitive.weight, placed: self.placement != 0, ..c }
    }
}

/// A bound on `|s_ray - s_field|` for points of magnitude up to `scale`:
/// each side computes a point's position with a relative error of a few
/// units in the last place, so the squared distance differs by at most
/// `2 r δp + δp²` with `r <= R` (inside the support) and `δp = 8 ε scale`;
/// over `R²` that is `2 δp / R`, plus a few units in the last place of `s`.
#[inline]
fn rounding(scale: f32, inv_r2: f32) -> f32 {
    let dp = 8.0 * f32::EPSILON * scale;
    2.0 * dp * inv_r2.sqrt() + dp * dp * inv_r2 + 16.0 * f32::EPSILON
}

/// Pushes `c` clipped to `[t0, t1]`, if anything of it is left.
#[inline]
fn clip_push(mut c: Crossing, (t0, t1): (f32, f32), out: &mut Vec<Crossing>) {
    c.t_in = c.t_in.max(t0);
    c.t_out = c.t_out.min(t1);
    if c.t_in < c.t_out {
        out.push(c);
    }
}

/// The crossings of a segment support from `a` along unit `axis` for
/// `length`: the caps' point quadratics beyond its ends, the line's between.
fn segment_crossings(
    s: &Support,
    (a, axis, length): (Vec3A, Vec3A, f32),
    (o, d, scale): (Vec3A, Vec3A, f32),
    span: (f32, f32),
    out: &mut Vec<Crossing>,
) {
    let w0 = o - a;
    let scale = scale + a.length() + length;
    // The projection onto the axis, λ(t) = λ0 + t λd, splits the ray.
    let (l0, ld) = (w0.dot(axis), d.dot(axis));
    let (before, after) = if ld.abs() > f32::MIN_POSITIVE {
        let (t_a, t_b) = (-l0 / ld, (length - l0) / ld);
        if ld > 0.0 { (t_a, t_b) } else { (t_b, t_a) }
    } else if l0 < 0.0 {
        (f32::INFINITY, f32::INFINITY)
    } else if l0 > length {
        (f32::NEG_INFINITY, f32::NEG_INFINITY)
    } else {
        (f32::NEG_INFINITY, f32::INFINITY)
    };
    // The end met first along the ray (λ falling: the far end `b`).
    let (first_end, last_end) = if ld >= 0.0 { (a, a + axis * length) } else { (a + axis * length, a) };
    let stretches = [
        (span.0, before.min(span.1), Some(first_end)),
        (before.max(span.0), after.min(span.1), None),
        (after.max(span.0), span.1, Some(last_end)),
    ];
    for (t0, t1, end) in stretches {
        if t0 >= t1 {
            continue;
        }
        let quadratic = match end {
            Some(c) => point_quadratic(o - c, d, s.primitive.inv_r2(), || scale).map(|c| s.weigh(c)),
            None => line_quadratic(w0 - axis * l0, d - axis * ld, d, s, scale),
        };
        if let Some(c) = quadratic {
            clip_push(c, (t0, t1), out);
        }
    }
}

/// The quadratic of the distance to a segment's line: `w0p` and `dp` are the
/// ray's origin offset and direction perpendicular to the axis, `d` the
/// whole direction (for a ray along the axis, where the distance is fixed).
#[inline]
fn line_quadratic(w0p: Vec3A, dp: Vec3A, d: Vec3A, s: &Support, scale: f32) -> Option<Crossing> {
    let dd = dp.length_squared();
    if dd <= f32::EPSILON * f32::EPSILON * d.length_squared() {
        let a0 = 1.0 - w0p.length_squared() * s.primitive.inv_r2();
        let err = rounding(scale, s.primitive.inv_r2());
        return (a0 > 0.0).then_some(Crossing {
            t_in: f32::NEG_INFINITY,
            t_out: f32::INFINITY,
            a0,
            k: 0.0,
            tm: 0.0,
            weight: s.primitive.weight,
            support: 0,
            placed: s.placement != 0,
            err,
        });
    }
    // Only the motion across the axis changes the distance to the line.
    point_quadratic(w0p, dp, s.primitive.inv_r2(), || scale).map(|c| s.weigh(c))
}
