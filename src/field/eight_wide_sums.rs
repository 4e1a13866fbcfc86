//! Point sums eight at a time, on x86-64 processors with AVX2 and FMA (found
//! at run time; elsewhere the index's four-wide sums serve). Setting the
//! environment variable `BLOBTRACE_SUMS=4` forces the four-wide sums on any
//! processor, so that a regression suite blessed on one kind of machine can
//! be checked as the other kind computes it: the two sum in different orders
//! and differ in the last bits.
//!
//! A dense model's exact evaluation is almost all one loop: the points listed
//! in the index cell around the query, each `w·(1 − d²/R²)³` (about 275 of them
//! per evaluation on Medusa). Eight lanes halve that loop's arithmetic. The
//! loop runs over a cell's list packed eight points to a [`Chunk`], one row per
//! component, so that it loads its points instead of gathering them through
//! the list: gathering and transposing took twice the arithmetic's time, and
//! a third of it went to the weights alone.
//!
//! As in the four-wide sums, values are accumulated in double precision and
//! gradients in single; [`sum_and_gradient`] gives the value to the same bits
//! as [`sum`], which the tracer's lattice snapping needs (a value taken with
//! the gradient must equal the value taken alone).

use glam::{Vec3A, Vec4};

/// The environment variable that, set to `4`, forces the four-wide sums.
pub const SUMS_ENV: &str = "BLOBTRACE_SUMS";

/// True when the eight-wide sums run: the processor has them and
/// [`SUMS_ENV`] does not ask for four-wide ones (read once per process).
#[inline]
pub fn available() -> bool {
    static RUNS: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *RUNS.get_or_init(|| detected() && std::env::var(SUMS_ENV).map_or(true, |v| v.trim() != "4"))
}

/// Lanes of the field's sums in this process: 8 when [`available`], else 4.
#[must_use]
pub fn sum_lanes() -> usize {
    if available() { 8 } else { 4 }
}

/// True when this processor has AVX2 and FMA.
fn detected() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Eight listed points laid out by component, one lane each. Lanes past the
/// end of a list hold weight zero, and add exactly zero.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(32))]
pub struct Chunk {
    x: [f32; 8],
    y: [f32; 8],
    z: [f32; 8],
    inv_r2: [f32; 8],
    weight: [f32; 8],
}

/// The listed points (`x, y, z, 1/R²` in `terms`, and `weights`), eight per
/// chunk, in list order.
pub fn pack<'a>(terms: &'a [Vec4], weights: &'a [f32], items: &'a [u32]) -> impl Iterator<Item = Chunk> + 'a {
    items.chunks(8).map(|eight| {
        let mut chunk = Chunk::default();
        for (lane, &i) in eight.iter().enumerate() {
            let t = terms[i as usize];
            (chunk.x[lane], chunk.y[lane], chunk.z[lane], chunk.inv_r2[lane]) = (t.x, t.y, t.z, t.w);
            chunk.weight[lane] = weights[i as usize];
        }
        chunk
    })
}

/// The sum of the packed points' values at `p`; `None` where [`available`] is false.
#[inline]
pub fn sum(chunks: &[Chunk], p: Vec3A) -> Option<f64> {
    #[cfg(target_arch = "x86_64")]
    if available() {
        // SAFETY: the processor has AVX2 and FMA (checked just above).
        return Some(unsafe { avx2::sum(chunks, p) });
    }
    let _ = (chunks, p);
    None
}

/// [`sum`] and the sum of the packed points' gradients in one pass, the
/// value to the same bits; `None` where [`available`] is false.
#[inline]
pub fn sum_and_gradient(chunks: &[Chunk], p: Vec3A) -> Option<(f64, Vec3A)> {
    #[cfg(target_arch = "x86_64")]
    if available() {
        // SAFETY: as in `sum`.
        return Some(unsafe { avx2::sum_and_gradient(chunks, p) });
    }
    let _ = (chunks, p);
    None
}

/// Bounds of the sum of the packed points' values over the box `lo..hi`:
/// each point between its values at the box's nearest and farthest points,
/// the bounds summed in double precision; `None` where [`available`] is false.
#[inline]
pub fn interval(chunks: &[Chunk], lo: Vec3A, hi: Vec3A) -> Option<(f64, f64)> {
    #[cfg(target_arch = "x86_64")]
    if available() {
        // SAFETY: as in `sum`.
        return Some(unsafe { avx2::interval(chunks, lo, hi) });
    }
    let _ = (chunks, lo, hi);
    None
}

/// Bounds over the box `lo..hi` of the packed points' summed slope (`|∇f|`)
/// and of their summed second derivative along any line, each point's taken
/// over its range of distances to the box as [`crate::field::Kernel::lipschitz`]
/// and [`crate::field::Primitive::curvature_over`] take them, summed in double
/// precision; `None` where [`available`] is false.
#[inline]
pub fn slope_bounds(chunks: &[Chunk], lo: Vec3A, hi: Vec3A) -> Option<(f64, f64)> {
    #[cfg(target_arch = "x86_64")]
    if available() {
        // SAFETY: as in `sum`.
        return Some(unsafe { avx2::slope_bounds(chunks, lo, hi) });
    }
    let _ = (chunks, lo, hi);
    None
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use glam::Vec3A;

    use super::Chunk;

    #[target_feature(enable = "avx2,fma")]
    pub fn sum(chunks: &[Chunk], p: Vec3A) -> f64 {
        accumulate::<false>(chunks, p).0
    }

    #[target_feature(enable = "avx2,fma")]
    pub fn sum_and_gradient(chunks: &[Chunk], p: Vec3A) -> (f64, Vec3A) {
        accumulate::<true>(chunks, p)
    }

    #[target_feature(enable = "avx2,fma")]
    pub fn interval(chunks: &[Chunk], lo: Vec3A, hi: Vec3A) -> (f64, f64) {
        let lo = [_mm256_set1_ps(lo.x), _mm256_set1_ps(lo.y), _mm256_set1_ps(lo.z)];
        let hi = [_mm256_set1_ps(hi.x), _mm256_set1_ps(hi.y), _mm256_set1_ps(hi.z)];
        let (mut lows, mut highs) = (_mm256_setzero_pd(), _mm256_setzero_pd());
        for chunk in chunks {
            let (near2, far2) = box_distances(chunk, &lo, &hi);
            let (inv_r2, weight) = (load(&chunk.inv_r2), load(&chunk.weight));
            let (at_near, at_far) = (wyvill(near2, inv_r2, weight), wyvill(far2, inv_r2, weight));
            lows = add_halves(lows, _mm256_min_ps(at_near, at_far));
            highs = add_halves(highs, _mm256_max_ps(at_near, at_far));
        }
        (total(lows), total(highs))
    }

    #[target_feature(enable = "avx2,fma")]
    pub fn slope_bounds(chunks: &[Chunk], lo: Vec3A, hi: Vec3A) -> (f64, f64) {
        let lo = [_mm256_set1_ps(lo.x), _mm256_set1_ps(lo.y), _mm256_set1_ps(lo.z)];
        let hi = [_mm256_set1_ps(hi.x), _mm256_set1_ps(hi.y), _mm256_set1_ps(hi.z)];
        let (zero, one, six) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0), _mm256_set1_ps(6.0));
        let (mut slopes, mut bends) = (_mm256_setzero_pd(), _mm256_setzero_pd());
        for chunk in chunks {
            let (near2, far2) = box_distances(chunk, &lo, &hi);
            let (inv_r2, weight) = (load(&chunk.inv_r2), load(&chunk.weight));
            let (x_near, x_far) = (_mm256_mul_ps(near2, inv_r2), _mm256_mul_ps(far2, inv_r2));
            // `x = d²/R²` clamped into the range: where the profile peaks, or its nearer end.
            let at = |peak: f32| _mm256_min_ps(_mm256_max_ps(_mm256_set1_ps(peak), x_near), x_far);
            let inside = |x: __m256| _mm256_max_ps(_mm256_sub_ps(one, x), zero);
            // The slope `6·√(x)/R·(1 − x)²`, steepest at x = 1/5.
            let x = at(0.2);
            let s = inside(x);
            let slope =
                _mm256_mul_ps(_mm256_mul_ps(six, _mm256_sqrt_ps(_mm256_mul_ps(x, inv_r2))), _mm256_mul_ps(s, s));
            let size = _mm256_andnot_ps(_mm256_set1_ps(-0.0), weight);
            slopes = add_halves(slopes, _mm256_mul_ps(size, slope));
            // A point of positive weight bends by `6·(1 − x)(5x − 1)/R²`
            // (largest at x = 3/5), one of negative weight by at most
            // `6·(1 − x)(1 + 3x)/R²` (largest at x = 1/3) times its size.
            let (x, xk) = (at(0.6), at(1.0 / 3.0));
            let bend = _mm256_mul_ps(inside(x), _mm256_fmsub_ps(_mm256_set1_ps(5.0), x, one));
            let sag = _mm256_mul_ps(inside(xk), _mm256_fmadd_ps(_mm256_set1_ps(3.0), xk, one));
            let negative = _mm256_cmp_ps::<_CMP_LT_OQ>(weight, zero);
            let (term, factor) = (_mm256_blendv_ps(bend, sag, negative), _mm256_blendv_ps(weight, size, negative));
            bends = add_halves(bends, _mm256_mul_ps(_mm256_mul_ps(six, inv_r2), _mm256_mul_ps(term, factor)));
        }
        (total(slopes), total(bends))
    }

    /// Per lane, the squared distances from the point to the box `lo..hi`
    /// (zero inside it) and to the box's farthest corner.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn box_distances(chunk: &Chunk, lo: &[__m256; 3], hi: &[__m256; 3]) -> (__m256, __m256) {
        let zero = _mm256_setzero_ps();
        let (mut near2, mut far2) = (zero, zero);
        for (axis, row) in [&chunk.x, &chunk.y, &chunk.z].into_iter().enumerate() {
            let c = load(row);
            let (below, above) = (_mm256_sub_ps(lo[axis], c), _mm256_sub_ps(c, hi[axis]));
            // The gap to the slab (zero inside it), and the distance to its farther face.
            let near = _mm256_max_ps(_mm256_max_ps(below, above), zero);
            let far = _mm256_max_ps(_mm256_sub_ps(c, lo[axis]), _mm256_sub_ps(hi[axis], c));
            near2 = _mm256_fmadd_ps(near, near, near2);
            far2 = _mm256_fmadd_ps(far, far, far2);
        }
        (near2, far2)
    }

    /// `w·(1 − d²/R²)³` per lane, zero past the support.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn wyvill(d2: __m256, inv_r2: __m256, weight: __m256) -> __m256 {
        let s = _mm256_max_ps(_mm256_fnmadd_ps(d2, inv_r2, _mm256_set1_ps(1.0)), _mm256_setzero_ps());
        _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(s, s), s), weight)
    }

    /// One row of a chunk.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn load(row: &[f32; 8]) -> __m256 {
        // SAFETY: reads the eight floats of a row, aligned with its chunk.
        unsafe { _mm256_load_ps(row.as_ptr()) }
    }

    /// `acc` plus the eight lanes of `v`, paired into four double lanes.
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn add_halves(acc: __m256d, v: __m256) -> __m256d {
        let halves = (_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v));
        _mm256_add_pd(acc, _mm256_add_pd(_mm256_cvtps_pd(halves.0), _mm256_cvtps_pd(halves.1)))
    }

    /// The sum of the packed points' values at `p` and, with `GRADIENT`, of
    /// their gradients. One loop body with no closures (only functions with
    /// the same target features), so that nothing is left out of line (a `target_feature` function cannot be forced inline,
    /// and one the compiler left out of line ran without the features, at
    /// half the speed).
    #[inline]
    #[target_feature(enable = "avx2,fma")]
    fn accumulate<const GRADIENT: bool>(chunks: &[Chunk], p: Vec3A) -> (f64, Vec3A) {
        let p = [_mm256_set1_ps(p.x), _mm256_set1_ps(p.y), _mm256_set1_ps(p.z)];
        let (one, zero, six) = (_mm256_set1_ps(1.0), _mm256_setzero_ps(), _mm256_set1_ps(6.0));
        let mut values = _mm256_setzero_pd();
        let mut gradient = [zero; 3];
        for chunk in chunks {
            let (inv_r2, weight) = (load(&chunk.inv_r2), load(&chunk.weight));
            let to_center = [
                _mm256_sub_ps(load(&chunk.x), p[0]),
                _mm256_sub_ps(load(&chunk.y), p[1]),
                _mm256_sub_ps(load(&chunk.z), p[2]),
            ];
            let [dx, dy, dz] = to_center;
            let d2 = _mm256_fmadd_ps(dz, dz, _mm256_fmadd_ps(dy, dy, _mm256_mul_ps(dx, dx)));
            let s = _mm256_max_ps(_mm256_fnmadd_ps(d2, inv_r2, one), zero);
            let s2 = _mm256_mul_ps(s, s);
            let value = _mm256_mul_ps(_mm256_mul_ps(s2, s), weight);
            values = add_halves(values, value);
            if GRADIENT {
                // The gradient of w·g(|c − p|²) is 6·w·s²/R² times c − p.
                let pull = _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(six, s2), inv_r2), weight);
                for (axis, to_center) in gradient.iter_mut().zip(to_center) {
                    *axis = _mm256_fmadd_ps(to_center, pull, *axis);
                }
            }
        }
        (total(values), Vec3A::new(total_f32(gradient[0]), total_f32(gradient[1]), total_f32(gradient[2])))
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
            let chunks: Vec<Chunk> = pack(&terms, &weights, &items).collect();
            assert_eq!(chunks.len(), len.div_ceil(8));
            for q in [Vec3A::ZERO, Vec3A::new(0.3, -0.2, 0.1), Vec3A::new(-0.5, 0.4, 0.2)] {
                let plain: f64 = items.iter().map(|&i| f64::from(prims[i as usize].value(q))).sum();
                let plain_gradient = items.iter().fold(Vec3A::ZERO, |g, &i| g + prims[i as usize].gradient(q));
                let value = sum(&chunks, q).unwrap();
                let (both_value, gradient) = sum_and_gradient(&chunks, q).unwrap();
                assert!((value - plain).abs() <= 1e-5, "{len} points at {q}: {value} against {plain}");
                assert_eq!(both_value.to_bits(), value.to_bits(), "{len} points at {q}");
                let off = (gradient - plain_gradient).length();
                assert!(
                    off <= 1e-4 * (1.0 + plain_gradient.length()),
                    "{len} points at {q}: {gradient} against {plain_gradient}"
                );
            }
        }
    }
}
