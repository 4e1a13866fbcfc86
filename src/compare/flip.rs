//! The LDR-ꟻLIP perceptual difference (Andersson et al. 2020) through
//! NVIDIA's own implementation (the `nv-flip` crate), at the viewing
//! conditions NVIDIA's tools assume: a 0.7 m wide 3840-pixel monitor seen
//! from 0.7 m, about 67 pixels per degree.
//!
//! ꟻLIP's filters reach a fixed number of pixels (at 67 pixels per degree:
//! 10 for the colour pipeline's spatial filter, 9 for the feature
//! detectors), so the image is evaluated in horizontal strips on the worker
//! threads, each with `HALO` extra rows above and below it; every pixel sees
//! exactly the neighbours it sees in a whole-image evaluation, so the error
//! map is bit-identical to NVIDIA's single-threaded one (a test holds this).

use rayon::prelude::*;

/// Rows each strip reads beyond its own, more than either filter's radius.
const HALO: u32 = 24;
/// Buckets of the pooled histogram over `[0, 1]`, as ꟻLIP's tool uses.
pub const FLIP_BUCKETS: usize = 100;

/// ꟻLIP's pooled statistics of an error map.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FlipStats {
    /// Pixels per degree of visual angle the errors were computed at.
    pub pixels_per_degree: f32,
    /// Mean error.
    pub mean: f32,
    /// Weighted median (each error weighted by itself, as ꟻLIP reports).
    pub weighted_median: f32,
    /// First weighted quartile.
    pub weighted_q1: f32,
    /// Third weighted quartile.
    pub weighted_q3: f32,
    /// Smallest error.
    pub min: f32,
    /// Largest error.
    pub max: f32,
    /// Pixels per bucket of width 1/`FLIP_BUCKETS` over `[0, 1]`.
    pub histogram: Vec<usize>,
    /// HDR-ꟻLIP's exposures (absent for LDR-ꟻLIP).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub exposures: Option<super::hdr_flip::Exposures>,
}

/// The pixels per degree NVIDIA's ꟻLIP tools default to.
#[must_use]
pub fn default_pixels_per_degree() -> f32 {
    nv_flip::pixels_per_degree(0.7, 3840.0, 0.7)
}

/// Per-pixel ꟻLIP errors of `test` against `reference`, both row-major
/// 8-bit sRGB RGB of `width × height`.
#[must_use]
pub fn flip_errors(reference: &[u8], test: &[u8], width: u32, height: u32, ppd: f32) -> Vec<f32> {
    let strip = height.div_ceil(2 * rayon::current_num_threads() as u32).max(4 * HALO);
    let starts: Vec<u32> = (0..height).step_by(strip as usize).collect();
    let strips: Vec<Vec<f32>> = starts
        .par_iter()
        .map(|&y0| {
            let y1 = (y0 + strip).min(height);
            let (lo, hi) = (y0.saturating_sub(HALO), (y1 + HALO).min(height));
            let rows = (lo * width * 3) as usize..(hi * width * 3) as usize;
            let errors = flip_whole(&reference[rows.clone()], &test[rows], width, hi - lo, ppd);
            errors[((y0 - lo) * width) as usize..((y1 - lo) * width) as usize].to_vec()
        })
        .collect();
    strips.concat()
}

/// ꟻLIP of two whole images in one call of NVIDIA's code.
#[must_use]
pub fn flip_whole(reference: &[u8], test: &[u8], width: u32, height: u32, ppd: f32) -> Vec<f32> {
    let image = |data: &[u8]| nv_flip::FlipImageRgb8::with_data(width, height, data);
    nv_flip::flip(image(reference), image(test), ppd).to_vec()
}

/// ꟻLIP's pooled statistics of `errors` (one per pixel of `width × height`).
#[must_use]
pub fn flip_stats(errors: &[f32], width: u32, height: u32, ppd: f32) -> FlipStats {
    let map = nv_flip::FlipImageFloat::with_data(width, height, errors);
    let mut pool = nv_flip::FlipPool::from_image(&map);
    let mut histogram = vec![0; FLIP_BUCKETS];
    for &e in errors {
        histogram[((e * FLIP_BUCKETS as f32) as usize).min(FLIP_BUCKETS - 1)] += 1;
    }
    FlipStats {
        pixels_per_degree: ppd,
        mean: pool.mean(),
        weighted_median: pool.get_percentile(0.5, true),
        weighted_q1: pool.get_percentile(0.25, true),
        weighted_q3: pool.get_percentile(0.75, true),
        min: pool.min_value(),
        max: pool.max_value(),
        histogram,
        exposures: None,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A test image: a gradient with noise, different for each `seed`.
    pub(crate) fn pattern(width: u32, height: u32, seed: u32) -> Vec<u8> {
        (0..width * height * 3)
            .map(|i| {
                let (x, y) = ((i / 3) % width, (i / 3) / width);
                let noise = (i.wrapping_mul(2_654_435_761) ^ seed).rotate_left(7) % 40;
                ((x * 255 / width + y * 3 + noise) % 256) as u8
            })
            .collect()
    }

    #[test]
    fn strips_give_the_whole_image_errors_bit_for_bit() {
        let (w, h) = (70, 301);
        let (a, b) = (pattern(w, h, 1), pattern(w, h, 99));
        let ppd = default_pixels_per_degree();
        let whole = flip_whole(&a, &b, w, h, ppd);
        let pool = rayon::ThreadPoolBuilder::new().num_threads(4).build().unwrap();
        let strips = pool.install(|| flip_errors(&a, &b, w, h, ppd));
        assert_eq!(
            whole.iter().map(|e| e.to_bits()).collect::<Vec<_>>(),
            strips.iter().map(|e| e.to_bits()).collect::<Vec<_>>()
        );
        let stats = flip_stats(&strips, w, h, ppd);
        assert!(stats.mean > 0.0 && stats.min <= stats.weighted_q1 && stats.weighted_q3 <= stats.max, "{stats:?}");
        assert_eq!(stats.histogram.iter().sum::<usize>(), (w * h) as usize);
        // ꟻLIP's pool starts its maximum at the smallest positive float.
        assert!(flip_stats(&flip_errors(&a, &a, w, h, ppd), w, h, ppd).max < 1e-30);
    }
}
