//! Heat maps: per-pixel values through a perceptually uniform colour map, with
//! a colour bar and its scale printed under the image, so two heat maps made
//! with the same scale can be compared by eye. Values beyond the scale are
//! drawn in a colour of their own and their share is printed: a heat map
//! never clips silently. A scale is fixed by the caller or chosen from the
//! data ([`Scale::from_data`]).

use super::rgb8_image::{LINE_HEIGHT, Rgb8Image};

/// How values map to colours.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Scale {
    /// `0..=max` through magma (larger is brighter); above `max` or below 0: [`OVER_RANGE`].
    Magnitude {
        /// The value drawn in the brightest colour.
        max: f32,
    },
    /// `-max..=max` through a red–blue diverging map (positive red, zero
    /// white); beyond: [`OVER_RANGE`].
    Signed {
        /// The magnitude drawn in the strongest colours.
        max: f32,
    },
}

/// Colour of pixels that have no value (`NaN`): missed by both images.
pub const NO_VALUE: [u8; 3] = [40, 40, 46];
/// Colour of pixels whose value is infinite: hit in one image only.
pub const MISMATCH: [u8; 3] = [0, 230, 230];

/// Colour of pixels whose value lies beyond the scale (in neither map).
pub const OVER_RANGE: [u8; 3] = [80, 255, 40];

/// Height of the strip under the image holding the title, the colour bar,
/// its labels and two rows of legend.
const STRIP: u32 = 6 * LINE_HEIGHT + 20;
/// Narrowest canvas, so the scale stays legible under small images.
const MIN_WIDTH: u32 = 280;

impl Scale {
    /// `values` (row-major, `width × height`) in the scale's colours, with
    /// no legend: for views that draw their colour bar elsewhere.
    #[must_use]
    pub fn paint(&self, values: &[f32], width: u32, height: u32) -> Rgb8Image {
        Rgb8Image { width, height, pixels: values.iter().flat_map(|&v| self.color(v)).collect() }
    }

    /// The colour of `v`.
    #[must_use]
    pub fn color(&self, v: f32) -> [u8; 3] {
        if v.is_nan() {
            return NO_VALUE;
        }
        if v.is_infinite() {
            return MISMATCH;
        }
        if self.is_beyond(v) {
            return OVER_RANGE;
        }
        let c = match *self {
            Scale::Magnitude { max } => colorous::MAGMA.eval_continuous(f64::from((v / max).clamp(0.0, 1.0))),
            Scale::Signed { max } => {
                colorous::RED_BLUE.eval_continuous(f64::from((0.5 - 0.5 * v / max).clamp(0.0, 1.0)))
            }
        };
        [c.r, c.g, c.b]
    }

    /// A scale for `values` chosen from the data: their 99th percentile (of
    /// the finite magnitudes) rounded up to 1, 2 or 5 times a power of ten, so
    /// outliers do not wash the rest out and are marked beyond the scale;
    /// `fallback` where that percentile is zero.
    #[must_use]
    pub fn from_data(values: &[f32], signed: bool, fallback: f32) -> Self {
        let mut magnitudes: Vec<f32> = values.iter().filter(|v| v.is_finite()).map(|v| v.abs()).collect();
        magnitudes.sort_by(f32::total_cmp);
        let p99 = magnitudes.get((magnitudes.len().saturating_sub(1) * 99) / 100).copied().unwrap_or(0.0);
        let max = if p99 > 0.0 { nice_ceiling(p99) } else { fallback };
        if signed { Scale::Signed { max } } else { Scale::Magnitude { max } }
    }

    /// The scale's full-scale magnitude.
    #[must_use]
    pub fn max(&self) -> f32 {
        match *self {
            Scale::Magnitude { max } | Scale::Signed { max } => max,
        }
    }

    /// Whether finite `v` lies beyond the scale.
    fn is_beyond(&self, v: f32) -> bool {
        match *self {
            Scale::Magnitude { max } => v > max || v < 0.0,
            Scale::Signed { max } => v.abs() > max,
        }
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
    heat_map_labelled(values, (width, height), scale, (title, unit), &SpecialLabels::default())
}

/// What a heat map's special colours mean where its values come from.
#[derive(Clone, Copy, Debug)]
pub struct SpecialLabels<'a> {
    /// Pixels without a value (`NaN`).
    pub no_value: &'a str,
    /// Pixels with an infinite value.
    pub infinite: &'a str,
}

impl Default for SpecialLabels<'_> {
    /// The labels of a comparison of two renders.
    fn default() -> Self {
        Self { no_value: "missed by both", infinite: "hit in one only" }
    }
}

/// [`heat_map`], with the special colours' legend saying what they mean here.
#[must_use]
pub fn heat_map_labelled(
    values: &[f32],
    (width, height): (u32, u32),
    scale: Scale,
    (title, unit): (&str, &str),
    labels: &SpecialLabels,
) -> Rgb8Image {
    heat_map_zoomed(values, (width, height), 1, scale, (title, unit), labels)
}

/// [`heat_map_labelled`] with each value drawn as a `zoom × zoom` square
/// (its key and counts of the values themselves), for a page that shows the
/// map beside images scaled up as much.
#[must_use]
pub fn heat_map_zoomed(
    values: &[f32],
    (width, height): (u32, u32),
    zoom: u32,
    scale: Scale,
    (title, unit): (&str, &str),
    labels: &SpecialLabels,
) -> Rgb8Image {
    let z = zoom.max(1);
    let mut img = Rgb8Image::filled((width * z).max(MIN_WIDTH), height * z + STRIP, [255, 255, 255]);
    for y in 0..height {
        for x in 0..width {
            let (px, py, side) = (i64::from(x * z), i64::from(y * z), i64::from(z));
            img.fill_rect(px, py, side, side, scale.color(values[(y * width + x) as usize]));
        }
    }
    draw_bar(&mut img, height * z, scale, title, unit, &legend(values, scale, labels));
    img
}

/// What a heat map's colours mean, for a colour bar drawn beside it: its
/// scale, metric and unit, and the special colours its image shows.
#[derive(Clone, Debug, PartialEq)]
pub struct ColourKey {
    /// The scale the colours follow.
    pub scale: Scale,
    /// The metric.
    pub title: &'static str,
    /// Its unit.
    pub unit: &'static str,
    /// Each special colour the image uses, with what it means there, and
    /// the share of values beyond the scale when there are any.
    pub specials: Vec<([u8; 3], String)>,
}

impl ColourKey {
    /// The key of the heat map of `values` on `scale`, of the metric and
    /// unit `title_unit`, its special colours meaning what `labels` say.
    #[must_use]
    pub fn of(
        values: &[f32],
        scale: Scale,
        (title, unit): (&'static str, &'static str),
        labels: &SpecialLabels,
    ) -> Self {
        Self { scale, title, unit, specials: legend(values, scale, labels) }
    }
}

/// The legend entries an image needs: only the special colours it uses, and
/// the share of its values beyond the scale.
fn legend(values: &[f32], scale: Scale, labels: &SpecialLabels) -> Vec<([u8; 3], String)> {
    let (mut nan, mut inf, mut beyond, mut finite) = (false, false, 0usize, 0usize);
    for &v in values {
        nan |= v.is_nan();
        inf |= v.is_infinite();
        if v.is_finite() {
            finite += 1;
            beyond += usize::from(scale.is_beyond(v));
        }
    }
    let mut entries = vec![];
    if inf {
        entries.push((MISMATCH, labels.infinite.to_string()));
    }
    if nan {
        entries.push((NO_VALUE, labels.no_value.to_string()));
    }
    if beyond > 0 {
        let share = 100.0 * beyond as f64 / finite as f64;
        entries.push((OVER_RANGE, format!("beyond scale: {} px ({share:.2}%)", beyond)));
    }
    entries
}

/// The smallest of 1, 2 and 5 times a power of ten at or above `x > 0`.
fn nice_ceiling(x: f32) -> f32 {
    let power = 10f32.powf(x.log10().floor());
    let nice = [1.0, 2.0, 5.0, 10.0].into_iter().map(|m| m * power).find(|&v| v >= x * (1.0 - 1e-6));
    nice.filter(|v| v.is_finite()).unwrap_or(f32::MAX)
}

/// Draws the title, the bar, its labels and the `legend` entries, two a row.
fn draw_bar(img: &mut Rgb8Image, top: u32, scale: Scale, title: &str, unit: &str, legend: &[([u8; 3], String)]) {
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
    let legend_y = label_y + i64::from(LINE_HEIGHT) + 3;
    // The share beyond the scale is long: it takes a row of its own.
    let (mut row, mut column) = (0, 0);
    for (color, name) in legend {
        if column == 2 || (*color == OVER_RANGE && column > 0) {
            (row, column) = (row + 1, 0);
        }
        img.legend_entry(margin + column * 140, legend_y + row * 12, *color, name);
        column += 1;
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
        // Beyond the scale is marked, not clipped into its brightest colour.
        assert_eq!(m.color(5.0), OVER_RANGE);
        assert_ne!(m.color(2.0), OVER_RANGE);
        assert_ne!(m.color(0.0), m.color(2.0));
        assert_eq!(Scale::Signed { max: 1.0 }.color(-1.5), OVER_RANGE);
        assert_eq!(m.color(-0.1), OVER_RANGE, "a magnitude scale has no room below zero either");
        assert_eq!(nice_ceiling(3e38), f32::MAX);
        assert_eq!(m.color(f32::NAN), NO_VALUE);
        assert_eq!(m.color(f32::INFINITY), MISMATCH);
        let s = Scale::Signed { max: 1.0 };
        let (neg, pos) = (s.color(-1.0), s.color(1.0));
        assert!(pos[0] > pos[2] && neg[2] > neg[0], "{pos:?} {neg:?}");
        assert_eq!(format_value(0.05), "0.05");
        assert_eq!(format_value(2e-4), "2.0e-4");
    }

    #[test]
    fn a_zoomed_map_draws_each_value_as_a_square_and_counts_the_values_themselves() {
        let (scale, labels) = (Scale::Magnitude { max: 1.0 }, SpecialLabels::default());
        let values = [0.0, 0.5, 2.0, 1.0];
        let img = heat_map_zoomed(&values, (2, 2), 3, scale, ("t", ""), &labels);
        let at = |x: u32, y: u32| &img.pixels[3 * (y * img.width + x) as usize..][..3];
        for (k, &v) in values.iter().enumerate() {
            for (dx, dy) in [(0, 0), (2, 2), (1, 2)] {
                assert_eq!(at(3 * (k as u32 % 2) + dx, 3 * (k as u32 / 2) + dy), scale.color(v), "value {k}");
            }
        }
        // The key below (its count of values beyond the scale included) is the unzoomed map's.
        let plain = heat_map(&values, 2, 2, scale, "t", "");
        let row_bytes = 3 * img.width as usize;
        assert_eq!((img.width, img.height - 6), (plain.width, plain.height - 2));
        assert_eq!(img.pixels[6 * row_bytes..], plain.pixels[2 * row_bytes..]);
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
    fn a_scale_from_the_data_is_a_round_number_at_the_99th_percentile() {
        let mut values: Vec<f32> = (1..=1000).map(|k| k as f32 * 0.0037).collect();
        values.extend([1e6, f32::NAN, f32::INFINITY]);
        assert_eq!(Scale::from_data(&values, false, 1.0), Scale::Magnitude { max: 5.0 });
        let negative: Vec<f32> = values.iter().map(|v| -v).collect();
        assert_eq!(Scale::from_data(&negative, true, 1.0), Scale::Signed { max: 5.0 });
        assert_eq!(Scale::from_data(&[0.0, f32::NAN], false, 0.1), Scale::Magnitude { max: 0.1 });
        assert_eq!([nice_ceiling(0.29), nice_ceiling(41.9), nice_ceiling(1.0)], [0.5, 50.0, 1.0]);
    }

    #[test]
    fn values_beyond_the_scale_are_counted_on_the_bar() {
        let values = [0.5, 3.0, 0.1, 9.0];
        let entries = legend(&values, Scale::Magnitude { max: 1.0 }, &SpecialLabels::default());
        assert_eq!(entries, [(OVER_RANGE, "beyond scale: 2 px (50.00%)".to_string())]);
        let img = heat_map(&values, 2, 2, Scale::Magnitude { max: 1.0 }, "t", "u");
        let green = img.pixels.chunks(3).filter(|p| *p == OVER_RANGE).count();
        assert!(green > 2, "the two pixels and the legend's swatch: {green}");
        let labels = SpecialLabels { no_value: "gradient vanishes", infinite: "-" };
        let entries = legend(&[f32::NAN, 0.0], Scale::Magnitude { max: 1.0 }, &labels);
        assert_eq!(entries, [(NO_VALUE, "gradient vanishes".to_string())], "only what the image shows");
    }

    #[test]
    fn heat_map_has_the_image_above_a_strip() {
        let img = heat_map(&[0.0, 1.0, f32::INFINITY, f32::NAN], 2, 2, Scale::Magnitude { max: 1.0 }, "t", "u");
        assert_eq!((img.width, img.height), (MIN_WIDTH, 2 + STRIP));
        let below = (MIN_WIDTH * 3) as usize;
        assert_eq!(&img.pixels[below..below + 3], &MISMATCH[..]);
    }
}
