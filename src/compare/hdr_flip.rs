//! HDR-ꟻLIP (Andersson et al. 2021) as NVIDIA's flip-evaluator computes
//! it: both images are exposed at a series of exposures, tone-mapped with
//! ACES (flip-evaluator's default), clamped to `[0, 1]`, compared by LDR-ꟻLIP
//! ([`super::flip_linear`]), and each pixel keeps its largest error.
//!
//! Unless given, the exposure range comes from the reference's luminance:
//! the start exposure maps its brightest pixel, and the stop exposure its
//! median (at least `f32::EPSILON`, as flip-evaluator 1.7 takes it: a render
//! whose background covers half the frame has a median of 0, and then a stop
//! of 24.08), to where the tone curve reaches 0.85; there are
//! `max(2, ⌈stop − start⌉)` exposures, evenly spaced and both ends included.

use glam::Vec3;

use super::flip_linear::flip_linear;

/// ACES (Narkowicz's fit) as a ratio of quadratics, `(c²·t0 + c·t1 + t2) /
/// (c²·t3 + c·t4 + t5)`, with flip-evaluator's 0.6 pre-exposure cancelled.
const ACES: [f32; 6] = [0.6 * 0.6 * 2.51, 0.6 * 0.03, 0.0, 0.6 * 0.6 * 2.43, 0.6 * 0.59, 0.14];

/// The exposures HDR-ꟻLIP evaluates at, in stops.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Exposures {
    /// The first (darkest) exposure.
    pub start: f32,
    /// The last (brightest).
    pub stop: f32,
    /// How many, evenly spaced from `start` to `stop`.
    pub count: u32,
}

impl Exposures {
    /// The range flip-evaluator chooses from `reference` (linear RGB), with
    /// `start` and `stop` overriding its ends; an error when an end the image
    /// must give is not finite (an all-black reference has no start) or start
    /// exceeds stop.
    pub fn for_reference(reference: &[Vec3], start: Option<f32>, stop: Option<f32>) -> Result<Self, String> {
        let (auto_start, auto_stop) = match (start, stop) {
            (Some(a), Some(b)) => (a, b),
            _ => automatic_range(reference),
        };
        let (start, stop) = (start.unwrap_or(auto_start), stop.unwrap_or(auto_stop));
        if !start.is_finite() || !stop.is_finite() {
            return Err(format!(
                "HDR-FLIP cannot choose its exposures from this reference (start {start}, stop {stop}: \
                 it is black); give --start-exposure and --stop-exposure"
            ));
        }
        if start > stop {
            return Err(format!("the start exposure {start} must not exceed the stop exposure {stop}"));
        }
        let count = (stop - start).ceil().max(2.0) as u32;
        Ok(Self { start, stop, count })
    }

    /// The `i`-th exposure, computed as flip-evaluator computes it.
    #[must_use]
    pub fn at(&self, i: u32) -> f32 {
        let step = (self.stop - self.start) / (self.count - 1) as f32;
        self.start + i as f32 * step
    }
}

/// flip-evaluator's start and stop exposures for `reference`.
fn automatic_range(reference: &[Vec3]) -> (f32, f32) {
    let t = 0.85f32;
    let (a, b, c) = (ACES[0] - t * ACES[3], ACES[1] - t * ACES[4], ACES[2] - t * ACES[5]);
    // The larger root of a·x² + b·x + c = 0: where the tone curve reaches t.
    let x_max = if a == 0.0 {
        -c / b
    } else {
        let d1 = -0.5 * (b / a);
        d1 + ((d1 * d1) - (c / a)).sqrt()
    };
    let mut luminances: Vec<f32> = reference.iter().map(|c| 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z).collect();
    let y_max = luminances.iter().copied().fold(-1e30f32, |m, y| if m < y { y } else { m });
    // std::nth_element at n/2: the upper median.
    let mid = luminances.len() / 2;
    let (_, &mut y_median, _) = luminances.select_nth_unstable_by(mid, f32::total_cmp);
    ((x_max / y_max).log2(), (x_max / y_median.max(f32::EPSILON)).log2())
}

/// Per-pixel HDR-ꟻLIP errors of `test` against `reference` (linear RGB, any
/// non-negative values, `width × height`) over `exposures`, at `ppd`.
#[must_use]
pub fn hdr_flip(
    reference: &[Vec3],
    test: &[Vec3],
    width: u32,
    height: u32,
    ppd: f32,
    exposures: Exposures,
) -> Vec<f32> {
    let mut worst = vec![0.0f32; reference.len()];
    for i in 0..exposures.count {
        let scale = 2.0f32.powf(exposures.at(i));
        let tone_mapped = |img: &[Vec3]| -> Vec<Vec3> { img.iter().map(|&c| tone_map(c * scale)).collect() };
        let errors = flip_linear(&tone_mapped(reference), &tone_mapped(test), width, height, ppd);
        for (w, e) in worst.iter_mut().zip(errors) {
            if e > *w {
                *w = e;
            }
        }
    }
    worst
}

/// ACES, clamped to `[0, 1]`.
fn tone_map(c: Vec3) -> Vec3 {
    let t = ACES;
    let mapped = ((c * c) * t[0] + c * t[1] + t[2]) / (c * c * t[3] + c * t[4] + t[5]);
    mapped.clamp(Vec3::ZERO, Vec3::ONE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exposures_span_the_reference_from_its_brightest_to_its_median_pixel() {
        // Luminance of grey g is g; the median of 1, 2, 4, 8 (upper) is 4.
        let reference: Vec<Vec3> = [1.0, 8.0, 2.0, 4.0].map(Vec3::splat).to_vec();
        let e = Exposures::for_reference(&reference, None, None).unwrap();
        assert!((e.stop - e.start - 1.0).abs() < 1e-5, "log2(8 / 4) stops apart: {e:?}");
        assert_eq!(e.count, 2);
        // The start maps the brightest pixel to where ACES reaches 0.85.
        let brightest = tone_map(Vec3::splat(8.0 * 2.0f32.powf(e.start)));
        assert!((brightest.x - 0.85).abs() < 1e-4, "{brightest}");
        let given = Exposures::for_reference(&reference, Some(-3.0), Some(2.5)).unwrap();
        assert_eq!((given.count, given.at(0), given.at(5)), (6, -3.0, 2.5));
        assert!(Exposures::for_reference(&[Vec3::ZERO; 4], None, None).is_err());
        // A median of 0 is taken as f32::EPSILON: flip-evaluator 1.7 stops at 24.083 stops for this one.
        let mostly_black = [0.0, 0.0, 0.0, 1.0].map(Vec3::splat);
        let e = Exposures::for_reference(&mostly_black, None, None).unwrap();
        assert!((e.start - 1.083_297_3).abs() < 1e-5 && (e.stop - 24.083_298).abs() < 1e-4, "{e:?}");
        assert_eq!(e.count, 23);
        assert!(Exposures::for_reference(&reference, Some(3.0), Some(1.0)).is_err());
    }

    #[test]
    fn identical_images_have_no_error_and_a_brighter_one_does() {
        let (w, h) = (24, 16);
        let a: Vec<Vec3> = (0..w * h).map(|i| Vec3::new(0.1 + (i % w) as f32 * 0.2, 0.5, 3.0)).collect();
        let e = Exposures::for_reference(&a, None, None).unwrap();
        assert!(hdr_flip(&a, &a, w, h, 67.0, e).iter().all(|&v| v == 0.0));
        let b: Vec<Vec3> = a.iter().map(|&c| c * 1.5).collect();
        let errors = hdr_flip(&a, &b, w, h, 67.0, e);
        assert!(errors.iter().all(|&v| v > 0.0 && v <= 1.0), "{errors:?}");
    }
}
