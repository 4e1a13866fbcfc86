//! Shading shared by every renderer (field and mesh), so two images of the same
//! surface differ only where the geometry differs: a key light fixed to the
//! camera, a headlight, ambient, and a soft highlight.

use glam::{Vec3, Vec3A};

use crate::camera::Camera;

/// Light set-up; the defaults suit the bundled scenes.
#[derive(Clone, Copy, Debug)]
pub struct Lighting {
    /// Key light strength.
    pub key: f32,
    /// Headlight (light at the eye) strength.
    pub head: f32,
    /// Ambient term.
    pub ambient: f32,
    /// Highlight strength of the key light.
    pub specular: f32,
    /// Highlight exponent.
    pub shininess: f32,
}

impl Default for Lighting {
    fn default() -> Self {
        Self { key: 0.75, head: 0.3, ambient: 0.1, specular: 0.25, shininess: 40.0 }
    }
}

impl Lighting {
    /// Linear colour of a surface point with unit outward `normal` and `albedo`,
    /// seen along the unit ray direction `dir` from `camera`.
    #[must_use]
    pub fn shade(&self, camera: &Camera, dir: Vec3A, normal: Vec3A, albedo: Vec3) -> Vec3 {
        // Up and to the left of the viewer, slightly behind the camera.
        let key = (camera.up() * 0.7 - camera.right() * 0.5 - camera.forward() * 0.6).normalize();
        let view = -dir;
        let diffuse = self.ambient + self.key * normal.dot(key).max(0.0) + self.head * normal.dot(view).max(0.0);
        let half = (key + view).normalize();
        let highlight = self.specular * normal.dot(half).max(0.0).powf(self.shininess);
        albedo * diffuse + Vec3::splat(highlight)
    }
}
