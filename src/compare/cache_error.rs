//! error_C: how far a cached field departs from the exact one, |f_C(p) − f(p)|,
//! at given points (the first paper's estimate takes mesh vertices).

use glam::{Vec3, Vec3A};
use rayon::prelude::*;

use crate::field::{EvalMode, Field, Model, ModelField};

/// Statistics of error_C over a set of points.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct CacheErrorStats {
    /// Mean |f_C − f|.
    pub mean: f64,
    /// Largest |f_C − f|.
    pub max: f32,
    /// Mean relative to the iso-value T (the paper's "about 3%" for Medusa at 128³).
    pub mean_relative: f64,
    /// Largest relative to T.
    pub max_relative: f32,
    /// Points measured.
    pub points: usize,
}

/// |f_C(p) − f(p)| at each point, the exact field evaluated indexed; in parallel.
#[must_use]
pub fn cache_error_at(model: &Model, points: &[Vec3]) -> Vec<f32> {
    let (exact, cached) = (ModelField::new(model, EvalMode::Indexed), ModelField::new(model, EvalMode::Cached));
    points
        .par_iter()
        .map(|&p| {
            let p = Vec3A::from(p);
            (cached.value(p) - exact.value(p)).abs()
        })
        .collect()
}

/// Mean and maximum of `errors`, absolute and relative to `threshold`.
#[must_use]
pub fn cache_error_stats(errors: &[f32], threshold: f32) -> CacheErrorStats {
    let n = errors.len().max(1) as f64;
    let mean = errors.iter().map(|&e| f64::from(e)).sum::<f64>() / n;
    let max = errors.iter().copied().fold(0.0f32, f32::max);
    CacheErrorStats {
        mean,
        max,
        mean_relative: mean / f64::from(threshold),
        max_relative: max / threshold,
        points: errors.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_are_relative_to_the_threshold() {
        let s = cache_error_stats(&[0.01, 0.03], 0.5);
        assert!((s.mean - 0.02).abs() < 1e-7 && (s.mean_relative - 0.04).abs() < 1e-6);
        assert_eq!((s.max, s.points), (0.03, 2));
    }
}
