//! The points of a `Points` node (a particle file's, or a long spline's):
//! one node over packed arrays, not a node and an index leaf per point. A
//! million points take 24 bytes each (centre and `1/R²` in one 16-byte load
//! for the sums, radius and weight), and 12 more where the file gives
//! colours; as nodes and leaves they took 240.

use std::sync::Arc;

use glam::{Vec3, Vec3A, Vec4};

use super::index::{BlendIndex, Leaf, Leaves};
use super::kernel::Kernel;
use super::primitive::{Primitive, Skeleton};
use crate::geom::{Aabb, Interval};

/// Points of one kernel, each with its own centre, radius, weight and,
/// optionally, colour.
#[derive(Debug, PartialEq)]
pub struct PointSet {
    /// Centre and `1/R²` of each point.
    terms: Vec<Vec4>,
    radii: Vec<f32>,
    weights: Vec<f32>,
    /// Linear RGB per point, where the points have their own.
    colors: Option<Vec<Vec3>>,
    kernel: Kernel,
    /// The box holding every point's support.
    bounds: Aabb,
}

impl PointSet {
    /// The set of `points` (centre, support radius, weight), all of
    /// `kernel`, coloured by `colors` where given.
    ///
    /// # Panics
    /// If `colors` is given with another length than the points.
    #[must_use]
    pub fn new(
        points: impl ExactSizeIterator<Item = (Vec3, f32, f32)>,
        kernel: Kernel,
        colors: Option<Vec<Vec3>>,
    ) -> Self {
        let n = points.len();
        assert!(colors.as_ref().is_none_or(|c| c.len() == n), "one colour per point");
        let (mut terms, mut radii, mut weights) = (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
        for (center, radius, weight) in points {
            // The inverse as `Primitive::new` takes it, so the packed sums and
            // a primitive made from the point agree to the bit.
            let p = Primitive::new(Skeleton::Point { center: center.into() }, radius, weight, kernel);
            terms.push(center.extend(p.inv_r2()));
            radii.push(radius);
            weights.push(weight);
        }
        let mut set = Self { terms, radii, weights, colors, kernel, bounds: Aabb::EMPTY };
        set.bounds = (0..n).fold(Aabb::EMPTY, |b, i| b.union(&set.primitive(i).bounds()));
        set
    }

    /// The index over the points, as a blend of them would have: the same
    /// grid and lists, the same sums to the bit.
    #[must_use]
    pub fn indexed(self: &Arc<Self>) -> BlendIndex {
        // A point's bounds are the same in every evaluation mode (see `Model::build_indices`).
        BlendIndex::build(
            self.bounds,
            Leaves::Points(Arc::clone(self)),
            |leaf, b| match &leaf.leaf {
                Leaf::Primitive(p) if leaf.bounds.overlaps(b) => p.interval(b),
                _ => Interval::ZERO,
            },
            |leaf, region| match &leaf.leaf {
                Leaf::Primitive(p) if region.meets(&leaf.bounds) => p.lipschitz_over(region),
                _ => 0.0,
            },
        )
    }

    /// The set of the Wyvill points among `primitives`, in order; `None` if
    /// any is not one (its terms and weights are what the packed sums read).
    #[must_use]
    pub fn of_wyvill_points<'a>(primitives: impl ExactSizeIterator<Item = Option<&'a Primitive>>) -> Option<Self> {
        let n = primitives.len();
        let mut set = Self {
            terms: Vec::with_capacity(n),
            radii: Vec::with_capacity(n),
            weights: Vec::with_capacity(n),
            colors: None,
            kernel: Kernel::Wyvill,
            bounds: Aabb::EMPTY,
        };
        for p in primitives {
            let (term, weight) = p?.wyvill_point()?;
            set.terms.push(term);
            set.radii.push(p?.radius);
            set.weights.push(weight);
        }
        set.bounds = (0..set.len()).fold(Aabb::EMPTY, |b, i| b.union(&set.primitive(i).bounds()));
        Some(set)
    }

    /// Number of points.
    #[inline]
    #[must_use]
    pub fn len(&self) -> usize {
        self.terms.len()
    }

    /// True when there is no point.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }

    /// The falloff of every point.
    #[must_use]
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// Centre and `1/R²` of every point.
    #[inline]
    #[must_use]
    pub fn terms(&self) -> &[Vec4] {
        &self.terms
    }

    /// Weight of every point.
    #[inline]
    #[must_use]
    pub fn weights(&self) -> &[f32] {
        &self.weights
    }

    /// Point `i` as a primitive.
    #[inline]
    #[must_use]
    pub fn primitive(&self, i: usize) -> Primitive {
        let term = self.terms[i];
        let center = Vec3A::from(term.truncate());
        // The term's `1/R²` is the one `Primitive::new` computes (see `new`).
        Primitive::with_inverse_square(Skeleton::Point { center }, self.radii[i], self.weights[i], self.kernel, term.w)
    }

    /// Centre and support radius of point `i`.
    #[inline]
    #[must_use]
    pub fn ball(&self, i: usize) -> (Vec3A, f32) {
        (Vec3A::from(self.terms[i].truncate()), self.radii[i])
    }

    /// Point `i`'s own colour, if the points have colours.
    #[inline]
    #[must_use]
    pub fn color(&self, i: usize) -> Option<Vec3> {
        self.colors.as_ref().map(|c| c[i])
    }

    /// True when some point's weight is negative.
    #[must_use]
    pub fn has_negative_weight(&self) -> bool {
        self.weights.iter().any(|&w| w < 0.0)
    }

    /// The box holding every point's support.
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Bytes the arrays hold.
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.len() * (size_of::<Vec4>() + 2 * size_of::<f32>())
            + self.colors.as_ref().map_or(0, |c| c.len() * size_of::<Vec3>())
    }
}
