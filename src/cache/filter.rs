//! Reconstruction filters: the field between lattice points, from the samples
//! around it (paper section 4.4).
//!
//! Both filters are separable: a 1D weight per axis, multiplied. Tri-linear
//! interpolates the 8 corners of the cell holding the point; the tri-quadratic
//! B-spline approximates from the 27 samples around the nearest lattice point.
//! Both weight sets are non-negative and sum to one, so a reconstructed value
//! lies within the range of the samples it uses, and its derivative along an
//! axis is a convex combination of sample differences along that axis: the
//! two facts the tracer's bounds rest on.

use glam::{IVec3, Vec3A};

/// A reconstruction filter, chosen per cache for values and for gradients.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
pub enum Filter {
    /// Tri-linear interpolation of the 8 corners: exact at the samples, C⁰.
    #[default]
    Trilinear,
    /// The tri-quadratic B-spline over 27 samples: smooth (C¹), approximating.
    Triquadratic,
}

/// How far, in cells, the samples a filter reads may lie from the query point
/// along each axis (the trilinear corners within 1 cell, the quadratic's
/// 3×3×3 neighbourhood around the nearest lattice point within 1.5).
pub const MAX_SUPPORT_CELLS: f32 = 1.5;

/// One axis of a filter's footprint: the first sample and the weights and
/// weight derivatives of the samples from there.
#[derive(Clone, Copy, Debug)]
struct AxisWeights {
    first: i32,
    w: [f32; 3],
    dw: [f32; 3],
}

impl Filter {
    /// Samples per axis: 2 or 3.
    #[must_use]
    pub fn taps(self) -> usize {
        match self {
            Filter::Trilinear => 2,
            Filter::Triquadratic => 3,
        }
    }

    /// The filter weights along one axis at lattice coordinate `u`.
    #[inline]
    fn axis(self, u: f32) -> AxisWeights {
        match self {
            Filter::Trilinear => {
                let (first, at) = floor(u);
                let t = u - at;
                AxisWeights { first, w: [1.0 - t, t, 0.0], dw: [-1.0, 1.0, 0.0] }
            }
            Filter::Triquadratic => {
                // R_q(s₋, s₀, s₊, t) = ((s₋+s₊)/2 − s₀) t² + (s₀ − s₋) t + (s₋+s₀)/2 over
                // [n − ½, n + ½], n the nearest lattice point, t = u − n + ½; regrouped per sample.
                let (nearest, at) = floor(u + 0.5);
                let t = u - at + 0.5;
                AxisWeights {
                    first: nearest.saturating_sub(1),
                    w: [0.5 * (1.0 - t) * (1.0 - t), 0.5 + t - t * t, 0.5 * t * t],
                    dw: [t - 1.0, 1.0 - 2.0 * t, t],
                }
            }
        }
    }

    /// The filter's weights at lattice coordinate `u`, for its footprint and its sums.
    #[must_use]
    #[inline]
    pub fn at(self, u: Vec3A) -> Weights {
        Weights { filter: self, axes: [self.axis(u.x), self.axis(u.y), self.axis(u.z)] }
    }

    /// The lattice points the filter reads at `u`: first corner and taps per axis.
    #[must_use]
    pub fn footprint(self, u: Vec3A) -> (IVec3, usize) {
        self.at(u).footprint()
    }

    /// The reconstructed value at lattice coordinate `u` from `samples`, the
    /// footprint's samples in x-fastest order (`taps³` of them).
    #[must_use]
    pub fn value(self, u: Vec3A, samples: &[f32]) -> f32 {
        self.at(u).value(samples)
    }

    /// The gradient of the reconstruction at `u`, per lattice unit (divide by
    /// the cell size for world units), from the footprint's samples.
    #[must_use]
    pub fn gradient(self, u: Vec3A, samples: &[f32]) -> Vec3A {
        self.at(u).gradient(samples)
    }
}

/// A filter's weights at one point, computed once for the footprint and for
/// the sums over it (a lookup used to compute them again for each).
#[derive(Clone, Copy, Debug)]
pub struct Weights {
    filter: Filter,
    axes: [AxisWeights; 3],
}

impl Weights {
    /// The lattice points the weights apply to: first corner and taps per axis.
    #[must_use]
    #[inline]
    pub fn footprint(&self) -> (IVec3, usize) {
        let [x, y, z] = self.axes;
        (IVec3::new(x.first, y.first, z.first), self.filter.taps())
    }

    /// The reconstructed value from `samples`, the footprint's samples in
    /// x-fastest order (`taps³` of them).
    #[must_use]
    #[inline]
    pub fn value(&self, samples: &[f32]) -> f32 {
        // One loop per tap count, so each unrolls: the same sums in the same order.
        match self.filter {
            Filter::Trilinear => self.value_with_taps::<2>(samples),
            Filter::Triquadratic => self.value_with_taps::<3>(samples),
        }
    }

    fn value_with_taps<const N: usize>(&self, samples: &[f32]) -> f32 {
        let [ax, ay, az] = self.axes;
        let mut sum = 0.0;
        for k in 0..N {
            for j in 0..N {
                let wyz = ay.w[j] * az.w[k];
                let row = &samples[(k * N + j) * N..][..N];
                let along_x: f32 = row.iter().zip(&ax.w).map(|(s, w)| s * w).sum();
                sum += wyz * along_x;
            }
        }
        sum
    }

    /// The gradient of the reconstruction, per lattice unit (divide by the
    /// cell size for world units), from the footprint's samples.
    #[must_use]
    #[inline]
    pub fn gradient(&self, samples: &[f32]) -> Vec3A {
        match self.filter {
            Filter::Trilinear => self.gradient_with_taps::<2>(samples),
            Filter::Triquadratic => self.gradient_with_taps::<3>(samples),
        }
    }

    fn gradient_with_taps<const N: usize>(&self, samples: &[f32]) -> Vec3A {
        let [ax, ay, az] = self.axes;
        let mut g = Vec3A::ZERO;
        for k in 0..N {
            for j in 0..N {
                let row = &samples[(k * N + j) * N..][..N];
                let (mut s_w, mut s_dw) = (0.0, 0.0);
                for (i, s) in row.iter().enumerate() {
                    s_w += s * ax.w[i];
                    s_dw += s * ax.dw[i];
                }
                g += Vec3A::new(s_dw * ay.w[j] * az.w[k], s_w * ay.dw[j] * az.w[k], s_w * ay.w[j] * az.dw[k]);
            }
        }
        g
    }
}

/// `x.floor()` for lattice coordinates (well inside `i32`), as an integer
/// and as a float, without the libm call that `f32::floor` becomes on
/// baseline x86-64: it sits on the hot path. One conversion serves both.
#[inline]
fn floor(x: f32) -> (i32, f32) {
    let i = x as i32;
    let t = i as f32;
    if t > x { (i.saturating_sub(1), t - 1.0) } else { (i, t) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gather(filter: Filter, u: Vec3A, f: impl Fn(IVec3) -> f32) -> Vec<f32> {
        let (first, n) = filter.footprint(u);
        let n = n as i32;
        let mut out = Vec::new();
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    out.push(f(first + IVec3::new(i, j, k)));
                }
            }
        }
        out
    }

    #[test]
    fn fast_floor_agrees_with_floor() {
        for &x in &[-2.5f32, -2.0, -1e-7, 0.0, 1e-7, 0.5, 3.0, 3.999, -1000.25] {
            assert_eq!(floor(x), (x.floor() as i32, x.floor()), "{x}");
        }
    }

    #[test]
    fn quadratic_weights_match_the_paper_formula() {
        let r_q = |a: f32, b: f32, c: f32, t: f32| ((a + c) / 2.0 - b) * t * t + (b - a) * t + (a + b) / 2.0;
        for &u in &[0.1f32, 0.49, 0.51, 3.7, -2.2] {
            let ax = Filter::Triquadratic.axis(u);
            let s = [0.3f32, -1.2, 2.5];
            let t = u - (u + 0.5).floor() + 0.5;
            let mine: f32 = (0..3).map(|i| ax.w[i] * s[i]).sum();
            assert!((mine - r_q(s[0], s[1], s[2], t)).abs() < 1e-6, "u = {u}");
        }
    }

    #[test]
    fn both_filters_reproduce_linear_fields_and_their_gradients() {
        let lin = |p: Vec3A| 0.3 * p.x - 1.1 * p.y + 0.7 * p.z + 2.0;
        for filter in [Filter::Trilinear, Filter::Triquadratic] {
            for &u in &[Vec3A::new(0.2, 3.9, -1.4), Vec3A::new(5.5, 0.0, 2.25)] {
                let s = gather(filter, u, |i| lin(i.as_vec3a()));
                assert!((filter.value(u, &s) - lin(u)).abs() < 1e-5, "{filter:?} at {u}");
                let g = filter.gradient(u, &s);
                assert!((g - Vec3A::new(0.3, -1.1, 0.7)).length() < 1e-5, "{filter:?} gradient {g}");
            }
        }
    }
}
