//! Degree-6 polynomials in Bernstein form on a stretch `[t0, t1]` of a ray,
//! and the first place one can rise above zero.
//!
//! In Bernstein form a polynomial lies within the convex hull of its
//! control points: when every coefficient is below `-margin`, so is the
//! polynomial, over the whole stretch. Halving a stretch (de Casteljau)
//! gives each half's coefficients, which close in on the polynomial, so
//! isolating the first root only ever refines the first half that can hold one.

use super::supports::Crossing;
use crate::trace::segment::false_position;

/// Coefficients of a degree-6 polynomial in the Bernstein basis of `[0, 1]`.
pub type Bernstein = [f32; 7];

/// Adds `w·s³` on `[t0, t1]` to `sum`, for the quadratic `s` of crossing `c`.
///
/// `s` on the stretch has Bernstein coefficients `s(t0)`, `s(t0) + h s'(t0)/2`,
/// `s(t1)` (`h = t1 - t0`), each computed from `t - t_m`, which is small
/// inside the support, so no large terms cancel. Its square and cube follow
/// from the product rule of Bernstein polynomials.
#[inline]
pub fn add_cube(sum: &mut Bernstein, c: &Crossing, t0: f32, t1: f32) {
    let (u0, u1) = (t0 - c.tm, t1 - c.tm);
    let b0 = c.a0 - c.k * u0 * u0;
    let b2 = c.a0 - c.k * u1 * u1;
    let b1 = b0 - c.k * u0 * (t1 - t0);
    // The square, degree 4.
    let q0 = b0 * b0;
    let q1 = b0 * b1;
    let q2 = (b0 * b2 + 2.0 * b1 * b1) * (1.0 / 3.0);
    let q3 = b1 * b2;
    let q4 = b2 * b2;
    let w = c.weight;
    sum[0] += w * (q0 * b0);
    sum[1] += w * ((4.0 * q1 * b0 + 2.0 * q0 * b1) * (1.0 / 6.0));
    sum[2] += w * ((6.0 * q2 * b0 + 8.0 * q1 * b1 + q0 * b2) * (1.0 / 15.0));
    sum[3] += w * ((q3 * b0 + 3.0 * q2 * b1 + q1 * b2) * 0.2);
    sum[4] += w * ((q4 * b0 + 8.0 * q3 * b1 + 6.0 * q2 * b2) * (1.0 / 15.0));
    sum[5] += w * ((2.0 * q4 * b1 + 4.0 * q3 * b2) * (1.0 / 6.0));
    sum[6] += w * (q4 * b2);
}

/// The polynomial at `x ∈ [0, 1]`, by de Casteljau's algorithm.
#[must_use]
#[cfg(test)]
fn eval(c: &Bernstein, x: f32) -> f32 {
    let mut b = *c;
    for n in (1..7).rev() {
        for i in 0..n {
            b[i] += (b[i + 1] - b[i]) * x;
        }
    }
    b[0]
}

/// The two halves of `c`, on `[0, 1/2]` and `[1/2, 1]`.
#[must_use]
pub fn halves(c: &Bernstein) -> (Bernstein, Bernstein) {
    let (mut left, mut right) = ([0.0; 7], [0.0; 7]);
    let mut b = *c;
    left[0] = b[0];
    right[6] = b[6];
    for n in (1..7).rev() {
        for i in 0..n {
            b[i] = 0.5 * (b[i] + b[i + 1]);
        }
        left[7 - n] = b[0];
        right[n - 1] = b[n - 1];
    }
    (left, right)
}

/// Where a polynomial first comes above `-margin` on its stretch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rise {
    /// Nowhere: it stays below `-margin`.
    Never,
    /// Somewhere in `[a, b]`, a stretch no wider than asked; before `a` it
    /// stays below `-margin`. With `a == b` where it may be above `-margin`
    /// at the stretch's start.
    Within(f32, f32),
}

/// Most halvings before a stretch is given up as narrow enough, however wide.
const MAX_DEPTH: u32 = 40;

/// The first place on `[t0, t1]` where `c` may reach above `-margin`, to
/// within `width`: the halves that can are refined first-half first, and a
/// half whose control points change sign once holds one root, found by
/// false position on the polynomial.
#[must_use]
pub fn first_rise(c: &Bernstein, (t0, t1): (f32, f32), margin: f32, width: f32) -> Rise {
    if c[0] > 0.0 {
        return Rise::Within(t0, t0);
    }
    rise_in(c, (t0, t1), margin, width, 0).unwrap_or(Rise::Never)
}

/// [`first_rise`] on a stretch `depth` halvings deep; `None` for nowhere.
fn rise_in(c: &Bernstein, (a, b): (f32, f32), margin: f32, width: f32, depth: u32) -> Option<Rise> {
    if c.iter().all(|&x| x <= -margin) {
        return None;
    }
    if c[0] > -margin {
        // Within the margin of `T` where the stretch starts: it may be inside
        // from there, and the snap looks lattice point by lattice point from
        // there. (Handed the whole stretch, the snap would try its far end
        // alone and march on from past it, over every lattice point between:
        // through a million points, chords above `T` over a unit long.)
        return Some(Rise::Within(a, a));
    }
    if b - a <= width || depth >= MAX_DEPTH {
        return Some(Rise::Within(a, b));
    }
    if c[6] > 0.0 && sign_changes(c) == 1 {
        return Some(Rise::Within(a, b).narrowed(c, width));
    }
    let (left, right) = halves(c);
    let mid = 0.5 * (a + b);
    rise_in(&left, (a, mid), margin, width, depth + 1).or_else(|| rise_in(&right, (mid, b), margin, width, depth + 1))
}

/// Sign changes along the control polygon: by Descartes' rule for Bernstein
/// form, an upper bound on the roots, of the same parity.
fn sign_changes(c: &Bernstein) -> u32 {
    c.windows(2).map(|w| u32::from((w[0] > 0.0) != (w[1] > 0.0))).sum()
}

impl Rise {
    /// The stretch narrowed around the one root of `c` (negative at the start,
    /// positive at the end) by Illinois false position, to within `width`.
    /// The polynomial is evaluated in power form in double precision: six
    /// Horner steps instead of de Casteljau's twenty-one (plain products:
    /// built for any x86-64, `mul_add` is a library call), and no rounding that
    /// matters (the coefficients grow at most 729-fold from the control
    /// points', far inside what 53 bits hold); the snap that follows decides
    /// the hit on the field's own values whatever this brackets.
    fn narrowed(self, c: &Bernstein, width: f32) -> Rise {
        let Rise::Within(a, b) = self else { return self };
        let power = power_form(c);
        let at = |x: f32| {
            let x = f64::from(x);
            power.iter().rev().fold(0.0f64, |acc, &k| acc * x + k) as f32
        };
        let ((xa, xb), _) = false_position(at, (0.0, c[0]), (1.0, c[6]), width / (b - a));
        Rise::Within(a + (b - a) * xa, a + (b - a) * xb)
    }
}

/// The coefficients of `c` in the power basis `1, x, …, x⁶`: the `k`-th is
/// `C(6, k)` times the `k`-th forward difference of the control points.
fn power_form(c: &Bernstein) -> [f64; 7] {
    const BINOMIAL: [f64; 7] = [1.0, 6.0, 15.0, 20.0, 15.0, 6.0, 1.0];
    let mut d = c.map(f64::from);
    let mut out = [0.0; 7];
    for k in 0..7 {
        out[k] = BINOMIAL[k] * d[0];
        for i in 0..6 - k {
            d[i] = d[i + 1] - d[i];
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn crossing(a0: f32, k: f32, tm: f32, weight: f32) -> Crossing {
        Crossing {
            t_in: f32::NEG_INFINITY,
            t_out: f32::INFINITY,
            a0,
            k,
            tm,
            weight,
            support: 0,
            placed: false,
            err: 0.0,
        }
    }

    #[test]
    fn the_cube_in_bernstein_form_is_the_cube_of_the_quadratic() {
        let c = crossing(0.8, 0.7, 1.3, 1.7);
        let (t0, t1) = (0.4, 2.1);
        let mut b = [0.0; 7];
        add_cube(&mut b, &c, t0, t1);
        for i in 0..=20 {
            let x = i as f32 / 20.0;
            let t = t0 + (t1 - t0) * x;
            let direct = c.weight * c.s(t).powi(3);
            assert!((eval(&b, x) - direct).abs() < 1e-5, "at {t}: {} against {direct}", eval(&b, x));
        }
    }

    #[test]
    fn the_power_form_is_the_same_polynomial() {
        let c: Bernstein = [-0.3, 0.2, -0.1, 0.5, -0.4, 0.1, 0.25];
        let power = power_form(&c);
        for i in 0..=10 {
            let x = f64::from(i as f32 / 10.0);
            let p: f64 = power.iter().enumerate().map(|(k, a)| a * x.powi(k as i32)).sum();
            assert!((p - f64::from(eval(&c, x as f32))).abs() < 1e-6, "at {x}");
        }
    }

    #[test]
    fn halves_are_the_polynomial_on_each_half() {
        let c: Bernstein = [-0.3, 0.2, -0.1, 0.5, -0.4, 0.1, 0.25];
        let (l, r) = halves(&c);
        for i in 0..=10 {
            let x = i as f32 / 10.0;
            assert!((eval(&l, x) - eval(&c, 0.5 * x)).abs() < 1e-6);
            assert!((eval(&r, x) - eval(&c, 0.5 + 0.5 * x)).abs() < 1e-6);
        }
    }

    #[test]
    fn the_first_rise_is_found_before_a_later_one_and_never_skipped() {
        // Two bumps just above zero, a narrow one near x = 0.3 (first
        // above zero at x ≈ 0.287865) and a wide one at x = 0.7.
        let f = |x: f32| 0.001 - 40.0 * (x - 0.3).powi(2) * (x - 0.7).powi(2);
        let c = interpolate(f);
        let Rise::Within(a, b) = first_rise(&c, (0.0, 1.0), 1e-6, 1e-4) else { panic!("no rise found") };
        assert!(a <= 0.28787 && b >= 0.28786 && b - a <= 1e-4 + 1e-6, "[{a}, {b}]");
        // Below zero everywhere: nothing.
        let below = c.map(|x| x - 0.01);
        assert_eq!(first_rise(&below, (0.0, 1.0), 1e-6, 1e-4), Rise::Never);
    }

    /// The Bernstein coefficients of the polynomial of degree at most 6 through `f`'s values.
    fn interpolate(f: impl Fn(f32) -> f32) -> Bernstein {
        // Solve the 7×7 collocation system at x = i/6 in f64.
        let n = 7;
        let mut m = vec![vec![0.0f64; n + 1]; n];
        for (i, row) in m.iter_mut().enumerate() {
            let x = i as f64 / 6.0;
            for (j, cell) in row.iter_mut().take(n).enumerate() {
                let binom = [1.0, 6.0, 15.0, 20.0, 15.0, 6.0, 1.0][j];
                *cell = binom * x.powi(j as i32) * (1.0 - x).powi(6 - j as i32);
            }
            row[n] = f64::from(f(x as f32));
        }
        for col in 0..n {
            let pivot = (col..n).max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs())).unwrap();
            m.swap(col, pivot);
            let pivot_row = m[col].clone();
            for (r, row) in m.iter_mut().enumerate() {
                if r != col {
                    let factor = row[col] / pivot_row[col];
                    for (cell, p) in row.iter_mut().zip(&pivot_row).skip(col) {
                        *cell -= factor * p;
                    }
                }
            }
        }
        std::array::from_fn(|i| (m[i][n] / m[i][i]) as f32)
    }

    #[test]
    fn a_start_within_the_margin_is_a_rise_where_the_stretch_starts() {
        // Starts 0.004 below zero, within the margin 0.01, dips, and crosses
        // zero well inside: the rise is given at the start (where the field
        // may already be inside), never as the whole stretch, whose far end
        // alone a snap would try.
        let c: Bernstein = [-0.004, -0.2, -0.2, 0.5, 0.5, -0.3, -0.3];
        assert_eq!(first_rise(&c, (10.0, 20.0), 0.01, 0.001), Rise::Within(10.0, 10.0));
        // Below the margin at the start, the crossing itself is narrowed.
        let c: Bernstein = [-0.1, -0.2, -0.2, 0.5, 0.5, 0.3, 0.3];
        let Rise::Within(a, b) = first_rise(&c, (10.0, 20.0), 0.01, 0.001) else { panic!("a root") };
        assert!(b - a <= 0.001 && a > 10.0, "{a} {b}");
    }
}
