//! Catmull-Rom splines sampled at even arc-length spacing: how `SplinePoints`
//! lays point primitives along a curve, as the Medusa model is built.

use glam::Vec3A;

/// Sub-samples per span used to measure arc length.
const SAMPLES_PER_SPAN: usize = 64;

/// Point on the uniform Catmull-Rom span from `p1` to `p2` at `t ∈ [0, 1]`.
#[must_use]
pub fn catmull_rom(p0: Vec3A, p1: Vec3A, p2: Vec3A, p3: Vec3A, t: f32) -> Vec3A {
    let t2 = t * t;
    let t3 = t2 * t;
    0.5 * ((2.0 * p1)
        + (p2 - p0) * t
        + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t2
        + (3.0 * p1 - p0 - 3.0 * p2 + p3) * t3)
}

/// A dense polyline along the spline through `control` (ends repeated, so the
/// curve passes through every control point).
fn polyline(control: &[Vec3A]) -> Vec<Vec3A> {
    if control.len() == 1 {
        return vec![control[0]];
    }
    let at = |i: isize| control[i.clamp(0, control.len() as isize - 1) as usize];
    let mut pts = Vec::with_capacity((control.len() - 1) * SAMPLES_PER_SPAN + 1);
    for span in 0..control.len() as isize - 1 {
        for s in 0..SAMPLES_PER_SPAN {
            let t = s as f32 / SAMPLES_PER_SPAN as f32;
            pts.push(catmull_rom(at(span - 1), at(span), at(span + 1), at(span + 2), t));
        }
    }
    pts.push(*control.last().expect("non-empty"));
    pts
}

/// `count` points spaced evenly by arc length along the spline through
/// `control`, from its first control point to its last, each with its arc-length
/// fraction in `[0, 1]`. One point sits at the middle of the curve.
#[must_use]
pub fn even_points(control: &[Vec3A], count: usize) -> Vec<(Vec3A, f32)> {
    let line = polyline(control);
    let mut cumulative = Vec::with_capacity(line.len());
    let mut total = 0.0f32;
    cumulative.push(0.0);
    for w in line.windows(2) {
        total += (w[1] - w[0]).length();
        cumulative.push(total);
    }
    let fractions: Vec<f32> =
        if count == 1 { vec![0.5] } else { (0..count).map(|i| i as f32 / (count - 1) as f32).collect() };
    fractions
        .into_iter()
        .map(|u| {
            let target = u * total;
            let k = cumulative.partition_point(|&c| c < target).clamp(1, line.len().max(2) - 1);
            let (c0, c1) = (cumulative[k - 1], cumulative[k.min(cumulative.len() - 1)]);
            let s = if c1 > c0 { (target - c0) / (c1 - c0) } else { 0.0 };
            let a = line[k - 1];
            let b = line[k.min(line.len() - 1)];
            (a.lerp(b, s), u)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_through_ends_with_even_spacing() {
        let control = [Vec3A::ZERO, Vec3A::new(1.0, 1.0, 0.0), Vec3A::new(2.0, 0.0, 0.0), Vec3A::new(3.0, 1.0, 1.0)];
        let pts = even_points(&control, 25);
        assert_eq!(pts.len(), 25);
        assert!((pts[0].0 - control[0]).length() < 1e-5);
        assert!((pts[24].0 - control[3]).length() < 1e-5);
        let gaps: Vec<f32> = pts.windows(2).map(|w| (w[1].0 - w[0].0).length()).collect();
        let mean = gaps.iter().sum::<f32>() / gaps.len() as f32;
        for g in gaps {
            assert!((g - mean).abs() < 0.05 * mean, "gap {g} vs mean {mean}");
        }
    }

    #[test]
    fn degenerate_inputs() {
        assert_eq!(even_points(&[Vec3A::ONE], 3).len(), 3);
        assert!((even_points(&[Vec3A::ZERO, Vec3A::ONE], 1)[0].0 - Vec3A::splat(0.5)).length() < 1e-5);
    }
}
