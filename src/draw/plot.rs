//! Line plots of per-frame timings (the caching paper's Figure 8), drawn
//! directly on an RGB image with labelled axes and a legend.

use super::rgb8_image::{LINE_HEIGHT, Rgb8Image};

/// Colours of successive series.
const SERIES_COLORS: [[u8; 3]; 4] = [[200, 60, 40], [40, 110, 200], [60, 160, 60], [150, 80, 170]];

/// Ratio of the largest value to the smallest positive one past which the
/// y axis is logarithmic: on a linear one the faster series would lie flat
/// on the axis (cached local updates against naive frames from scratch).
const LOG_AXIS_SPREAD: f64 = 30.0;

/// How values map to heights.
#[derive(Clone, Copy, Debug)]
pub(super) enum Axis {
    /// From 0 to the maximum.
    Linear { max: f64 },
    /// From one power of ten to another (`log10` of each end).
    Log { lo: f64, hi: f64 },
}

impl Axis {
    /// The axis for `values`: logarithmic when they spread over more than
    /// [`LOG_AXIS_SPREAD`].
    pub(super) fn fitting(values: impl Iterator<Item = f64> + Clone) -> Self {
        let finite = values.filter(|v| v.is_finite());
        let max = finite.clone().fold(0.0f64, f64::max);
        let min_positive = finite.filter(|&v| v > 0.0).fold(f64::INFINITY, f64::min);
        if max > 0.0 && max / min_positive > LOG_AXIS_SPREAD {
            Axis::Log { lo: min_positive.log10().floor(), hi: max.log10().ceil() }
        } else {
            Axis::Linear { max: if max > 0.0 { max * 1.05 } else { 1.0 } }
        }
    }

    /// Where `v` lies from the bottom (0) to the top (1); values below a
    /// logarithmic axis sit on its bottom.
    pub(super) fn fraction(self, v: f64) -> f64 {
        match self {
            Axis::Linear { max } => v / max,
            Axis::Log { lo, hi } => ((v.max(10f64.powf(lo)).log10() - lo) / (hi - lo)).clamp(0.0, 1.0),
        }
    }

    /// The ticks: each with its fraction of the height and its label.
    pub(super) fn ticks(self) -> Vec<(f64, String)> {
        match self {
            Axis::Linear { max } => {
                (0..=4).map(|k| (f64::from(k) / 4.0, format!("{:.3}", max * f64::from(k) / 4.0))).collect()
            }
            Axis::Log { lo, hi } => {
                let decades = (hi - lo).round() as i32;
                // Every decade, or every other one past eight.
                let step = if decades > 8 { 2 } else { 1 };
                (0..=decades)
                    .step_by(step)
                    .map(|k| (f64::from(k) / f64::from(decades), format!("1e{}", lo as i32 + k)))
                    .collect()
            }
        }
    }
}

/// Plots `series` (name, one value per frame) against the frame number,
/// titled `title`, y values in `unit`: on a y axis from 0 to the largest
/// value, or logarithmic over whole decades when the values spread over more
/// than `LOG_AXIS_SPREAD`.
#[must_use]
pub fn line_plot(title: &str, unit: &str, series: &[(&str, &[f64])], width: u32, height: u32) -> Rgb8Image {
    let mut img = Rgb8Image::filled(width, height, [255, 255, 255]);
    let (left, right, top, bottom) = (64i64, 16i64, 2 * i64::from(LINE_HEIGHT) + 12, 3 * i64::from(LINE_HEIGHT));
    let (pw, ph) = (i64::from(width) - left - right, i64::from(height) - top - bottom);
    let frames = series.iter().map(|(_, v)| v.len()).max().unwrap_or(0).max(2);
    let axis = Axis::fitting(series.iter().flat_map(|(_, v)| v.iter().copied()));
    let black = [0, 0, 0];
    let scale = if matches!(axis, Axis::Log { .. }) { ", log scale" } else { "" };
    img.text(left, 4, &format!("{title}{scale}"), black);
    // Axes, ticks and labels.
    for x in 0..=pw {
        img.put(left + x, top + ph, black);
    }
    for y in 0..=ph {
        img.put(left, top + y, black);
    }
    for (fraction, label) in axis.ticks() {
        let y = top + ph - (ph as f64 * fraction) as i64;
        for x in 0..pw {
            if x % 4 == 0 {
                img.put(left + x, y, [210, 210, 210]);
            }
        }
        img.text(2, y - 4, &label, black);
    }
    img.text(2, top - i64::from(LINE_HEIGHT) - 4, unit, black);
    img.text(left + pw / 2 - 20, top + ph + 6, "frame", black);
    img.text(left, top + ph + 6, "0", black);
    let last = format!("{}", frames - 1);
    img.text(left + pw - 8 * last.len() as i64, top + ph + 6, &last, black);
    let to_px = |i: usize, v: f64| {
        (left + (pw as f64 * i as f64 / (frames - 1) as f64) as i64, top + ph - (ph as f64 * axis.fraction(v)) as i64)
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
pub(super) fn line(img: &mut Rgb8Image, a: (i64, i64), b: (i64, i64), color: [u8; 3]) {
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

    #[test]
    fn series_a_thousand_times_apart_are_both_drawn_clear_of_the_axis() {
        let (slow, fast) = ([2.0, 3.0, 2.5, 2.8], [0.002, 0.003, 0.0025, 0.004]);
        let (width, height) = (300, 200);
        for (a, b, log) in [(&slow, &fast, true), (&slow, &[1.0, 1.5, 1.2, 1.1], false)] {
            let img = line_plot("t", "s", &[("slow", a), ("fast", b)], width, height);
            // The lowest row the second series is drawn in, from the top.
            let rows = (0..height as usize).filter(|&y| {
                (0..width as usize).any(|x| img.pixels[3 * (y * width as usize + x)..][..3] == SERIES_COLORS[1])
            });
            let lowest = rows.max().expect("the second series is drawn");
            let axis_row = height as usize - 3 * LINE_HEIGHT as usize;
            // On a linear axis the faster series would lie within a row of it.
            assert!(
                axis_row - lowest > 8,
                "log {log}: the faster series lies {} rows above the axis",
                axis_row - lowest
            );
            assert_eq!(matches!(Axis::fitting(a.iter().chain(b).copied()), Axis::Log { .. }), log);
        }
        let ticks = Axis::Log { lo: -3.0, hi: 1.0 }.ticks();
        assert_eq!(ticks.iter().map(|t| t.1.as_str()).collect::<Vec<_>>(), ["1e-3", "1e-2", "1e-1", "1e0", "1e1"]);
    }
}
