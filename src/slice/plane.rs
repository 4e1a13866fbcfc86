//! The plane a slice shows, and its pixel grid.

use glam::Vec3A;

use crate::camera::Camera;
use crate::geom::Aabb;

/// A rectangle of a plane sampled on a pixel grid, row 0 at the top.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlicePlane {
    /// World position of the top-left corner.
    pub origin: Vec3A,
    /// World step from one pixel to the next to the right.
    pub right: Vec3A,
    /// World step from one pixel to the next downwards.
    pub down: Vec3A,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// Why a plane could not be read.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PlaneError {
    /// The text is not one of the accepted forms.
    #[error("--plane {0:?}: expected x=V, y=V, z=V or PX,PY,PZ+NX,NY,NZ (a point and a normal)")]
    Syntax(String),
    /// The normal has no length.
    #[error("--plane {0:?}: the normal must not be zero")]
    ZeroNormal(String),
}

impl SlicePlane {
    /// The plane named by `spec` (`x=0.2`, `y=…`, `z=…`, or `px,py,pz+nx,ny,nz`),
    /// covering what `bounds` projects onto it, at most `width × height` pixels
    /// with square pixels.
    pub fn parse(spec: &str, bounds: &Aabb, width: u32, height: u32) -> Result<Self, PlaneError> {
        let syntax = || PlaneError::Syntax(spec.to_string());
        let (point, normal) = if let Some((axis, v)) = spec.split_once('=') {
            let v: f32 = v.trim().parse().ok().filter(|v: &f32| v.is_finite()).ok_or_else(syntax)?;
            let axis = ["x", "y", "z"].iter().position(|a| *a == axis.trim()).ok_or_else(syntax)?;
            let mut point = bounds.center();
            point[axis] = v;
            (point, Vec3A::AXES[axis])
        } else {
            let (p, n) = spec.split_once('+').ok_or_else(syntax)?;
            (vector(p).ok_or_else(syntax)?, vector(n).ok_or_else(syntax)?)
        };
        let normal = normal.try_normalize().ok_or_else(|| PlaneError::ZeroNormal(spec.to_string()))?;
        Ok(Self::through(point, normal, bounds, width, height))
    }

    /// Whether the plane passes through `bounds` (a slice beside the model
    /// shows only empty space).
    #[must_use]
    pub fn meets(&self, bounds: &Aabb) -> bool {
        let normal = self.right.cross(self.down).normalize_or_zero();
        let (lo, hi) = (0..8).fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), k| {
            let corner = Vec3A::select(glam::BVec3A::new(k & 1 != 0, k & 2 != 0, k & 4 != 0), bounds.max, bounds.min);
            let d = (corner - self.origin).dot(normal);
            (lo.min(d), hi.max(d))
        });
        !bounds.is_empty() && lo <= 0.0 && hi >= 0.0
    }

    /// The plane through `point` with unit `normal`, framed on `bounds`.
    #[must_use]
    pub fn through(point: Vec3A, normal: Vec3A, bounds: &Aabb, width: u32, height: u32) -> Self {
        // Axis planes keep the other two axes in order (x right, y up where possible).
        let up_hint = if normal.y.abs() > 0.9 { Vec3A::NEG_Z } else { Vec3A::Y };
        let right = up_hint.cross(normal).normalize();
        let up = normal.cross(right);
        let (mut lo, mut hi) = (glam::Vec2::splat(f32::INFINITY), glam::Vec2::splat(f32::NEG_INFINITY));
        for c in bounds.corners() {
            let q = glam::Vec2::new((c - point).dot(right), (c - point).dot(up));
            (lo, hi) = (lo.min(q), hi.max(q));
        }
        let extent = hi - lo;
        let pixel = (extent.x / width.max(1) as f32).max(extent.y / height.max(1) as f32);
        let (w, h) = (((extent.x / pixel).round() as u32).max(1), ((extent.y / pixel).round() as u32).max(1));
        let top_left = point + right * lo.x + up * hi.y;
        Self {
            origin: top_left + (right - up) * (0.5 * pixel),
            right: right * pixel,
            down: -up * pixel,
            width: w,
            height: h,
        }
    }

    /// The plane facing `camera` at `depth` in front of its eye (along its
    /// view axis), each pixel of a `width × height` image where that
    /// pixel's primary ray meets the plane: a cross-section seen head on,
    /// lined up with the renders.
    #[must_use]
    pub fn facing(camera: &Camera, width: u32, height: u32, depth: f32) -> Self {
        // A ray's direction is forward + right·sx + up·sy, sx and sy linear in the pixel:
        // where it meets the plane is linear in the pixel too.
        let (w, h) = (width.max(1) as f32, height.max(1) as f32);
        let half_height = camera.tan_half_fov() * depth;
        let half_width = half_height * w / h;
        let at = |px: f32, py: f32| {
            camera.eye
                + camera.forward() * depth
                + camera.right() * ((2.0 * px / w - 1.0) * half_width)
                + camera.up() * ((1.0 - 2.0 * py / h) * half_height)
        };
        let origin = at(0.5, 0.5);
        Self { origin, right: at(1.5, 0.5) - origin, down: at(0.5, 1.5) - origin, width, height }
    }

    /// World position of the centre of pixel (`x`, `y`).
    #[must_use]
    pub fn point(&self, x: u32, y: u32) -> Vec3A {
        self.origin + self.right * x as f32 + self.down * y as f32
    }
}

fn vector(s: &str) -> Option<Vec3A> {
    let v: Vec<f32> =
        s.split(',').map(|c| c.trim().parse::<f32>().ok().filter(|v| v.is_finite())).collect::<Option<_>>()?;
    (v.len() == 3).then(|| Vec3A::new(v[0], v[1], v[2]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_plane_facing_the_camera_meets_each_pixel_s_ray() {
        let camera = Camera::look_at(glam::Vec3::new(1.0, 2.0, 9.0), glam::Vec3::ZERO, glam::Vec3::Y, 50.0);
        let (w, h, depth) = (40, 30, 6.5);
        let plane = SlicePlane::facing(&camera, w, h, depth);
        for (x, y) in [(0, 0), (39, 0), (17, 11), (39, 29)] {
            let ray = camera.ray(x, y, w, h);
            let p = plane.point(x, y);
            // On the ray, and at the plane's depth along the view axis.
            let along = (p - ray.origin).dot(ray.dir);
            assert!((ray.at(along) - p).length() < 1e-4, "({x}, {y}) off its ray");
            assert!(((p - camera.eye).dot(camera.forward()) - depth).abs() < 1e-4);
        }
    }

    #[test]
    fn axis_planes_cover_the_bounds_with_square_pixels() {
        let b = Aabb::new(Vec3A::new(-2.0, -1.0, -1.0), Vec3A::new(2.0, 1.0, 1.0));
        let p = SlicePlane::parse("z=0.25", &b, 200, 200).unwrap();
        assert_eq!((p.width, p.height), (200, 100));
        assert!((p.point(0, 0) - Vec3A::new(-1.99, 0.99, 0.25)).length() < 1e-4, "{}", p.point(0, 0));
        assert!((p.point(199, 99) - Vec3A::new(1.99, -0.99, 0.25)).length() < 1e-4);
        let q = SlicePlane::parse("0,0,0+0,0,2", &b, 200, 200).unwrap();
        assert_eq!(q.right, p.right);
        assert!(matches!(SlicePlane::parse("w=1", &b, 10, 10), Err(PlaneError::Syntax(_))));
        assert!(matches!(SlicePlane::parse("0,0,0+0,0,0", &b, 10, 10), Err(PlaneError::ZeroNormal(_))));
        assert!(SlicePlane::parse("x=nan", &b, 10, 10).is_err());
    }
}
