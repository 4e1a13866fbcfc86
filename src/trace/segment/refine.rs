//! Root refinement: false position on a bracket around a crossing, then
//! the first point inside on the ray's lattice, so that a hit depends on the
//! field near it alone.

use crate::field::Field;
use crate::geom::Ray;

/// Illinois false position on a bracket `[a, b]` with `f(a) <= T < f(b)`, until
/// the bracket is narrower than `tol`. Returns the bracket and the evaluations spent.
pub(super) fn refine<F: Field + ?Sized>(
    field: &F,
    ray: &Ray,
    a: (f32, f32),
    b: (f32, f32),
    tol: f32,
) -> ((f32, f32), u32) {
    let iso = field.threshold();
    false_position(|t| field.value(ray.at(t)) - iso, a, b, tol)
}

/// Illinois false position for the root of `g` on a bracket `(a, g(a))`,
/// `(b, g(b))` with `g(a) <= 0 < g(b)`, until the bracket is narrower than
/// `tol` or 64 values are spent; the bracket and the values spent.
pub(crate) fn false_position(
    mut g: impl FnMut(f32) -> f32,
    (mut ta, mut va): (f32, f32),
    (mut tb, mut vb): (f32, f32),
    tol: f32,
) -> ((f32, f32), u32) {
    let mut evals = 0;
    let mut side = 0i8;
    while tb - ta > tol && evals < 64 {
        let secant = ta + (tb - ta) * (va / (va - vb));
        // Fall back to bisection when the secant lands outside or on the ends.
        let tm = if secant > ta && secant < tb { secant } else { 0.5 * (ta + tb) };
        let vm = g(tm);
        evals += 1;
        if vm > 0.0 {
            tb = tm;
            vb = vm;
            if side == 1 {
                va *= 0.5;
            }
            side = 1;
        } else {
            ta = tm;
            va = vm;
            if side == -1 {
                vb *= 0.5;
            }
            side = -1;
        }
    }
    ((ta, tb), evals)
}

/// Most lattice steps `snap` walks outwards to re-establish its bracket.
pub(crate) const MAX_SNAP_WALK: u32 = 64;

/// Where a crossing snapped to on the ray's lattice.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Snapped {
    /// The first lattice point inside.
    Hit(f32),
    /// No lattice point near the crossing is inside: the field touched the
    /// surface between two of them (or rounding said so), a feature below the
    /// precision asked for. The last lattice point found outside, and the
    /// field's value there less `T`, to march on from.
    Past(f32, f32),
}

/// The first lattice point `k · q` inside the surface after the crossing in
/// the narrow bracket `[a, b]`: bisection on the integers `k`, so the answer
/// depends only on the field at lattice points near the crossing. Returns it
/// (or where to march on from, when none is inside) and the evaluations spent.
pub(crate) fn snap<F: Field + ?Sized>(field: &F, ray: &Ray, a: f32, b: f32, q: f32) -> (Snapped, u32) {
    let iso = field.threshold();
    let mut evals = 0;
    let snapped = snap_on(
        |t| {
            evals += 1;
            field.value(ray.at(t)) - iso
        },
        a,
        b,
        q,
    );
    (snapped, evals)
}

/// [`snap`] with the field's value less `T` at distance `t` along the ray
/// given by `margin(t)`, which only its sign need get right.
pub(crate) fn snap_on(mut margin: impl FnMut(f32) -> f32, a: f32, b: f32, q: f32) -> Snapped {
    let mut margin = |k: i64| margin(k as f32 * q);
    let (mut lo, mut hi) = ((a / q).floor() as i64, (b / q).ceil() as i64);
    // Rounding outwards may have stepped across the crossing: walk back out.
    let mut walk = 0;
    while walk < MAX_SNAP_WALK && margin(lo) > 0.0 {
        lo -= 1;
        walk += 1;
    }
    let mut at_hi = margin(hi);
    while at_hi <= 0.0 {
        if walk == 2 * MAX_SNAP_WALK {
            return Snapped::Past(hi as f32 * q, at_hi);
        }
        hi += 1;
        walk += 1;
        at_hi = margin(hi);
    }
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if margin(mid) > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Snapped::Hit(hi as f32 * q)
}

#[cfg(test)]
mod tests {
    use glam::Vec3A;

    use super::*;
    use crate::field::AlongX;

    /// Along +x, a bump peaking `height` above `T = 0.5` at `peak`, and a wall
    /// inside from `wall` on.
    fn bump(peak: f32, height: f32, wall: f32) -> AlongX<impl Fn(f32) -> f32 + Sync> {
        AlongX(move |x: f32| if x >= wall { 1.0 } else { 0.5 + height - (x - peak).powi(2) })
    }

    #[test]
    fn a_touch_between_lattice_points_is_marched_past_and_a_wide_crossing_is_snapped() {
        let q = 1e-3;
        let ray = Ray::new(Vec3A::ZERO, Vec3A::X);
        // Inside over ±0.3 q around a point halfway between lattice points 1000 and 1001.
        let bump = bump(1000.5 * q, (0.3 * q) * (0.3 * q), 1.2);
        let (a, b) = (1000.3 * q, 1000.7 * q);
        assert!(bump.value(ray.at(0.5 * (a + b))) > 0.5);
        let (snapped, evals) = snap(&bump, &ray, a, b, q);
        let Snapped::Past(t, v) = snapped else { panic!("{snapped:?}: no lattice point is inside") };
        assert!(t > b && v <= 0.0 && bump.value(ray.at(t)) <= 0.5, "march on from {t} ({v})");
        assert!(evals <= 2 * MAX_SNAP_WALK + 2, "{evals}");
        // The wall's first lattice point inside, from a bracket around its face.
        let (snapped, _) = snap(&bump, &ray, 1.2 - 0.4 * q, 1.2 + 0.2 * q, q);
        assert_eq!(snapped, Snapped::Hit(1200.0 * q));
    }
}
