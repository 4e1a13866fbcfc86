//! idiff's thresholds: how far a pixel may differ before it counts against
//! the warning or failure percentages, or fails the image outright.

/// Thresholds of a judgement, idiff's options and defaults (any difference
/// above 1e-6 fails).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Thresholds {
    /// A pixel differing by more than this counts against `failpercent`.
    pub fail: f32,
    /// ... and by more than this fraction of the mean of the two magnitudes.
    pub failrelative: f32,
    /// Percentage of pixels allowed above `fail`.
    pub failpercent: f64,
    /// Any pixel above this fails the image.
    pub hardfail: f32,
    /// Up to this many failed pixels pass, whatever their error.
    pub allowfailures: usize,
    /// A pixel differing by more than this counts against `warnpercent`.
    pub warn: f32,
    /// ... and by more than this fraction of the mean of the two magnitudes.
    pub warnrelative: f32,
    /// Percentage of pixels allowed above `warn` before a warning.
    pub warnpercent: f64,
    /// Any pixel above this warns.
    pub hardwarn: f32,
}

impl Default for Thresholds {
    fn default() -> Self {
        Self {
            fail: 1e-6,
            failrelative: 0.0,
            failpercent: 0.0,
            hardfail: f32::INFINITY,
            allowfailures: 0,
            warn: 1e-6,
            warnrelative: 0.0,
            warnpercent: 0.0,
            hardwarn: f32::INFINITY,
        }
    }
}

impl Thresholds {
    /// idiff's test for one finite difference `f`: above the absolute
    /// threshold and above the relative one (`f` against the mean of the two
    /// magnitudes). Non-finite values are judged before, as mismatches.
    #[must_use]
    pub fn exceeds(threshold: f32, relative: f32, f: f64, mean_magnitude: f32) -> bool {
        let rel = if mean_magnitude > 0.0 { f / f64::from(mean_magnitude) } else { 0.0 };
        f > f64::from(threshold) && rel > f64::from(relative)
    }
}
