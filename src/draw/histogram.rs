//! Histogram plots: one bar per bucket over `[0, 1]`, each coloured as the
//! heat map colours its value, with marked statistics — ꟻLIP's histogram of
//! per-pixel errors.

use super::plot::Axis;
use super::rgb8_image::{LINE_HEIGHT, Rgb8Image};

/// Draws `counts` (equal buckets over `[0, 1]`) as bars titled `title`, the x
/// axis named `x_label`, with a vertical line and label at each of `marks`.
/// The count axis is logarithmic when the counts spread widely.
#[must_use]
pub fn histogram_plot(
    title: &str,
    x_label: &str,
    counts: &[usize],
    marks: &[(&str, f64)],
    width: u32,
    height: u32,
) -> Rgb8Image {
    let mut img = Rgb8Image::filled(width, height, [255, 255, 255]);
    let (left, right, top, bottom) = (64i64, 16i64, 3 * i64::from(LINE_HEIGHT) + 12, 3 * i64::from(LINE_HEIGHT));
    let (pw, ph) = (i64::from(width) - left - right, i64::from(height) - top - bottom);
    let axis = Axis::fitting(counts.iter().map(|&c| c as f64));
    let black = [0, 0, 0];
    let scale = if matches!(axis, Axis::Log { .. }) { ", log scale" } else { "" };
    img.text(left, 4, &format!("{title}{scale}"), black);
    let n = counts.len().max(1) as i64;
    for (k, &count) in counts.iter().enumerate() {
        if count == 0 {
            continue;
        }
        let (x0, x1) = (left + pw * k as i64 / n, left + pw * (k as i64 + 1) / n);
        let bar = (ph as f64 * axis.fraction(count as f64)).round().max(1.0) as i64;
        let value = (k as f64 + 0.5) / n as f64;
        let color = colorous::MAGMA.eval_continuous(value.clamp(0.0, 1.0)).as_array();
        img.fill_rect(x0, top + ph - bar, (x1 - x0).max(1), bar, color);
    }
    for x in 0..=pw {
        img.put(left + x, top + ph, black);
    }
    for y in 0..=ph {
        img.put(left, top + y, black);
    }
    for (fraction, label) in axis.ticks() {
        img.text(2, top + ph - (ph as f64 * fraction) as i64 - 4, &label, black);
    }
    img.text(2, top - i64::from(LINE_HEIGHT) - 4, "pixels", black);
    for (k, label) in ["0", "0.5", "1"].iter().enumerate() {
        img.text(left + pw * k as i64 / 2 - 4 * k as i64, top + ph + 6, label, black);
    }
    img.text(left + pw / 2 - 4 * x_label.len() as i64, top + ph + 6 + i64::from(LINE_HEIGHT), x_label, black);
    for (k, (name, value)) in marks.iter().enumerate() {
        let x = left + (pw as f64 * value.clamp(0.0, 1.0)) as i64;
        for y in (0..ph).step_by(2) {
            img.put(x, top + y, [40, 110, 200]);
        }
        let row = i64::from(LINE_HEIGHT) + 8 + k as i64 * i64::from(LINE_HEIGHT);
        img.text(left + 8, row, &format!("{name} {value:.4}"), [40, 110, 200]);
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_non_empty_bucket_is_a_bar_in_its_colour() {
        let mut counts = vec![0; 100];
        counts[5] = 1000;
        counts[90] = 3;
        let img = histogram_plot("t", "x", &counts, &[("mean", 0.3)], 400, 240);
        let has = |c: [u8; 3]| img.pixels.chunks(3).any(|p| p == c);
        assert!(has(colorous::MAGMA.eval_continuous(0.055).as_array()));
        assert!(has(colorous::MAGMA.eval_continuous(0.905).as_array()));
        assert!(!has(colorous::MAGMA.eval_continuous(0.505).as_array()));
        assert!(has([40, 110, 200]));
    }
}
