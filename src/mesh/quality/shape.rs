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
    let sides = Sides::of(a, b, c);
    (sides.quality(), sides.smallest_corner().map_or(0.0, |(u, v)| angle(u, v)))
}

/// A triangle's sides and their squared lengths.
struct Sides {
    ab: DVec3,
    bc: DVec3,
    ca: DVec3,
    l_ab: f64,
    l_bc: f64,
    l_ca: f64,
}

impl Sides {
    fn of(a: DVec3, b: DVec3, c: DVec3) -> Self {
        let (ab, bc, ca) = (b - a, c - b, a - c);
        Self { ab, bc, ca, l_ab: ab.length_squared(), l_bc: bc.length_squared(), l_ca: ca.length_squared() }
    }

    fn quality(&self) -> f64 {
        let doubled_area = self.ab.cross(-self.ca).length();
        let squares = self.l_ab + self.l_bc + self.l_ca;
        if squares > 0.0 { (3f64.sqrt() * 2.0 * doubled_area / squares).min(1.0) } else { 0.0 }
    }

    /// The two sides meeting at the smallest angle, which faces the shortest
    /// side (the law of sines); `None` when two corners are in one place,
    /// where the angle facing them is nothing.
    fn smallest_corner(&self) -> Option<(DVec3, DVec3)> {
        if self.l_ab.min(self.l_bc).min(self.l_ca) == 0.0 {
            return None;
        }
        // The shortest side (ab 0, bc 1, ca 2; bc, then ca, where lengths
        // tie) picked without branches, which a random mesh mispredicts.
        let bc_least = self.l_bc <= self.l_ab && self.l_bc <= self.l_ca;
        let ca_least = !bc_least && self.l_ca <= self.l_ab;
        let shortest = usize::from(bc_least) | usize::from(ca_least) << 1;
        let sides = [self.ab, self.bc, self.ca];
        // The corner facing side j is between sides j + 2 and j + 1.
        Some((sides[(shortest + 2) % 3], -sides[(shortest + 1) % 3]))
    }
}

/// The angle between `u` and `v`, in degrees.
fn angle(u: DVec3, v: DVec3) -> f64 {
    u.cross(v).length().atan2(u.dot(v)).to_degrees()
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
                let mut tally = Tally::default();
                for t in run {
                    let [a, b, c] = t.map(|i| positions[i as usize].as_dvec3());
                    tally.add(&Sides::of(a, b, c));
                }
                tally
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
    /// `u · v` and `|u × v|²` of the sides at `min_angle`.
    least: (f64, f64),
    below_1_degree: u64,
}

impl Default for Tally {
    fn default() -> Self {
        Self { histogram: [0; QUALITY_BINS], sum: 0.0, min_angle: f64::INFINITY, least: (0.0, 0.0), below_1_degree: 0 }
    }
}

/// How far, relatively, the comparisons of squared tangents keep from
/// their boundary before the angle itself is computed: far wider than
/// their rounding, so they decide only where the arctangent would agree.
const MARGIN: f64 = 1e-6;

/// `tan² 1°`.
const TAN_SQUARED_ONE_DEGREE: f64 = 0.0003046792916482916;

impl Tally {
    /// Tallies one triangle. The arctangent of its smallest angle (most of
    /// the cost) is taken only where that angle may be the least so far or
    /// near 1°; elsewhere comparing tangents decides (`tan θ = |u × v| / u · v`).
    fn add(&mut self, sides: &Sides) {
        let quality = sides.quality();
        self.histogram[((quality * QUALITY_BINS as f64) as usize).min(QUALITY_BINS - 1)] += 1;
        self.sum += quality;
        let Some((u, v)) = sides.smallest_corner() else {
            self.min_angle = self.min_angle.min(0.0);
            self.least = (1.0, 0.0);
            self.below_1_degree += 1;
            return;
        };
        let (x, y2) = (u.dot(v), u.cross(v).length_squared());
        let one = x * x * TAN_SQUARED_ONE_DEGREE;
        let (lx, ly2) = self.least;
        let clearly = if x > 0.0 && y2 < one * (1.0 - MARGIN) {
            Some(true)
        } else if x > 0.0 && y2 > one * (1.0 + MARGIN) {
            Some(false)
        } else {
            None
        };
        let maybe_least = !(x > 0.0 && lx > 0.0 && y2 * lx * lx > ly2 * x * x * (1.0 + MARGIN));
        if clearly.is_some() && !maybe_least {
            self.below_1_degree += u64::from(clearly == Some(true));
            return;
        }
        let angle = angle(u, v);
        self.below_1_degree += u64::from(angle < 1.0);
        if angle < self.min_angle {
            (self.min_angle, self.least) = (angle, (x, y2));
        }
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
    fn the_squared_tangent_of_one_degree_is_what_its_name_says() {
        assert!((TAN_SQUARED_ONE_DEGREE - 1f64.to_radians().tan().powi(2)).abs() < 1e-18);
    }

    #[test]
    fn the_tally_counts_and_finds_the_least_angle_as_every_arctangent_would() {
        // Thin triangles with smallest angles on either side of 1° by a hair,
        // random ones, and ones with corners in one place.
        let mut positions = vec![];
        for k in 0..4000 {
            let f = f64::from(k);
            let degrees = match k % 4 {
                0 => 1.0 + (f - 2000.0) * 1e-12,
                1 => 1.0 + (f - 2000.0) * 1e-4,
                2 => 30.0 + (f * 0.37).sin() * 29.0,
                _ => 1e-3 * f,
            };
            let spin = DVec3::new((f * 0.11).cos(), (f * 0.13).sin(), 0.3 * (f * 0.7).cos());
            let (u, w) = (spin.normalize(), spin.any_orthonormal_vector());
            let a = DVec3::new(f, -f, 0.5 * f) * 0.01;
            let b = a + u * (1.0 + 0.1 * (f * 0.3).sin());
            let c = a + (u * degrees.to_radians().cos() + w * degrees.to_radians().sin()) * 0.8;
            let c = if k % 97 == 0 { b } else { c };
            positions.extend([a, b, c].map(|p| p.as_vec3()));
        }
        let triangles: Vec<[u32; 3]> = (0..positions.len() as u32 / 3).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
        let shapes: Vec<(f64, f64)> = triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| positions[i as usize].as_dvec3());
                triangle_shape(a, b, c)
            })
            .collect();
        let shape = ShapeQuality::of(&positions, &triangles);
        let least = shapes.iter().map(|s| s.1).fold(f64::INFINITY, f64::min);
        let below = shapes.iter().filter(|s| s.1 < 1.0).count() as u64;
        assert_eq!((shape.min_angle_degrees, shape.below_1_degree), (least, below));
        assert!(below > 1000 && below < 3000, "{below} below 1°");
        // Without the corners in one place, the least is a real angle.
        let apart: Vec<[u32; 3]> = triangles.iter().copied().filter(|t| t[0] % 97 != 0).collect();
        let least_apart =
            shapes.iter().enumerate().filter(|(t, _)| t % 97 != 0).map(|(_, s)| s.1).fold(f64::INFINITY, f64::min);
        assert!(least_apart > 0.0);
        assert_eq!(ShapeQuality::of(&positions, &apart).min_angle_degrees, least_apart);
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
