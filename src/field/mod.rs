//! The field stage: a BlobTree stored as an arena of nodes, and the one
//! [`Field`] interface through which every other stage queries it.
//!
//! A [`Model`] answers four questions about any node: its value and analytic
//! gradient at a point, a range of its values over a box, and a bound on its
//! slope over a segment or box (Galin et al.'s local Lipschitz bound). The
//! tracer, the polygonizer and the slicers ask those questions only through
//! [`Field`], so exact, indexed and cached evaluation stay interchangeable.

mod cache_cost;
mod change_reach;
mod eight_wide_sums;
mod empty;
mod eval;
mod index;
mod kernel;
mod model;
mod named_edit;
mod node;
mod node_id;
mod point_set;
mod primitive;
mod region_bounds;
mod root_parts;
pub mod spline;
mod warp;
mod warp_bounds;

use glam::{Vec3, Vec3A};

pub use crate::geom::Region;
pub use cache_cost::{
    CacheDecision, LATTICE_COST, LOOKUP_COST, LOOSE_BOUND_STEPS, POWER_COST, RENDER_OVERHEAD, WARP_COST,
};
pub use eight_wide_sums::{SUMS_ENV, sum_lanes};
pub use empty::EmptySpace;
pub use index::{BlendIndex, IndexedLeaf, Leaf, Leaves};
pub use kernel::Kernel;
pub use model::{Change, Model, ModelBuilder, ModelCounts, ModelError, TracerChoice};
pub use named_edit::{Edit, Operator};
pub use node::{Node, NodeKind, Placement};
pub use node_id::NodeId;
pub use point_set::PointSet;
pub use primitive::{Primitive, Skeleton};
pub use warp::{Axis, Warp};

/// How many points the exact sums add at a time: 8 where the processor runs
/// the eight-wide sums (and [`SUMS_ENV`] does not force four), else 4.
#[must_use]
pub fn point_sum_lanes() -> u32 {
    if eight_wide_sums::available() { 8 } else { 4 }
}

/// Largest magnitude of any number in a model or an edit: beyond it, squared
/// distances and sums of supports leave single precision's useful range (a
/// radius of 1e20 squares to infinity). Scene files are held to it as they parse.
pub const MAX_MAGNITUDE: f32 = 1e6;

use root_parts::RootParts;

use crate::geom::{Aabb, Interval, Ray};

/// The surface colour used where the scene names none (linear RGB, a light clay).
pub const DEFAULT_COLOR: Vec3 = Vec3::new(0.72, 0.66, 0.58);

/// How exact evaluation finds the primitives that matter at a point.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EvalMode {
    /// Wide blends use their grid: only supports that can contain the point are touched.
    #[default]
    Indexed,
    /// Plain tree traversal with per-node box rejection: the paper's baseline.
    Naive,
    /// Indexed, with every `Cache` node answering from its lattice: the field
    /// the caches reconstruct, which approximates the exact one.
    Cached,
}

impl EvalMode {
    /// True when wide blends use their grid.
    #[inline]
    #[must_use]
    pub fn indexed(self) -> bool {
        matches!(self, EvalMode::Indexed | EvalMode::Cached)
    }
}

/// A scalar field with an iso-value: what the tracer, the polygonizer and the
/// slicers query. Inside is where `value > threshold`.
pub trait Field: Sync {
    /// Field value at `p`.
    fn value(&self, p: Vec3A) -> f32;
    /// Gradient of the field at `p` (points inwards, towards higher values).
    fn gradient(&self, p: Vec3A) -> Vec3A;
    /// A direction in which the field rises at `p`, for walks that look for
    /// the surface (the polygonizer's seeds): the gradient, unless another
    /// is cheaper. Any direction will do, so long as it depends on the field
    /// near `p` alone.
    fn uphill(&self, p: Vec3A) -> Vec3A {
        self.gradient(p)
    }
    /// [`Field::value`] and [`Field::gradient`] at `p` together, the same
    /// values, where computing both at once is cheaper.
    fn value_and_gradient(&self, p: Vec3A) -> (f32, Vec3A) {
        (self.value(p), self.gradient(p))
    }
    /// Surface colour at `p` (linear RGB).
    fn color(&self, p: Vec3A) -> Vec3;
    /// [`Field::gradient`] and [`Field::color`] at `p` together, the same
    /// values, where computing both at once is cheaper (a shaded hit, a
    /// coloured vertex).
    fn gradient_and_color(&self, p: Vec3A) -> (Vec3A, Vec3) {
        (self.gradient(p), self.color(p))
    }
    /// Conservative bounds of the value over a box.
    fn interval(&self, b: &Aabb) -> Interval;
    /// A bound on `|∇f|` over a region: `|f(x) - f(y)| <= L |x - y|` for x, y in it.
    fn lipschitz(&self, region: &Region) -> f32;
    /// A lower bound on the derivative of `f` along the segment `a..b`, per
    /// unit length towards `b`, where the field knows one.
    fn slope_floor(&self, a: Vec3A, b: Vec3A) -> Option<f32> {
        let _ = (a, b);
        None
    }
    /// An upper bound `M` on the second derivative of `f` along any line
    /// through a region (`d²/ds² f(x + s u) <= M` for unit `u`; negative where
    /// `f` is concave), infinite where the gradient may jump. The default
    /// knows nothing.
    fn curvature(&self, region: &Region) -> f32 {
        let _ = region;
        f32::INFINITY
    }
    /// A box outside which the field is zero.
    fn bounds(&self) -> Aabb;
    /// The iso-value `T`.
    fn threshold(&self) -> f32;
    /// True when reading a value may fill lazily built caches, so a value
    /// nobody else asks for costs exact evaluations rather than a lookup.
    fn fills_caches_on_read(&self) -> bool {
        false
    }
    /// False when [`Field::color`] is the same everywhere, so callers may skip asking.
    fn varies_in_color(&self) -> bool {
        true
    }
    /// Where the empty space holding `ray.at(t)` ends along the ray (at most
    /// `t_end`), if the field knows it is below the threshold there: see
    /// [`EmptySpace::skip`]. By default nothing is known.
    fn skip_empty(&self, ray: &Ray, t: f32, t_end: f32) -> Option<f32> {
        let _ = (ray, t, t_end);
        None
    }
}

/// How far below the threshold `T` a value must be computed for the space
/// around it to count as outside: twice the largest rounding error of an
/// evaluation, taken as 2⁻¹⁹·T (sixteen units in the last place of `T`; the
/// hundreds of terms of a dense sum stay well within it).
///
/// A step certified by a slope bound from a computed value, or a cell marked
/// empty from a computed range, holds for the true field. Kept this far from
/// `T`, they hold for the computed field too: no point whose computed value
/// exceeds `T` is ever stepped over, so where a ray first meets such a
/// lattice point does not depend on where its march started (a ray touching
/// the surface to within rounding would otherwise hit it or not by chance).
#[must_use]
pub fn outside_margin(threshold: f32) -> f32 {
    2.0 * threshold.abs() / (1 << 19) as f32
}

/// Evaluation of a [`Model`]: exact (indexed or naive) or through its caches.
#[derive(Clone, Copy)]
pub struct ModelField<'a> {
    model: &'a Model,
    mode: EvalMode,
    empty: Option<&'a EmptySpace>,
    /// The root's components, where it splits into them (indexed and cached
    /// modes; the naive baseline walks the tree as it stands).
    root: Option<RootParts>,
}

impl<'a> ModelField<'a> {
    /// Evaluation of `model` in `mode`.
    #[must_use]
    pub fn new(model: &'a Model, mode: EvalMode) -> Self {
        let root = if mode.indexed() { RootParts::of(model, mode) } else { None };
        Self { model, mode, empty: None, root }
    }

    /// The same evaluation, skipping the cells `empty` marks (built from this
    /// field, and updated after every edit since).
    #[must_use]
    pub fn skipping(self, empty: &'a EmptySpace) -> Self {
        Self { empty: Some(empty), ..self }
    }
}

impl Field for ModelField<'_> {
    fn value(&self, p: Vec3A) -> f32 {
        match &self.root {
            Some(parts) => parts.value(self.model, p, self.mode),
            None => self.model.node_value(self.model.root(), p, self.mode),
        }
    }
    fn gradient(&self, p: Vec3A) -> Vec3A {
        match &self.root {
            Some(parts) => parts.gradient(self.model, p, self.mode),
            None => self.model.node_gradient(self.model.root(), p, self.mode),
        }
    }
    fn uphill(&self, p: Vec3A) -> Vec3A {
        // Through the caches, a gradient fills the 27 samples of each one's
        // quadratic filter that no other lookup may need; the exact gradient
        // fills none, and an edit changes it only where it changes the caches.
        let mode = if self.mode == EvalMode::Cached { EvalMode::Indexed } else { self.mode };
        self.model.node_gradient(self.model.root(), p, mode)
    }
    fn value_and_gradient(&self, p: Vec3A) -> (f32, Vec3A) {
        match &self.root {
            Some(parts) => parts.value_and_gradient(self.model, p, self.mode),
            None => self.model.node_value_and_gradient(self.model.root(), p, self.mode),
        }
    }
    fn color(&self, p: Vec3A) -> Vec3 {
        self.model.node_color(self.model.root(), p, self.mode)
    }
    fn gradient_and_color(&self, p: Vec3A) -> (Vec3A, Vec3) {
        let parts = self.root.as_ref().and_then(|parts| parts.gradient_and_color(self.model, p, self.mode));
        parts.unwrap_or_else(|| self.model.node_gradient_and_color(self.model.root(), p, self.mode))
    }
    fn interval(&self, b: &Aabb) -> Interval {
        match &self.root {
            Some(parts) => parts.interval(self.model, b, self.mode),
            None => self.model.node_interval(self.model.root(), b, self.mode),
        }
    }
    fn slope_floor(&self, a: Vec3A, b: Vec3A) -> Option<f32> {
        let u = (b - a).normalize_or_zero();
        if self.mode != EvalMode::Cached || u == Vec3A::ZERO {
            return None;
        }
        self.model.node_slope_floor(self.model.root(), (a, b), u, self.mode)
    }
    fn fills_caches_on_read(&self) -> bool {
        self.mode == EvalMode::Cached && self.model.counts().caches > 0
    }
    fn lipschitz(&self, region: &Region) -> f32 {
        match &self.root {
            Some(parts) => parts.lipschitz(self.model, region, self.mode),
            None => self.model.node_lipschitz(self.model.root(), region, self.mode),
        }
    }
    fn curvature(&self, region: &Region) -> f32 {
        match &self.root {
            Some(parts) => parts.curvature(self.model, region, self.mode),
            None => self.model.node_curvature(self.model.root(), region, self.mode),
        }
    }
    fn bounds(&self) -> Aabb {
        self.model.bounds()
    }
    fn varies_in_color(&self) -> bool {
        self.model.nodes().iter().any(|n| n.color.is_some())
    }
    fn threshold(&self) -> f32 {
        self.model.threshold()
    }
    fn skip_empty(&self, ray: &Ray, t: f32, t_end: f32) -> Option<f32> {
        self.empty?.skip(self, ray, t, t_end)
    }
}

/// A field for unit tests of what walks along a line (root finding, hit
/// snapping): `value(x)` of the x coordinate alone, with threshold 0.5, no
/// bound tighter than trivial, and bounds far beyond the tests' lines.
#[cfg(test)]
pub(crate) struct AlongX<V>(pub V);

#[cfg(test)]
impl<V: Fn(f32) -> f32 + Sync> Field for AlongX<V> {
    fn value(&self, p: Vec3A) -> f32 {
        (self.0)(p.x)
    }
    fn gradient(&self, p: Vec3A) -> Vec3A {
        let h = 1e-3;
        Vec3A::X * ((self.0)(p.x + h) - (self.0)(p.x - h)) / (2.0 * h)
    }
    fn color(&self, _: Vec3A) -> Vec3 {
        Vec3::ONE
    }
    fn interval(&self, _: &Aabb) -> Interval {
        Interval::new(f32::NEG_INFINITY, f32::INFINITY)
    }
    fn lipschitz(&self, _: &Region) -> f32 {
        f32::INFINITY
    }
    fn bounds(&self) -> Aabb {
        Aabb::new(Vec3A::splat(-10.0), Vec3A::splat(10.0))
    }
    fn threshold(&self) -> f32 {
        0.5
    }
}
