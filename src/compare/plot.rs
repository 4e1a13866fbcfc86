//! Line plots of per-frame timings (the caching paper's Figure 8), drawn
//! directly on an RGB image with labelled axes and a legend.

use super::text::{LINE_HEIGHT, Rgb8Image};

/// Colours of successive series.
const SERIES_COLORS: [[u8; 3]; 4] = [[200, 60, 40], [40, 110, 200], [60, 160, 60], [150, 80, 170]];

/// Plots `series` (name, one value per frame) against the frame number, on a
/// y axis from 0 to the largest value, titled `title`, y values in `unit`.
#[must_use]
pub fn line_plot(title: &str, unit: &str, series: &[(&str, &[f64])], width: u32, height: u32) -> Rgb8Image {
    let mut img = Rgb8Image::filled(width, height, [255, 255, 255]);
    let (left, right, top, bottom) = (64i64, 16i64, 2 * i64::from(LINE_HEIGHT) + 12, 3 * i64::from(LINE_HEIGHT));
    let (pw, ph) = (i64::from(width) - left - right, i64::from(height) - top - bottom);
    let frames = series.iter().map(|(_, v)| v.len()).max().unwrap_or(0).max(2);
    let y_max = series.iter().flat_map(|(_, v)| v.iter().copied()).filter(|v| v.is_finite()).fold(0.0f64, f64::max);
    let y_max = if y_max > 0.0 { y_max * 1.05 } else { 1.0 };
    let black = [0, 0, 0];
    img.text(left, 4, title, black);
    // Axes, ticks and labels.
    for x in 0..=pw {
        img.put(left + x, top + ph, black);
    }
    for y in 0..=ph {
        img.put(left, top + y, black);
    }
    for k in 0..=4 {
        let v = y_max * f64::from(k) / 4.0;
        let y = top + ph - (ph as f64 * f64::from(k) / 4.0) as i64;
        for x in 0..pw {
            if x % 4 == 0 {
                img.put(left + x, y, [210, 210, 210]);
            }
        }
        img.text(2, y - 4, &format!("{v:.3}"), black);
    }
    img.text(2, top - i64::from(LINE_HEIGHT) - 4, unit, black);
    img.text(left + pw / 2 - 20, top + ph + 6, "frame", black);
    img.text(left, top + ph + 6, "0", black);
    let last = format!("{}", frames - 1);
    img.text(left + pw - 8 * last.len() as i64, top + ph + 6, &last, black);
    let to_px = |i: usize, v: f64| {
        (left + (pw as f64 * i as f64 / (frames - 1) as f64) as i64, top + ph - (ph as f64 * v / y_max) as i64)
    };
    for (k, (name, values)) in series.iter().enumerate() {
        let color = SERIES_COLORS[k % SERIES_COLORS.len()];
        for i in 1..values.len() {
            if values[i - 1].is_finite() && values[i].is_finite() {
                line(&mut img, to_px(i - 1, values[i - 1]), to_px(i, values[i]), color);
            }
        }
        let lx = left + 8 + k as i64 * (pw / series.len().max(1) as i64);
        let ly = i64::from(LINE_HEIGHT) + 8;
        img.fill_rect(lx, ly + 3, 12, 2, color);
        img.text(lx + 16, ly, name, black);
    }
    img
}

/// A line from `a` to `b`, two pixels thick.
fn line(img: &mut Rgb8Image, a: (i64, i64), b: (i64, i64), color: [u8; 3]) {
    let n = (b.0 - a.0).abs().max((b.1 - a.1).abs()).max(1);
    for s in 0..=n {
        let x = a.0 + (b.0 - a.0) * s / n;
        let y = a.1 + (b.1 - a.1) * s / n;
        img.put(x, y, color);
        img.put(x, y + 1, color);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn series_are_drawn_in_their_colours() {
        let a = [1.0, 2.0, 3.0];
        let b = [0.5, 0.5, 0.5];
        let img = line_plot("t", "s", &[("a", &a), ("b", &b)], 300, 200);
        let count = |c: [u8; 3]| img.pixels.chunks(3).filter(|p| *p == c).count();
        assert!(count(SERIES_COLORS[0]) > 100 && count(SERIES_COLORS[1]) > 100);
    }
}
