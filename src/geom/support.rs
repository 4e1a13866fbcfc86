//! Where a field may be nonzero, as tight as cheap tests allow: a box, or a
//! ball grown by a cube (a point primitive's support, widened by a cache's
//! reach). A ball fills about half its box: bounded by balls, a step of
//! Table 2's probe through the hair re-evaluates a third fewer mesh corners
//! and re-traces a third fewer rays than bounded by their boxes.

use glam::{Affine3A, Vec3A};

use super::Aabb;

/// Relative difference within which a map's columns count as orthogonal and
/// of equal length (a rotation, a uniform scale): such a map takes a ball to
/// a ball.
const SIMILARITY_TOLERANCE: f32 = 1e-5;

/// A closed region of space: a box, or the points within `pad` (along each
/// axis) of a ball.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Support {
    /// An axis-aligned box.
    Box(Aabb),
    /// The ball of `radius` about `center`, grown by a cube of half-side `pad`.
    Ball {
        /// Centre of the ball.
        center: Vec3A,
        /// Radius of the ball.
        radius: f32,
        /// Half-side of the cube it is grown by.
        pad: f32,
    },
}

impl Support {
    /// The ball of `radius` about `center`.
    #[must_use]
    pub fn ball(center: Vec3A, radius: f32) -> Self {
        Support::Ball { center, radius, pad: 0.0 }
    }

    /// The smallest box holding the region.
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        match *self {
            Support::Box(b) => b,
            Support::Ball { center, radius, pad } => Aabb::around(center, radius + pad),
        }
    }

    /// True when the region and the closed box `b` share a point.
    #[inline]
    #[must_use]
    pub fn meets(&self, b: &Aabb) -> bool {
        match self {
            Support::Box(r) => r.overlaps(b),
            // The grown ball meets `b` where the ball meets `b` grown by the cube.
            Support::Ball { center, radius, pad } => b.padded(*pad).distance_squared(*center) <= radius * radius,
        }
    }

    /// True when the region holds `p`.
    #[inline]
    #[must_use]
    pub fn contains(&self, p: Vec3A) -> bool {
        self.meets(&Aabb::new(p, p))
    }

    /// True when some point of the region lies within distance `d` of `p`.
    #[must_use]
    pub fn within(&self, p: Vec3A, d: f32) -> bool {
        match self {
            Support::Box(b) => b.distance_squared(p) <= d * d,
            // The points within `d` of the grown ball are the ball of radius
            // `radius + d` grown by the same cube.
            Support::Ball { center, radius, pad } => {
                Aabb::around(p, *pad).distance_squared(*center) <= (radius + d) * (radius + d)
            }
        }
    }

    /// The stretch `(x0, x1)` of the line through `(·, y, z)` along x that
    /// holds every point it shares with the region, or `None` when it
    /// shares none.
    #[must_use]
    pub fn row_span(&self, y: f32, z: f32) -> Option<(f32, f32)> {
        self.slab_span((y, y), (z, z))
    }

    /// The stretch `(x0, x1)` along x holding every point the region shares
    /// with the slab of `y` in `ys` and `z` in `zs` (each `(lo, hi)`), or
    /// `None` when it shares none.
    #[inline]
    #[must_use]
    pub fn slab_span(&self, (y0, y1): (f32, f32), (z0, z1): (f32, f32)) -> Option<(f32, f32)> {
        match *self {
            Support::Box(b) => (b.min.y <= y1 && y0 <= b.max.y && b.min.z <= z1 && z0 <= b.max.z && !b.is_empty())
                .then_some((b.min.x, b.max.x)),
            Support::Ball { center, radius, pad } => {
                // The slab's nearest approach to the ball, across the cube.
                let dy = ((y0 - center.y).max(center.y - y1) - pad).max(0.0);
                let dz = ((z0 - center.z).max(center.z - z1) - pad).max(0.0);
                let left = radius * radius - dy * dy - dz * dz;
                // Widened by a few roundings of the terms.
                let half =
                    (left.max(0.0).sqrt() + pad) * (1.0 + 8.0 * f32::EPSILON) + 8.0 * f32::EPSILON * center.x.abs();
                (left >= 0.0).then_some((center.x - half, center.x + half))
            }
        }
    }

    /// The region grown by a cube of half-side `r` (as [`Aabb::padded`] grows a box).
    #[must_use]
    pub fn padded(&self, r: f32) -> Self {
        match *self {
            Support::Box(b) => Support::Box(b.padded(r)),
            Support::Ball { center, radius, pad } => Support::Ball { center, radius, pad: pad + r },
        }
    }

    /// A region holding the image of this one under `m`: a ball stays a
    /// ball under a similarity (its cube grown to hold the cube's image), and
    /// becomes its image's bounding box under any other map.
    #[must_use]
    pub fn transformed(&self, m: &Affine3A) -> Self {
        match *self {
            Support::Box(b) => Support::Box(b.transformed(m)),
            Support::Ball { center, radius, pad } => match similarity_scale(m) {
                Some(scale) => Support::Ball {
                    center: m.transform_point3a(center),
                    // Rounded up: the scale and the cube's image are each a
                    // product of a few roundings.
                    radius: radius * scale * (1.0 + 4.0 * f32::EPSILON),
                    pad: cube_image_half_side(m, pad),
                },
                None => Support::Box(self.bounds().transformed(m)),
            },
        }
    }
}

/// The half-side of a cube holding the image, under `m`'s linear part, of
/// the cube of half-side `pad` about the origin (rounded up).
fn cube_image_half_side(m: &Affine3A, pad: f32) -> f32 {
    let linear = Affine3A { matrix3: m.matrix3, translation: Vec3A::ZERO };
    Aabb::around(Vec3A::ZERO, pad).transformed(&linear).max.max_element() * (1.0 + 4.0 * f32::EPSILON)
}

/// The factor by which `m` scales every length, when it scales them all
/// alike (a rotation or reflection times a uniform scale); a little over it.
fn similarity_scale(m: &Affine3A) -> Option<f32> {
    let [x, y, z] = [m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis];
    let lengths = [x.length(), y.length(), z.length()];
    let scale = lengths.iter().copied().fold(0.0f32, f32::max);
    let tolerance = SIMILARITY_TOLERANCE * scale * scale;
    let equal = lengths.iter().all(|&l| (scale - l) <= SIMILARITY_TOLERANCE * scale);
    let orthogonal = x.dot(y).abs() <= tolerance && y.dot(z).abs() <= tolerance && x.dot(z).abs() <= tolerance;
    // Within the tolerance, no length grows by more than a few times it.
    (scale.is_finite() && scale > 0.0 && equal && orthogonal).then_some(scale * (1.0 + 4.0 * SIMILARITY_TOLERANCE))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;

    /// Deterministic points in `[-r, r]³`.
    fn points(n: usize, r: f32) -> Vec<Vec3A> {
        crate::geom::scattered_points(n, r, 0x9e37_79b9_7f4a_7c15)
    }

    /// Whether `p` lies within `pad` along each axis of the ball.
    fn in_grown_ball(p: Vec3A, center: Vec3A, radius: f32, pad: f32) -> bool {
        // The nearest point of the ball to `p`'s cube.
        Aabb::around(p, pad).distance_squared(center) <= radius * radius
    }

    #[test]
    fn a_grown_ball_meets_the_boxes_its_points_lie_in_and_no_others() {
        let ball = Support::Ball { center: Vec3A::new(0.2, -0.1, 0.3), radius: 0.7, pad: 0.15 };
        let (mut met, mut missed) = (0, 0);
        for (i, p) in points(4000, 1.5).into_iter().enumerate() {
            let b = Aabb::around(p, 0.05 + 0.01 * (i % 7) as f32);
            // Points of the box on a fine grid: one inside the grown ball means they meet.
            let steps = 6;
            let inside = (0..=steps).any(|i| {
                (0..=steps).any(|j| {
                    (0..=steps).any(|k| {
                        let t = Vec3A::new(i as f32, j as f32, k as f32) / steps as f32;
                        in_grown_ball(b.min + (b.max - b.min) * t, Vec3A::new(0.2, -0.1, 0.3), 0.7, 0.15)
                    })
                })
            });
            if inside {
                assert!(ball.meets(&b), "box {b:?} holds a point of the grown ball");
                met += 1;
            } else if !ball.meets(&b) {
                missed += 1;
            }
            if ball.meets(&b) {
                assert!(ball.bounds().overlaps(&b), "the bounds hold the region");
            }
        }
        assert!(met > 300 && missed > 300, "{met} boxes met, {missed} missed");
        // Where the ball's box and the ball differ: a corner of the box.
        let corner = Aabb::around(Vec3A::new(0.2, -0.1, 0.3) + Vec3A::splat(0.8), 0.01);
        assert!(ball.bounds().overlaps(&corner) && !ball.meets(&corner));
    }

    #[test]
    fn a_moved_ball_holds_the_moved_points() {
        let m = Affine3A::from_scale_rotation_translation(
            glam::Vec3::splat(1.7),
            Quat::from_euler(glam::EulerRot::ZYX, 0.4, -1.1, 0.3),
            glam::Vec3::new(0.5, -2.0, 1.0),
        );
        let (center, radius, pad) = (Vec3A::new(0.1, 0.2, -0.3), 0.6, 0.1);
        let moved = Support::Ball { center, radius, pad }.transformed(&m);
        assert!(matches!(moved, Support::Ball { .. }), "a similarity keeps a ball a ball: {moved:?}");
        for p in points(20000, 1.0) {
            if in_grown_ball(p, center, radius, pad) {
                assert!(moved.contains(m.transform_point3a(p)), "{p} moved out of the region");
            }
        }
        // A stretch along one axis leaves the ball's box, which holds the image.
        let stretch = Affine3A::from_scale(glam::Vec3::new(1.0, 3.0, 1.0));
        let stretched = Support::ball(center, radius).transformed(&stretch);
        assert_eq!(stretched, Support::Box(Aabb::around(center, radius).transformed(&stretch)));
    }

    #[test]
    fn a_rows_span_holds_every_point_it_shares_with_the_region() {
        let ball = Support::Ball { center: Vec3A::new(0.3, -0.2, 0.1), radius: 0.8, pad: 0.2 };
        let cube = Support::Box(Aabb::new(Vec3A::new(-0.5, -0.4, 0.0), Vec3A::new(0.7, 0.6, 0.9)));
        let (mut rows_met, mut rows_missed) = (0, 0);
        for region in [ball, cube] {
            for p in points(3000, 1.4) {
                let span = region.row_span(p.y, p.z);
                // The row's points on a fine comb of x.
                let inside: Vec<f32> = (0..=400)
                    .map(|i| -1.6 + 3.2 * i as f32 / 400.0)
                    .filter(|&x| region.contains(Vec3A::new(x, p.y, p.z)))
                    .collect();
                match span {
                    Some((x0, x1)) => {
                        assert!(
                            inside.iter().all(|&x| x0 <= x && x <= x1),
                            "{region:?} row {p}: {inside:?} outside {x0}..{x1}"
                        );
                        rows_met += 1;
                    }
                    None => {
                        assert!(inside.is_empty(), "{region:?} row {p} has no span but meets it");
                        rows_missed += 1;
                    }
                }
            }
        }
        assert!(rows_met > 1000 && rows_missed > 1000, "{rows_met} rows met, {rows_missed} missed");
        // A row past the ball's box corner meets its box but not the ball.
        assert_eq!(ball.row_span(0.7, 0.9), None);
        assert!(ball.bounds().overlaps(&Aabb::new(Vec3A::new(-5.0, 0.7, 0.9), Vec3A::new(5.0, 0.7, 0.9))));
    }

    #[test]
    fn a_slabs_span_holds_the_spans_of_its_rows() {
        let ball = Support::Ball { center: Vec3A::new(0.3, -0.2, 0.1), radius: 0.8, pad: 0.2 };
        let cube = Support::Box(Aabb::new(Vec3A::new(-0.5, -0.4, 0.0), Vec3A::new(0.7, 0.6, 0.9)));
        for region in [ball, cube] {
            for p in points(500, 1.4) {
                let (ys, zs) = ((p.y, p.y + 0.3), (p.z - 0.2, p.z));
                let slab = region.slab_span(ys, zs);
                for i in 0..=20 {
                    for j in 0..=20 {
                        let (y, z) = (ys.0 + 0.3 * i as f32 / 20.0, zs.0 + 0.2 * j as f32 / 20.0);
                        if let Some((x0, x1)) = region.row_span(y, z) {
                            let (s0, s1) =
                                slab.unwrap_or_else(|| panic!("{region:?}: row {y},{z} meets, its slab not"));
                            assert!(
                                s0 <= x0 && x1 <= s1,
                                "{region:?}: row {y},{z} spans {x0}..{x1}, its slab {s0}..{s1}"
                            );
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn a_point_is_within_a_distance_of_the_region_where_a_nearby_point_lies_in_it() {
        let ball = Support::Ball { center: Vec3A::new(0.1, 0.0, -0.2), radius: 0.5, pad: 0.1 };
        let cube = Support::Box(Aabb::around(Vec3A::new(0.2, 0.1, 0.0), 0.4));
        for region in [ball, cube] {
            let probes = points(400, 0.4);
            for p in points(3000, 1.5) {
                let d = 0.3;
                // A point of the region within `d` of `p`, among those tried, means `within`.
                let near = probes.iter().any(|&o| o.length() <= d && region.contains(p + o));
                if near {
                    assert!(region.within(p, d), "{region:?}: {p} has a point of the region within {d}");
                }
            }
            assert!(!region.within(Vec3A::splat(1.5), 0.3), "{region:?}: a far point");
            assert!(region.within(Vec3A::new(0.1, 0.0, -0.2), 0.0), "{region:?}: a point inside");
        }
    }

    #[test]
    fn padding_a_support_grows_it_by_a_cube() {
        let ball = Support::ball(Vec3A::ZERO, 1.0);
        // Along a diagonal, the cube's corner reaches past the ball.
        let diagonal = Vec3A::splat(1.0 / 3f32.sqrt() + 0.09);
        assert!(!ball.contains(diagonal) && ball.padded(0.1).contains(diagonal));
        assert!(!ball.padded(0.1).contains(Vec3A::new(1.11, 0.0, 0.0)));
        let b = Support::Box(Aabb::around(Vec3A::ZERO, 1.0));
        assert_eq!(b.padded(0.5).bounds(), Aabb::around(Vec3A::ZERO, 1.5));
    }
}
