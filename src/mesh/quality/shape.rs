//! Triangle shape: the smallest angles and a histogram of the quality
//! measure `q = 4√3·A / (l₀² + l₁² + l₂²)`, which is 1 for an equilateral
//! triangle and falls to 0 as a triangle degenerates to a sliver or a needle.

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

/// The name reports give the quality measure.
pub const QUALITY_MEASURE: &str = "4*sqrt(3)*area / sum of squared edge lengths (1 equilateral, 0 degenerate)";

/// Bins of the quality histogram, each a tenth wide.
pub const QUALITY_BINS: usize = 10;

/// The shape of a mesh's triangles.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ShapeQuality {
    /// What `mean`, `below_0_1` and `histogram` measure.
    pub measure: &'static str,
    /// Mean quality.
    pub mean: f64,
    /// Fraction of triangles with quality below 0.1.
    pub below_0_1: f64,
    /// Triangles with quality in [0, 0.1), [0.1, 0.2), …, [0.9, 1].
    pub histogram: [u64; QUALITY_BINS],
    /// The smallest interior angle of any triangle, in degrees.
    pub min_angle_degrees: f64,
    /// Triangles with an interior angle below 1°.
    pub below_1_degree: u64,
}

/// Quality and smallest angle (degrees) of the triangle `a b c`, in double precision.
#[must_use]
pub fn triangle_shape(a: DVec3, b: DVec3, c: DVec3) -> (f64, f64) {
    let (ab, bc, ca) = (b - a, c - b, a - c);
    let doubled_area = ab.cross(-ca).length();
    let squares = ab.length_squared() + bc.length_squared() + ca.length_squared();
    let quality = if squares > 0.0 { (3f64.sqrt() * 2.0 * doubled_area / squares).min(1.0) } else { 0.0 };
    let angle = |u: DVec3, v: DVec3| u.cross(v).length().atan2(u.dot(v)).to_degrees();
    let smallest = angle(ab, -ca).min(angle(bc, -ab)).min(angle(ca, -bc));
    (quality, smallest)
}

impl ShapeQuality {
    /// The shape of `triangles` over `positions`.
    #[must_use]
    pub fn of(positions: &[glam::Vec3], triangles: &[[u32; 3]]) -> Self {
        let shapes: Vec<(f64, f64)> = triangles
            .par_iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| positions[i as usize].as_dvec3());
                triangle_shape(a, b, c)
            })
            .collect();
        let mut histogram = [0u64; QUALITY_BINS];
        let (mut sum, mut min_angle, mut below_1_degree) = (0.0, f64::INFINITY, 0);
        for &(q, angle) in &shapes {
            histogram[((q * QUALITY_BINS as f64) as usize).min(QUALITY_BINS - 1)] += 1;
            sum += q;
            min_angle = min_angle.min(angle);
            below_1_degree += u64::from(angle < 1.0);
        }
        let n = shapes.len().max(1) as f64;
        Self {
            measure: QUALITY_MEASURE,
            mean: sum / n,
            below_0_1: histogram[0] as f64 / n,
            histogram,
            min_angle_degrees: if shapes.is_empty() { 0.0 } else { min_angle },
            below_1_degree,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_equilateral_triangle_has_quality_one_and_sixty_degree_angles() {
        let (q, angle) = triangle_shape(DVec3::ZERO, DVec3::X, DVec3::new(0.5, 3f64.sqrt() / 2.0, 0.0));
        assert!((q - 1.0).abs() < 1e-12 && (angle - 60.0).abs() < 1e-9, "{q} {angle}");
        let (q, angle) = triangle_shape(DVec3::ZERO, DVec3::X, DVec3::new(0.5, 0.0, 0.0));
        assert_eq!((q, angle), (0.0, 0.0), "a flat triangle");
        let (_, angle) = triangle_shape(DVec3::ZERO, DVec3::X * 2.0, DVec3::new(1.0, 1.0, 0.0));
        assert!((angle - 45.0).abs() < 1e-9, "{angle}");
    }
}
