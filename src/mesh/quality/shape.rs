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
    let (l_ab, l_bc, l_ca) = (ab.length_squared(), bc.length_squared(), ca.length_squared());
    let squares = l_ab + l_bc + l_ca;
    let quality = if squares > 0.0 { (3f64.sqrt() * 2.0 * doubled_area / squares).min(1.0) } else { 0.0 };
    // The smallest angle faces the shortest side (the law of sines): one
    // arctangent instead of three.
    let angle = |u: DVec3, v: DVec3| u.cross(v).length().atan2(u.dot(v)).to_degrees();
    let smallest = if l_ab.min(l_bc).min(l_ca) == 0.0 {
        // Two corners in one place: the angle facing them is nothing.
        0.0
    } else if l_bc <= l_ab && l_bc <= l_ca {
        angle(ab, -ca)
    } else if l_ca <= l_ab {
        angle(bc, -ab)
    } else {
        angle(ca, -bc)
    };
    (quality, smallest)
}

impl ShapeQuality {
    /// The shape of `triangles` over `positions`.
    #[must_use]
    pub fn of(positions: &[glam::Vec3], triangles: &[[u32; 3]]) -> Self {
        // Tallied in runs of fixed length, in parallel, and the runs' tallies
        // added in order: the same sums for any thread count, without a
        // list of every triangle's figures (16 bytes a triangle).
        let runs: Vec<Tally> = triangles
            .par_chunks(TRIANGLES_PER_RUN)
            .map(|run| {
                run.iter().fold(Tally::default(), |mut tally, t| {
                    let [a, b, c] = t.map(|i| positions[i as usize].as_dvec3());
                    tally.add(triangle_shape(a, b, c));
                    tally
                })
            })
            .collect();
        let total = runs.into_iter().fold(Tally::default(), Tally::join);
        let n = triangles.len().max(1) as f64;
        Self {
            measure: QUALITY_MEASURE,
            mean: total.sum / n,
            below_0_1: total.histogram[0] as f64 / n,
            histogram: total.histogram,
            min_angle_degrees: if triangles.is_empty() { 0.0 } else { total.min_angle },
            below_1_degree: total.below_1_degree,
        }
    }
}

/// Triangles one task tallies.
const TRIANGLES_PER_RUN: usize = 1 << 16;

/// The shape figures of some triangles.
#[derive(Clone, Copy)]
struct Tally {
    histogram: [u64; QUALITY_BINS],
    sum: f64,
    min_angle: f64,
    below_1_degree: u64,
}

impl Default for Tally {
    fn default() -> Self {
        Self { histogram: [0; QUALITY_BINS], sum: 0.0, min_angle: f64::INFINITY, below_1_degree: 0 }
    }
}

impl Tally {
    fn add(&mut self, (quality, angle): (f64, f64)) {
        self.histogram[((quality * QUALITY_BINS as f64) as usize).min(QUALITY_BINS - 1)] += 1;
        self.sum += quality;
        self.min_angle = self.min_angle.min(angle);
        self.below_1_degree += u64::from(angle < 1.0);
    }

    fn join(mut self, other: Self) -> Self {
        for (a, b) in self.histogram.iter_mut().zip(other.histogram) {
            *a += b;
        }
        self.sum += other.sum;
        self.min_angle = self.min_angle.min(other.min_angle);
        self.below_1_degree += other.below_1_degree;
        self
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

    #[test]
    fn the_smallest_angle_is_the_least_of_the_three_whichever_corner_it_is_at() {
        let all_three = |a: DVec3, b: DVec3, c: DVec3| {
            let angle = |u: DVec3, v: DVec3| u.cross(v).length().atan2(u.dot(v)).to_degrees();
            angle(b - a, c - a).min(angle(c - b, a - b)).min(angle(a - c, b - c))
        };
        for k in 0..2000 {
            let f = k as f64;
            let p = |s: f64| DVec3::new((f * s).sin(), (f * s * 1.7).cos(), (f * s * 0.3).sin() * 0.2);
            let (a, b, c) = (p(0.37), p(0.91), p(1.53));
            for (x, y, z) in [(a, b, c), (b, c, a), (c, a, b)] {
                let (_, smallest) = triangle_shape(x, y, z);
                assert!((smallest - all_three(x, y, z)).abs() < 1e-9, "{x} {y} {z}");
            }
        }
    }
}
