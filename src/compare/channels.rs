//! Images as OpenImageIO's `idiff` reads them: every channel of the file, by
//! name, as 32-bit floats, in OpenImageIO's canonical channel order.
//!
//! A PNG's 8- or 16-bit codes are divided by 255 or 65535 and compared as
//! stored (sRGB-encoded), not linearised; `Decoding::Linear` decodes sRGB
//! first. PNG stores colour unassociated with alpha, and OpenImageIO 2.4
//! associates it on reading with integer arithmetic (`code·alpha / max`,
//! truncated, when the file carries no gamma of its own); this reader does the
//! same so that every statistic equals idiff's. An EXR's channels are read as
//! they are (`f16` widened exactly), ordered as OpenImageIO orders them: by
//! layer, then `R, G, B, A, Z`-style special names, then by name.

use std::io::BufReader;
use std::path::Path;

use crate::frame::{Size, read_exr_channels, srgb8_to_linear};

/// How PNG codes become values.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Decoding {
    /// Code / maximum code, as stored (idiff's way).
    #[default]
    Stored,
    /// sRGB codes decoded to linear light (alpha stays as stored).
    Linear,
}

/// Named float channels of one image, each a row-major plane.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Channel names in order.
    pub names: Vec<String>,
    /// One plane per name.
    pub planes: Vec<Vec<f32>>,
}

impl ChannelImage {
    /// The plane of the channel called `name`.
    #[must_use]
    pub fn channel(&self, name: &str) -> Option<&[f32]> {
        self.names.iter().position(|n| n == name).map(|i| self.planes[i].as_slice())
    }

    /// The image on a `width × height` canvas (at least its own size), the
    /// pixels beyond it reading 0, as OpenImageIO reads past a data window.
    #[must_use]
    pub fn padded(&self, width: u32, height: u32) -> ChannelImage {
        let (w, h) = (width.max(self.width) as usize, height.max(self.height) as usize);
        let own = self.width as usize;
        let planes = self
            .planes
            .iter()
            .map(|p| {
                let mut out = vec![0.0; w * h];
                for (y, row) in p.chunks_exact(own.max(1)).enumerate() {
                    out[y * w..y * w + own].copy_from_slice(row);
                }
                out
            })
            .collect();
        ChannelImage { width: w as u32, height: h as u32, names: self.names.clone(), planes }
    }

    /// Keeps only the channels `names`, in that order; names one missing.
    pub fn select(&self, names: &[String]) -> Result<ChannelImage, String> {
        let planes = names
            .iter()
            .map(|n| self.channel(n).map(<[f32]>::to_vec).ok_or_else(|| n.clone()))
            .collect::<Result<Vec<_>, String>>()?;
        Ok(ChannelImage { width: self.width, height: self.height, names: names.to_vec(), planes })
    }
}

/// Reads a PNG or an EXR (by extension) with every channel.
pub fn load_channels(path: &Path, decoding: Decoding) -> Result<ChannelImage, String> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("exr") => load_exr(path),
        Some("png") => load_png(path, decoding),
        _ => Err(format!("{}: not a .png or .exr image", path.display())),
    }
}

fn load_exr(path: &Path) -> Result<ChannelImage, String> {
    let exr = read_exr_channels(path)?;
    let (mut names, mut planes): (Vec<String>, Vec<Vec<f32>>) = exr.channels.into_iter().unzip();
    let order = canonical_order(&names);
    let names = order.iter().map(|&i| std::mem::take(&mut names[i])).collect();
    let planes = order.iter().map(|&i| std::mem::take(&mut planes[i])).collect();
    Ok(ChannelImage { width: exr.width as u32, height: exr.height as u32, names, planes })
}

/// The order OpenImageIO presents EXR channels `names` in, as indices into them.
fn canonical_order(names: &[String]) -> Vec<usize> {
    let keys = canonical_keys(names.iter().map(String::as_str));
    let mut order: Vec<usize> = (0..names.len()).collect();
    order.sort_by(|&i, &j| keys[i].cmp(&keys[j]));
    order
}

/// OpenImageIO's sort keys for EXR channels: layer (text before the last
/// dot), then the suffix's rank among special names, then the suffix. A
/// layer holding `X` and `Y` or `Z` is a vector (a position or normal) and
/// ranks `X, Y, Z` ahead of the rest.
fn canonical_keys<'a>(names: impl Iterator<Item = &'a str> + Clone) -> Vec<(&'a str, usize, &'a str)> {
    let split = |name: &'a str| name.rsplit_once('.').unwrap_or(("", name));
    let has =
        |layer: &str, suffix: &str| names.clone().map(split).any(|(l, s)| l == layer && s.eq_ignore_ascii_case(suffix));
    names
        .clone()
        .map(|name| {
            let (layer, suffix) = split(name);
            let vector = has(layer, "X") && (has(layer, "Y") || has(layer, "Z"));
            (layer, special_rank(suffix, vector), suffix)
        })
        .collect()
}

fn special_rank(suffix: &str, vector: bool) -> usize {
    const USUAL: [&str; 20] = [
        "R", "Red", "G", "Green", "B", "Blue", "Y", "real", "imag", "A", "Alpha", "AR", "RA", "AG", "GA", "AB", "BA",
        "Z", "Depth", "Zback",
    ];
    const VECTOR: [&str; 21] = [
        "R", "Red", "G", "Green", "B", "Blue", "X", "Y", "Z", "real", "imag", "A", "Alpha", "AR", "RA", "AG", "GA",
        "AB", "BA", "Depth", "Zback",
    ];
    let list: &[&str] = if vector { &VECTOR } else { &USUAL };
    list.iter().position(|s| s.eq_ignore_ascii_case(suffix)).unwrap_or(10_000)
}

fn load_png(path: &Path, decoding: Decoding) -> Result<ChannelImage, String> {
    let failed = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let file = std::fs::File::open(path).map_err(|e| failed(&e))?;
    let mut decoder = png::Decoder::new(BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(|e| failed(&e))?;
    let (w, h) = (reader.info().width, reader.info().height);
    // A small file can declare a huge image: refuse it before decoding.
    Size::checked(w, h).map_err(|e| failed(&e))?;
    let tagged_gamma = reader.info().srgb.is_none() && reader.info().gamma().is_some();
    let mut buf = vec![0; reader.output_buffer_size().ok_or_else(|| failed(&"image too large"))?];
    let info = reader.next_frame(&mut buf).map_err(|e| failed(&e))?;
    let names = channel_names(info.color_type);
    let codes = sample_codes(&buf[..info.buffer_size()], info.bit_depth);
    let max = if info.bit_depth == png::BitDepth::Sixteen { 65_535 } else { 255 };
    let has_alpha = matches!(info.color_type, png::ColorType::GrayscaleAlpha | png::ColorType::Rgba);
    if has_alpha && tagged_gamma {
        return Err(failed(&"a PNG with alpha and its own gamma (gAMA) is not supported; re-save it as sRGB"));
    }
    Ok(png_planes(w, h, names, &codes, max, has_alpha, decoding))
}

fn channel_names(color: png::ColorType) -> Vec<String> {
    let names: &[&str] = match color {
        png::ColorType::Grayscale => &["Y"],
        png::ColorType::GrayscaleAlpha => &["Y", "A"],
        png::ColorType::Rgba => &["R", "G", "B", "A"],
        // Indexed colour is expanded to RGB.
        png::ColorType::Rgb | png::ColorType::Indexed => &["R", "G", "B"],
    };
    names.iter().map(ToString::to_string).collect()
}

fn sample_codes(bytes: &[u8], depth: png::BitDepth) -> Vec<u32> {
    match depth {
        png::BitDepth::Sixteen => bytes.chunks_exact(2).map(|b| u32::from(u16::from_be_bytes([b[0], b[1]]))).collect(),
        _ => bytes.iter().map(|&b| u32::from(b)).collect(),
    }
}

/// Splits interleaved codes into planes, associating alpha as OpenImageIO does.
fn png_planes(
    width: u32,
    height: u32,
    names: Vec<String>,
    codes: &[u32],
    max: u32,
    has_alpha: bool,
    decoding: Decoding,
) -> ChannelImage {
    let n = names.len();
    let alpha = n - 1;
    let scale = 1.0 / max as f32;
    let mut planes = vec![Vec::with_capacity(codes.len() / n); n];
    for pixel in codes.chunks_exact(n) {
        for (c, &code) in pixel.iter().enumerate() {
            let stored = if has_alpha && c != alpha { code * pixel[alpha] / max } else { code };
            let value = match decoding {
                Decoding::Linear if c != alpha || !has_alpha => linear_value(stored, max),
                _ => stored as f32 * scale,
            };
            planes[c].push(value);
        }
    }
    ChannelImage { width, height, names, planes }
}

fn linear_value(code: u32, max: u32) -> f32 {
    if max == 255 {
        srgb8_to_linear(code as u8)
    } else {
        let s = code as f32 / max as f32;
        if s <= 0.040_45 { s / 12.92 } else { ((s + 0.055) / 1.055).powf(2.4) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exr_channels_sort_as_openimageio_sorts_them() {
        let names = ["A", "B", "G", "N.X", "N.Y", "N.Z", "R", "Z", "depth.Z", "steps.Y"].map(String::from);
        let order = canonical_order(&names);
        assert_eq!(
            order.iter().map(|&i| names[i].as_str()).collect::<Vec<_>>(),
            ["R", "G", "B", "A", "Z", "N.X", "N.Y", "N.Z", "depth.Z", "steps.Y"]
        );
    }

    #[test]
    fn png_alpha_is_associated_with_truncating_integer_arithmetic() {
        let names = ["R", "G", "B", "A"].map(String::from).to_vec();
        let img = png_planes(1, 1, names, &[200, 101, 255, 128], 255, true, Decoding::Stored);
        // 200·128/255 = 100.39 → 100; 101·128/255 = 50.7 → 50; 255·128/255 = 128.
        let codes: Vec<f32> = img.planes.iter().map(|p| p[0] * 255.0).collect();
        for (got, want) in codes.iter().zip([100.0, 50.0, 128.0, 128.0]) {
            assert!((got - want).abs() < 1e-4, "{codes:?}");
        }
    }
}
