//! Proven bounds through warps: boxes holding a box's image under `W⁻¹` and
//! under `W`, and the largest stretch `‖∂q/∂p‖₂` over a box. Each is derived
//! beside its code; none is tuned.

use glam::Vec3A;

use super::warp::{Axis, Warp};
use crate::geom::Aabb;

impl Warp {
    /// A box holding `W⁻¹(b)`: where the child is evaluated for points of `b`.
    #[must_use]
    pub fn inverse_box(&self, b: &Aabb) -> Aabb {
        if b.is_empty() {
            return *b;
        }
        match *self {
            Warp::Twist { axis, rate } => {
                turned_box(b, axis, (-rate * b.max[axis.indices().0], -rate * b.min[axis.indices().0]))
            }
            Warp::Taper { axis, .. } => self.scaled_box(b, axis, false),
            Warp::Bend { rate: 0.0 } => *b,
            Warp::Bend { rate } => unbent_box(b, rate),
        }
    }

    /// A box holding `W(b)`: the world bounds of a child bounded by `b`.
    #[must_use]
    pub fn forward_box(&self, b: &Aabb) -> Aabb {
        if b.is_empty() {
            return *b;
        }
        match *self {
            Warp::Twist { axis, rate } => {
                turned_box(b, axis, (rate * b.min[axis.indices().0], rate * b.max[axis.indices().0]))
            }
            Warp::Taper { axis, .. } => self.scaled_box(b, axis, true),
            Warp::Bend { rate: 0.0 } => *b,
            Warp::Bend { rate } => bent_box(b, rate),
        }
    }

    /// An upper bound on `‖∂q/∂p‖₂` over `b` where the child can be nonzero
    /// (`child`: its bounds), so `|∇f| ≤ stretch · |∇f_child|` there.
    #[must_use]
    pub fn stretch_over(&self, b: &Aabb, child: &Aabb) -> f32 {
        match *self {
            // J = [[R, w], [0, 1]] with R a rotation and |w| = |K|·ρ, ρ the
            // distance from the axis. JJᵀ = [[I + wwᵀ, w], [wᵀ, 1]] has largest
            // eigenvalue (√(1 + t²/4) + t/2)², t = |K|·ρ.
            Warp::Twist { axis, rate } => {
                let t = rate.abs() * radial_reach(b, axis);
                (1.0 + 0.25 * t * t).sqrt() + 0.5 * t
            }
            // J = diag(1/s, 1/s, 1) + the h-column (−u·s′/s², −v·s′/s², 0):
            // ‖J‖ ≤ max(1/s, 1) + ρ·|s′|/s², with s at its smallest over the box.
            Warp::Taper { axis, from, to, scale_from, scale_to } => {
                let s_min = self.taper_scale_range(b, axis).0;
                let slope = ((scale_to - scale_from) / (to - from)).abs();
                (1.0 / s_min).max(1.0) + radial_reach(b, axis) * slope / (s_min * s_min)
            }
            // J = diag(1/ρ, 1, 1) · (a rotation) with ρ = 1 − K·q_y the
            // scaled distance from the bend's centre: ‖J‖ = max(1, 1/ρ). The
            // child is zero where ρ is below its own smallest ρ, so only
            // points at least that far count.
            Warp::Bend { rate: 0.0 } => 1.0,
            Warp::Bend { rate: k } => {
                let rho_child = 1.0 - (k * child.min.y).max(k * child.max.y);
                let rho_box = k.abs() * distance_to_box(Vec3A::new(0.0, 1.0 / k, 0.0), b, true);
                1.0 / rho_box.max(rho_child).min(1.0)
            }
        }
    }

    /// An upper bound on `‖∂p/∂q‖₂` (the forward map's stretch) over the
    /// child's box `b`: how much longer a child's length may be in the world.
    #[must_use]
    pub fn forward_stretch_over(&self, b: &Aabb) -> f32 {
        match *self {
            // The same shape as the inverse's Jacobian: [[R, w], [0, 1]], |w| = |K|·ρ.
            Warp::Twist { .. } => self.stretch_over(b, b),
            // diag(s, s, 1) + the h-column (u·s′, v·s′, 0).
            Warp::Taper { axis, from, to, scale_from, scale_to } => {
                let slope = ((scale_to - scale_from) / (to - from)).abs();
                self.taper_scale_range(b, axis).1.max(1.0) + radial_reach(b, axis) * slope
            }
            // A rotation times diag(r, 1, 1), r = 1 − K·q_y.
            Warp::Bend { rate: k } => (1.0 - (k * b.min.y).min(k * b.max.y)).max(1.0),
        }
    }

    /// An upper bound on `|q''(t)|` along any unit-speed line `p(t)` through
    /// `b`: how fast the warped path turns. With it, along such a line
    /// `d²f/dt² = q′ᵀ H q′ + ∇f_child · q″ ≤ stretch² · max(c, 0) + L · accel`
    /// for `c` and `L` the child's curvature and slope bounds.
    #[must_use]
    pub fn acceleration_over(&self, b: &Aabb) -> f32 {
        match *self {
            // q = R(θ) p with θ = −K·h(t) linear in t: q″ = θ′² R″ p + 2θ′ R′ d,
            // |R″ p| = ρ and |R′ d| ≤ 1, |θ′| ≤ |K|.
            Warp::Twist { axis, rate } => rate * rate * radial_reach(b, axis) + 2.0 * rate.abs(),
            // s(h(t)) is linear on the ramp and constant beyond it, so q_u = u/s
            // has q_u″ = −2u′s′/s² + 2u s′²/s³ there and 0 beyond; across a
            // ramp end s′ jumps and q′ with it: no bound.
            Warp::Taper { axis, from, to, scale_from, scale_to } => {
                let (h, _, _) = axis.indices();
                let (lo, hi) = (b.min[h], b.max[h]);
                if hi <= from || lo >= to {
                    return 0.0;
                }
                if lo < from || hi > to {
                    return f32::INFINITY;
                }
                let (s, sigma) = (self.taper_scale_range(b, axis).0, ((scale_to - scale_from) / (to - from)).abs());
                2.0 * (2.0 * sigma / (s * s) + 2.0 * radial_reach(b, axis) * sigma * sigma / (s * s * s))
            }
            // The bend's path turns without a bound near its centre; not derived.
            Warp::Bend { rate: 0.0 } => 0.0,
            Warp::Bend { .. } => f32::INFINITY,
        }
    }

    /// A taper's box through `s(h)` (`forward`: multiplied by it, else divided).
    fn scaled_box(&self, b: &Aabb, axis: Axis, forward: bool) -> Aabb {
        let (_, u, v) = axis.indices();
        let (s_lo, s_hi) = self.taper_scale_range(b, axis);
        let mut out = *b;
        for i in [u, v] {
            let (lo, hi) = (b.min[i], b.max[i]);
            let candidates = if forward {
                [lo * s_lo, lo * s_hi, hi * s_lo, hi * s_hi]
            } else {
                [lo / s_lo, lo / s_hi, hi / s_lo, hi / s_hi]
            };
            out.min[i] = candidates.iter().copied().fold(f32::INFINITY, f32::min);
            out.max[i] = candidates.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        }
        widen(out)
    }

    /// The smallest and largest taper scale over `b`: `s` is monotone in
    /// `h`, so they are its values at the ends of `b`'s range along the axis.
    fn taper_scale_range(&self, b: &Aabb, axis: Axis) -> (f32, f32) {
        let h = axis.indices().0;
        let ends = [self.taper_scale(b.min[h]), self.taper_scale(b.max[h])];
        (ends[0].min(ends[1]), ends[0].max(ends[1]))
    }
}

/// The largest distance from `axis` of a point of `b`.
fn radial_reach(b: &Aabb, axis: Axis) -> f32 {
    let (_, u, v) = axis.indices();
    let far = |i: usize| b.min[i].abs().max(b.max[i].abs());
    far(u).hypot(far(v))
}

/// The distance from `c` to `b` (in the XY plane when `xy`).
fn distance_to_box(c: Vec3A, b: &Aabb, xy: bool) -> f32 {
    let d = (b.min - c).max(c - b.max).max(Vec3A::ZERO);
    if xy { d.x.hypot(d.y) } else { d.length() }
}

/// A box holding `b` turned about `axis` by every angle in `angles`.
///
/// Each point `x` turned by `θ = θm + δ`, `|δ| ≤ Δ/2`, lies within
/// `2|x|·sin(|δ|/2) ≤ ρ·Δ/2` of `x` turned by `θm`; `b` turned by `θm` lies in
/// the box of its turned corners (a rotation is linear). So that box, grown by
/// `ρ·Δ/2`, holds the set; so does the disc of radius `ρ`. The tighter of the
/// two is taken per coordinate.
fn turned_box(b: &Aabb, axis: Axis, (a0, a1): (f32, f32)) -> Aabb {
    let (h, u, v) = axis.indices();
    let rho = radial_reach(b, axis);
    let (mid, half) = (0.5 * (a0 + a1), 0.5 * (a1 - a0).abs());
    let (s, c) = mid.sin_cos();
    let corners = [(b.min[u], b.min[v]), (b.min[u], b.max[v]), (b.max[u], b.min[v]), (b.max[u], b.max[v])];
    let turned = corners.map(|(x, y)| (x * c - y * s, x * s + y * c));
    let grow = rho * half;
    let mut out = Aabb::new(Vec3A::ZERO, Vec3A::ZERO);
    out.min[h] = b.min[h];
    out.max[h] = b.max[h];
    for (i, pick) in [(u, 0), (v, 1)] {
        let values = turned.map(|t| if pick == 0 { t.0 } else { t.1 });
        let lo = values.iter().copied().fold(f32::INFINITY, f32::min) - grow;
        let hi = values.iter().copied().fold(f32::NEG_INFINITY, f32::max) + grow;
        out.min[i] = lo.max(-rho);
        out.max[i] = hi.min(rho);
    }
    widen(out)
}

/// A box holding `W⁻¹(b)` for a bend of rate `k ≠ 0`: in the scaled plane
/// `(A, B) = (k·x, 1 − k·y)`, `q_x = atan2(A, B)/k` and `q_y = (1 − |(A, B)|)/k`.
/// `|(A, B)|` over the box ranges between its nearest and farthest points
/// from the origin; the angle, seen from outside a convex box, between its
/// corners' angles — unless the box holds the origin or straddles the cut
/// (`A = 0`, `B < 0`), where every angle may occur.
fn unbent_box(b: &Aabb, k: f32) -> Aabb {
    let (a_lo, a_hi) = ordered(k * b.min.x, k * b.max.x);
    let (b_lo, b_hi) = ordered(1.0 - k * b.min.y, 1.0 - k * b.max.y);
    let scaled = Aabb::new(Vec3A::new(a_lo, b_lo, 0.0), Vec3A::new(a_hi, b_hi, 0.0));
    let near = distance_to_box(Vec3A::ZERO, &scaled, true);
    let far = a_lo.abs().max(a_hi.abs()).hypot(b_lo.abs().max(b_hi.abs()));
    let straddles_cut = a_lo <= 0.0 && a_hi >= 0.0 && b_lo <= 0.0;
    let (angle_lo, angle_hi) = if straddles_cut {
        (-std::f32::consts::PI, std::f32::consts::PI)
    } else {
        let angles = [(a_lo, b_lo), (a_lo, b_hi), (a_hi, b_lo), (a_hi, b_hi)].map(|(a, b)| a.atan2(b));
        (angles.iter().copied().fold(f32::INFINITY, f32::min), angles.iter().copied().fold(f32::NEG_INFINITY, f32::max))
    };
    let (qx_lo, qx_hi) = ordered(angle_lo / k, angle_hi / k);
    let (qy_lo, qy_hi) = ordered((1.0 - near) / k, (1.0 - far) / k);
    widen(Aabb::new(Vec3A::new(qx_lo, qy_lo, b.min.z), Vec3A::new(qx_hi, qy_hi, b.max.z)))
}

/// A box holding `W(b)` for a bend of rate `k ≠ 0`: `p = (r·sin θ / k,
/// (1 − r·cos θ)/k)` with `r = 1 − k·q_y` and `θ = k·q_x`; interval products of
/// `r` with the ranges of `sin θ` and `cos θ` over `θ`'s interval.
fn bent_box(b: &Aabb, k: f32) -> Aabb {
    let (r_lo, r_hi) = ordered(1.0 - k * b.min.y, 1.0 - k * b.max.y);
    let (t_lo, t_hi) = ordered(k * b.min.x, k * b.max.x);
    let (sin_lo, sin_hi) = sin_range(t_lo, t_hi);
    let (cos_lo, cos_hi) = sin_range(t_lo + std::f32::consts::FRAC_PI_2, t_hi + std::f32::consts::FRAC_PI_2);
    let product = |lo: f32, hi: f32| {
        let c = [r_lo * lo, r_lo * hi, r_hi * lo, r_hi * hi];
        (c.iter().copied().fold(f32::INFINITY, f32::min), c.iter().copied().fold(f32::NEG_INFINITY, f32::max))
    };
    let (a_lo, a_hi) = product(sin_lo, sin_hi);
    let (c_lo, c_hi) = product(cos_lo, cos_hi);
    let (x_lo, x_hi) = ordered(a_lo / k, a_hi / k);
    let (y_lo, y_hi) = ordered((1.0 - c_lo) / k, (1.0 - c_hi) / k);
    widen(Aabb::new(Vec3A::new(x_lo, y_lo, b.min.z), Vec3A::new(x_hi, y_hi, b.max.z)))
}

/// The range of `sin` over `[lo, hi]`: its ends, and ±1 where a peak lies inside.
fn sin_range(lo: f32, hi: f32) -> (f32, f32) {
    use std::f32::consts::{FRAC_PI_2, TAU};
    if hi - lo >= TAU {
        return (-1.0, 1.0);
    }
    let (mut min, mut max) = (lo.sin().min(hi.sin()), lo.sin().max(hi.sin()));
    // Peaks at π/2 + 2πn, troughs at −π/2 + 2πn.
    let contains = |at: f32| ((lo - at) / TAU).ceil() * TAU + at <= hi;
    if contains(FRAC_PI_2) {
        max = 1.0;
    }
    if contains(-FRAC_PI_2) {
        min = -1.0;
    }
    (min, max)
}

fn ordered(a: f32, b: f32) -> (f32, f32) {
    (a.min(b), a.max(b))
}

/// `b` grown by a few units in the last place of its largest coordinate, so
/// that rounding in the maps above cannot leave a point just outside it.
fn widen(b: Aabb) -> Aabb {
    let scale = b.min.abs().max(b.max.abs()).max_element().max(1.0);
    let pad = Vec3A::splat(8.0 * f32::EPSILON * scale);
    Aabb::new(b.min - pad, b.max + pad)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// True when a box from these maps holds every mapped sample point.
    fn holds_mapped_samples(b: &Aabb, mapped: &Aabb, map: impl Fn(Vec3A) -> Vec3A) -> bool {
        (0..=6).all(|i| {
            (0..=6).all(|j| {
                (0..=6).all(|l| {
                    let t = Vec3A::new(i as f32, j as f32, l as f32) / 6.0;
                    let p = b.min + (b.max - b.min) * t;
                    mapped.contains(map(p))
                })
            })
        })
    }

    fn warps() -> Vec<Warp> {
        vec![
            Warp::Twist { axis: Axis::Y, rate: 1.3 },
            Warp::Twist { axis: Axis::Z, rate: -2.1 },
            Warp::Taper { axis: Axis::Y, from: -1.0, to: 1.0, scale_from: 1.0, scale_to: 0.4 },
            Warp::Taper { axis: Axis::X, from: 0.0, to: 0.5, scale_from: 0.5, scale_to: 2.0 },
            Warp::Bend { rate: 0.6 },
            Warp::Bend { rate: -0.45 },
        ]
    }

    fn boxes() -> Vec<Aabb> {
        (0..40)
            .map(|i| {
                let t = i as f32;
                let c = Vec3A::new((t * 0.37).sin() * 1.2, (t * 0.91).cos() * 0.6, (t * 0.53).sin());
                let half = Vec3A::new(0.05 + 0.3 * (t * 0.2).sin().abs(), 0.02 + 0.2 * (t * 0.7).cos().abs(), 0.1);
                Aabb::new(c - half, c + half)
            })
            .collect()
    }

    #[test]
    fn mapped_boxes_hold_every_mapped_point() {
        for w in warps() {
            for b in boxes() {
                assert!(holds_mapped_samples(&b, &w.inverse_box(&b), |p| w.inverse(p)), "{w:?} inverse of {b:?}");
                assert!(holds_mapped_samples(&b, &w.forward_box(&b), |p| w.forward(p)), "{w:?} forward of {b:?}");
            }
        }
    }

    #[test]
    fn stretch_bounds_the_jacobian_norm_at_sample_points() {
        let child = Aabb::new(Vec3A::splat(-1.2), Vec3A::splat(0.9));
        for w in warps() {
            for b in boxes() {
                let bound = w.stretch_over(&b, &child);
                for i in 0..=4 {
                    for j in 0..=4 {
                        let p = b.min + (b.max - b.min) * Vec3A::new(i as f32 / 4.0, j as f32 / 4.0, 0.5);
                        let j = w.inverse_jacobian(p);
                        // ‖J‖₂ is at least its largest column, and images of unit vectors.
                        let norm = [
                            Vec3A::X,
                            Vec3A::Y,
                            Vec3A::Z,
                            Vec3A::ONE.normalize(),
                            Vec3A::new(1.0, -1.0, 0.5).normalize(),
                        ]
                        .iter()
                        .map(|&e| (j * e).length())
                        .fold(0.0, f32::max);
                        assert!(norm <= bound * 1.0001, "{w:?} at {p}: {norm} > {bound}");
                    }
                }
            }
        }
    }

    #[test]
    fn acceleration_bounds_the_second_difference_of_warped_lines() {
        for w in warps() {
            for b in boxes() {
                let bound = w.acceleration_over(&b);
                if !bound.is_finite() {
                    continue;
                }
                for k in 0..12 {
                    let t = k as f32;
                    let d = Vec3A::new((t * 1.7).sin(), (t * 0.9).cos(), (t * 2.3).sin()).normalize();
                    let p = b.center();
                    let h = 1e-2f32.min(0.5 * (b.max - b.min).min_element());
                    let second = (w.inverse(p + d * h) - 2.0 * w.inverse(p) + w.inverse(p - d * h)) / (h * h);
                    assert!(second.length() <= bound * 1.05 + 1e-2, "{w:?} along {d}: {} > {bound}", second.length());
                }
            }
        }
    }

    #[test]
    fn sine_ranges_find_their_peaks() {
        assert_eq!(sin_range(0.0, 3.0).1, 1.0);
        assert_eq!(sin_range(-2.0, -1.0).0, -1.0);
        let (lo, hi) = sin_range(0.1, 0.2);
        assert!((lo - 0.1f32.sin()).abs() < 1e-7 && (hi - 0.2f32.sin()).abs() < 1e-7);
    }
}
