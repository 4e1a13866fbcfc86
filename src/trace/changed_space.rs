//! The space an edit changed: the field's supports before and after (a
//! point's ball, another primitive's box), marked on a coarse grid, so each
//! primary ray learns the one stretch along it where the field may differ. A
//! moved subtree of hundreds of primitives fills much less of its bounding box
//! than the box itself, and a ball a little over half of its own.

use super::dirty_rects::{PixelRect, screen_rect};
use crate::camera::Camera;
use crate::geom::{Aabb, Ray, Support, UniformGrid};

/// Grid cells along the longest side of the changed space.
const CELLS_ALONG_LONGEST_SIDE: f32 = 32.0;
/// Extra padding of each box, in cells: a ray that meets a box meets its
/// cells over at least this length, so rounding in the walk cannot skip them.
const SLACK_CELLS: f32 = 1e-2;

/// Cells of a grid over the changed space, marked where a changed box reaches.
#[derive(Clone, Debug)]
pub struct ChangedSpace {
    grid: UniformGrid,
    marked: Vec<bool>,
    bounds: Aabb,
}

impl ChangedSpace {
    /// The space within `regions` (world frame), each padded by `pad`.
    #[must_use]
    pub fn new(regions: &[Support], pad: f32) -> Self {
        let regions: Vec<Support> = regions.iter().filter(|s| !s.bounds().is_empty()).copied().collect();
        let core = regions.iter().fold(Aabb::EMPTY, |u, s| u.union(&s.bounds()));
        if core.is_empty() {
            return Self {
                grid: UniformGrid::new(glam::Vec3A::ZERO, 1.0, glam::UVec3::ONE),
                marked: vec![],
                bounds: core,
            };
        }
        let cell = (core.padded(pad).size().max_element() / CELLS_ALONG_LONGEST_SIDE).max(f32::MIN_POSITIVE);
        let pad = pad + SLACK_CELLS * cell;
        let bounds = core.padded(pad);
        let dims = (bounds.size() / cell).ceil().as_uvec3().max(glam::UVec3::ONE);
        let grid = UniformGrid::new(bounds.min, cell, dims);
        let mut marked = vec![false; grid.cell_count()];
        for s in &regions {
            grid.for_each_row_meeting(&s.padded(pad), |row| marked[row].fill(true));
        }
        Self { grid, marked, bounds }
    }

    /// A box holding all of the changed space.
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The rectangle of the `width × height` image whose rays can meet the
    /// changed space (see [`screen_rect`]).
    #[must_use]
    pub fn screen_rect(&self, camera: &Camera, width: u32, height: u32) -> Option<PixelRect> {
        screen_rect(camera, width, height, &self.bounds)
    }

    /// The stretch `(t0, t1)` of `ray` (with `t ≥ 0`) holding every point it
    /// shares with the changed space, or `None` when it shares none.
    #[must_use]
    pub fn span(&self, ray: &Ray) -> Option<(f32, f32)> {
        let inv = ray.dir.recip();
        let (t_in, t_out) = self.bounds.clip_ray(ray.origin, inv, 0.0, f32::INFINITY)?;
        let (mut first, mut last) = (None, None);
        self.grid.walk_segment(ray.at(t_in), ray.at(t_out), |c| {
            if self.marked[c] {
                first.get_or_insert(c);
                last = Some(c);
            }
        });
        let clip = |c: usize| self.grid.cell_box(c).clip_ray(ray.origin, inv, 0.0, f32::INFINITY);
        let t0 = clip(first?).map_or(t_in, |s| s.0.max(t_in));
        let t1 = clip(last?).map_or(t_out, |s| s.1.min(t_out));
        Some((t0, t1.max(t0)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    /// The stretch of `ray` (with `t ≥ 0`) inside the ball of `radius` about `center`.
    fn ball_stretch(ray: &Ray, center: Vec3A, radius: f32) -> Option<(f32, f32)> {
        let (a, o) = (ray.dir.length_squared(), ray.origin - center);
        let (b, c) = (o.dot(ray.dir), o.length_squared() - radius * radius);
        let disc = b * b - a * c;
        (disc >= 0.0)
            .then(|| ((-b - disc.sqrt()) / a, (-b + disc.sqrt()) / a))
            .filter(|s| s.1 >= 0.0)
            .map(|s| (s.0.max(0.0), s.1))
    }

    #[test]
    fn every_point_a_ray_shares_with_a_box_or_a_ball_lies_in_its_span() {
        let regions: Vec<Support> = (0..40)
            .map(|i| {
                let a = i as f32 * 0.7;
                let (c, r) = (Vec3A::new(a.cos() * 2.0, (a * 0.3).sin(), a.sin() * 2.0), 0.15 + 0.01 * (i % 5) as f32);
                if i % 2 == 0 { Support::Box(Aabb::around(c, r)) } else { Support::ball(c, r) }
            })
            .collect();
        let space = ChangedSpace::new(&regions, 0.0);
        let (mut met, mut missed) = (0, 0);
        for i in 0..4000 {
            let u = i as f32 * 0.618_034;
            let target = Vec3A::new((u * 3.1).sin() * 2.5, (u * 1.7).cos() * 1.2, (u * 2.3).cos() * 2.5);
            let ray = Ray::new(Vec3A::new(0.3, 4.0, 6.0), target - Vec3A::new(0.3, 4.0, 6.0));
            let meets = regions.iter().filter_map(|s| match *s {
                Support::Box(b) => b.clip_ray(ray.origin, ray.dir.recip(), 0.0, f32::INFINITY),
                Support::Ball { center, radius, .. } => ball_stretch(&ray, center, radius),
            });
            let Some((t0, t1)) = space.span(&ray) else {
                assert_eq!(meets.count(), 0, "ray {i} meets a region but has no span");
                missed += 1;
                continue;
            };
            for (a, b) in meets {
                assert!(t0 <= a + 1e-5 && b <= t1 + 1e-5, "ray {i}: stretch {a}..{b} outside the span {t0}..{t1}");
            }
            met += 1;
        }
        assert!(met > 100 && missed > 100, "{met} rays met the space, {missed} missed");
    }

    #[test]
    fn a_ray_through_the_gap_between_two_boxes_has_no_span() {
        let boxes = [Aabb::around(Vec3A::new(-2.0, 0.0, 0.0), 0.5), Aabb::around(Vec3A::new(2.0, 0.0, 0.0), 0.5)];
        let space = ChangedSpace::new(&boxes.map(Support::Box), 0.01);
        let gap = Ray::new(Vec3A::new(0.0, 0.0, 5.0), -Vec3A::Z);
        assert!(space.bounds().clip_ray(gap.origin, gap.dir.recip(), 0.0, f32::INFINITY).is_some());
        assert_eq!(space.span(&gap), None);
        let through = Ray::new(Vec3A::new(2.0, 0.0, 5.0), -Vec3A::Z);
        let (t0, t1) = space.span(&through).unwrap();
        assert!(t0 <= 4.49 && t1 >= 5.51 && t1 - t0 < 1.2, "{t0}..{t1}");
        // A ray through the corner of a ball's box, clear of the ball.
        let ball = ChangedSpace::new(&[Support::ball(Vec3A::ZERO, 1.0)], 0.01);
        let corner = Ray::new(Vec3A::new(0.85, 0.85, 5.0), -Vec3A::Z);
        assert!(ball.bounds().clip_ray(corner.origin, corner.dir.recip(), 0.0, f32::INFINITY).is_some());
        assert_eq!(ball.span(&corner), None);
    }
}
