//! idiff's comparison, channel by channel: every value of every pixel is
//! compared (`|a − b|`, the subtraction in `f32`, sums in `f64` in batches of
//! 4,096 pixels as OpenImageIO sums them), so mean, RMS, PSNR, maximum and the
//! counts over `fail` and `warn` equal `idiff`'s on the same files. Images with
//! different channel counts are compared channel by channel in order, a
//! missing channel reading 0, as idiff does.
//!
//! Non-finite values are handled explicitly: equal kinds (both infinite, as
//! two renders' misses in `Z`, or both NaN) agree; a value finite in one image
//! only is a coverage mismatch — the pixel fails and warns, is counted in
//! `mismatch_px`, and stays out of the sums so the mean never becomes
//! infinite or NaN (idiff's would).

use super::channels::ChannelImage;
use super::diff::{DiffReport, MaxAt, Metric, Totals, report};
use super::idiff_stats::IdiffAccumulator;
use super::thresholds::Thresholds;

/// OpenImageIO sums differences in batches of this many pixels.
const BATCH: usize = 4096;

/// Compares `a` and `b` (same size) over every channel, leaving out pixels
/// where `masked` is set; returns the report and every pixel's largest
/// difference over its channels (infinite for a mismatch), masked or not.
/// Percentages are of the judged pixels, or of `percent_base` pixels when
/// given (idiff's: the first image's, when the images differ in size); the
/// report carries idiff's own figures too, over every pixel, masked or not.
#[must_use]
pub fn compare_channels(
    a: &ChannelImage,
    b: &ChannelImage,
    masked: &[bool],
    t: Thresholds,
    percent_base: Option<usize>,
) -> (DiffReport, Vec<f32>) {
    let nch = a.names.len().max(b.names.len());
    let value = |img: &ChannelImage, c: usize, i: usize| img.planes.get(c).map_or(0.0, |p| p[i]);
    let mut totals = Totals { peak: 1.0, percent_base, ..Totals::default() };
    let mut idiff = IdiffAccumulator::new(t);
    let mut per_pixel = Vec::with_capacity(masked.len());
    for start in (0..masked.len()).step_by(BATCH) {
        let (mut batch_sum, mut batch_sq) = (0.0, 0.0);
        for (i, &is_masked) in masked.iter().enumerate().skip(start).take(BATCH) {
            let mut pixel = PixelState::default();
            let (x, y) = (i as u32 % a.width, i as u32 / a.width);
            idiff.start_pixel();
            for c in 0..nch {
                pixel.add(value(a, c, i), value(b, c, i), c, t);
                idiff.add(value(a, c, i), value(b, c, i), (x, y, c));
            }
            per_pixel.push(if pixel.mismatch { f32::INFINITY } else { pixel.max as f32 });
            if is_masked {
                totals.masked_px += 1;
                totals.masked_over_fail_px += usize::from(pixel.failed);
                continue;
            }
            batch_sum += pixel.sum;
            batch_sq += pixel.sum_sq;
            totals.compared += 1;
            totals.values += nch;
            totals.peak = totals.peak.max(pixel.peak);
            totals.over_fail_px += usize::from(pixel.failed);
            totals.over_warn_px += usize::from(pixel.warned);
            totals.mismatch_px += usize::from(pixel.mismatch);
            if let Some(c) = pixel.max_channel.filter(|_| pixel.max > totals.max) {
                totals.max = pixel.max;
                totals.max_at = Some(max_at(a, b, i, c));
            }
        }
        totals.sum += batch_sum;
        totals.sum_sq += batch_sq;
        idiff.end_batch();
    }
    let names = (0..nch).map(|c| channel_name(a, b, c)).collect();
    let magnitudes = per_pixel.iter().zip(masked).filter(|(_, m)| !**m).map(|(&v, _)| v).collect();
    let mut r = report(Metric::Abs, names, masked.len(), magnitudes, totals, t);
    let mut stats = idiff.finish(percent_base.unwrap_or(masked.len()));
    let at = max_at(a, b, (stats.max_y * a.width + stats.max_x) as usize, stats.max_channel);
    (stats.channel, stats.a, stats.b) = (at.channel, at.a, at.b);
    r.idiff = Some(stats);
    (r, per_pixel)
}

/// One pixel's differences over its channels.
#[derive(Default)]
struct PixelState {
    sum: f64,
    sum_sq: f64,
    max: f64,
    max_channel: Option<usize>,
    peak: f32,
    failed: bool,
    warned: bool,
    mismatch: bool,
}

impl PixelState {
    fn add(&mut self, a: f32, b: f32, c: usize, t: Thresholds) {
        if !a.is_finite() || !b.is_finite() {
            let agree = a.is_nan() == b.is_nan() && a.is_infinite() == b.is_infinite();
            self.mismatch |= !agree;
            self.failed |= !agree;
            self.warned |= !agree;
            return;
        }
        let (abs_a, abs_b) = (a.abs(), b.abs());
        let mean_magnitude = abs_a * 0.5 + abs_b * 0.5;
        self.peak = self.peak.max(abs_a.max(abs_b));
        let f = f64::from((a - b).abs());
        self.sum += f;
        self.sum_sq += f * f;
        if f > self.max {
            self.max = f;
            self.max_channel = Some(c);
        }
        self.failed |= Thresholds::exceeds(t.fail, t.failrelative, f, mean_magnitude);
        self.warned |= Thresholds::exceeds(t.warn, t.warnrelative, f, mean_magnitude);
    }
}

fn max_at(a: &ChannelImage, b: &ChannelImage, i: usize, c: usize) -> MaxAt {
    let values = |img: &ChannelImage| img.planes.iter().map(|p| p[i]).collect();
    let (x, y) = (i as u32 % a.width, i as u32 / a.width);
    MaxAt { x, y, channel: channel_name(a, b, c), a: values(a), b: values(b) }
}

fn channel_name(a: &ChannelImage, b: &ChannelImage, c: usize) -> String {
    a.names.get(c).or_else(|| b.names.get(c)).cloned().unwrap_or_else(|| format!("channel {c}"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compare::Verdict;

    fn image(names: &[&str], planes: Vec<Vec<f32>>) -> ChannelImage {
        let width = planes[0].len() as u32;
        ChannelImage { width, height: 1, names: names.iter().map(ToString::to_string).collect(), planes }
    }

    #[test]
    fn statistics_are_per_channel_and_a_missing_channel_reads_zero() {
        let a = image(&["R", "A"], vec![vec![0.5, 0.25], vec![1.0, 1.0]]);
        let b = image(&["R"], vec![vec![0.5, 0.75]]);
        let (r, _) = compare_channels(&a, &b, &[false, false], Thresholds::default(), None);
        // Values: R 0, 0.5; A 1, 1 → mean 2.5/4, rms sqrt(2.25/4).
        assert!((r.mean - 0.625).abs() < 1e-12 && (r.rms - 0.75).abs() < 1e-12, "{r:?}");
        let at = r.max_at.unwrap();
        assert_eq!((at.x, at.channel.as_str(), r.max), (0, "A", 1.0));
        assert_eq!((r.over_fail_px, r.verdict), (2, Verdict::Fail));
    }

    #[test]
    fn equal_infinities_agree_and_a_one_sided_one_is_a_mismatch() {
        let inf = f32::INFINITY;
        let a = image(&["Z"], vec![vec![inf, inf, 1.0, 2.0]]);
        let b = image(&["Z"], vec![vec![inf, 3.0, 1.0, 2.5]]);
        let (r, per_pixel) =
            compare_channels(&a, &b, &[false; 4], Thresholds { fail: 0.6, warn: 0.6, ..Default::default() }, None);
        assert_eq!(per_pixel, [0.0, f32::INFINITY, 0.0, 0.5]);
        assert_eq!((r.mismatch_px, r.over_fail_px, r.max), (1, 1, 0.5));
        assert!((r.mean - 0.125).abs() < 1e-12, "mean stays finite: {}", r.mean);
        assert_eq!(r.verdict, Verdict::Fail);
        let allowed = Thresholds { fail: 0.6, warn: 0.6, allowfailures: 1, ..Default::default() };
        assert_eq!(compare_channels(&a, &b, &[false; 4], allowed, None).0.verdict, Verdict::Pass);
    }
}
