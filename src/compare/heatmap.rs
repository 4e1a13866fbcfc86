//! Heat maps: per-pixel values through a perceptually uniform colour map, with
//! a colour bar and its fixed scale printed under the image, so two heat maps
//! made with the same scale can be compared by eye.

use super::rgb8_image::{LINE_HEIGHT, Rgb8Image};

/// How values map to colours.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scale {
    /// `0..=max` through magma (larger is brighter); above `max` saturates.
    Magnitude {
        /// The value drawn in the brightest colour.
        max: f32,
    },
    /// `-max..=max` through a red–blue diverging map (positive red, zero white).
    Signed {
        /// The magnitude drawn in the strongest colours.
        max: f32,
    },
}

/// Colour of pixels that have no value (`NaN`): missed by both images.
pub const NO_VALUE: [u8; 3] = [40, 40, 46];
/// Colour of pixels whose value is infinite: hit in one image only.
pub const MISMATCH: [u8; 3] = [0, 230, 230];

/// Height of the strip under the image holding the title and the colour bar.
const STRIP: u32 = 5 * LINE_HEIGHT + 14;
/// Narrowest canvas, so the scale stays legible under small images.
const MIN_WIDTH: u32 = 280;

impl Scale {
    /// The colour of `v`.
    #[must_use]
    pub fn color(&self, v: f32) -> [u8; 3] {
        if v.is_nan() {
            return NO_VALUE;
        }
        if v.is_infinite() {
            return MISMATCH;
        }
        let c = match *self {
            Scale::Magnitude { max } => colorous::MAGMA.eval_continuous(f64::from((v / max).clamp(0.0, 1.0))),
            Scale::Signed { max } => {
                colorous::RED_BLUE.eval_continuous(f64::from((0.5 - 0.5 * v / max).clamp(0.0, 1.0)))
            }
        };
        [c.r, c.g, c.b]
    }

    /// The lowest and highest values of the bar.
    fn range(&self) -> (f32, f32) {
        match *self {
            Scale::Magnitude { max } => (0.0, max),
            Scale::Signed { max } => (-max, max),
        }
    }
}

/// Draws `values` (row-major, `width × height`) with `scale`, and under them
/// `title` and a colour bar labelled in `unit`.
#[must_use]
pub fn heat_map(values: &[f32], width: u32, height: u32, scale: Scale, title: &str, unit: &str) -> Rgb8Image {
    let canvas_width = width.max(MIN_WIDTH);
    let mut img = Rgb8Image::filled(canvas_width, height + STRIP, [255, 255, 255]);
    for y in 0..height {
        for x in 0..width {
            img.put(i64::from(x), i64::from(y), scale.color(values[(y * width + x) as usize]));
        }
    }
    let special = values.iter().any(|v| !v.is_finite());
    draw_bar(&mut img, height, scale, title, unit, special);
    img
}

/// Draws the title, the bar and its labels; the legend of special colours only
/// when the image uses them.
fn draw_bar(img: &mut Rgb8Image, top: u32, scale: Scale, title: &str, unit: &str, legend: bool) {
    let black = [0, 0, 0];
    let margin = 8i64;
    let y0 = i64::from(top) + 4;
    img.text(margin, y0, title, black);
    let bar_y = y0 + i64::from(LINE_HEIGHT) + 4;
    let bar_w = i64::from(img.width) - 2 * margin;
    let (lo, hi) = scale.range();
    for dx in 0..bar_w {
        let v = lo + (hi - lo) * dx as f32 / (bar_w - 1).max(1) as f32;
        img.fill_rect(margin + dx, bar_y, 1, 10, scale.color(v));
    }
    let label_y = bar_y + 12;
    for (x, y, text) in bar_labels(img.width, top, scale, unit) {
        img.text(x, y, &text, black);
    }
    if !legend {
        return;
    }
    let legend_y = label_y + i64::from(LINE_HEIGHT) + 3;
    for (k, (color, name)) in [(MISMATCH, "hit in one only"), (NO_VALUE, "missed by both")].into_iter().enumerate() {
        img.legend_entry(margin + k as i64 * 140, legend_y, color, name);
    }
}

/// The colour bar's printed values — its low end, middle and high end (with
/// the unit) — and where they go, for a canvas `width` wide whose strip starts
/// at `top`.
#[must_use]
pub fn bar_labels(width: u32, top: u32, scale: Scale, unit: &str) -> Vec<(i64, i64, String)> {
    let margin = 8i64;
    let label_y = i64::from(top) + 4 + i64::from(LINE_HEIGHT) + 4 + 12;
    let bar_w = i64::from(width) - 2 * margin;
    let (lo, hi) = scale.range();
    [(lo, 0.0), ((lo + hi) * 0.5, 0.5), (hi, 1.0)]
        .into_iter()
        .map(|(v, at)| {
            let text =
                if at == 1.0 && !unit.is_empty() { format!("{} {unit}", format_value(v)) } else { format_value(v) };
            let w = i64::from(Rgb8Image::text_width(&text));
            let x = (margin + (bar_w as f32 * at) as i64 - (w as f32 * at) as i64).max(0);
            (x, label_y, text)
        })
        .collect()
}

/// A short label for a scale value.
fn format_value(v: f32) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if (0.01..1000.0).contains(&a) {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.1e}")
    }
}

/// Colours of the silhouette map: both hit, first only, second only, neither.
pub const SILHOUETTE_COLORS: [[u8; 3]; 4] = [[200, 200, 200], [240, 140, 20], [0, 200, 230], NO_VALUE];

/// Where each of two renders hit the surface: both, the first only, the second
/// only, neither — each in its own colour, with a legend naming them.
#[must_use]
pub fn silhouette_map(first: &[f32], second: &[f32], width: u32, height: u32, names: [&str; 2]) -> Rgb8Image {
    let canvas_width = width.max(MIN_WIDTH);
    let mut img = Rgb8Image::filled(canvas_width, height + STRIP, [255, 255, 255]);
    for y in 0..height {
        for x in 0..width {
            let i = (y * width + x) as usize;
            let k = match (first[i].is_finite(), second[i].is_finite()) {
                (true, true) => 0,
                (true, false) => 1,
                (false, true) => 2,
                (false, false) => 3,
            };
            img.put(i64::from(x), i64::from(y), SILHOUETTE_COLORS[k]);
        }
    }
    let labels = ["both hit".to_string(), format!("{} only", names[0]), format!("{} only", names[1]), "neither".into()];
    let y0 = i64::from(height) + 4;
    img.text(8, y0, "silhouette mismatch", [0, 0, 0]);
    for (k, label) in labels.iter().enumerate() {
        let (x, y) = (8 + (k as i64 % 2) * 140, y0 + 14 + (k as i64 / 2) * 12);
        img.legend_entry(x, y, SILHOUETTE_COLORS[k], label);
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scales_saturate_and_mark_special_values() {
        let m = Scale::Magnitude { max: 2.0 };
        assert_eq!(m.color(5.0), m.color(2.0));
        assert_ne!(m.color(0.0), m.color(2.0));
        assert_eq!(m.color(f32::NAN), NO_VALUE);
        assert_eq!(m.color(f32::INFINITY), MISMATCH);
        let s = Scale::Signed { max: 1.0 };
        let (neg, pos) = (s.color(-1.0), s.color(1.0));
        assert!(pos[0] > pos[2] && neg[2] > neg[0], "{pos:?} {neg:?}");
        assert_eq!(format_value(0.05), "0.05");
        assert_eq!(format_value(2e-4), "2.0e-4");
    }

    #[test]
    fn the_bar_prints_the_ends_of_the_scale_it_draws() {
        for (scale, ends) in [
            (Scale::Magnitude { max: 0.05 }, ["0", "0.05 deg"]),
            (Scale::Signed { max: 2.0 }, ["-2", "2 deg"]),
            (Scale::Magnitude { max: 3e-4 }, ["0", "3.0e-4 deg"]),
        ] {
            let img = heat_map(&[0.0; 12], 4, 3, scale, "t", "deg");
            let labels = bar_labels(img.width, 3, scale, "deg");
            assert_eq!([labels[0].2.as_str(), labels[2].2.as_str()], ends);
            for (x, y, text) in labels {
                // Every pixel of the label's glyphs is drawn black on the heat map.
                let mut alone = Rgb8Image::filled(img.width, img.height, [255, 255, 255]);
                alone.text(x, y, &text, [0, 0, 0]);
                let glyph_px = alone.pixels.chunks(3).zip(img.pixels.chunks(3)).filter(|(a, _)| a == &[0, 0, 0]);
                let mut count = 0;
                for (_, drawn) in glyph_px {
                    assert_eq!(drawn, &[0, 0, 0], "label {text}");
                    count += 1;
                }
                assert!(count > 5, "label {text} drawn");
            }
        }
    }

    #[test]
    fn heat_map_has_the_image_above_a_strip() {
        let img = heat_map(&[0.0, 1.0, f32::INFINITY, f32::NAN], 2, 2, Scale::Magnitude { max: 1.0 }, "t", "u");
        assert_eq!((img.width, img.height), (MIN_WIDTH, 2 + STRIP));
        let below = (MIN_WIDTH * 3) as usize;
        assert_eq!(&img.pixels[below..below + 3], &MISMATCH[..]);
    }
}
