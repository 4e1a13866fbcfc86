//! Reading images to compare: 8-bit PNG (colour, and coverage when it has an
//! alpha channel) or float EXR (every AOV blobtrace writes).

use std::path::Path;

use glam::Vec3;

use crate::frame::Size;
use crate::frame::{Frame, read_exr_channels, srgb8_to_linear};

/// An image read for comparison, and which AOVs it carried.
#[derive(Clone, Debug)]
pub struct LoadedImage {
    /// Colour (linear), coverage, depth and normals; absent AOVs hold misses.
    pub frame: Frame,
    /// True when the file had depth (`Z`).
    pub has_depth: bool,
    /// True when the file had normals (`N.X`, `N.Y`, `N.Z`).
    pub has_normal: bool,
}

/// Reads a PNG or an EXR by extension.
pub fn load_image(path: &Path) -> Result<LoadedImage, String> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("exr") => load_exr(path),
        Some("png") => load_png(path),
        _ => Err(format!("{}: not a .png or .exr image", path.display())),
    }
}

fn load_png(path: &Path) -> Result<LoadedImage, String> {
    let failed = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let open =
        || image::ImageReader::open(path).and_then(image::ImageReader::with_guessed_format).map_err(|e| failed(&e));
    // A small file can declare a huge image: refuse it before decoding.
    let (w, h) = open()?.into_dimensions().map_err(|e| failed(&e))?;
    Size::checked(w, h).map_err(|e| failed(&e))?;
    let img = open()?.decode().map_err(|e| failed(&e))?;
    let has_alpha = img.color().has_alpha();
    let rgba = img.to_rgba8();
    let mut frame = Frame::new(rgba.width(), rgba.height(), Vec3::ZERO);
    for (i, p) in rgba.pixels().enumerate() {
        frame.color[i] = Vec3::new(srgb8_to_linear(p[0]), srgb8_to_linear(p[1]), srgb8_to_linear(p[2]));
        frame.alpha[i] = if has_alpha { f32::from(p[3]) / 255.0 } else { 1.0 };
    }
    Ok(LoadedImage { frame, has_depth: false, has_normal: false })
}

fn load_exr(path: &Path) -> Result<LoadedImage, String> {
    let exr = read_exr_channels(path)?;
    let (w, h) = (exr.width as u32, exr.height as u32);
    let channel = |name: &str| exr.channels.get(name);
    let [Some(r), Some(g), Some(b)] = ["R", "G", "B"].map(channel) else {
        return Err(format!("{}: no R, G, B channels", path.display()));
    };
    let mut frame = Frame::new(w, h, Vec3::ZERO);
    for i in 0..frame.len() {
        frame.color[i] = Vec3::new(r[i], g[i], b[i]);
    }
    if let Some(a) = channel("A") {
        frame.alpha.clone_from(a);
    } else {
        frame.alpha.fill(1.0);
    }
    let has_depth = channel("Z").is_some();
    if let Some(z) = channel("Z") {
        frame.depth.clone_from(z);
    }
    let normals = ["N.X", "N.Y", "N.Z"].map(channel);
    let has_normal = normals.iter().all(Option::is_some);
    if let [Some(x), Some(y), Some(z)] = normals {
        for i in 0..frame.len() {
            frame.normal[i] = Vec3::new(x[i], y[i], z[i]);
        }
    }
    Ok(LoadedImage { frame, has_depth, has_normal })
}
