//! idiff's own figures, non-finite values included, as OpenImageIO 2.4.7's
//! `ImageBufAlgo::compare` computes them (for `diff --idiff-stats`).
//!
//! Our report keeps non-finite values out of its sums (see
//! [`super::compare_channels`]); OpenImageIO does not, in a way worth
//! spelling out. Values of the same kind (both NaN, or both infinite, of
//! either sign) agree. The first mismatch found while the maximum error is
//! finite sets the maximum to infinity, names its location, and is neither
//! summed nor counted; every later mismatch is compared as numbers, so its
//! difference (infinite or NaN) enters the sums, the counts over the
//! thresholds and the peak. One mismatch therefore leaves the mean finite and
//! the pixel uncounted; two make the mean infinite (or NaN) and the PSNR NaN.

use super::thresholds::Thresholds;

/// What idiff computes and prints for a pair of images.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct IdiffStats {
    /// Mean error over every value of every pixel compared.
    #[serde(serialize_with = "number_or_word")]
    pub mean: f64,
    /// Root mean square error.
    #[serde(serialize_with = "number_or_word")]
    pub rms: f64,
    /// Peak signal-to-noise ratio, `20·log10(peak / rms)`.
    #[serde(serialize_with = "number_or_word")]
    pub psnr: f64,
    /// Largest error.
    #[serde(serialize_with = "number_or_word")]
    pub max: f64,
    /// Its column.
    pub max_x: u32,
    /// Its row.
    pub max_y: u32,
    /// Its channel index.
    pub max_channel: usize,
    /// Its channel's name (the first image's, else the second's).
    pub channel: String,
    /// The first image's values at that pixel, every channel.
    pub a: Vec<f32>,
    /// The second image's.
    pub b: Vec<f32>,
    /// Pixels counted over `warn`.
    pub nwarn: usize,
    /// Pixels counted over `fail`.
    pub nfail: usize,
    /// Pixels of the first image, which idiff's percentages are of.
    pub percent_base: usize,
}

/// Non-finite figures as the words idiff prints (`inf`, `nan`): JSON has no number for them.
fn number_or_word<S: serde::Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    match v {
        v if v.is_nan() => s.serialize_str("nan"),
        v if v.is_infinite() => s.serialize_str(if *v > 0.0 { "inf" } else { "-inf" }),
        v => s.serialize_f64(*v),
    }
}

/// OpenImageIO's running state over the values compared.
#[derive(Clone, Debug)]
pub struct IdiffAccumulator {
    thresholds: Thresholds,
    total: f64,
    total_sq: f64,
    batch: f64,
    batch_sq: f64,
    max: f64,
    max_at: (u32, u32, usize),
    peak: f32,
    nwarn: usize,
    nfail: usize,
    values: usize,
    pixel: (bool, bool),
}

impl IdiffAccumulator {
    /// A fresh state for `thresholds`.
    #[must_use]
    pub fn new(thresholds: Thresholds) -> Self {
        Self {
            thresholds,
            total: 0.0,
            total_sq: 0.0,
            batch: 0.0,
            batch_sq: 0.0,
            max: 0.0,
            max_at: (0, 0, 0),
            peak: 1.0,
            nwarn: 0,
            nfail: 0,
            values: 0,
            pixel: (false, false),
        }
    }

    /// Starts a pixel (its warned and failed flags).
    pub fn start_pixel(&mut self) {
        self.pixel = (false, false);
    }

    /// Ends a batch of pixels: OpenImageIO sums per batch, then batches.
    pub fn end_batch(&mut self) {
        self.total += self.batch;
        self.total_sq += self.batch_sq;
        (self.batch, self.batch_sq) = (0.0, 0.0);
    }

    /// Compares one value pair of channel `c` at (`x`, `y`), as `compare_value` does.
    pub fn add(&mut self, a: f32, b: f32, (x, y, c): (u32, u32, usize)) {
        self.values += 1;
        if !a.is_finite() || !b.is_finite() {
            if a.is_nan() == b.is_nan() && a.is_infinite() == b.is_infinite() {
                return;
            }
            if self.max.is_finite() {
                self.max = f64::INFINITY;
                self.max_at = (x, y, c);
                return;
            }
        }
        let (abs_a, abs_b) = (a.abs(), b.abs());
        let mean_abs = 0.5 * abs_a + 0.5 * abs_b;
        // std::max keeps the first argument unless the second is larger (a NaN never is).
        if self.peak < abs_a.max(abs_b) {
            self.peak = abs_a.max(abs_b);
        }
        let f = f64::from((a - b).abs());
        let rel = if mean_abs > 0.0 { f / f64::from(mean_abs) } else { 0.0 };
        self.batch += f;
        self.batch_sq += f * f;
        if not_at_most(f, self.max) {
            self.max = f;
            self.max_at = (x, y, c);
        }
        let t = self.thresholds;
        if !self.pixel.0 && not_at_most(f, f64::from(t.warn)) && not_at_most(rel, f64::from(t.warnrelative)) {
            self.nwarn += 1;
            self.pixel.0 = true;
        }
        if !self.pixel.1 && not_at_most(f, f64::from(t.fail)) && not_at_most(rel, f64::from(t.failrelative)) {
            self.nfail += 1;
            self.pixel.1 = true;
        }
    }

    /// The figures, with percentages of `percent_base` pixels (the first
    /// image's); the caller names the maximum's channel and values.
    #[must_use]
    pub fn finish(mut self, percent_base: usize) -> IdiffStats {
        self.end_batch();
        let values = self.values as f64;
        let rms = (self.total_sq / values).sqrt();
        IdiffStats {
            mean: self.total / values,
            rms,
            psnr: 20.0 * (f64::from(self.peak) / rms).log10(),
            max: self.max,
            max_x: self.max_at.0,
            max_y: self.max_at.1,
            max_channel: self.max_at.2,
            channel: String::new(),
            a: vec![],
            b: vec![],
            nwarn: self.nwarn,
            nfail: self.nfail,
            percent_base: percent_base.max(1),
        }
    }
}

/// OpenImageIO's `!(v <= limit)`: true for a NaN, so that a NaN difference
/// counts and becomes the maximum.
fn not_at_most(v: f64, limit: f64) -> bool {
    !matches!(v.partial_cmp(&limit), Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stats(a: &[f32], b: &[f32]) -> IdiffStats {
        let mut acc = IdiffAccumulator::new(Thresholds { fail: 0.5, warn: 0.5, ..Default::default() });
        for (x, (&va, &vb)) in a.iter().zip(b).enumerate() {
            acc.start_pixel();
            acc.add(va, vb, (x as u32, 0, 0));
        }
        acc.finish(a.len())
    }

    // Each case's figures are what OpenImageIO 2.4.7's Python bindings return.
    #[test]
    fn the_first_mismatch_is_only_the_maximum_and_later_ones_are_summed() {
        let inf = f32::INFINITY;
        let one = stats(&[1.0, 9.0, inf, 3.0], &[1.0, 2.0, 3.0, 3.0]);
        assert_eq!((one.mean, one.rms, one.max, one.max_x, one.nfail), (1.75, 3.5, f64::INFINITY, 2, 1));
        assert!((one.psnr - 8.203_489_301_780_987).abs() < 1e-12);
        let two = stats(&[1.0, inf, inf, 9.0], &[1.0, 2.0, 3.0, 3.0]);
        assert_eq!((two.mean, two.rms, two.max_x, two.nfail, two.nwarn), (f64::INFINITY, f64::INFINITY, 1, 2, 2));
        assert!(two.psnr.is_nan());
        let same_kind = stats(&[1.0, inf, f32::NAN], &[1.0, -inf, f32::NAN]);
        assert_eq!((same_kind.mean, same_kind.max, same_kind.psnr), (0.0, 0.0, f64::INFINITY));
        // NaN against a number after an infinity: the NaN difference becomes the maximum, uncounted
        // (its relative error is 0), and the next finite difference, however small, replaces it.
        let nan = stats(&[inf, f32::NAN, 1.0], &[0.0, 2.0, 1.0]);
        assert!(nan.mean.is_nan() && nan.psnr.is_nan(), "{nan:?}");
        assert_eq!((nan.max, nan.max_x, nan.nfail, nan.nwarn), (0.0, 2, 0, 0));
    }
}
