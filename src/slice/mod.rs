//! The slice stage: images of the field on a plane — f with its iso-contour,
//! the paper's "sharp" view (sin(11π f) with the iso-band in red), error_C =
//! |f_C − f|, and the angle between cached and exact gradients.

mod plane;

use glam::Vec3A;
use rayon::prelude::*;

pub use plane::{PlaneError, SlicePlane};

use crate::draw::Rgb8Image;

/// Samples `f` at every pixel centre of `plane`, rows in parallel.
pub fn sample(plane: &SlicePlane, f: impl Fn(Vec3A) -> f32 + Sync) -> Vec<f32> {
    (0..plane.height)
        .into_par_iter()
        .flat_map_iter(|y| (0..plane.width).map(move |x| (x, y)).map(|(x, y)| f(plane.point(x, y))).collect::<Vec<_>>())
        .collect()
}

/// Half-width of the red iso-band of the sharp view, in field units.
const ISO_BAND: f32 = 0.004;

/// The paper's Figure 6 view: `sin(11π f)` in grey, pixels within a thin band
/// of the iso-value in red, so a filter's creases and wobbles stand out.
#[must_use]
pub fn sharp_image(values: &[f32], width: u32, height: u32, threshold: f32) -> Rgb8Image {
    let mut img = Rgb8Image::filled(width, height, [0, 0, 0]);
    for (i, &f) in values.iter().enumerate() {
        let color = if (f - threshold).abs() < ISO_BAND {
            [220, 30, 30]
        } else {
            let g = (127.5 * (1.0 + (11.0 * std::f32::consts::PI * f).sin())) as u8;
            [g, g, g]
        };
        img.put(i as i64 % i64::from(width), i as i64 / i64::from(width), color);
    }
    img
}

/// `view` with a legend strip below it saying what the sharp view's colours
/// mean: the red band around the iso-value and the grey ramp of `sin(11π f)`.
#[must_use]
pub fn with_sharp_legend(view: &Rgb8Image, threshold: f32) -> Rgb8Image {
    use crate::draw::LINE_HEIGHT;
    let strip = 2 * LINE_HEIGHT + 12;
    let mut img = Rgb8Image::filled(view.width, view.height + strip, [255, 255, 255]);
    img.pixels[..view.pixels.len()].copy_from_slice(&view.pixels);
    let top = i64::from(view.height) + 4;
    let black = [0, 0, 0];
    img.legend_entry(8, top, [220, 30, 30], &format!("f within {ISO_BAND} of the iso-value {threshold}"));
    let ramp_y = top + i64::from(LINE_HEIGHT) + 2;
    img.text(8, ramp_y, "sin(11 pi f): -1", black);
    let ramp_x = 8 + i64::from(Rgb8Image::text_width("sin(11 pi f): -1 "));
    for dx in 0..128 {
        let g = (2 * dx) as u8;
        img.fill_rect(ramp_x + dx, ramp_y, 1, i64::from(LINE_HEIGHT) - 2, [g, g, g]);
    }
    img.text(ramp_x + 132, ramp_y, "+1", black);
    img
}

/// Pixels where the field crosses `threshold` between a pixel and its right or lower neighbour.
#[must_use]
pub fn iso_contour(values: &[f32], width: u32, height: u32, threshold: f32) -> Vec<bool> {
    let (w, h) = (width as usize, height as usize);
    let inside = |i: usize| values[i] > threshold;
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            (x + 1 < w && inside(i) != inside(i + 1)) || (y + 1 < h && inside(i) != inside(i + w))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sharp_view_marks_the_iso_band_and_contours_close() {
        let values = [0.0, 0.5, 1.0, 0.5];
        let img = sharp_image(&values, 2, 2, 0.5);
        assert_eq!(&img.pixels[3..6], &[220, 30, 30]);
        assert_eq!(&img.pixels[0..3], &[127, 127, 127]);
        let c = iso_contour(&[0.0, 1.0, 0.0, 1.0], 2, 2, 0.5);
        assert_eq!(c, vec![true, false, true, false]);
    }

    #[test]
    fn the_sharp_legend_sits_below_the_view_and_shows_the_band_colour() {
        let view = Rgb8Image::filled(300, 20, [90, 90, 90]);
        let img = with_sharp_legend(&view, 0.5);
        assert_eq!((img.width, &img.pixels[..view.pixels.len()]), (300, &view.pixels[..]));
        let below = &img.pixels[view.pixels.len()..];
        assert!(below.chunks(3).any(|p| p == [220, 30, 30]), "the red band's swatch");
        assert!(below.chunks(3).any(|p| p == [128, 128, 128]), "the grey ramp");
    }
}
