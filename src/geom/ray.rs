//! Rays with a unit direction.

use glam::Vec3A;

/// A ray `origin + t * dir` with `|dir| = 1`, so `t` is Euclidean distance.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    /// Start point.
    pub origin: Vec3A,
    /// Unit direction.
    pub dir: Vec3A,
}

impl Ray {
    /// A ray from a point and a (not necessarily unit) direction.
    #[must_use]
    pub fn new(origin: Vec3A, dir: Vec3A) -> Self {
        Self { origin, dir: dir.normalize() }
    }

    /// The point at distance `t`.
    #[inline]
    #[must_use]
    pub fn at(&self, t: f32) -> Vec3A {
        self.origin + self.dir * t
    }
}
