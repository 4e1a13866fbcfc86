//! Frames: a rendered image with its arbitrary output variables (AOVs), and
//! their files — 8-bit sRGB PNG for people, one multi-channel EXR for tools.

mod exr_io;
mod size;

use glam::Vec3;
use rayon::prelude::*;

pub use exr_io::{ExrChannels, channels_exr_bytes, read_exr_channels};
pub use size::{MAX_PIXELS, MAX_SIDE, Size};

/// Geometric disagreement between two renders of one view.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct GeometryDifference {
    /// Pixels hit in one frame and missed in the other.
    pub mismatch_px: usize,
    /// Pixels hit in both.
    pub both_hit_px: usize,
    /// Mean absolute depth difference over pixels hit in both (scene units).
    pub mean_depth_err: f64,
    /// 99th percentile of the angle between normals over pixels hit in both (degrees).
    pub p99_normal_err_deg: f32,
}

/// `n` copies of `value`, written by every thread: a frame's fresh pages
/// are then faulted in by all of them, not one.
#[must_use]
pub fn filled<T: Copy + Send + Sync>(n: usize, value: T) -> Vec<T> {
    (0..n).into_par_iter().map(|_| value).collect()
}

/// A rendered image and its AOVs, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Shaded colour, linear RGB, background where the ray missed.
    pub color: Vec<Vec3>,
    /// Coverage: 1 where the ray hit the surface, 0 where it missed.
    pub alpha: Vec<f32>,
    /// Distance from the eye along the unit ray to the hit; `+inf` on a miss.
    pub depth: Vec<f32>,
    /// World-space unit normal at the hit; zero on a miss.
    pub normal: Vec<Vec3>,
    /// Extra scalar AOVs by EXR channel name (`steps.Y`, `evals.Y`, …).
    pub extra: Vec<(String, Vec<f32>)>,
}

impl Frame {
    /// A frame of `width × height` pixels filled with misses on `background`.
    #[must_use]
    pub fn new(width: u32, height: u32, background: Vec3) -> Self {
        let n = (width * height) as usize;
        Self {
            width,
            height,
            color: filled(n, background),
            alpha: filled(n, 0.0),
            depth: filled(n, f32::INFINITY),
            normal: filled(n, Vec3::ZERO),
            extra: vec![],
        }
    }

    /// Number of pixels.
    #[must_use]
    pub fn len(&self) -> usize {
        self.color.len()
    }

    /// True for a frame with no pixels.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.color.is_empty()
    }

    /// Number of pixels whose ray hit the surface.
    #[must_use]
    pub fn hits(&self) -> usize {
        self.alpha.iter().filter(|&&a| a > 0.0).count()
    }

    /// How this frame's geometry departs from `reference`'s (same size): hit/miss
    /// disagreements, and depth and normal differences where both hit.
    #[must_use]
    pub fn geometry_difference(&self, reference: &Frame) -> GeometryDifference {
        let mut diff = GeometryDifference::default();
        let (mut depth_sum, mut angles) = (0.0f64, Vec::new());
        for i in 0..self.len().min(reference.len()) {
            let (a, b) = (self.depth[i].is_finite(), reference.depth[i].is_finite());
            if a != b {
                diff.mismatch_px += 1;
            } else if a {
                depth_sum += f64::from((self.depth[i] - reference.depth[i]).abs());
                let cos = self.normal[i].dot(reference.normal[i]).clamp(-1.0, 1.0);
                angles.push(cos.acos().to_degrees());
            }
        }
        diff.both_hit_px = angles.len();
        diff.mean_depth_err = depth_sum / angles.len().max(1) as f64;
        angles.sort_by(f32::total_cmp);
        diff.p99_normal_err_deg = angles.get(angles.len() * 99 / 100).copied().unwrap_or(0.0);
        diff
    }

    /// True when both frames show the same image bit for bit: colour,
    /// coverage, depth and normals (work counters like `steps.Y` aside).
    #[must_use]
    pub fn same_image(&self, o: &Frame) -> bool {
        let bits = |v: &[glam::Vec3]| v.iter().flat_map(|c| c.to_array().map(f32::to_bits)).collect::<Vec<u32>>();
        let fbits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
        (self.width, self.height) == (o.width, o.height)
            && bits(&self.color) == bits(&o.color)
            && bits(&self.normal) == bits(&o.normal)
            && fbits(&self.depth) == fbits(&o.depth)
            && fbits(&self.alpha) == fbits(&o.alpha)
    }

    /// Adds `depth.Z`, the planar depth: the distance from the eye along the
    /// camera's view axis (`Z` × the cosine between ray and axis), as
    /// compositors expect a depth pass; `+inf` on a miss. `Z` itself stays the
    /// distance along the ray.
    pub fn add_planar_depth(&mut self, camera: &crate::camera::Camera) {
        let forward = camera.forward();
        let (w, h) = (self.width, self.height);
        let planar = (0..self.len())
            .map(|i| {
                let ray = camera.ray(i as u32 % w, i as u32 / w, w, h);
                self.depth[i] * ray.dir.dot(forward)
            })
            .collect();
        self.extra.retain(|(n, _)| n != PLANAR_DEPTH);
        self.extra.push((PLANAR_DEPTH.into(), planar));
    }

    /// An extra AOV by channel name.
    #[must_use]
    pub fn aov(&self, name: &str) -> Option<&[f32]> {
        self.extra.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_slice())
    }

    /// The colour as 8-bit sRGB bytes, row-major RGB.
    #[must_use]
    pub fn to_srgb8(&self) -> Vec<u8> {
        srgb8_of(&self.color)
    }

    /// PNG bytes (8-bit sRGB, tagged as such).
    pub fn png_bytes(&self) -> Result<Vec<u8>, png::EncodingError> {
        srgb_png_bytes(&self.to_srgb8(), self.width, self.height)
    }

    /// Writes the colour as an 8-bit sRGB PNG, atomically.
    pub fn save_png(&self, path: &std::path::Path) -> Result<(), FrameIoError> {
        let bytes = self.png_bytes().map_err(|e| FrameIoError::Encode(path.display().to_string(), e.to_string()))?;
        crate::output::write_atomic(path, &bytes).map_err(|e| FrameIoError::Write(path.display().to_string(), e))
    }

    /// Every channel (`R,G,B,A`, `Z`, `N.X,N.Y,N.Z`, extras) as float EXR bytes;
    /// `path` names the file in the error.
    pub fn exr_bytes(&self, path: &std::path::Path) -> Result<Vec<u8>, FrameIoError> {
        exr_io::exr_bytes(self).map_err(|e| FrameIoError::Encode(path.display().to_string(), e))
    }

    /// PNG bytes, with an error naming `path`.
    pub fn png_bytes_for(&self, path: &std::path::Path) -> Result<Vec<u8>, FrameIoError> {
        self.png_bytes().map_err(|e| FrameIoError::Encode(path.display().to_string(), e.to_string()))
    }

    /// Writes every channel (`R,G,B,A`, `Z`, `N.X,N.Y,N.Z`, extras) as a float EXR, atomically.
    pub fn save_exr(&self, path: &std::path::Path) -> Result<(), FrameIoError> {
        let bytes = exr_io::exr_bytes(self).map_err(|e| FrameIoError::Encode(path.display().to_string(), e))?;
        crate::output::write_atomic(path, &bytes).map_err(|e| FrameIoError::Write(path.display().to_string(), e))
    }
}

/// Encodes row-major 8-bit RGB as a PNG carrying an sRGB chunk, so viewers
/// and tools read its codes as sRGB rather than guessing.
pub fn srgb_png_bytes(rgb: &[u8], width: u32, height: u32) -> Result<Vec<u8>, png::EncodingError> {
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(rgb)?;
    writer.finish()?;
    Ok(out)
}

/// The EXR channel of the planar depth (see [`Frame::add_planar_depth`]).
pub const PLANAR_DEPTH: &str = "depth.Z";

/// Why a frame could not be written.
#[derive(Debug, thiserror::Error)]
pub enum FrameIoError {
    /// Encoding failed.
    #[error("{0}: could not encode: {1}")]
    Encode(String, String),
    /// Writing failed.
    #[error("{0}: could not write: {1}")]
    Write(String, std::io::Error),
}

/// Linear colours as 8-bit sRGB bytes, in order.
#[must_use]
pub fn srgb8_of(colors: &[Vec3]) -> Vec<u8> {
    use rayon::prelude::*;
    // In parallel: the previewer converts a frame per pass it shows.
    colors.par_iter().flat_map_iter(|c| c.to_array().map(linear_to_srgb8)).collect()
}

/// Linear `[0, 1]` to an 8-bit sRGB code value.
#[must_use]
pub fn linear_to_srgb8(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let s = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5) as u8
}

/// 8-bit sRGB code value to linear `[0, 1]`.
#[must_use]
pub fn srgb8_to_linear(v: u8) -> f32 {
    let s = v as f32 / 255.0;
    if s <= 0.040_45 { s / 12.92 } else { ((s + 0.055) / 1.055).powf(2.4) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trips_every_code() {
        for v in 0..=255u8 {
            assert_eq!(linear_to_srgb8(srgb8_to_linear(v)), v);
        }
    }
}
