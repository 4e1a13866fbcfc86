//! A camera that orbits a centre: turned about its up axis and towards it
//! (stopping short of the poles), zoomed within bounds, panned by pixels.
//! The previewer's mouse and keys move it; `bench view` replays the same moves.

use glam::{Quat, Vec3};

use super::Camera;

/// Closest the camera's view comes to the up axis, in degrees.
const MIN_POLE_DEGREES: f32 = 5.0;

/// One move of an orbiting camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CameraMove {
    /// Degrees about the up axis (positive: the camera moves to its right)
    /// and towards the up axis.
    Orbit(f32, f32),
    /// Bring the camera this factor of its distance to the centre.
    Zoom(f32),
    /// Slide the camera and its centre by this many pixels right and down.
    Pan(f32, f32),
}

/// A camera orbiting a centre: its eye, the up axis it keeps, and its field of view.
pub struct Orbit {
    centre: Vec3,
    eye: Vec3,
    up: Vec3,
    fov_y: f32,
    /// The image's height in pixels, which a pan's pixels are measured in.
    height: f32,
    /// The eye's first distance from the centre, which bounds zooming.
    first_distance: f32,
}

impl Orbit {
    /// The orbit of `camera` about `centre`, for an image `height` pixels tall.
    #[must_use]
    pub fn new(camera: &Camera, centre: Vec3, height: u32) -> Self {
        let fov_y = 2.0 * camera.tan_half_fov().atan().to_degrees();
        let eye: Vec3 = camera.eye.into();
        let first_distance = eye.distance(centre).max(f32::MIN_POSITIVE);
        Self { centre, eye, up: camera.up().into(), fov_y, height: height.max(1) as f32, first_distance }
    }

    /// The point the camera orbits and looks at.
    #[must_use]
    pub fn centre(&self) -> Vec3 {
        self.centre
    }

    /// Applies `step` and returns the camera looking at the centre.
    pub fn moved(&mut self, step: CameraMove) -> Camera {
        let offset = self.eye - self.centre;
        let offset = match step {
            CameraMove::Orbit(yaw, pitch) => {
                let turned = Quat::from_axis_angle(self.up, yaw.to_radians()) * offset;
                let right = turned.cross(self.up).normalize_or_zero();
                // Stop short of the poles, where the view would flip over.
                let from_up = turned.angle_between(self.up).to_degrees();
                let pitch = pitch.clamp(from_up - (180.0 - MIN_POLE_DEGREES), from_up - MIN_POLE_DEGREES);
                Quat::from_axis_angle(right, pitch.to_radians()) * turned
            }
            // Kept between a thousandth and a thousand times the first
            // distance, so no run of zooms loses the camera.
            CameraMove::Zoom(factor) => {
                let distance = (offset.length() * factor).clamp(1e-3 * self.first_distance, 1e3 * self.first_distance);
                offset.normalize_or_zero() * distance
            }
            CameraMove::Pan(dx, dy) => {
                // A pixel at the centre's distance, so the centre follows the pointer.
                let per_pixel = 2.0 * offset.length() * (0.5 * self.fov_y).to_radians().tan() / self.height;
                let forward = -offset.normalize_or_zero();
                let right = forward.cross(self.up).normalize_or_zero();
                let up = right.cross(forward);
                self.centre += (up * dy - right * dx) * per_pixel;
                offset
            }
        };
        self.eye = self.centre + offset;
        Camera::look_at(self.eye, self.centre, self.up, self.fov_y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ORBIT_DEGREES: f32 = 10.0;
    const ZOOM_FACTOR: f32 = 0.9;

    #[test]
    fn orbits_turn_the_camera_about_the_centre_and_stop_short_of_the_pole() {
        let camera = Camera::look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0);
        let mut orbit = Orbit::new(&camera, Vec3::ZERO, 100);
        let right = orbit.moved(CameraMove::Orbit(ORBIT_DEGREES, 0.0));
        assert!(right.eye.x > 0.0 && (right.eye.length() - 5.0).abs() < 1e-4, "d moves the camera to its right");
        let up = orbit.moved(CameraMove::Orbit(0.0, ORBIT_DEGREES));
        assert!(up.eye.y > 0.0 && (up.eye.length() - 5.0).abs() < 1e-4, "w moves the camera up");
        assert!((up.forward() + up.eye.normalize()).length() < 1e-5, "it keeps looking at the centre");
        for _ in 0..30 {
            orbit.moved(CameraMove::Orbit(0.0, ORBIT_DEGREES));
        }
        let top = orbit.moved(CameraMove::Zoom(ZOOM_FACTOR));
        let from_up = top.eye.angle_between(glam::Vec3A::Y).to_degrees();
        assert!((from_up - MIN_POLE_DEGREES).abs() < 1e-3, "{from_up}");
        assert!((top.eye.length() - 5.0 * ZOOM_FACTOR).abs() < 1e-4);
        assert!((top.tan_half_fov() - camera.tan_half_fov()).abs() < 1e-6);
    }
}
