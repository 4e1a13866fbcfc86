//! Falloff kernels: how a primitive's field decays with distance to its skeleton.

use glam::Vec4;
use serde::{Deserialize, Serialize};

/// Radial falloff `g(r)` with compact support `R`: `g(0) = 1`, `g(r) = 0` for `r >= R`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Kernel {
    /// Wyvill's `(1 - r²/R²)³`, C¹ at the support boundary, cheap (no square root).
    #[default]
    Wyvill,
}

/// `r / R` where Wyvill's kernel is steepest: `1/√5`.
const WYVILL_STEEPEST: f32 = 0.447_213_6;

impl Kernel {
    /// `g` at squared distance `d2` for support radius with `inv_r2 = 1/R²`.
    #[inline]
    #[must_use]
    pub fn value(self, d2: f32, inv_r2: f32) -> f32 {
        match self {
            Kernel::Wyvill => {
                let s = 1.0 - d2 * inv_r2;
                if s <= 0.0 { 0.0 } else { s * s * s }
            }
        }
    }

    /// Wyvill's `g` for four squared distances at once: the same arithmetic
    /// as [`Kernel::value`], lane by lane.
    #[inline]
    #[must_use]
    pub fn wyvill4(d2: Vec4, inv_r2: Vec4) -> Vec4 {
        let s = (Vec4::ONE - d2 * inv_r2).max(Vec4::ZERO);
        s * s * s
    }

    /// `dg/d(r²)`: the gradient of `g(|p - q|)` at `p` is `2 (p - q)` times this.
    #[inline]
    #[must_use]
    pub fn derivative_d2(self, d2: f32, inv_r2: f32) -> f32 {
        match self {
            Kernel::Wyvill => {
                let s = 1.0 - d2 * inv_r2;
                if s <= 0.0 { 0.0 } else { -3.0 * s * s * inv_r2 }
            }
        }
    }

    /// `|g'(r)|` at distance `r` for support radius `radius`.
    #[must_use]
    pub fn slope(self, r: f32, radius: f32) -> f32 {
        match self {
            Kernel::Wyvill => {
                let u = r / radius;
                if !(0.0..1.0).contains(&u) {
                    return 0.0;
                }
                let s = 1.0 - u * u;
                6.0 * u * s * s / radius
            }
        }
    }

    /// The steepest slope `max |g'(r)|` over all `r`: about `1.7173 / R` for Wyvill.
    #[must_use]
    pub fn global_lipschitz(self, radius: f32) -> f32 {
        self.slope(WYVILL_STEEPEST * radius, radius)
    }

    /// `max |g'(r)|` over `r ∈ [r_min, r_max]`: Galin et al.'s local Lipschitz bound.
    ///
    /// The slope rises on `[0, R/√5]` and falls after, so the maximum is the
    /// peak when the range holds it, otherwise the larger end.
    #[must_use]
    pub fn lipschitz(self, r_min: f32, r_max: f32, radius: f32) -> f32 {
        let peak = WYVILL_STEEPEST * radius;
        if r_min <= peak && peak <= r_max {
            self.global_lipschitz(radius)
        } else {
            self.slope(r_min, radius).max(self.slope(r_max, radius))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wyvill_global_bound_matches_galin() {
        let k = Kernel::Wyvill;
        assert!((k.global_lipschitz(1.0) - 1.7173).abs() < 1e-3);
        assert!((k.global_lipschitz(2.0) - 1.7173 / 2.0).abs() < 1e-3);
        // The bound dominates a dense sampling of the slope.
        for i in 0..1000 {
            let r = i as f32 / 1000.0;
            assert!(k.slope(r, 1.0) <= k.global_lipschitz(1.0) + 1e-6);
        }
    }

    #[test]
    fn local_bound_dominates_finite_differences() {
        let k = Kernel::Wyvill;
        let radius = 1.5;
        for (a, b) in [(0.0, 0.2), (0.5, 0.9), (1.0, 1.4), (0.1, 1.6), (1.6, 2.0)] {
            let l = k.lipschitz(a, b, radius);
            let n = 200;
            for i in 0..n {
                let r0 = a + (b - a) * i as f32 / n as f32;
                let r1 = a + (b - a) * (i + 1) as f32 / n as f32;
                let g0 = k.value(r0 * r0, 1.0 / (radius * radius));
                let g1 = k.value(r1 * r1, 1.0 / (radius * radius));
                assert!((g1 - g0).abs() <= l * (r1 - r0) * 1.001 + 1e-7);
            }
        }
    }
}
