//! Warps (Wyvill, Guy and Galin 1999): twist, taper and bend. A warp node
//! evaluates its child at the inverse-warped point `q = W⁻¹(p)`, so
//! `f(p) = f_child(q)` and, by the chain rule, `∇f(p) = Jᵀ ∇f_child(q)` with
//! `J = ∂q/∂p`.
//!
//! What the tracer and the caches need of a warp, each proven:
//! - a box holding `W⁻¹(box)` (the child's range and slope are taken there)
//!   and one holding `W(box)` (the node's world bounds from the child's);
//! - the largest stretch `‖J‖₂` over a box, since
//!   `|∇f(p)| ≤ ‖J(p)‖₂ · |∇f_child(q)|`.
//!
//! Twist and taper act about an axis through the origin, with `h` the
//! coordinate along it and `(u, v)` the two others in cyclic order (for `Y`:
//! `u = z`, `v = x`), so the twist's rotation is the right-handed one.

use glam::{Mat3A, Vec3A};

use crate::geom::Aabb;

/// A coordinate axis.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Axis {
    /// The X axis.
    X,
    /// The Y axis.
    #[default]
    Y,
    /// The Z axis.
    Z,
}

impl Axis {
    /// Indices of `(h, u, v)`: the axis and the two others in cyclic order.
    pub(super) fn indices(self) -> (usize, usize, usize) {
        match self {
            Axis::X => (0, 1, 2),
            Axis::Y => (1, 2, 0),
            Axis::Z => (2, 0, 1),
        }
    }
}

/// A warp and its parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Warp {
    /// The child turned about `axis` by `rate · h` radians at height `h`.
    Twist {
        /// The axis.
        axis: Axis,
        /// Radians per scene unit.
        rate: f32,
    },
    /// The child's cross-sections scaled by `s(h)`, from `scale_from` at
    /// `h = from` to `scale_to` at `h = to`, constant beyond.
    Taper {
        /// The axis.
        axis: Axis,
        /// Where the ramp starts.
        from: f32,
        /// Where it ends (`from < to`).
        to: f32,
        /// Scale at and below `from`, positive.
        scale_from: f32,
        /// Scale at and above `to`, positive.
        scale_to: f32,
    },
    /// The child's X axis bent onto a circle of radius `1/rate` in the XY
    /// plane, toward +Y for a positive rate; 0 is the identity.
    Bend {
        /// Curvature, 1 / radius.
        rate: f32,
    },
}

/// Largest `|rate|` of a twist or bend, a magnitude scene files allow.
const MAX_RATE: f32 = 1e3;

impl Warp {
    /// Checks the parameters: finite rates, `from < to`, positive scales.
    pub fn check(&self) -> Result<(), String> {
        let finite = |v: f32| v.is_finite() && v.abs() <= MAX_RATE;
        match *self {
            Warp::Twist { rate, .. } | Warp::Bend { rate } if !finite(rate) => {
                Err(format!("rate {rate} must be finite and at most {MAX_RATE:e} in magnitude"))
            }
            Warp::Taper { from, to, .. } if !(from.is_finite() && to.is_finite() && from < to) => {
                Err(format!("a taper needs from < to, got from {from}, to {to}"))
            }
            Warp::Taper { scale_from, scale_to, .. }
                if !(scale_from.is_finite() && scale_to.is_finite() && scale_from > 0.0 && scale_to > 0.0) =>
            {
                Err(format!("taper scales must be positive, got {scale_from} and {scale_to}"))
            }
            _ => Ok(()),
        }
    }

    /// Checks that a child with bounds `child` lies in the warp's domain: a
    /// bend's child must keep `|rate · x| < π` and `rate · y < 1`, where the
    /// bend is one-to-one.
    pub fn check_domain(&self, child: &Aabb) -> Result<(), String> {
        let Warp::Bend { rate: k } = *self else { return Ok(()) };
        if k == 0.0 || child.is_empty() {
            return Ok(());
        }
        let reach_x = (k * child.min.x).abs().max((k * child.max.x).abs());
        let reach_y = (k * child.min.y).max(k * child.max.y);
        if reach_x >= std::f32::consts::PI || reach_y >= 1.0 {
            return Err(format!(
                "a bend of rate {k} needs its child within |rate·x| < π and rate·y < 1; the child's bounds \
                 reach |rate·x| = {reach_x:.3} and rate·y = {reach_y:.3}"
            ));
        }
        Ok(())
    }

    /// `q = W⁻¹(p)`: where the child is evaluated.
    #[must_use]
    pub fn inverse(&self, p: Vec3A) -> Vec3A {
        match *self {
            Warp::Twist { axis, rate } => rotate(p, axis, -rate * p[axis.indices().0]),
            Warp::Taper { axis, .. } => {
                let (h, u, v) = axis.indices();
                let s = self.taper_scale(p[h]);
                with(p, [(u, p[u] / s), (v, p[v] / s)])
            }
            Warp::Bend { rate: 0.0 } => p,
            Warp::Bend { rate: k } => {
                let (a, b) = (k * p.x, 1.0 - k * p.y);
                Vec3A::new(a.atan2(b) / k, (1.0 - a.hypot(b)) / k, p.z)
            }
        }
    }

    /// `p = W(q)`: where a child's point lands.
    #[must_use]
    pub fn forward(&self, q: Vec3A) -> Vec3A {
        match *self {
            Warp::Twist { axis, rate } => rotate(q, axis, rate * q[axis.indices().0]),
            Warp::Taper { axis, .. } => {
                let (h, u, v) = axis.indices();
                let s = self.taper_scale(q[h]);
                with(q, [(u, q[u] * s), (v, q[v] * s)])
            }
            Warp::Bend { rate: 0.0 } => q,
            Warp::Bend { rate: k } => {
                let (r, angle) = (1.0 - k * q.y, k * q.x);
                Vec3A::new(r * angle.sin() / k, (1.0 - r * angle.cos()) / k, q.z)
            }
        }
    }

    /// `J = ∂q/∂p` at `p`: row `i` holds the derivatives of `q_i`.
    #[must_use]
    pub fn inverse_jacobian(&self, p: Vec3A) -> Mat3A {
        let mut rows = [Vec3A::X, Vec3A::Y, Vec3A::Z];
        match *self {
            Warp::Twist { axis, rate } => {
                let (h, u, v) = axis.indices();
                let q = self.inverse(p);
                let (s, c) = (-rate * p[h]).sin_cos();
                rows[u] = with(Vec3A::ZERO, [(u, c), (v, -s), (h, rate * q[v])]);
                rows[v] = with(Vec3A::ZERO, [(u, s), (v, c), (h, -rate * q[u])]);
            }
            Warp::Taper { axis, .. } => {
                let (h, u, v) = axis.indices();
                let (s, slope) = (self.taper_scale(p[h]), self.taper_slope(p[h]));
                rows[u] = with(Vec3A::ZERO, [(u, 1.0 / s), (h, -p[u] * slope / (s * s))]);
                rows[v] = with(Vec3A::ZERO, [(v, 1.0 / s), (h, -p[v] * slope / (s * s))]);
            }
            Warp::Bend { rate: 0.0 } => {}
            Warp::Bend { rate: k } => {
                let (a, b) = (k * p.x, 1.0 - k * p.y);
                let rho2 = a * a + b * b;
                let rho = rho2.sqrt();
                rows[0] = Vec3A::new(b / rho2, a / rho2, 0.0);
                rows[1] = Vec3A::new(-a / rho, b / rho, 0.0);
            }
        }
        Mat3A::from_cols(rows[0], rows[1], rows[2]).transpose()
    }

    /// The gradient at `p` from the child's gradient `g` at `W⁻¹(p)`: `Jᵀ g`.
    #[must_use]
    pub fn gradient(&self, p: Vec3A, g: Vec3A) -> Vec3A {
        self.inverse_jacobian(p).transpose() * g
    }

    /// The taper's scale at height `h` (1 for other warps).
    pub(super) fn taper_scale(&self, h: f32) -> f32 {
        let Warp::Taper { from, to, scale_from, scale_to, .. } = *self else { return 1.0 };
        scale_from + (scale_to - scale_from) * ((h - from) / (to - from)).clamp(0.0, 1.0)
    }

    /// `ds/dh` (zero outside the ramp; at its ends either side's value is a subgradient).
    fn taper_slope(&self, h: f32) -> f32 {
        let Warp::Taper { from, to, scale_from, scale_to, .. } = *self else { return 0.0 };
        if (from..=to).contains(&h) { (scale_to - scale_from) / (to - from) } else { 0.0 }
    }
}

/// `p` rotated about `axis` (through the origin) by `angle`, right-handed.
fn rotate(p: Vec3A, axis: Axis, angle: f32) -> Vec3A {
    let (_, u, v) = axis.indices();
    let (s, c) = angle.sin_cos();
    with(p, [(u, p[u] * c - p[v] * s), (v, p[u] * s + p[v] * c)])
}

/// `p` with the given components replaced.
fn with<const N: usize>(mut p: Vec3A, components: [(usize, f32); N]) -> Vec3A {
    for (i, value) in components {
        p[i] = value;
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    fn warps() -> Vec<Warp> {
        vec![
            Warp::Twist { axis: Axis::Y, rate: 1.3 },
            Warp::Twist { axis: Axis::X, rate: -0.7 },
            Warp::Twist { axis: Axis::Z, rate: 2.1 },
            Warp::Taper { axis: Axis::Y, from: -1.0, to: 1.0, scale_from: 1.0, scale_to: 0.4 },
            Warp::Taper { axis: Axis::Z, from: 0.0, to: 0.5, scale_from: 0.5, scale_to: 2.0 },
            Warp::Bend { rate: 0.6 },
            Warp::Bend { rate: -0.45 },
        ]
    }

    fn points() -> impl Iterator<Item = Vec3A> {
        (0..200).map(|i| {
            let t = i as f32;
            Vec3A::new((t * 0.37).sin() * 1.2, (t * 0.91).cos() * 0.9, (t * 0.53).sin() * 1.1)
        })
    }

    #[test]
    fn forward_undoes_inverse() {
        for w in warps() {
            for p in points() {
                let back = w.forward(w.inverse(p));
                assert!((back - p).length() < 1e-4, "{w:?} at {p}: {back}");
            }
        }
    }

    #[test]
    fn twist_about_y_turns_the_child_by_rate_times_height() {
        let w = Warp::Twist { axis: Axis::Y, rate: 0.5 };
        // At height 2 the child appears turned by +1 radian: its +X lands at (cos 1, 2, −sin 1).
        let p = w.forward(Vec3A::new(1.0, 2.0, 0.0));
        assert!((p - Vec3A::new(1f32.cos(), 2.0, -(1f32.sin()))).length() < 1e-6, "{p}");
        // The formula for the inverse: q.x = x cos θ + z sin θ, q.z = −x sin θ + z cos θ, θ = −K·h.
        let (x, h, z) = (0.3f32, 1.7f32, -0.8f32);
        let theta = -0.5 * h;
        let q = w.inverse(Vec3A::new(x, h, z));
        let want = Vec3A::new(x * theta.cos() + z * theta.sin(), h, -x * theta.sin() + z * theta.cos());
        assert!((q - want).length() < 1e-6, "{q} against {want}");
    }

    #[test]
    fn bend_follows_its_formula_and_curls_toward_positive_y() {
        let k = 0.8f32;
        let w = Warp::Bend { rate: k };
        let (x, y) = (0.5f32, 0.2f32);
        let q = w.inverse(Vec3A::new(x, y, 0.3));
        let want = Vec3A::new((k * x).atan2(1.0 - k * y) / k, (1.0 - (k * x).hypot(1.0 - k * y)) / k, 0.3);
        assert!((q - want).length() < 1e-6);
        assert!(w.forward(Vec3A::new(1.0, 0.0, 0.0)).y > 0.0);
        assert!(Warp::Bend { rate: -k }.forward(Vec3A::new(1.0, 0.0, 0.0)).y < 0.0);
    }

    #[test]
    fn jacobians_match_finite_differences() {
        let h = 1e-3f32;
        for w in warps() {
            let kinks = match w {
                Warp::Taper { axis, from, to, .. } => Some((axis.indices().0, from, to)),
                _ => None,
            };
            for p in points() {
                // The taper's ramp ends are kinks: a centred difference there averages two sides.
                if kinks.is_some_and(|(h, from, to)| (p[h] - from).abs() < 2e-3 || (p[h] - to).abs() < 2e-3) {
                    continue;
                }
                let j = w.inverse_jacobian(p);
                for (axis, e) in [Vec3A::X, Vec3A::Y, Vec3A::Z].into_iter().enumerate() {
                    let numeric = (w.inverse(p + e * h) - w.inverse(p - e * h)) / (2.0 * h);
                    let column = j.col(axis);
                    assert!(
                        (numeric - column).length() < 2e-2 * (1.0 + column.length()),
                        "{w:?} at {p}, ∂/∂{axis}: {numeric} vs {column}"
                    );
                }
            }
        }
    }

    #[test]
    fn bad_parameters_and_out_of_domain_bends_are_refused() {
        assert!(Warp::Twist { axis: Axis::Y, rate: f32::NAN }.check().is_err());
        let taper = |from, to, s0, s1| Warp::Taper { axis: Axis::Y, from, to, scale_from: s0, scale_to: s1 };
        assert!(taper(1.0, 1.0, 1.0, 1.0).check().is_err());
        assert!(taper(0.0, 1.0, 0.0, 1.0).check().is_err());
        assert!(taper(0.0, 1.0, 1.0, 0.5).check().is_ok());
        let child = Aabb::new(Vec3A::new(-3.0, -0.5, -1.0), Vec3A::new(3.0, 0.5, 1.0));
        assert!(Warp::Bend { rate: 0.5 }.check_domain(&child).is_ok());
        assert!(Warp::Bend { rate: 1.2 }.check_domain(&child).is_err(), "|1.2 · 3| > π");
        assert!(Warp::Bend { rate: 2.5 }.check_domain(&Aabb::new(Vec3A::ZERO, Vec3A::splat(0.45))).is_err());
    }
}
