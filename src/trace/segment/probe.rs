//! Probes past the root the tangent (or secant) at a point of a march points
//! to: where the field is shown to rise all the way, the first lattice point
//! inside is found by false position on the lattice, without further steps.

use crate::field::{Field, outside_margin};
use crate::geom::Ray;

/// Probes past the Newton root are tried at most this often per march: one
/// that lands outside (the field bends away) is seldom followed by one that
/// lands inside soon.
pub(super) const MAX_PROBES: u32 = 4;
/// A probe is tried once the Newton root is at most this many lattice steps
/// ahead: farther, the certified steps close in for fewer evaluations than
/// a search of the bracket takes.
const MAX_PROBE_LATTICE_STEPS: f32 = 2048.0;
/// The probe lands this fraction past the Newton root (and a lattice step
/// more), so that a field bending slightly away still puts it inside.
const PROBE_OVERSHOOT: f32 = 0.2;

/// What shows the field rising from a probe back to a certified point.
#[derive(Clone, Copy)]
pub(super) enum Rise {
    /// The bound `M` on the second derivative along the ray, valid up to the
    /// probe's reach: `f'(s) >= f'(b) - M (b - s)`, with the derivative
    /// `f'(b)` taken at the probe.
    Curved { curvature: f32 },
    /// The field's own lower bound on its derivative along the stretch
    /// ([`Field::slope_floor`]).
    Floor,
}

/// A probe past the root the tangent (or secant) at `at` points to.
pub(super) struct Probe {
    /// Where the march is, and the value there less `T`.
    pub(super) at: (f32, f32),
    /// The field's derivative along the ray there, or an estimate of it.
    pub(super) slope: f32,
    /// How far the march's current step shows the field outside.
    pub(super) certified: f32,
    /// The farthest the probe may land: the end of the march's stretch, or
    /// of the curvature bound's segment.
    pub(super) reach: f32,
    pub(super) rise: Rise,
}

/// The first lattice point inside, found from a point of a march without
/// further steps, when the field allows it.
///
/// A lattice point a little past the estimated root is probed. If it is
/// inside, and `rise` shows the field rising along the whole stretch from
/// the certified end of the march's step to the probe by more than its
/// rounding per lattice step, then the lattice points there change from
/// outside to inside exactly once: the first inside is found by false
/// position on the lattice indices, and it is the very point a march walking
/// the lattice would stop at. Otherwise nothing is found and the march goes
/// on as if no probe was taken. Returns the evaluations spent.
pub(super) fn probe_past_root<F: Field + ?Sized>(field: &F, ray: &Ray, probe: &Probe, q: f32) -> (Option<f32>, u32) {
    let ((t, v), certified) = (probe.at, probe.certified);
    let estimate = -v / probe.slope;
    let hi = ((t + estimate * (1.0 + PROBE_OVERSHOOT) + q) / q).ceil() as i64;
    let b = hi as f32 * q;
    if !(probe.slope > 0.0 && estimate <= MAX_PROBE_LATTICE_STEPS * q && b <= probe.reach) {
        return (None, 0);
    }
    let iso = field.threshold();
    let (v_hi, rising, evals) = match probe.rise {
        Rise::Curved { curvature } => {
            let (value, gradient) = field.value_and_gradient(ray.at(b));
            (value - iso, gradient.dot(ray.dir) - curvature.max(0.0) * (b - certified), 1)
        }
        Rise::Floor => {
            // The bound first: without one the probe is not worth its value.
            let Some(floor) = field.slope_floor(ray.at(certified), ray.at(b)) else { return (None, 0) };
            if floor * q <= 2.0 * outside_margin(iso) {
                return (None, 1);
            }
            (field.value(ray.at(b)) - iso, floor, 2)
        }
    };
    if v_hi <= 0.0 || rising * q <= 2.0 * outside_margin(iso) {
        return (None, evals);
    }
    let lo = (certified / q).floor() as i64;
    let v_lo = field.value(ray.at(lo as f32 * q)) - iso;
    if v_lo > 0.0 || lo >= hi {
        // Rounding put the certified end inside: leave it to the march.
        return (None, evals + 1);
    }
    let (first, search) = first_inside(field, ray, q, (lo, v_lo), (hi, v_hi));
    (Some(first as f32 * q), evals + 1 + search)
}

/// The first lattice index inside in `(lo, hi]`, given `lo` outside, `hi`
/// inside and one change between them: false position on the indices,
/// halving a stale end's value (Illinois), so a few evaluations narrow a
/// bracket of hundreds of lattice steps. Returns it and the evaluations spent.
fn first_inside<F: Field + ?Sized>(
    field: &F,
    ray: &Ray,
    q: f32,
    (mut lo, mut v_lo): (i64, f32),
    (mut hi, mut v_hi): (i64, f32),
) -> (i64, u32) {
    let iso = field.threshold();
    let (mut evals, mut side) = (0, 0i8);
    while hi - lo > 1 {
        let at = lo as f32 + (hi - lo) as f32 * (v_lo / (v_lo - v_hi));
        let k = (at.round() as i64).clamp(lo + 1, hi - 1);
        let v = field.value(ray.at(k as f32 * q)) - iso;
        evals += 1;
        if v > 0.0 {
            (hi, v_hi) = (k, v);
            if side == 1 {
                v_lo *= 0.5;
            }
            side = 1;
        } else {
            (lo, v_lo) = (k, v);
            if side == -1 {
                v_hi *= 0.5;
            }
            side = -1;
        }
    }
    (hi, evals)
}

#[cfg(test)]
mod tests {
    use glam::Vec3A;

    use super::*;
    use crate::field::AlongX;
    use crate::geom::Region;
    use crate::trace::segment::CURVATURE_SAFETY;

    /// The first lattice index `k > from` with `f(k q)` inside, by walking.
    fn first_inside_by_walking(field: &impl Field, ray: &Ray, from: f32, q: f32) -> i64 {
        let mut k = (from / q).floor() as i64;
        while field.value(ray.at(k as f32 * q)) <= field.threshold() {
            k += 1;
        }
        k
    }

    /// Probes; where it finds a point, asserts it is the walk's and returns the evaluations spent.
    fn probes_as_walked(field: &impl Field, ray: &Ray, probe: &Probe, q: f32, case: &str) -> Option<u32> {
        let (found, evals) = probe_past_root(field, ray, probe, q);
        let walked = first_inside_by_walking(field, ray, probe.at.0, q) as f32 * q;
        assert!(found.is_none_or(|hit| hit == walked), "{case}: probe {found:?}, walk {walked}");
        found.map(|_| evals)
    }

    #[test]
    fn a_probe_past_the_newton_root_finds_the_lattice_point_a_walk_finds_or_declines() {
        let q = 1e-3;
        let ray = Ray::new(Vec3A::ZERO, Vec3A::X);
        let (mut found, mut declined) = (0, 0);
        // Parabolas `T + s (x - r) + c (x - r)² / 2`, bending towards the
        // surface and away from it, approached from several distances.
        for (slope, bend) in [(2.0f32, 30.0f32), (2.0, -30.0), (0.5, 200.0), (1.0, -400.0), (3.0, 0.0)] {
            let root = 1.0003;
            let field = AlongX(move |x: f32| 0.5 + slope * (x - root) + 0.5 * bend * (x - root).powi(2));
            for back in [0.002f32, 0.01, 0.05, 0.2] {
                let t = root - back;
                let v = field.value(ray.at(t)) - 0.5;
                if v >= 0.0 || slope + bend * (t - root) <= 0.0 {
                    continue;
                }
                let room = 4.0 * back + 0.01;
                // The exact second derivative bounds itself; the certified step as the tracer takes it.
                let g = slope + bend * (t - root);
                let step = CURVATURE_SAFETY * 2.0 * -v / (g + (g * g + 2.0 * bend.max(0.0) * -v).sqrt());
                let rise = Rise::Curved { curvature: bend };
                let probe = Probe { at: (t, v), slope: g, certified: t + step, reach: t + room, rise };
                match probes_as_walked(&field, &ray, &probe, q, &format!("slope {slope}, bend {bend}, {back} before")) {
                    Some(evals) => {
                        assert!(evals <= 12, "{evals} evaluations");
                        found += 1;
                    }
                    None => declined += 1,
                }
            }
        }
        // Fields bending away from the surface put some probes outside.
        assert!(found >= 10 && declined >= 1, "{found} found, {declined} declined");
    }

    #[test]
    fn a_probe_declines_where_the_curvature_bound_allows_a_dip_before_it() {
        let q = 1e-3;
        let ray = Ray::new(Vec3A::ZERO, Vec3A::X);
        // A steep rise to a first crossing, a dip back outside, and the rise
        // the tangent at the start points to: the first lattice point inside
        // is the narrow peak's, which only a bound of the peak's bend allows.
        let field = AlongX(|x: f32| {
            let peak = 0.5 + 1e-3 - 400.0 * (x - 1.0).powi(2);
            (0.5 + (x - 1.02)).max(peak)
        });
        let t = 0.99;
        let v = field.value(ray.at(t)) - 0.5;
        let probe = Probe {
            at: (t, v),
            slope: 1.0,
            certified: t + 1e-4,
            reach: t + 0.1,
            rise: Rise::Curved { curvature: 800.0 },
        };
        probes_as_walked(&field, &ray, &probe, q, "a peak");
    }

    /// A field along x that knows a floor on its slope.
    struct Floored<V>(AlongX<V>, f32);

    impl<V: Fn(f32) -> f32 + Sync> Field for Floored<V> {
        fn value(&self, p: Vec3A) -> f32 {
            self.0.value(p)
        }
        fn gradient(&self, p: Vec3A) -> Vec3A {
            self.0.gradient(p)
        }
        fn color(&self, p: Vec3A) -> glam::Vec3 {
            self.0.color(p)
        }
        fn interval(&self, b: &crate::geom::Aabb) -> crate::geom::Interval {
            self.0.interval(b)
        }
        fn lipschitz(&self, region: &Region) -> f32 {
            self.0.lipschitz(region)
        }
        fn slope_floor(&self, _: Vec3A, _: Vec3A) -> Option<f32> {
            Some(self.1)
        }
        fn bounds(&self) -> crate::geom::Aabb {
            self.0.bounds()
        }
        fn threshold(&self) -> f32 {
            0.5
        }
    }

    #[test]
    fn a_secant_probe_finds_the_walked_lattice_point_where_the_slope_floor_shows_a_rise() {
        let q = 1e-3;
        let ray = Ray::new(Vec3A::ZERO, Vec3A::X);
        let (mut found, mut declined) = (0, 0);
        // A line through `T` at 1.0003 with ripples of amplitude `a` and
        // frequency 50: its slope stays above `slope - 50 a`, which is the floor.
        for (slope, ripple) in [(2.0f32, 0.01f32), (1.0, 0.015), (0.5, 0.02), (0.3, 0.01)] {
            let line = move |x: f32| 0.5 + slope * (x - 1.0003) + ripple * (50.0 * x).sin();
            let field = Floored(AlongX(line), slope - 50.0 * ripple);
            for back in [0.003f32, 0.02, 0.08] {
                let t = 1.0003 - back;
                let v = field.value(ray.at(t)) - 0.5;
                if v >= 0.0 {
                    continue;
                }
                let probe = Probe { at: (t, v), slope, certified: t, reach: 10.0, rise: Rise::Floor };
                match probes_as_walked(
                    &field,
                    &ray,
                    &probe,
                    q,
                    &format!("slope {slope}, ripple {ripple}, {back} before"),
                ) {
                    Some(_) => found += 1,
                    None => declined += 1,
                }
            }
        }
        // The ripples of the last two fields can turn their slope negative.
        assert!(found >= 5 && declined >= 4, "{found} found, {declined} declined");
    }
}
