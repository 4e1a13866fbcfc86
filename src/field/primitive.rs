//! Skeletal primitives: a skeleton (point, segment, circle), a support radius,
//! a weight and a kernel. Their field is `w · g(distance to skeleton)`.

use glam::{Vec3A, Vec4};

use super::kernel::Kernel;
use crate::geom::{Aabb, Interval, Region};

/// The skeleton of a primitive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Skeleton {
    /// A single point.
    Point {
        /// The point.
        center: Vec3A,
    },
    /// A line segment `a..b`.
    Segment {
        /// First end.
        a: Vec3A,
        /// Second end.
        b: Vec3A,
    },
    /// A circle (the skeleton of a torus).
    Circle {
        /// Centre of the circle.
        center: Vec3A,
        /// Unit normal of the circle's plane.
        normal: Vec3A,
        /// Radius of the circle (not the support radius).
        ring: f32,
    },
}

/// A skeletal primitive: field `weight · kernel(distance to skeleton)` within `radius`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Primitive {
    /// The skeleton.
    pub skeleton: Skeleton,
    /// Support radius `R`: the field is zero farther than this from the skeleton.
    pub radius: f32,
    /// Weight `w` scaling the kernel.
    pub weight: f32,
    /// The falloff.
    pub kernel: Kernel,
    inv_r2: f32,
}

impl Primitive {
    /// A primitive from its parts.
    #[must_use]
    pub fn new(skeleton: Skeleton, radius: f32, weight: f32, kernel: Kernel) -> Self {
        Self { skeleton, radius, weight, kernel, inv_r2: 1.0 / (radius * radius) }
    }

    /// A primitive from its parts and the `1/R²` that [`Primitive::new`]
    /// computed for them before (a point set keeps it beside each centre):
    /// the same primitive, without the division.
    #[inline]
    #[must_use]
    pub(crate) fn with_inverse_square(
        skeleton: Skeleton,
        radius: f32,
        weight: f32,
        kernel: Kernel,
        inv_r2: f32,
    ) -> Self {
        Self { skeleton, radius, weight, kernel, inv_r2 }
    }

    /// `1/R²`, `R` the support radius.
    #[inline]
    #[must_use]
    pub fn inv_r2(&self) -> f32 {
        self.inv_r2
    }

    /// The same primitive with support radius `radius`.
    #[must_use]
    pub fn with_radius(&self, radius: f32) -> Self {
        Self::new(self.skeleton, radius, self.weight, self.kernel)
    }

    /// The same primitive with weight `weight`.
    #[must_use]
    pub fn with_weight(&self, weight: f32) -> Self {
        Self::new(self.skeleton, self.radius, weight, self.kernel)
    }

    /// The point of the skeleton nearest to `p`.
    #[inline]
    #[must_use]
    pub fn closest(&self, p: Vec3A) -> Vec3A {
        match self.skeleton {
            Skeleton::Point { center } => center,
            Skeleton::Segment { a, b } => closest_on_segment(p, a, b),
            Skeleton::Circle { center, normal, ring } => {
                let v = p - center;
                let radial = v - normal * v.dot(normal);
                let len = radial.length();
                // On the axis every point of the circle is nearest; pick one deterministically.
                let dir = if len > 1e-12 { radial / len } else { normal.any_orthonormal_vector() };
                center + dir * ring
            }
        }
    }

    /// The centre and `1/R²` of a point primitive with Wyvill's kernel, the
    /// leaves a blend index packs for its four-wide sum.
    #[must_use]
    pub fn wyvill_point(&self) -> Option<(Vec4, f32)> {
        match (self.skeleton, self.kernel) {
            (Skeleton::Point { center }, Kernel::Wyvill) => Some((center.extend(self.inv_r2), self.weight)),
            _ => None,
        }
    }

    /// Field value at `p`.
    #[inline]
    #[must_use]
    pub fn value(&self, p: Vec3A) -> f32 {
        let d2 = (p - self.closest(p)).length_squared();
        self.weight * self.kernel.value(d2, self.inv_r2)
    }

    /// Analytic gradient at `p`.
    #[inline]
    #[must_use]
    pub fn gradient(&self, p: Vec3A) -> Vec3A {
        let v = p - self.closest(p);
        v * (2.0 * self.weight * self.kernel.derivative_d2(v.length_squared(), self.inv_r2))
    }

    /// The box holding the support.
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        match self.skeleton {
            Skeleton::Point { center } => Aabb::around(center, self.radius),
            Skeleton::Segment { a, b } => Aabb::from_points(a, b).padded(self.radius),
            Skeleton::Circle { center, normal, ring } => {
                // A circle's extent along axis i is ring · sqrt(1 - n_i²).
                let ext = (Vec3A::ONE - normal * normal).max(Vec3A::ZERO).powf(0.5) * ring;
                Aabb::new(center - ext, center + ext).padded(self.radius)
            }
        }
    }

    /// True when the support, widened `slack` times, meets box `b`: outside,
    /// the primitive is zero all over the box.
    #[must_use]
    pub fn support_reaches(&self, b: &Aabb, slack: f32) -> bool {
        let reach = self.radius * slack;
        match self.skeleton {
            Skeleton::Point { center } => b.distance_squared(center) < reach * reach,
            _ => self.distance_range_box(b).0 < reach,
        }
    }

    /// Bounds `[min, max]` of the distance to the skeleton over a box.
    #[must_use]
    pub fn distance_range_box(&self, b: &Aabb) -> (f32, f32) {
        let half = b.size() * 0.5;
        let c = b.center();
        match self.skeleton {
            Skeleton::Point { center } => (b.distance_squared(center).sqrt(), b.max_distance_squared(center).sqrt()),
            Skeleton::Segment { a, b: e } => {
                // Distance to a convex set is convex, so its maximum over a box is at a corner.
                let far = b.corners().into_iter().map(|q| (q - closest_on_segment(q, a, e)).length());
                let far = far.fold(0.0f32, f32::max);
                // Two lower bounds, each valid alone: the box centre's distance less
                // the box's half diagonal, and the gap to the segment's own box.
                let from_center = (c - closest_on_segment(c, a, e)).length() - half.length();
                let near = from_center.max(box_gap(b, &Aabb::from_points(a, e))).max(0.0);
                (near, far)
            }
            Skeleton::Circle { center, normal, ring } => {
                let (h, q) = axial_radial_range(b, center, normal);
                let h_near = if h.contains(0.0) { 0.0 } else { h.lo.abs().min(h.hi.abs()) };
                let h_far = h.lo.abs().max(h.hi.abs());
                let q_near = if q.contains(ring) { 0.0 } else { (q.lo - ring).abs().min((q.hi - ring).abs()) };
                let q_far = (q.lo - ring).abs().max((q.hi - ring).abs());
                (h_near.hypot(q_near), h_far.hypot(q_far))
            }
        }
    }

    /// Bounds `[min, max]` of the distance to the skeleton along the segment `a..b`.
    #[must_use]
    pub fn distance_range_segment(&self, a: Vec3A, b: Vec3A) -> (f32, f32) {
        match self.skeleton {
            Skeleton::Point { center } => {
                let near = (center - closest_on_segment(center, a, b)).length();
                let far = (a - center).length().max((b - center).length());
                (near, far)
            }
            Skeleton::Segment { a: s0, b: s1 } => {
                let near = segment_segment_distance(a, b, s0, s1);
                let far =
                    (a - closest_on_segment(a, s0, s1)).length().max((b - closest_on_segment(b, s0, s1)).length());
                (near, far)
            }
            Skeleton::Circle { .. } => self.distance_range_box(&Aabb::from_points(a, b)),
        }
    }

    /// Bounds of the field over a box.
    #[must_use]
    pub fn interval(&self, b: &Aabb) -> Interval {
        let (near, far) = self.distance_range_box(b);
        let hi = self.kernel.value(near * near, self.inv_r2);
        let lo = self.kernel.value(far * far, self.inv_r2);
        Interval::new(lo, hi).scaled(self.weight)
    }
}

/// The point of segment `a..b` nearest to `p`.
#[inline]
#[must_use]
pub fn closest_on_segment(p: Vec3A, a: Vec3A, b: Vec3A) -> Vec3A {
    let ab = b - a;
    let len2 = ab.length_squared();
    if len2 <= 0.0 {
        return a;
    }
    a + ab * ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
}

/// Distance between segments `p0..p1` and `q0..q1` (Ericson, *Real-Time Collision Detection* 5.1.9).
#[must_use]
pub fn segment_segment_distance(p0: Vec3A, p1: Vec3A, q0: Vec3A, q1: Vec3A) -> f32 {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let a = d1.length_squared();
    let e = d2.length_squared();
    let f = d2.dot(r);
    let eps = 1e-12;
    let (s, t) = if a <= eps && e <= eps {
        (0.0, 0.0)
    } else if a <= eps {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(r);
        if e <= eps {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s = if denom > eps { ((b * f - c * e) / denom).clamp(0.0, 1.0) } else { 0.0 };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    ((p0 + d1 * s) - (q0 + d2 * t)).length()
}

/// Gap between two boxes (0 when they overlap).
fn box_gap(a: &Aabb, b: &Aabb) -> f32 {
    let d = (a.min - b.max).max(b.min - a.max).max(Vec3A::ZERO);
    d.length()
}

/// Ranges over a box of the axial coordinate `h = n·(x - c)` and of the distance
/// `q` from the axis through `c` along `n`.
fn axial_radial_range(b: &Aabb, c: Vec3A, n: Vec3A) -> (Interval, Interval) {
    let half = b.size() * 0.5;
    let mid = b.center() - c;
    let h_mid = n.dot(mid);
    let h_half = n.abs().dot(half);
    let h = Interval::new(h_mid - h_half, h_mid + h_half);
    let radial = |v: Vec3A| (v - n * n.dot(v)).length();
    // Distance from a line is convex: its maximum over the box is at a corner.
    let q_far = b.corners().iter().map(|&x| radial(x - c)).fold(0.0f32, f32::max);
    let q_near = (radial(mid) - half.length()).max(0.0);
    (h, Interval::new(q_near, q_far))
}

impl Primitive {
    /// Bounds `[min, max]` of the distance to the skeleton over a region.
    #[must_use]
    pub fn distance_range(&self, region: &Region) -> (f32, f32) {
        match region {
            Region::Segment(a, b) => self.distance_range_segment(*a, *b),
            Region::Box(b) => self.distance_range_box(b),
        }
    }

    /// An upper bound on the field's second derivative along any line
    /// through a region (see [`Kernel::point_bend`]; a segment's or a
    /// negative weight's falls back on the Hessian's norm); infinite for a
    /// circle, whose distance is not smooth on its axis.
    #[must_use]
    pub fn curvature_over(&self, region: &Region) -> f32 {
        let (near, far) = match self.skeleton {
            Skeleton::Circle { .. } => return f32::INFINITY,
            _ => self.distance_range(region),
        };
        match self.skeleton {
            Skeleton::Point { .. } if self.weight >= 0.0 => {
                self.weight * self.kernel.point_bend(near, far, self.radius)
            }
            _ => self.weight.abs() * self.kernel.curvature(near, far, self.radius),
        }
    }

    /// A bound on `|∇f|` over a region: a Lipschitz constant of the field there.
    #[inline]
    #[must_use]
    pub fn lipschitz_over(&self, region: &Region) -> f32 {
        if let (Skeleton::Point { center }, Region::Segment(a, b)) = (self.skeleton, region) {
            return self.point_lipschitz_on_segment(center, *a, *b);
        }
        let (near, far) = self.distance_range(region);
        self.weight.abs() * self.kernel.lipschitz(near, far, self.radius)
    }
}

impl Primitive {
    /// The hot case of segment tracing: a point skeleton and a segment. Rejects
    /// on squared distances before any square root.
    #[inline]
    fn point_lipschitz_on_segment(&self, center: Vec3A, a: Vec3A, b: Vec3A) -> f32 {
        let near2 = (center - closest_on_segment(center, a, b)).length_squared();
        let r2 = self.radius * self.radius;
        if near2 >= r2 {
            return 0.0;
        }
        let far2 = (a - center).length_squared().max((b - center).length_squared());
        self.weight.abs() * self.kernel.lipschitz(near2.sqrt(), far2.sqrt(), self.radius)
    }
}
