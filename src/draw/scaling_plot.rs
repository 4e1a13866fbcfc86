//! Log–log plots of figures against a count (load time, memory, render
//! time against the number of primitives): one panel per figure, each with
//! its series and a grey line of slope one through the first point, so a
//! figure growing linearly runs beside it and one growing faster climbs away.

use super::plot::line;
use super::rgb8_image::{LINE_HEIGHT, Rgb8Image};

/// Colours of successive series.
const SERIES_COLORS: [[u8; 3]; 4] = [[200, 60, 40], [40, 110, 200], [60, 160, 60], [150, 80, 170]];

/// One panel: its title (the figure and its unit) and its series, each a
/// name and one value per count (`NaN` where it was not measured).
pub struct Panel<'a> {
    /// The figure and its unit, such as `load (s)`.
    pub title: &'a str,
    /// Named series.
    pub series: Vec<(&'a str, Vec<f64>)>,
}

/// The panels side by side, two to a row, each `panel_size` pixels, every
/// series plotted against `counts` on logarithmic axes.
#[must_use]
pub fn scaling_plot(title: &str, counts: &[f64], panels: &[Panel], panel_size: (u32, u32)) -> Rgb8Image {
    let columns = 2u32.min(panels.len().max(1) as u32);
    let rows = (panels.len() as u32).div_ceil(columns).max(1);
    let top = 2 * LINE_HEIGHT + 8;
    let mut img = Rgb8Image::filled(columns * panel_size.0, top + rows * panel_size.1, [255, 255, 255]);
    img.text(8, 6, title, [0, 0, 0]);
    for (k, panel) in panels.iter().enumerate() {
        let (col, row) = (k as u32 % columns, k as u32 / columns);
        let origin = (i64::from(col * panel_size.0), i64::from(top + row * panel_size.1));
        draw_panel(&mut img, origin, panel_size, counts, panel);
    }
    img
}

/// Decades `lo..=hi` (log10) holding every positive finite value.
fn decades(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let positive: Vec<f64> = values.filter(|v| v.is_finite() && *v > 0.0).collect();
    let lo = positive.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = positive.iter().copied().fold(0.0f64, f64::max);
    (!positive.is_empty()).then(|| (lo.log10().floor(), hi.log10().ceil().max(lo.log10().floor() + 1.0)))
}

fn draw_panel(img: &mut Rgb8Image, (ox, oy): (i64, i64), (w, h): (u32, u32), counts: &[f64], panel: &Panel) {
    let black = [0, 0, 0];
    let (left, right, top, bottom) = (56i64, 16i64, 2 * i64::from(LINE_HEIGHT) + 10, 2 * i64::from(LINE_HEIGHT) + 8);
    let (pw, ph) = (i64::from(w) - left - right, i64::from(h) - top - bottom);
    let (x0, y0) = (ox + left, oy + top);
    img.text(x0, oy + 4, panel.title, black);
    let (Some((xlo, xhi)), Some((ylo, yhi))) =
        (decades(counts.iter().copied()), decades(panel.series.iter().flat_map(|(_, v)| v.iter().copied())))
    else {
        img.text(x0, y0 + ph / 2, "nothing measured", black);
        return;
    };
    let to_px = |n: f64, v: f64| {
        let fx = (n.log10() - xlo) / (xhi - xlo);
        let fy = ((v.log10() - ylo) / (yhi - ylo)).clamp(0.0, 1.0);
        (x0 + (pw as f64 * fx) as i64, y0 + ph - (ph as f64 * fy) as i64)
    };
    for k in 0..=(yhi - ylo) as i32 {
        let y = y0 + ph - ph * i64::from(k) / (yhi - ylo) as i64;
        (0..pw).step_by(4).for_each(|x| img.put(x0 + x, y, [210, 210, 210]));
        img.text(ox + 4, y - 4, &format!("1e{}", ylo as i32 + k), black);
    }
    for k in 0..=(xhi - xlo) as i32 {
        let x = x0 + pw * i64::from(k) / (xhi - xlo) as i64;
        (0..ph).step_by(4).for_each(|y| img.put(x, y0 + y, [210, 210, 210]));
        img.text(x - 12, y0 + ph + 6, &format!("1e{}", xlo as i32 + k), black);
    }
    for (x, y) in (0..=pw).map(|x| (x0 + x, y0 + ph)).chain((0..=ph).map(|y| (x0, y0 + y))) {
        img.put(x, y, black);
    }
    // Slope one through each series' first point: linear growth.
    for (_, values) in &panel.series {
        if let Some((n, v)) = counts.iter().zip(values).find(|(_, v)| v.is_finite() && **v > 0.0) {
            let last = counts.last().copied().unwrap_or(*n);
            let (a, b) = (to_px(*n, *v), to_px(last, v * last / n));
            dashed(img, a, b, [160, 160, 160]);
        }
    }
    for (k, (name, values)) in panel.series.iter().enumerate() {
        let color = SERIES_COLORS[k % SERIES_COLORS.len()];
        let points: Vec<(i64, i64)> =
            counts.iter().zip(values).filter(|(_, v)| v.is_finite() && **v > 0.0).map(|(n, v)| to_px(*n, *v)).collect();
        points.windows(2).for_each(|p| line(img, p[0], p[1], color));
        points.iter().for_each(|&(x, y)| img.fill_rect(x - 2, y - 2, 5, 5, color));
        let lx = x0 + 8 + k as i64 * 90;
        img.fill_rect(lx, oy + 4 + i64::from(LINE_HEIGHT) + 6, 12, 2, color);
        img.text(lx + 16, oy + 4 + i64::from(LINE_HEIGHT) + 2, name, black);
    }
    let (lx, ly) = (x0 + 8 + panel.series.len() as i64 * 90, oy + 4 + i64::from(LINE_HEIGHT) + 2);
    dashed(img, (lx, ly + 4), (lx + 12, ly + 4), [160, 160, 160]);
    img.text(lx + 16, ly, "linear", black);
}

/// A dashed line from `a` to `b`.
fn dashed(img: &mut Rgb8Image, a: (i64, i64), b: (i64, i64), color: [u8; 3]) {
    let n = (b.0 - a.0).abs().max((b.1 - a.1).abs()).max(1);
    for s in (0..=n).filter(|s| s % 8 < 5) {
        img.put(a.0 + (b.0 - a.0) * s / n, a.1 + (b.1 - a.1) * s / n, color);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_linear_series_runs_along_the_slope_one_line_and_a_faster_one_climbs_above_it() {
        let counts = [1e3, 1e4, 1e5, 1e6];
        let linear = vec![0.01, 0.1, 1.0, 10.0];
        let square = vec![0.01, 1.0, 100.0, 10_000.0];
        let panels = [Panel { title: "load (s)", series: vec![("linear", linear), ("square", square)] }];
        let img = scaling_plot("t", &counts, &panels, (400, 300));
        let rows_of = |c: [u8; 3], x: u32| {
            (0..img.height).filter(|&y| img.pixels[3 * (y * img.width + x) as usize..][..3] == c).collect::<Vec<_>>()
        };
        // At the right end the square series is far above (lower row) the linear one.
        let x = img.width - 16 - 3;
        let (a, b) = (rows_of(SERIES_COLORS[0], x), rows_of(SERIES_COLORS[1], x));
        assert!(!a.is_empty() && !b.is_empty());
        assert!(b[0] + 60 < a[0], "square at row {}, linear at row {}", b[0], a[0]);
        assert!(decades([0.5, 30.0].into_iter()) == Some((-1.0, 2.0)));
    }
}
