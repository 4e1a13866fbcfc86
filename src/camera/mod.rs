//! The pinhole camera: look-at, vertical field of view, rays through pixel
//! centres; and a camera orbiting a centre (`orbit`).

mod orbit;

pub use orbit::{CameraMove, Orbit};

use glam::{Vec3, Vec3A};

use crate::geom::Ray;

/// Where a camera stands and looks, as a scene file writes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LookAt {
    /// Eye position.
    pub eye: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Up direction (need not be orthogonal to the view direction).
    pub up: Vec3,
    /// Vertical field of view in degrees, in `(0, 180)`.
    pub fov_y: f32,
}

impl LookAt {
    /// Checks that the view is a valid camera: finite, eye and target apart,
    /// up not along the view, field of view in `(0, 180)` degrees.
    pub fn check(&self) -> Result<(), String> {
        let finite = [self.eye, self.target, self.up].iter().all(|v| v.is_finite()) && self.fov_y.is_finite();
        if !finite {
            return Err("camera numbers must be finite".into());
        }
        let view = self.target - self.eye;
        if view.length() <= 1e-6 {
            return Err("camera eye and target coincide".into());
        }
        if view.normalize().cross(self.up).length() <= 1e-6 {
            return Err("camera up is parallel to the view direction (or zero)".into());
        }
        if !(self.fov_y > 0.0 && self.fov_y < 180.0) {
            return Err(format!("fov_y must lie between 0 and 180 degrees, got {}", self.fov_y));
        }
        Ok(())
    }

    /// The camera of this view.
    #[must_use]
    pub fn camera(&self) -> Camera {
        Camera::look_at(self.eye, self.target, self.up, self.fov_y)
    }
}

/// A right-handed look-at pinhole camera; row 0 is the top of the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub eye: Vec3A,
    forward: Vec3A,
    right: Vec3A,
    up: Vec3A,
    tan_half_fov: f32,
}

impl Camera {
    /// A camera at `eye` looking at `target`, `up` roughly up, `fov_y_deg` vertical
    /// field of view in degrees. The caller guarantees a valid configuration.
    #[must_use]
    pub fn look_at(eye: Vec3, target: Vec3, up: Vec3, fov_y_deg: f32) -> Self {
        let forward = (target - eye).normalize();
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        Self {
            eye: eye.into(),
            forward: forward.into(),
            right: right.into(),
            up: up.into(),
            tan_half_fov: (fov_y_deg.to_radians() * 0.5).tan(),
        }
    }

    /// The ray through the centre of pixel `(x, y)` of a `width × height` image.
    #[must_use]
    pub fn ray(&self, x: u32, y: u32, width: u32, height: u32) -> Ray {
        self.ray_at(x as f32 + 0.5, y as f32 + 0.5, width, height)
    }

    /// The ray through image position `(px, py)` in pixel units (0,0 = top-left corner).
    #[must_use]
    pub fn ray_at(&self, px: f32, py: f32, width: u32, height: u32) -> Ray {
        let aspect = width as f32 / height as f32;
        let sx = (2.0 * px / width as f32 - 1.0) * self.tan_half_fov * aspect;
        let sy = (1.0 - 2.0 * py / height as f32) * self.tan_half_fov;
        Ray::new(self.eye, self.forward + self.right * sx + self.up * sy)
    }

    /// Tangent of half the vertical field of view.
    #[must_use]
    pub fn tan_half_fov(&self) -> f32 {
        self.tan_half_fov
    }

    /// Unit view direction.
    #[must_use]
    pub fn forward(&self) -> Vec3A {
        self.forward
    }

    /// Unit right vector.
    #[must_use]
    pub fn right(&self) -> Vec3A {
        self.right
    }

    /// Unit up vector (orthogonal to forward).
    #[must_use]
    pub fn up(&self) -> Vec3A {
        self.up
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_pixel_looks_forward_and_row_zero_is_up() {
        let cam = Camera::look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 60.0);
        let r = cam.ray_at(50.0, 50.0, 100, 100);
        assert!((r.dir - Vec3A::NEG_Z).length() < 1e-6);
        assert!(cam.ray(50, 0, 100, 100).dir.y > 0.0);
        assert!(cam.ray(99, 50, 100, 100).dir.x > 0.0);
        // Top edge of the image is at half the vertical field of view.
        let top = cam.ray_at(50.0, 0.0, 100, 100);
        assert!((top.dir.y.atan2(-top.dir.z).to_degrees() - 30.0).abs() < 1e-4);
    }
}
