//! idiff's difference image (`idiff -o`): every channel's `A − B`, or
//! `|A − B|` with `-abs`, times `-scale`. As EXR it keeps every channel in
//! float; as PNG its first four channels become 8-bit codes, clamped to
//! `[0, 1]` and rounded, as OpenImageIO converts floats to 8 bits (a signed
//! difference loses its negative half there, which is why a PNG without
//! `-abs` is our heat map instead).

use super::channels::ChannelImage;

/// How the difference is formed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DifferenceForm {
    /// `|A − B|` rather than `A − B`.
    pub absolute: bool,
    /// Multiplies every value.
    pub scale: f32,
}

/// The named planes of the difference of `a` and `b` (same size; a channel
/// one image lacks reads 0, as in the comparison).
#[must_use]
pub fn difference_planes(a: &ChannelImage, b: &ChannelImage, form: DifferenceForm) -> Vec<(String, Vec<f32>)> {
    let n = a.names.len().max(b.names.len());
    let len = (a.width * a.height) as usize;
    let plane = |img: &ChannelImage, c: usize| img.planes.get(c).cloned().unwrap_or_else(|| vec![0.0; len]);
    (0..n)
        .map(|c| {
            let name = a.names.get(c).or_else(|| b.names.get(c)).cloned().unwrap_or_else(|| format!("channel{c}"));
            let (pa, pb) = (plane(a, c), plane(b, c));
            let values = pa
                .iter()
                .zip(&pb)
                .map(|(&x, &y)| {
                    let d = x - y;
                    if form.absolute { d.abs() * form.scale } else { d * form.scale }
                })
                .collect();
            (name, values)
        })
        .collect()
}

/// The planes (at most four used: grey, grey and alpha, RGB, RGBA) as 8-bit PNG bytes.
pub fn planes_png_bytes(planes: &[(String, Vec<f32>)], width: u32, height: u32) -> Result<Vec<u8>, String> {
    let used = &planes[..planes.len().min(4)];
    let color = match used.len() {
        1 => png::ColorType::Grayscale,
        2 => png::ColorType::GrayscaleAlpha,
        3 => png::ColorType::Rgb,
        4 => png::ColorType::Rgba,
        _ => return Err("no channel to write".into()),
    };
    let len = (width * height) as usize;
    let codes: Vec<u8> =
        (0..len).flat_map(|i| used.iter().map(move |(_, p)| (p[i].clamp(0.0, 1.0) * 255.0 + 0.5) as u8)).collect();
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, width, height);
    encoder.set_color(color);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
    writer.write_image_data(&codes).map_err(|e| e.to_string())?;
    writer.finish().map_err(|e| e.to_string())?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn differences_are_signed_or_absolute_and_scaled() {
        let image = |names: &[&str], planes: Vec<Vec<f32>>| ChannelImage {
            width: 2,
            height: 1,
            names: names.iter().map(ToString::to_string).collect(),
            planes,
        };
        let a = image(&["R", "A"], vec![vec![0.25, 1.0], vec![1.0, 1.0]]);
        let b = image(&["R"], vec![vec![0.5, 0.5]]);
        let signed = difference_planes(&a, &b, DifferenceForm { absolute: false, scale: 2.0 });
        assert_eq!(signed, vec![("R".into(), vec![-0.5, 1.0]), ("A".into(), vec![2.0, 2.0])]);
        let abs = difference_planes(&a, &b, DifferenceForm { absolute: true, scale: 1.0 });
        assert_eq!(abs[0].1, vec![0.25, 0.5]);
        let png = planes_png_bytes(&abs, 2, 1).unwrap();
        let decoded = image::load_from_memory(&png).unwrap().to_luma_alpha8();
        assert_eq!(decoded.as_raw(), &vec![64, 255, 128, 255]);
    }
}
