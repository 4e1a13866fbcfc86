//! Point sums eight at a time, on x86-64 processors with AVX2 and FMA (found
//! at run time; elsewhere the index's four-wide sums serve).
//!
//! A dense model's exact evaluation is almost all one loop: the points listed
//! in the index cell around the query, each `w·(1 − d²/R²)³` (about 275 of them
//! per evaluation on Medusa). Eight lanes halve that loop's arithmetic; the
//! points are still gathered through the cell's list, four-float records
//! (`x, y, z, 1/R²`) transposed in registers into one row per component.
//!
//! As in the four-wide sums, values are accumulated in double precision and
//! gradients in single; [`sum_and_gradient`] gives each to the same bits as
//! [`sum`] and [`gradient`] apart, which the tracer's lattice snapping needs
//! (a value taken with the gradient must equal the value taken alone).

use glam::{Vec3A, Vec4};

/// True when this processor runs the eight-wide sums.
#[inline]
pub fn available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The sum of the listed points' values at `p`; `None` where [`available`] is false.
#[inline]
pub fn sum(terms: &[Vec4], weights: &[f32], items: &[u32], p: Vec3A) -> Option<f64> {
    #[cfg(target_arch = "x86_64")]
    if available() {
        // SAFETY: the processor has AVX2 and FMA (checked just above).
        return Some(unsafe { avx2::sum(terms, weights, items, p) });
    }
    let _ = (terms, weights, items, p);
    None
}

/// The sum of the listed points' gradients at `p`; `None` where [`available`] is false.
#[inline]
pub fn gradient(terms: &[Vec4], weights: &[f32], items: &[u32], p: Vec3A) -> Option<Vec3A> {
    #[cfg(target_arch = "x86_64")]
    if available() {
        // SAFETY: as in `sum`.
        return Some(unsafe { avx2::sum_and_gradient(terms, weights, items, p).1 });
    }
    let _ = (terms, weights, items, p);
    None
}

/// [`sum`] and [`gradient`] in one pass, each to the same bits.
#[inline]
pub fn sum_and_gradient(terms: &[Vec4], weights: &[f32], items: &[u32], p: Vec3A) -> Option<(f64, Vec3A)> {
    #[cfg(target_arch = "x86_64")]
    if available() {
        // SAFETY: as in `sum`.
        return Some(unsafe { avx2::sum_and_gradient(terms, weights, items, p) });
    }
    let _ = (terms, weights, items, p);
    None
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use glam::{Vec3A, Vec4};

    /// The sum of the listed points' values at `p` and, with `GRADIENT`, of
    /// their gradients: eight points per pass, the tail repeating its first
    /// point in lanes whose weight is masked to zero. One loop body, so that
    /// nothing is left out of line (a `target_feature` function cannot be
    /// forced inline).
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn accumulate<const GRADIENT: bool>(terms: &[Vec4], weights: &[f32], items: &[u32], p: Vec3A) -> (f64, Vec3A) {
        // One check of the whole list spares the loop a bounds check per load.
        let largest = items.iter().fold(0, |m, &i| m.max(i)) as usize;
        assert!(items.is_empty() || largest < terms.len().min(weights.len()), "a listed point is out of range");
        let mut sums = Sums::<GRADIENT>::new(p);
        let mut chunks = items.chunks_exact(8);
        for chunk in &mut chunks {
            let chunk: &[u32; 8] = chunk.try_into().expect("chunks of eight");
            // SAFETY: every listed index is below both lengths (checked above).
            unsafe { sums.add(terms, weights, chunk, 8) };
        }
        let tail = chunks.remainder();
        if let Some(&first) = tail.first() {
            let mut padded = [first; 8];
            padded[..tail.len()].copy_from_slice(tail);
            // SAFETY: as above; the padding repeats a listed index.
            unsafe { sums.add(terms, weights, &padded, tail.len()) };
        }
        sums.totals()
    }

    /// Running sums of values (four double lanes) and gradients (eight single
    /// lanes per axis) at one point.
    struct Sums<const GRADIENT: bool> {
        p: [__m256; 3],
        values: __m256d,
        gradient: [__m256; 3],
    }

    impl<const GRADIENT: bool> Sums<GRADIENT> {
        #[inline]
        #[target_feature(enable = "avx2,fma")]
        fn new(p: Vec3A) -> Self {
            let zero = _mm256_setzero_ps();
            Self {
                p: [_mm256_set1_ps(p.x), _mm256_set1_ps(p.y), _mm256_set1_ps(p.z)],
                values: _mm256_setzero_pd(),
                gradient: [zero; 3],
            }
        }

        /// Adds the first `live` of the eight points `idx`.
        ///
        /// # Safety
        /// Every index in `idx` is below `terms.len()` and `weights.len()`.
        #[inline]
        #[target_feature(enable = "avx2,fma")]
        unsafe fn add(&mut self, terms: &[Vec4], weights: &[f32], idx: &[u32; 8], live: usize) {
            let load = |k: usize| {
                // SAFETY: the caller promises the index is in range; a Vec4 is four floats.
                unsafe { _mm_loadu_ps(terms.get_unchecked(idx[k] as usize) as *const Vec4 as *const f32) }
            };
            // SAFETY: as for `load`.
            let weight = |k: usize| unsafe { *weights.get_unchecked(idx[k] as usize) };
            // Rows hold points (k, k + 4) as (x, y, z, 1/R²) in their two
            // halves; a 4×4 transpose within each half makes component rows.
            let rows = [
                _mm256_set_m128(load(4), load(0)),
                _mm256_set_m128(load(5), load(1)),
                _mm256_set_m128(load(6), load(2)),
                _mm256_set_m128(load(7), load(3)),
            ];
            let xy_lo = _mm256_unpacklo_ps(rows[0], rows[1]);
            let xy_hi = _mm256_unpacklo_ps(rows[2], rows[3]);
            let zr_lo = _mm256_unpackhi_ps(rows[0], rows[1]);
            let zr_hi = _mm256_unpackhi_ps(rows[2], rows[3]);
            let to_center = [
                _mm256_sub_ps(_mm256_shuffle_ps::<0x44>(xy_lo, xy_hi), self.p[0]),
                _mm256_sub_ps(_mm256_shuffle_ps::<0xEE>(xy_lo, xy_hi), self.p[1]),
                _mm256_sub_ps(_mm256_shuffle_ps::<0x44>(zr_lo, zr_hi), self.p[2]),
            ];
            let inv_r2 = _mm256_shuffle_ps::<0xEE>(zr_lo, zr_hi);
            let mut weight =
                _mm256_set_ps(weight(7), weight(6), weight(5), weight(4), weight(3), weight(2), weight(1), weight(0));
            if live < 8 {
                let lane = _mm256_set_ps(7.0, 6.0, 5.0, 4.0, 3.0, 2.0, 1.0, 0.0);
                weight = _mm256_and_ps(weight, _mm256_cmp_ps::<_CMP_LT_OQ>(lane, _mm256_set1_ps(live as f32)));
            }
            let [dx, dy, dz] = to_center;
            let d2 = _mm256_fmadd_ps(dz, dz, _mm256_fmadd_ps(dy, dy, _mm256_mul_ps(dx, dx)));
            let s = _mm256_max_ps(_mm256_fnmadd_ps(d2, inv_r2, _mm256_set1_ps(1.0)), _mm256_setzero_ps());
            let s2 = _mm256_mul_ps(s, s);
            let value = _mm256_mul_ps(_mm256_mul_ps(s2, s), weight);
            let halves = (_mm256_castps256_ps128(value), _mm256_extractf128_ps::<1>(value));
            self.values =
                _mm256_add_pd(self.values, _mm256_add_pd(_mm256_cvtps_pd(halves.0), _mm256_cvtps_pd(halves.1)));
            if GRADIENT {
                // The gradient of w·g(|c − p|²) is 6·w·s²/R² times c − p.
                let pull = _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(_mm256_set1_ps(6.0), s2), inv_r2), weight);
                for (axis, to_center) in self.gradient.iter_mut().zip(to_center) {
                    *axis = _mm256_fmadd_ps(to_center, pull, *axis);
                }
            }
        }

        #[inline]
        #[target_feature(enable = "avx2,fma")]
        fn totals(&self) -> (f64, Vec3A) {
            let g = self.gradient;
            (total(self.values), Vec3A::new(total_f32(g[0]), total_f32(g[1]), total_f32(g[2])))
        }
    }

    /// The total of four double lanes, summed in pairs.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn total(v: __m256d) -> f64 {
        let mut lanes = [0.0f64; 4];
        // SAFETY: stores four doubles into a local array of four.
        unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), v) };
        (lanes[0] + lanes[1]) + (lanes[2] + lanes[3])
    }

    /// The total of eight single lanes, summed in pairs.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn total_f32(v: __m256) -> f32 {
        let mut lanes = [0.0f32; 8];
        // SAFETY: stores eight floats into a local array of eight.
        unsafe { _mm256_storeu_ps(lanes.as_mut_ptr(), v) };
        ((lanes[0] + lanes[1]) + (lanes[2] + lanes[3])) + ((lanes[4] + lanes[5]) + (lanes[6] + lanes[7]))
    }

    #[target_feature(enable = "avx2,fma")]
    pub fn sum(terms: &[Vec4], weights: &[f32], items: &[u32], p: Vec3A) -> f64 {
        accumulate::<false>(terms, weights, items, p).0
    }

    #[target_feature(enable = "avx2,fma")]
    pub fn sum_and_gradient(terms: &[Vec4], weights: &[f32], items: &[u32], p: Vec3A) -> (f64, Vec3A) {
        accumulate::<true>(terms, weights, items, p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::{Kernel, Primitive, Skeleton};

    /// Points of varied radii and weights around the origin, one of them negative.
    fn points() -> Vec<Primitive> {
        (0..23)
            .map(|i| {
                let f = i as f32;
                let center = Vec3A::new((f * 0.37).sin(), (f * 0.71).cos(), (f * 0.23).sin() * 0.5) * 0.6;
                let weight = if i == 5 { -0.7 } else { 1.0 + 0.1 * f };
                Primitive::new(Skeleton::Point { center }, 0.5 + 0.04 * f, weight, Kernel::Wyvill)
            })
            .collect()
    }

    #[test]
    fn eight_wide_sums_match_point_by_point_sums_for_every_tail_length() {
        if !available() {
            eprintln!("this processor lacks AVX2 or FMA: the four-wide sums serve, and are tested in `index`");
            return;
        }
        let prims = points();
        let (terms, weights): (Vec<Vec4>, Vec<f32>) = prims.iter().map(|p| p.wyvill_point().unwrap()).unzip();
        for len in 0..=prims.len() {
            // Every list order the index could hold, including a point listed twice.
            let items: Vec<u32> = (0..len as u32).map(|k| (k * 7) % prims.len() as u32).collect();
            for q in [Vec3A::ZERO, Vec3A::new(0.3, -0.2, 0.1), Vec3A::new(-0.5, 0.4, 0.2)] {
                let plain: f64 = items.iter().map(|&i| f64::from(prims[i as usize].value(q))).sum();
                let plain_gradient = items.iter().fold(Vec3A::ZERO, |g, &i| g + prims[i as usize].gradient(q));
                let value = sum(&terms, &weights, &items, q).unwrap();
                let gradient = gradient(&terms, &weights, &items, q).unwrap();
                assert!((value - plain).abs() <= 1e-5, "{len} points at {q}: {value} against {plain}");
                let off = (gradient - plain_gradient).length();
                assert!(
                    off <= 1e-4 * (1.0 + plain_gradient.length()),
                    "{len} points at {q}: {gradient} against {plain_gradient}"
                );
                let (both_value, both_gradient) = sum_and_gradient(&terms, &weights, &items, q).unwrap();
                assert_eq!(both_value.to_bits(), value.to_bits(), "{len} points at {q}");
                assert_eq!(both_gradient, gradient, "{len} points at {q}");
            }
        }
    }
}
