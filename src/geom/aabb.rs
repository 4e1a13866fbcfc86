//! Axis-aligned bounding boxes.

use glam::{Affine3A, Vec3A};

/// An axis-aligned box `[min, max]`; empty when any `min > max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3A,
    /// Largest corner.
    pub max: Vec3A,
}

impl Aabb {
    /// The empty box: the identity of [`Aabb::union`].
    pub const EMPTY: Aabb = Aabb { min: Vec3A::splat(f32::INFINITY), max: Vec3A::splat(f32::NEG_INFINITY) };

    /// A box from two corners.
    #[must_use]
    pub fn new(min: Vec3A, max: Vec3A) -> Self {
        Self { min, max }
    }

    /// The cube of half-width `r` around `c`.
    #[must_use]
    pub fn around(c: Vec3A, r: f32) -> Self {
        Self::new(c - Vec3A::splat(r), c + Vec3A::splat(r))
    }

    /// The smallest box holding both points.
    #[must_use]
    pub fn from_points(a: Vec3A, b: Vec3A) -> Self {
        Self::new(a.min(b), a.max(b))
    }

    /// True when the box holds no point.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    /// The smallest box holding both boxes.
    #[must_use]
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb::new(self.min.min(o.min), self.max.max(o.max))
    }

    /// The common part of both boxes (possibly empty).
    #[must_use]
    pub fn intersection(&self, o: &Aabb) -> Aabb {
        Aabb::new(self.min.max(o.min), self.max.min(o.max))
    }

    /// True when the boxes share at least one point.
    #[must_use]
    pub fn overlaps(&self, o: &Aabb) -> bool {
        !(self.min.cmpgt(o.max).any() || o.min.cmpgt(self.max).any())
    }

    /// True when `p` lies inside or on the boundary.
    #[inline]
    #[must_use]
    pub fn contains(&self, p: Vec3A) -> bool {
        !(p.cmplt(self.min).any() || p.cmpgt(self.max).any())
    }

    /// The box grown by `r` on every side.
    #[must_use]
    pub fn padded(&self, r: f32) -> Aabb {
        Aabb::new(self.min - Vec3A::splat(r), self.max + Vec3A::splat(r))
    }

    /// Centre point.
    #[must_use]
    pub fn center(&self) -> Vec3A {
        (self.min + self.max) * 0.5
    }

    /// The volume; 0 for an empty box.
    #[must_use]
    pub fn volume(&self) -> f32 {
        if self.is_empty() { 0.0 } else { (self.max - self.min).element_product() }
    }

    /// Side lengths.
    #[must_use]
    pub fn size(&self) -> Vec3A {
        self.max - self.min
    }

    /// Length of the diagonal; 0 for an empty box.
    #[must_use]
    pub fn diagonal(&self) -> f32 {
        if self.is_empty() { 0.0 } else { self.size().length() }
    }

    /// The eight corners.
    #[must_use]
    pub fn corners(&self) -> [Vec3A; 8] {
        let (a, b) = (self.min, self.max);
        std::array::from_fn(|i| {
            Vec3A::new(
                if i & 1 == 0 { a.x } else { b.x },
                if i & 2 == 0 { a.y } else { b.y },
                if i & 4 == 0 { a.z } else { b.z },
            )
        })
    }

    /// The box holding the image of this box under an affine map.
    #[must_use]
    pub fn transformed(&self, m: &Affine3A) -> Aabb {
        if self.is_empty() {
            return Aabb::EMPTY;
        }
        // Arvo's method: each output axis is the sum of the extreme
        // contributions of the input axes, exact for the transformed corners.
        let mut min = m.translation;
        let mut max = m.translation;
        let cols = [m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis];
        for (axis, col) in cols.iter().enumerate() {
            let a = *col * self.min[axis];
            let b = *col * self.max[axis];
            min += a.min(b);
            max += a.max(b);
        }
        Aabb::new(min, max)
    }

    /// Squared distance from `p` to the box (0 inside).
    #[inline]
    #[must_use]
    pub fn distance_squared(&self, p: Vec3A) -> f32 {
        let d = (self.min - p).max(p - self.max).max(Vec3A::ZERO);
        d.length_squared()
    }

    /// Squared distance from `p` to the farthest point of the box.
    #[inline]
    #[must_use]
    pub fn max_distance_squared(&self, p: Vec3A) -> f32 {
        let d = (p - self.min).abs().max((p - self.max).abs());
        d.length_squared()
    }

    /// The parameter range `[t0, t1]` where `origin + t * dir` lies in the box,
    /// clipped to `[t_min, t_max]`; `None` when the ray misses.
    #[must_use]
    pub fn clip_ray(&self, origin: Vec3A, inv_dir: Vec3A, t_min: f32, t_max: f32) -> Option<(f32, f32)> {
        // The slabs of an inverted box would swap into a real one.
        if self.is_empty() {
            return None;
        }
        let t_a = (self.min - origin) * inv_dir;
        let t_b = (self.max - origin) * inv_dir;
        // NaN from 0 * inf (ray in the slab plane) is dropped by min/max.
        let near = t_a.min(t_b).max_element().max(t_min);
        let far = t_a.max(t_b).min_element().min(t_max);
        (near <= far).then_some((near, far))
    }

    /// True when the segment `a..b` touches the box.
    #[must_use]
    pub fn meets_segment(&self, a: Vec3A, b: Vec3A) -> bool {
        let d = b - a;
        let inv = d.recip();
        self.clip_ray(a, inv, 0.0, 1.0).is_some() || (self.contains(a) || self.contains(b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transformed_box_holds_transformed_corners() {
        let b = Aabb::new(Vec3A::new(-1.0, 0.0, 2.0), Vec3A::new(1.0, 3.0, 2.5));
        let m = Affine3A::from_scale_rotation_translation(
            glam::Vec3::new(2.0, 0.5, 1.0),
            glam::Quat::from_rotation_z(0.7),
            glam::Vec3::new(1.0, 2.0, 3.0),
        );
        let t = b.transformed(&m);
        for c in b.corners() {
            let q = m.transform_point3a(c);
            assert!(t.padded(1e-5).contains(q), "{q} not in {t:?}");
        }
    }

    #[test]
    fn segment_meets_box() {
        let b = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
        assert!(b.meets_segment(Vec3A::new(-1.0, 0.5, 0.5), Vec3A::new(2.0, 0.5, 0.5)));
        assert!(!b.meets_segment(Vec3A::new(-1.0, 2.0, 0.5), Vec3A::new(2.0, 2.0, 0.5)));
        assert!(b.meets_segment(Vec3A::splat(0.5), Vec3A::splat(0.6)));
        assert!(!b.meets_segment(Vec3A::splat(1.5), Vec3A::splat(2.0)));
    }
}
