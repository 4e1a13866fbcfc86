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

    /// `-2 dg/d(r²)` of Wyvill's kernel for four squared distances: the
    /// gradient of `g(|p - q|²)` is this times `q - p`.
    #[inline]
    #[must_use]
    pub fn wyvill4_pull(d2: Vec4, inv_r2: Vec4) -> Vec4 {
        let s = (Vec4::ONE - d2 * inv_r2).max(Vec4::ZERO);
        6.0 * s * s * inv_r2
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

    /// A bound on the slope of the gradient (the Hessian's norm) of
    /// `g(d(p))`, `d` the distance to a convex skeleton, where `d ∈ [r_min,
    /// r_max]`.
    ///
    /// With `u = d²`, `∇f = 2 g'(u) (p - π(p))` for the projection `π` onto
    /// the skeleton, whose complement is 1-Lipschitz, so the gradient moves
    /// at most `2|g'(u)| + 4u|g''(u)|` per unit: for Wyvill, with `x = u/R²`,
    /// `6 (1 - x)(1 + 3x) / R²`, rising to 8/R² at `x = 1/3`, then falling to 0.
    #[must_use]
    pub fn curvature(self, r_min: f32, r_max: f32, radius: f32) -> f32 {
        match self {
            Kernel::Wyvill => {
                let (lo, hi, inv_r2) = x_range(r_min, r_max, radius);
                let x = (1.0f32 / 3.0).max(lo).min(hi);
                if x >= 1.0 { 0.0 } else { 6.0 * (1.0 - x) * (1.0 + 3.0 * x) * inv_r2 }
            }
        }
    }

    /// An upper bound on the second derivative of `g(|p - c|)` along any
    /// line, where `|p - c| ∈ [r_min, r_max]`: one-sided, and far below
    /// [`Kernel::curvature`].
    ///
    /// Along a unit direction `e` it is `2 g'(u) + 4 g''(u) (v·e)²` with
    /// `v = p - c`; `g'' >= 0`, so at most `2 g'(u) + 4 u g''(u)`: for Wyvill
    /// `6 (1 - x)(5x - 1) / R²`, negative near the centre (`x < 1/5`), 4.8/R²
    /// at its peak `x = 3/5`, zero from the support's edge on.
    #[must_use]
    pub fn point_bend(self, r_min: f32, r_max: f32, radius: f32) -> f32 {
        match self {
            Kernel::Wyvill => {
                let (lo, hi, inv_r2) = x_range(r_min, r_max, radius);
                let x = 0.6f32.max(lo).min(hi);
                if x >= 1.0 { 0.0 } else { 6.0 * (1.0 - x) * (5.0 * x - 1.0) * inv_r2 }
            }
        }
    }
}

/// `d²/R²` over `[r_min, r_max]`, and `1/R²`. The ends may cross by a
/// rounding, so callers use `max`/`min`, not `clamp`.
fn x_range(r_min: f32, r_max: f32, radius: f32) -> (f32, f32, f32) {
    let inv_r2 = 1.0 / (radius * radius);
    (r_min * r_min * inv_r2, r_max * r_max * inv_r2, inv_r2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    #[test]
    fn curvature_bound_dominates_second_differences_along_lines() {
        let k = Kernel::Wyvill;
        let radius = 1.3;
        let f = |p: Vec3A| k.value(p.length_squared(), 1.0 / (radius * radius));
        let h = 1e-2;
        for i in 0..400 {
            let a = i as f32 * 0.37;
            let p = Vec3A::new(a.cos(), a.sin(), (a * 0.3).cos()) * (i as f32 / 400.0) * radius;
            let dir = Vec3A::new((a * 1.7).sin(), (a * 0.9).cos(), 0.5).normalize();
            let second = (f(p + dir * h) - 2.0 * f(p) + f(p - dir * h)) / (h * h);
            let d = p.length();
            let m = k.curvature((d - h).max(0.0), d + h, radius);
            assert!(second.abs() <= m * 1.01 + 1e-3, "at {p}: {second} against the bound {m}");
        }
        for i in 0..400 {
            let a = i as f32 * 0.53;
            let p = Vec3A::new(a.cos(), a.sin(), (a * 0.7).cos()) * (i as f32 / 400.0) * radius;
            let dir = Vec3A::new((a * 1.3).sin(), (a * 0.4).cos(), -0.3).normalize();
            let second = (f(p + dir * h) - 2.0 * f(p) + f(p - dir * h)) / (h * h);
            let d = p.length();
            let bend = k.point_bend((d - h).max(0.0), d + h, radius);
            assert!(second <= bend + 1e-2 * (1.0 + bend.abs()), "at {p}: {second} above the one-sided bound {bend}");
        }
        assert!(k.point_bend(0.0, 0.1, 1.0) < 0.0, "a point's field is concave near its centre");
        assert!((k.point_bend(0.0, 10.0, 1.0) - 4.8).abs() < 1e-5, "the one-sided peak is 4.8/R²");
        assert!((k.curvature(0.0, 10.0, 1.0) - 8.0).abs() < 1e-5, "the peak is 8/R²");
        assert_eq!(k.curvature(1.0, 2.0, 1.0), 0.0, "zero outside the support");
    }

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
