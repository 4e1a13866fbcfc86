//! Dirty rectangles: the pixels whose primary rays can meet a changed box.
//! Shading is local to each primary ray, so a pixel whose ray misses every
//! changed box shows the same thing before and after an edit.

use crate::camera::Camera;
use crate::geom::Aabb;

/// A pixel rectangle `[x0, x1) × [y0, y1)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct PixelRect {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl PixelRect {
    /// The whole `width × height` image.
    #[must_use]
    pub fn full(width: u32, height: u32) -> Self {
        Self { x0: 0, y0: 0, x1: width, y1: height }
    }

    /// Number of pixels.
    #[must_use]
    pub fn area(&self) -> u64 {
        u64::from(self.x1 - self.x0) * u64::from(self.y1 - self.y0)
    }

    /// True when pixel (`x`, `y`) lies inside.
    #[must_use]
    pub fn contains(&self, x: u32, y: u32) -> bool {
        (self.x0..self.x1).contains(&x) && (self.y0..self.y1).contains(&y)
    }

    fn overlaps(&self, o: &PixelRect) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }

    fn union(&self, o: &PixelRect) -> PixelRect {
        PixelRect { x0: self.x0.min(o.x0), y0: self.y0.min(o.y0), x1: self.x1.max(o.x1), y1: self.y1.max(o.y1) }
    }
}

/// Distance in front of the eye below which a box counts as reaching the eye plane.
const NEAR: f32 = 1e-4;

/// A rectangle holding every pixel whose primary ray can meet `b`, or `None`
/// when none can (the box is empty, behind the eye, or off-screen). A box
/// reaching the eye plane gives the whole image: its projection is unbounded.
#[must_use]
pub fn screen_rect(camera: &Camera, width: u32, height: u32, b: &Aabb) -> Option<PixelRect> {
    if b.is_empty() || width == 0 || height == 0 {
        return None;
    }
    let depths = b.corners().map(|c| (c - camera.eye).dot(camera.forward()));
    if depths.iter().all(|&z| z <= 0.0) {
        return None;
    }
    if depths.iter().any(|&z| z <= NEAR) {
        return Some(PixelRect::full(width, height));
    }
    let (lo, hi) = projected_extent(camera, width, height, b);
    // Pixel centres at x + 0.5 inside [lo, hi]; one pixel of slack for rounding.
    let clip = |v: f32, n: u32| v.clamp(0.0, n as f32) as u32;
    let rect = PixelRect {
        x0: clip(lo.x.floor() - 1.0, width),
        y0: clip(lo.y.floor() - 1.0, height),
        x1: clip(hi.x.ceil() + 1.0, width),
        y1: clip(hi.y.ceil() + 1.0, height),
    };
    (rect.x0 < rect.x1 && rect.y0 < rect.y1).then_some(rect)
}

/// The pixel-space bounds of the box's corners, all in front of the eye: the
/// projection of a convex box lies within their hull.
fn projected_extent(camera: &Camera, width: u32, height: u32, b: &Aabb) -> (glam::Vec2, glam::Vec2) {
    let aspect = width as f32 / height as f32;
    let (mut lo, mut hi) = (glam::Vec2::splat(f32::INFINITY), glam::Vec2::splat(f32::NEG_INFINITY));
    for c in b.corners() {
        let v = c - camera.eye;
        let z = v.dot(camera.forward());
        let sx = v.dot(camera.right()) / z / (camera.tan_half_fov() * aspect);
        let sy = v.dot(camera.up()) / z / camera.tan_half_fov();
        let p = glam::Vec2::new((sx + 1.0) * 0.5 * width as f32, (1.0 - sy) * 0.5 * height as f32);
        (lo, hi) = (lo.min(p), hi.max(p));
    }
    (lo, hi)
}

/// Merges overlapping rectangles until none overlap.
#[must_use]
pub fn merge_rects(mut rects: Vec<PixelRect>) -> Vec<PixelRect> {
    let mut merged = true;
    while merged {
        merged = false;
        'outer: for i in 0..rects.len() {
            for j in i + 1..rects.len() {
                if rects[i].overlaps(&rects[j]) {
                    rects[i] = rects[i].union(&rects[j]);
                    rects.swap_remove(j);
                    merged = true;
                    break 'outer;
                }
            }
        }
    }
    rects
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec3, Vec3A};

    fn camera() -> Camera {
        Camera::look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0)
    }

    #[test]
    fn boxes_behind_across_and_beside_the_eye() {
        let c = camera();
        let small = Aabb::around(Vec3A::ZERO, 0.2);
        let r = screen_rect(&c, 100, 80, &small).unwrap();
        assert!(r.contains(50, 40) && r.area() < 400, "{r:?}");
        assert_eq!(screen_rect(&c, 100, 80, &Aabb::around(Vec3A::new(0.0, 0.0, 9.0), 1.0)), None);
        assert_eq!(
            screen_rect(&c, 100, 80, &Aabb::around(Vec3A::new(0.0, 0.0, 5.0), 0.5)),
            Some(PixelRect::full(100, 80))
        );
        assert_eq!(screen_rect(&c, 100, 80, &Aabb::around(Vec3A::new(50.0, 0.0, 0.0), 1.0)), None);
        assert_eq!(screen_rect(&c, 100, 80, &Aabb::around(Vec3A::ZERO, 50.0)), Some(PixelRect::full(100, 80)));
        assert_eq!(screen_rect(&c, 100, 80, &Aabb::EMPTY), None);
    }

    #[test]
    fn every_ray_meeting_the_box_starts_in_its_rectangle() {
        let c = camera();
        let b = Aabb::new(Vec3A::new(-0.3, 0.2, -1.0), Vec3A::new(0.9, 0.7, 0.4));
        let r = screen_rect(&c, 120, 90, &b).unwrap();
        for y in 0..90 {
            for x in 0..120 {
                let ray = c.ray(x, y, 120, 90);
                if b.clip_ray(ray.origin, ray.dir.recip(), 0.0, f32::INFINITY).is_some() {
                    assert!(r.contains(x, y), "pixel {x},{y} outside {r:?}");
                }
            }
        }
        assert!(r.area() < 120 * 90 / 3);
    }

    #[test]
    fn overlapping_rectangles_merge() {
        let a = PixelRect { x0: 0, y0: 0, x1: 10, y1: 10 };
        let b = PixelRect { x0: 5, y0: 5, x1: 20, y1: 12 };
        let far = PixelRect { x0: 50, y0: 50, x1: 60, y1: 60 };
        let m = merge_rects(vec![a, far, b]);
        assert_eq!(m.len(), 2);
        assert!(m.contains(&PixelRect { x0: 0, y0: 0, x1: 20, y1: 12 }));
    }
}
