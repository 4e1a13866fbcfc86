//! Image differences judged the way OpenImageIO's `idiff` judges them: an
//! image fails when more than `failpercent`% of its pixels differ by more than
//! `fail`, or any pixel by more than `hardfail`; it warns likewise with `warn`
//! and `warnpercent`. Pixels near silhouette edges can be set aside, since a
//! sub-pixel shift of an edge changes them completely without anything being
//! wrong; they are reported separately.

use crate::frame::Frame;

/// What is compared per pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Metric {
    /// Largest absolute difference of the linear R, G, B values.
    #[default]
    Abs,
    /// Largest difference of R, G, B relative to the larger of the two values.
    Rel,
    /// Angle between the normals, in degrees (both images need `N.X,N.Y,N.Z`).
    Normal,
    /// Depth of the first minus depth of the second (both need `Z`); signed.
    Depth,
}

impl Metric {
    /// The unit printed on heat maps.
    #[must_use]
    pub fn unit(self) -> &'static str {
        match self {
            Metric::Abs | Metric::Rel => "",
            Metric::Normal => "deg",
            Metric::Depth => "units",
        }
    }
}

/// Per-pixel values of `metric` between `a` and `b` (same size): `NaN` where
/// neither image has a surface (for normal and depth), `+inf` where only one has.
#[must_use]
pub fn differences(a: &Frame, b: &Frame, metric: Metric) -> Vec<f32> {
    (0..a.len()).map(|i| difference_at(a, b, i, metric)).collect()
}

/// The value of `metric` between `a` and `b` at pixel `i` (see [`differences`]).
#[must_use]
pub fn difference_at(a: &Frame, b: &Frame, i: usize, metric: Metric) -> f32 {
    match metric {
        Metric::Abs => (a.color[i] - b.color[i]).abs().max_element(),
        Metric::Rel => {
            let d = (a.color[i] - b.color[i]).abs();
            let m = a.color[i].abs().max(b.color[i].abs()).max(glam::Vec3::splat(1e-3));
            (d / m).max_element()
        }
        Metric::Normal | Metric::Depth => match (a.depth[i].is_finite(), b.depth[i].is_finite()) {
            (false, false) => f32::NAN,
            (true, true) if metric == Metric::Depth => a.depth[i] - b.depth[i],
            (true, true) => a.normal[i].dot(b.normal[i]).clamp(-1.0, 1.0).acos().to_degrees(),
            _ => f32::INFINITY,
        },
    }
}

/// Pixels within `k` pixels (Chebyshev distance) of a silhouette edge of
/// either image: a pixel whose coverage differs from a 4-neighbour's.
#[must_use]
pub fn edge_mask(a: &Frame, b: &Frame, k: u32) -> Vec<bool> {
    let (w, h) = (a.width as i64, a.height as i64);
    let covered = |f: &Frame, x: i64, y: i64| f.alpha[(y * w + x) as usize] > 0.5;
    let on_edge = |x: i64, y: i64| {
        [(1, 0), (-1, 0), (0, 1), (0, -1)].iter().any(|&(dx, dy)| {
            let (nx, ny) = (x + dx, y + dy);
            (0..w).contains(&nx)
                && (0..h).contains(&ny)
                && [a, b].iter().any(|f| covered(f, x, y) != covered(f, nx, ny))
        })
    };
    let mut mask = vec![false; a.len()];
    let k = i64::from(k);
    for y in 0..h {
        for x in 0..w {
            if on_edge(x, y) {
                for yy in (y - k).max(0)..=(y + k).min(h - 1) {
                    for xx in (x - k).max(0)..=(x + k).min(w - 1) {
                        mask[(yy * w + xx) as usize] = true;
                    }
                }
            }
        }
    }
    mask
}

/// Thresholds of a judgement (idiff's defaults: any difference above 1e-6 fails).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Thresholds {
    /// A pixel differing by more than this counts against `failpercent`.
    pub fail: f32,
    /// Percentage of pixels allowed above `fail`.
    pub failpercent: f64,
    /// Any pixel above this fails the image.
    pub hardfail: f32,
    /// A pixel differing by more than this counts against `warnpercent`.
    pub warn: f32,
    /// Percentage of pixels allowed above `warn` before a warning.
    pub warnpercent: f64,
}

impl Default for Thresholds {
    fn default() -> Self {
        Self { fail: 1e-6, failpercent: 0.0, hardfail: f32::INFINITY, warn: 1e-6, warnpercent: 0.0 }
    }
}

/// The outcome, with idiff's exit codes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Verdict {
    /// Within every threshold (exit 0).
    Pass,
    /// Above the warning thresholds only (exit 1).
    Warn,
    /// Above a failure threshold (exit 2).
    Fail,
}

/// Statistics of a difference image and the verdict.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct DiffReport {
    /// The metric.
    pub metric: Metric,
    /// Pixels in each image.
    pub pixels: usize,
    /// Pixels judged (with a value, not masked).
    pub compared: usize,
    /// Pixels set aside near silhouette edges.
    pub masked_px: usize,
    /// Of the masked pixels, those above `fail`.
    pub masked_over_fail_px: usize,
    /// Pixels hit in one image only (normal and depth metrics).
    pub mismatch_px: usize,
    /// Mean of the finite magnitudes over judged pixels.
    pub mean: f64,
    /// Median, 95th and 99th percentiles and maximum of the magnitudes (mismatches count as infinite).
    pub median: f32,
    /// 95th percentile.
    pub p95: f32,
    /// 99th percentile.
    pub p99: f32,
    /// Largest magnitude.
    pub max: f32,
    /// Judged pixels above `fail`.
    pub over_fail_px: usize,
    /// The same as a percentage of judged pixels.
    pub over_fail_percent: f64,
    /// Judged pixels above `warn`.
    pub over_warn_px: usize,
    /// The thresholds used.
    pub thresholds: Thresholds,
    /// Pass, warn or fail.
    pub verdict: Verdict,
}

/// Judges the per-pixel `values` (see [`differences`]) against `t`, leaving
/// out pixels where `masked` is set.
#[must_use]
pub fn judge(metric: Metric, values: &[f32], masked: &[bool], t: Thresholds) -> DiffReport {
    let mut magnitudes = vec![];
    let (mut masked_px, mut masked_over_fail_px, mut mismatch_px) = (0, 0, 0);
    for (&v, &m) in values.iter().zip(masked) {
        if v.is_nan() {
            continue;
        }
        mismatch_px += usize::from(v.is_infinite());
        if m {
            masked_px += 1;
            masked_over_fail_px += usize::from(v.abs() > t.fail);
        } else {
            magnitudes.push(v.abs());
        }
    }
    magnitudes.sort_by(f32::total_cmp);
    let n = magnitudes.len();
    let percentile = |p: usize| if n == 0 { 0.0 } else { magnitudes[((n - 1) * p) / 100] };
    let finite: Vec<f32> = magnitudes.iter().copied().filter(|v| v.is_finite()).collect();
    let over_fail_px = magnitudes.iter().filter(|&&v| v > t.fail).count();
    let over_warn_px = magnitudes.iter().filter(|&&v| v > t.warn).count();
    let percent = |k: usize| 100.0 * k as f64 / n.max(1) as f64;
    let max = magnitudes.last().copied().unwrap_or(0.0);
    let verdict = if percent(over_fail_px) > t.failpercent || max > t.hardfail {
        Verdict::Fail
    } else if percent(over_warn_px) > t.warnpercent {
        Verdict::Warn
    } else {
        Verdict::Pass
    };
    DiffReport {
        metric,
        pixels: values.len(),
        compared: n,
        masked_px,
        masked_over_fail_px,
        mismatch_px,
        mean: finite.iter().map(|&v| f64::from(v)).sum::<f64>() / finite.len().max(1) as f64,
        median: percentile(50),
        p95: percentile(95),
        p99: percentile(99),
        max,
        over_fail_px,
        over_fail_percent: percent(over_fail_px),
        over_warn_px,
        thresholds: t,
        verdict,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn frame(values: &[f32]) -> Frame {
        let mut f = Frame::new(values.len() as u32, 1, Vec3::ZERO);
        for (i, &v) in values.iter().enumerate() {
            f.color[i] = Vec3::splat(v);
            f.alpha[i] = 1.0;
        }
        f
    }

    #[test]
    fn verdicts_follow_idiff() {
        let a = frame(&[0.0; 100]);
        let mut values = [0.0f32; 100];
        values[..3].fill(0.2);
        let b = frame(&values);
        let d = differences(&a, &b, Metric::Abs);
        let none = vec![false; 100];
        assert_eq!(judge(Metric::Abs, &d, &none, Thresholds::default()).verdict, Verdict::Fail);
        let lenient = Thresholds { fail: 0.1, failpercent: 5.0, ..Default::default() };
        let r = judge(Metric::Abs, &d, &none, lenient);
        assert_eq!((r.verdict, r.over_fail_px), (Verdict::Warn, 3));
        let pass = Thresholds { warn: 0.3, ..lenient };
        assert_eq!(judge(Metric::Abs, &d, &none, pass).verdict, Verdict::Pass);
        let hard = Thresholds { hardfail: 0.15, ..pass };
        assert_eq!(judge(Metric::Abs, &d, &none, hard).verdict, Verdict::Fail);
        assert_eq!(
            judge(Metric::Abs, &differences(&a, &a, Metric::Abs), &none, Thresholds::default()).verdict,
            Verdict::Pass
        );
    }

    #[test]
    fn depth_marks_one_sided_hits_and_edges_can_be_masked() {
        let mut a = Frame::new(8, 1, Vec3::ZERO);
        let mut b = a.clone();
        for i in 0..4 {
            a.depth[i] = 1.0;
            a.alpha[i] = 1.0;
        }
        for i in 0..5 {
            b.depth[i] = 1.5;
            b.alpha[i] = 1.0;
        }
        let d = differences(&a, &b, Metric::Depth);
        assert_eq!(d[0], -0.5);
        assert_eq!(d[4], f32::INFINITY);
        assert!(d[6].is_nan());
        let mask = edge_mask(&a, &b, 1);
        assert_eq!(mask, vec![false, false, true, true, true, true, true, false]);
        let r = judge(Metric::Depth, &d, &mask, Thresholds { fail: 1.0, warn: 1.0, ..Default::default() });
        assert_eq!((r.mismatch_px, r.masked_over_fail_px, r.verdict), (1, 1, Verdict::Pass));
    }
}
