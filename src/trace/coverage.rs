//! Where each pixel's ray can first meet the surface, found before any ray
//! is traced: the boxes of the cells the empty space has not ruled out are
//! projected onto the screen (each onto the rectangle of pixels whose rays
//! can meet it, as dirty rectangles are), and each pixel keeps the distance
//! from the eye to the nearest box whose rectangle holds it.
//!
//! A ray meets the surface only inside such a box, and a point of a box is
//! no nearer the eye than the box, so before that distance the ray holds no
//! crossing: its march starts there, and a pixel no box covers is a miss
//! with no evaluation at all. Marching from a point the field is known to
//! stay outside before finds the same snapped hit as marching from the
//! eye, so the image does not change; only the work does.
//!
//! For a model the kernel tracer traces, the coverage is its screen tiles'
//! lists of supports instead (see [`super::kernel`]): a pixel whose tile
//! lists none is a miss with no evaluation, and the rest are traced by kernels.

use rayon::prelude::*;

use super::dirty_rects::{PixelRect, screen_rect};
use super::kernel::KernelTracer;
use crate::camera::Camera;
use crate::field::EmptySpace;
use crate::geom::Aabb;

/// Rows of pixels per band filled on one thread.
const BAND_ROWS: u32 = 8;

/// A box's distance is shortened by this fraction, so that rounding in it
/// never puts a march's start past the box.
const DISTANCE_SLACK: f32 = 1e-4;

/// The nearest distance along each pixel's ray at which the surface can be.
#[derive(Clone, Debug)]
pub struct Coverage {
    width: u32,
    /// Per pixel, row-major; `+inf` where no box covers the pixel. Empty
    /// with a kernel tracer.
    near: Vec<f32>,
    /// The kernel tracer and its tiles, for a model it traces.
    kernel: Option<Box<KernelTracer>>,
}

impl Coverage {
    /// The coverage of the cells `empty` has not ruled out (and of the parts
    /// of `bounds`, the field's bounds, outside its grid), seen through `camera`.
    #[must_use]
    pub fn of(empty: &EmptySpace, bounds: &Aabb, camera: &Camera, width: u32, height: u32) -> Self {
        Self::of_boxes(&empty.occupied_boxes(bounds), camera, width, height)
    }

    /// The coverage of `boxes`, outside which the surface cannot be.
    #[must_use]
    pub fn of_boxes(boxes: &[Aabb], camera: &Camera, width: u32, height: u32) -> Self {
        let eye = camera.eye;
        let whole = PixelRect::full(width, height);
        // Boxes reaching the eye plane cover the whole image: one minimum
        // serves them all (from inside a model there can be thousands).
        let mut nearest_whole = f32::INFINITY;
        let mut projected: Vec<(PixelRect, f32)> = vec![];
        for b in boxes {
            let Some(rect) = screen_rect(camera, width, height, b) else { continue };
            let distance = b.distance_squared(eye).sqrt() * (1.0 - DISTANCE_SLACK);
            if rect == whole {
                nearest_whole = nearest_whole.min(distance);
            } else {
                projected.push((rect, distance));
            }
        }
        if nearest_whole.is_finite() {
            projected.push((whole, nearest_whole));
        }
        let mut near = vec![f32::INFINITY; (width as usize) * (height as usize)];
        let band_len = (BAND_ROWS * width) as usize;
        near.par_chunks_mut(band_len.max(1)).enumerate().for_each(|(band, pixels)| {
            let (y0, y1) = (band as u32 * BAND_ROWS, (band as u32 * BAND_ROWS + BAND_ROWS).min(height));
            for (r, d) in &projected {
                for y in r.y0.max(y0)..r.y1.min(y1) {
                    let row = ((y - y0) * width) as usize;
                    for n in &mut pixels[row + r.x0 as usize..row + r.x1 as usize] {
                        *n = n.min(*d);
                    }
                }
            }
        });
        Self { width, near, kernel: None }
    }

    /// The coverage of a model the kernel tracer traces: its tiles' lists.
    #[must_use]
    pub fn of_kernels(tracer: KernelTracer, width: u32) -> Self {
        Self { width, near: vec![], kernel: Some(Box::new(tracer)) }
    }

    /// The kernel tracer, where the model is traced by kernels.
    #[must_use]
    pub fn kernel(&self) -> Option<&KernelTracer> {
        self.kernel.as_deref()
    }

    /// The distance along pixel (`x`, `y`)'s ray before which it meets no
    /// surface; `+inf` when it meets none.
    #[must_use]
    pub fn near(&self, x: u32, y: u32) -> f32 {
        match &self.kernel {
            Some(k) if k.misses(x, y) => f32::INFINITY,
            Some(_) => 0.0,
            None => self.near[(y * self.width + x) as usize],
        }
    }

    /// The fraction of the pixels no box covers: misses known before tracing.
    #[must_use]
    pub fn uncovered_fraction(&self) -> f64 {
        if let Some(k) = &self.kernel {
            return k.missed_fraction();
        }
        self.near.iter().filter(|d| d.is_infinite()).count() as f64 / self.near.len().max(1) as f64
    }
}

#[cfg(test)]
mod tests {
    use glam::{Vec3, Vec3A};

    use super::*;

    #[test]
    fn a_box_covers_the_pixels_whose_rays_meet_it_at_its_distance_at_most() {
        let camera = Camera::look_at(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, Vec3::Y, 40.0);
        let (w, h) = (64, 48);
        let near_box = Aabb::new(Vec3A::new(-1.0, -1.0, 2.0), Vec3A::new(0.0, 0.0, 3.0));
        let far_box = Aabb::new(Vec3A::new(-1.0, -1.0, -1.0), Vec3A::new(1.0, 1.0, 1.0));
        let coverage = Coverage::of_boxes(&[far_box, near_box], &camera, w, h);
        let mut covered = 0;
        for y in 0..h {
            for x in 0..w {
                let ray = camera.ray(x, y, w, h);
                let inv = ray.dir.recip();
                let first = [near_box, far_box]
                    .iter()
                    .filter_map(|b| b.clip_ray(ray.origin, inv, 0.0, f32::INFINITY))
                    .map(|(t, _)| t)
                    .reduce(f32::min);
                let near = coverage.near(x, y);
                match first {
                    Some(t) => assert!(near <= t, "({x}, {y}): starts at {near}, past the entry {t}"),
                    None => covered += usize::from(near.is_finite()),
                }
            }
        }
        // Rectangles hold a box's projection with a pixel to spare: a few rays that miss are covered.
        assert!(covered < 200, "{covered} pixels covered needlessly");
        assert!(coverage.near(w / 2, h / 2) < 8.0, "the near box is in front at the centre");
        assert!(coverage.near(0, 0).is_infinite(), "a corner sees nothing");
        assert!(coverage.uncovered_fraction() > 0.5);
    }
}
