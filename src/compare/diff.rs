//! Image differences judged the way OpenImageIO's `idiff` judges them: an
//! image fails when more than `failpercent`% of its pixels differ by more than
//! `fail`, or any pixel by more than `hardfail`; it warns likewise with `warn`
//! and `warnpercent`. Pixels near silhouette edges can be set aside, since a
//! sub-pixel shift of an edge changes them completely without anything being
//! wrong; they are reported separately.

use super::flip::FlipStats;
use super::idiff_stats::IdiffStats;
use super::thresholds::Thresholds;
use crate::frame::Frame;

/// What is compared per pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Metric {
    /// Absolute difference per channel, as idiff compares (per pixel: the
    /// largest over the channels).
    #[default]
    Abs,
    /// Angle between the normals, in degrees (both images need `N.X,N.Y,N.Z`).
    Normal,
    /// Depth of the first minus depth of the second (both need `Z`); signed.
    Depth,
    /// The ꟻLIP perceptual error (LDR, or HDR for two EXRs) of the second image against the first
    /// (the reference), in `[0, 1]`.
    Flip,
}

impl Metric {
    /// The unit printed on heat maps.
    #[must_use]
    pub fn unit(self) -> &'static str {
        match self {
            Metric::Abs | Metric::Flip => "",
            Metric::Normal => "deg",
            Metric::Depth => "units",
        }
    }
}

/// Per-pixel values of `metric` between `a` and `b` (same size): `NaN` where
/// neither image has a surface (for normal and depth), `+inf` where only one
/// has. `Abs` and `Flip` give the largest linear colour difference here;
/// idiff's per-channel comparison is [`super::compare_channels`], and ꟻLIP,
/// which filters whole images, is [`super::flip_errors`].
#[must_use]
pub fn differences(a: &Frame, b: &Frame, metric: Metric) -> Vec<f32> {
    (0..a.len()).map(|i| difference_at(a, b, i, metric)).collect()
}

/// The value of `metric` between `a` and `b` at pixel `i` (see [`differences`]).
#[must_use]
pub fn difference_at(a: &Frame, b: &Frame, i: usize, metric: Metric) -> f32 {
    match metric {
        Metric::Abs | Metric::Flip => (a.color[i] - b.color[i]).abs().max_element(),
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

/// Where the largest difference is, and both images' values there.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MaxAt {
    /// Column.
    pub x: u32,
    /// Row.
    pub y: u32,
    /// The channel (for the depth and normal metrics, the metric's name).
    pub channel: String,
    /// The first image's values at that pixel, every channel.
    pub a: Vec<f32>,
    /// The second image's values there.
    pub b: Vec<f32>,
}

/// The sums a judgement is made from, before percentiles and verdict.
#[derive(Clone, Debug, Default)]
pub struct Totals {
    /// Pixels judged.
    pub compared: usize,
    /// Values the mean and RMS divide by: every channel of every judged
    /// pixel (idiff's), or for depth and normals the pixels both images hit.
    pub values: usize,
    /// Sum of the finite differences.
    pub sum: f64,
    /// Sum of their squares.
    pub sum_sq: f64,
    /// Largest finite difference.
    pub max: f64,
    /// Its location.
    pub max_at: Option<MaxAt>,
    /// Largest magnitude of any value compared, at least 1 (PSNR's peak).
    pub peak: f32,
    /// Pixels above the fail test.
    pub over_fail_px: usize,
    /// Pixels above the warn test.
    pub over_warn_px: usize,
    /// Pixels finite in one image and not in the other (a coverage mismatch).
    pub mismatch_px: usize,
    /// Pixels set aside near edges.
    pub masked_px: usize,
    /// Masked pixels above `fail`.
    pub masked_over_fail_px: usize,
    /// Pixels the percentages (and `failpercent`, `warnpercent`) are of, when
    /// not the judged pixels: idiff's, the first image's, when sizes differ.
    pub percent_base: Option<usize>,
}

/// Statistics of a difference image and the verdict.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct DiffReport {
    /// The metric.
    pub metric: Metric,
    /// The channels compared (the `abs` metric).
    pub channels: Vec<String>,
    /// Pixels in each image.
    pub pixels: usize,
    /// Pixels judged (with a value, not masked).
    pub compared: usize,
    /// Pixels set aside near silhouette edges.
    pub masked_px: usize,
    /// Of the masked pixels, those above `fail`.
    pub masked_over_fail_px: usize,
    /// Pixels with a non-finite value in one image only (for depth and
    /// normals: hit in one image only). They fail and warn, and are left out
    /// of the sums, so the mean stays finite.
    pub mismatch_px: usize,
    /// idiff's mean error: the sum of the finite differences over every
    /// judged value (pixels × channels; for depth and normals, over the pixels
    /// both images hit).
    pub mean: f64,
    /// Root mean square over the same values.
    pub rms: f64,
    /// Peak signal-to-noise ratio in dB, `20·log10(peak / rms)` with the peak
    /// the largest magnitude seen, at least 1 (idiff's); `None` when the rms is 0.
    pub psnr: Option<f64>,
    /// Median of the per-pixel magnitudes (the largest over a pixel's
    /// channels; mismatches count as infinite).
    pub median: f32,
    /// 95th percentile.
    pub p95: f32,
    /// 99th percentile.
    pub p99: f32,
    /// Largest finite difference.
    pub max: f32,
    /// Where it is.
    pub max_at: Option<MaxAt>,
    /// Judged pixels above `fail`.
    pub over_fail_px: usize,
    /// The same as a percentage of judged pixels.
    pub over_fail_percent: f64,
    /// Judged pixels above `warn`.
    pub over_warn_px: usize,
    /// The same as a percentage.
    pub over_warn_percent: f64,
    /// The thresholds used.
    pub thresholds: Thresholds,
    /// Pass, warn or fail.
    pub verdict: Verdict,
    /// ꟻLIP's own pooled statistics (the `flip` metric).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flip: Option<FlipStats>,
    /// idiff's own figures, non-finite values included (the `abs` metric).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub idiff: Option<IdiffStats>,
    /// The two images' sizes, when they differ (the `abs` metric compares
    /// them over the larger extent, as idiff does).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sizes: Option<[(u32, u32); 2]>,
}

/// Judges the per-pixel `values` (see [`differences`]) of a `width`-wide
/// image against `t`, leaving out pixels where `masked` is set.
#[must_use]
pub fn judge(metric: Metric, values: &[f32], masked: &[bool], width: u32, t: Thresholds) -> DiffReport {
    let mut totals = Totals { peak: 1.0, ..Totals::default() };
    let mut magnitudes = vec![];
    for (i, (&v, &m)) in values.iter().zip(masked).enumerate() {
        if v.is_nan() {
            continue;
        }
        let f = f64::from(v.abs());
        if m {
            totals.masked_px += 1;
            totals.masked_over_fail_px += usize::from(f > f64::from(t.fail));
            continue;
        }
        magnitudes.push(v.abs());
        totals.compared += 1;
        if v.is_infinite() {
            totals.mismatch_px += 1;
            totals.over_fail_px += 1;
            totals.over_warn_px += 1;
            continue;
        }
        totals.values += 1;
        totals.sum += f;
        totals.sum_sq += f * f;
        totals.peak = totals.peak.max(v.abs());
        if f > totals.max {
            totals.max = f;
            let (x, y) = (i as u32 % width, i as u32 / width);
            totals.max_at = Some(MaxAt { x, y, channel: format!("{metric:?}").to_lowercase(), a: vec![], b: vec![] });
        }
        totals.over_fail_px += usize::from(f > f64::from(t.fail));
        totals.over_warn_px += usize::from(f > f64::from(t.warn));
    }
    report(metric, vec![], values.len(), magnitudes, totals, t)
}

/// The report from the sums and the per-pixel `magnitudes` of judged pixels.
#[must_use]
pub fn report(
    metric: Metric,
    channels: Vec<String>,
    pixels: usize,
    mut magnitudes: Vec<f32>,
    totals: Totals,
    t: Thresholds,
) -> DiffReport {
    magnitudes.sort_by(f32::total_cmp);
    let n = magnitudes.len();
    let percentile = |p: usize| if n == 0 { 0.0 } else { magnitudes[((n - 1) * p) / 100] };
    let base = totals.percent_base.unwrap_or(totals.compared).max(1);
    let percent = |k: usize| 100.0 * k as f64 / base as f64;
    let values = totals.values.max(1) as f64;
    let rms = (totals.sum_sq / values).sqrt();
    DiffReport {
        metric,
        channels,
        pixels,
        compared: totals.compared,
        masked_px: totals.masked_px,
        masked_over_fail_px: totals.masked_over_fail_px,
        mismatch_px: totals.mismatch_px,
        mean: totals.sum / values,
        rms,
        psnr: (rms > 0.0).then(|| 20.0 * (f64::from(totals.peak) / rms).log10()),
        median: percentile(50),
        p95: percentile(95),
        p99: percentile(99),
        max: totals.max as f32,
        over_fail_px: totals.over_fail_px,
        over_fail_percent: percent(totals.over_fail_px),
        over_warn_px: totals.over_warn_px,
        over_warn_percent: percent(totals.over_warn_px),
        verdict: verdict(&totals, t),
        max_at: totals.max_at,
        thresholds: t,
        flip: None,
        idiff: None,
        sizes: None,
    }
}

/// idiff's verdict: within `allowfailures` failed pixels (0 by default)
/// passes outright, so, as in idiff, a warning needs failures that
/// `failpercent` tolerates; then fail on too many failed pixels or one above
/// `hardfail`; then warn likewise. A coverage mismatch counts as an infinite
/// difference.
fn verdict(totals: &Totals, t: Thresholds) -> Verdict {
    let base = totals.percent_base.unwrap_or(totals.compared);
    let allowed = |percent: f64| percent / 100.0 * base as f64;
    let max = if totals.mismatch_px > 0 { f64::INFINITY } else { totals.max };
    if totals.over_fail_px <= t.allowfailures {
        Verdict::Pass
    } else if totals.over_fail_px as f64 > allowed(t.failpercent) || max > f64::from(t.hardfail) {
        Verdict::Fail
    } else if totals.over_warn_px as f64 > allowed(t.warnpercent) || max > f64::from(t.hardwarn) {
        Verdict::Warn
    } else {
        Verdict::Pass
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
        assert_eq!(judge(Metric::Abs, &d, &none, 100, Thresholds::default()).verdict, Verdict::Fail);
        let lenient = Thresholds { fail: 0.1, failpercent: 5.0, ..Default::default() };
        let r = judge(Metric::Abs, &d, &none, 100, lenient);
        assert_eq!((r.verdict, r.over_fail_px), (Verdict::Warn, 3));
        let pass = Thresholds { warn: 0.3, ..lenient };
        assert_eq!(judge(Metric::Abs, &d, &none, 100, pass).verdict, Verdict::Pass);
        let hard = Thresholds { hardfail: 0.15, ..pass };
        assert_eq!(judge(Metric::Abs, &d, &none, 100, hard).verdict, Verdict::Fail);
        let allowed = Thresholds { allowfailures: 3, ..hard };
        assert_eq!(judge(Metric::Abs, &d, &none, 100, allowed).verdict, Verdict::Pass);
        assert_eq!(judge(Metric::Abs, &d, &none, 100, Thresholds { allowfailures: 2, ..hard }).verdict, Verdict::Fail);
        assert_eq!(
            judge(Metric::Abs, &differences(&a, &a, Metric::Abs), &none, 100, Thresholds::default()).verdict,
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
        let t = Thresholds { fail: 1.0, warn: 1.0, ..Default::default() };
        // The one-sided hit sits near the edge: set aside, it is reported but does not fail.
        let r = judge(Metric::Depth, &d, &mask, 8, t);
        assert_eq!((r.mismatch_px, r.masked_over_fail_px, r.verdict), (0, 1, Verdict::Pass));
        let r = judge(Metric::Depth, &d, &[false; 8], 8, t);
        assert_eq!((r.mismatch_px, r.over_fail_px, r.verdict), (1, 1, Verdict::Fail));
        assert_eq!((r.max, r.mean, r.max_at.map(|m| m.x)), (0.5, 0.5, Some(0)));
    }
}
