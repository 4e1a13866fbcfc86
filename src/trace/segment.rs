//! Segment tracing (Galin et al. 2020, *Segment Tracing Using Local Lipschitz
//! Bounds*): march along a ray with steps bounded by `|f - T| / λ`, where λ
//! bounds the slope of `f` over the next segment only, then refine the root.
//!
//! A step of `|f - T| / λ` cannot cross the iso-surface, because on that
//! segment `f` moves by at most `λ` per unit length: no crossing is skipped.

use glam::Vec3A;

use crate::field::{Field, outside_margin};
use crate::geom::{Ray, Region};

/// Knobs of the tracer, each with its trade-off.
#[derive(Clone, Copy, Debug)]
pub struct TraceOptions {
    /// Hit-distance tolerance as a fraction of the scene's bounding diagonal.
    /// Smaller costs a few more refinement evaluations per hit.
    pub tolerance: f32,
    /// Segment growth factor κ: the next segment is κ × the last step. Larger
    /// crosses empty space faster but takes looser (larger) slope bounds.
    pub growth: f32,
    /// First segment length as a fraction of the bounding diagonal.
    pub first_segment: f32,
    /// Steps before a ray is given up as a miss (only grazing rays come near).
    pub max_steps: u32,
    /// Hits are snapped to the first point inside the surface on the lattice
    /// `t = k · quantum` along the ray, so the hit depends on the field along
    /// the ray only, never on the steps that led there (which change with
    /// bounds elsewhere in the model). `None`: the hit tolerance.
    pub quantum: Option<f32>,
}

impl Default for TraceOptions {
    fn default() -> Self {
        Self { tolerance: 1e-5, growth: 2.0, first_segment: 1.0 / 16.0, max_steps: 1 << 14, quantum: None }
    }
}

impl TraceOptions {
    /// The defaults, with hits snapped to a lattice of the tolerance times the
    /// diagonal of `bounds` (fixed from then on, whatever edits do to the bounds).
    #[must_use]
    pub fn for_bounds(bounds: &crate::geom::Aabb) -> Self {
        let d = Self::default();
        Self { quantum: Some(d.tolerance * bounds.diagonal()), ..d }
    }
}

/// What tracing one ray found.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TraceResult {
    /// Distance to the first crossing into the surface, if any.
    pub hit: Option<f32>,
    /// Segment-tracing steps taken.
    pub steps: u32,
    /// Field evaluations (values and slope bounds), including root refinement.
    pub evals: u32,
}

/// Traces `ray` through `field`, returning the first entry into `f > T`.
pub fn trace_ray<F: Field + ?Sized>(field: &F, ray: &Ray, opts: &TraceOptions) -> TraceResult {
    let Some(span) = field.bounds().clip_ray(ray.origin, ray.dir.recip(), 0.0, f32::INFINITY) else {
        return TraceResult::default();
    };
    let (found, mut out) = march(field, ray, opts, span);
    out.hit = match found {
        // The eye (or the entry point) is already inside.
        Crossing::InsideAtStart => Some(span.0),
        Crossing::At(t) => Some(t),
        Crossing::None => None,
    };
    out
}

/// What marching a stretch of a ray found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Crossing {
    /// The stretch starts inside the surface.
    InsideAtStart,
    /// The first entry into the surface, snapped to the ray's lattice.
    At(f32),
    /// The field stays outside over the whole stretch.
    None,
}

/// Marches `ray` over `[span.0, span.1]` only (the field is taken as zero
/// beyond), returning the first crossing there and the work spent (`hit` unset).
/// A snapped crossing depends on the field near it only, so marching a stretch
/// that starts after a known crossing-free part finds what a whole trace finds.
pub fn march<F: Field + ?Sized>(
    field: &F,
    ray: &Ray,
    opts: &TraceOptions,
    (t_start, t_end): (f32, f32),
) -> (Crossing, TraceResult) {
    let mut out = TraceResult::default();
    if t_start >= t_end {
        return (Crossing::None, out);
    }
    let diag = field.bounds().diagonal();
    let tol = (opts.tolerance * diag).max(f32::EPSILON * t_end.abs());
    let iso = field.threshold();
    let outside = outside_margin(iso);
    let mut t = t_start;
    let mut v = field.value(ray.at(t)) - iso;
    out.evals = 1;
    if v > 0.0 {
        return (Crossing::InsideAtStart, out);
    }
    let mut segment = opts.first_segment * diag;
    let mut relax = true;
    let mut skipped = false;
    let mut probes_left = MAX_PROBES;
    // The point the last step started from, and the value there less `T`.
    let mut previous = None;
    // The gradient at `t`, when the value there came with it.
    let mut gradient = None;
    while out.steps < opts.max_steps {
        if !skipped {
            match skip_empty(field, ray, (t, t_end), tol) {
                Skip::ToEnd => return (Crossing::None, out),
                Skip::To(t_skip, v_skip) => {
                    (t, v, skipped, gradient, previous) = (t_skip, v_skip, true, None, None);
                    out.evals += 1;
                    continue;
                }
                Skip::No => {}
            }
        }
        skipped = false;
        out.steps += 1;
        let room = (t + segment).min(t_end) - t;
        // Steps are certified for the field as computed: `-v` less the
        // evaluation's rounding (see `outside_margin`).
        let margin = (-v - outside).max(0.0);
        // Near the surface a curvature step is longer than a Lipschitz one
        // in all but one step in two hundred on Medusa: take it alone
        // where the field's gradient is smooth enough to have one.
        let curved =
            if -v < CURVATURE_MARGIN * iso { curvature_step(field, ray, (t, gradient), margin, room) } else { None };
        let bound = curved.map_or_else(
            || {
                let halvings = if -v > HALVING_MARGIN * iso { MAX_BOUNDS_PER_STEP } else { 1 };
                bounded_step(field, ray, t, margin, room, halvings)
            },
            |c| c.bound,
        );
        out.evals += bound.bounds;
        // Near enough, a probe past the root the tangent points to (or, where
        // slope bounds alone step and close in by a fixed fraction, as on
        // cached lattices, the secant through the last two values) may settle
        // the hit at once.
        let probe = match (curved, previous) {
            (Some(c), _) => Some((c.slope, t + c.bound.room, Rise::Curved { curvature: c.curvature })),
            (None, Some((t_before, v_before))) if -v < CURVATURE_MARGIN * iso && v > v_before => {
                Some(((v - v_before) / (t - t_before), t_end, Rise::Floor))
            }
            _ => None,
        };
        if let Some((slope, reach, rise)) = probe
            && probes_left > 0
        {
            probes_left -= 1;
            let probe = Probe { at: (t, v), slope, certified: t + bound.step, reach, rise };
            let (found, evals) = probe_past_root(field, ray, &probe, opts.quantum.unwrap_or(tol));
            out.evals += evals;
            if let Some(root) = found {
                return (Crossing::At(root), out);
            }
        }
        let mut ahead = None;
        let t_next = if bound.step < tol && bound.step < bound.room {
            // Near the surface the bound's steps shrink towards the crossing:
            // walk the ray's lattice instead, which keeps grazing rays moving
            // and finds the first lattice point inside whatever stretch a
            // march starts from (a feature between two lattice points is
            // below the precision asked for). A step cut short by its segment
            // alone is taken whole, so that the segment grows again after a
            // walk on a lattice finer than the tolerance (the lattice is fixed
            // by the first frame's bounds; edits may grow the tolerance past it).
            lattice_step(t, bound.step, opts.quantum.unwrap_or(tol))
        } else if relax && curved.is_none() && bound.step < bound.room {
            // Try a longer step and keep it if the slope bound still shows,
            // from both of its ends, that it crosses nothing (Keinert et al.
            // 2014); after the first miss the march stays conservative.
            let s = (OVER_RELAXATION * bound.step).min(bound.room);
            let v_far = field.value(ray.at(t + s)) - iso;
            out.evals += 1;
            if v_far <= 0.0 && margin + (-v_far - outside) >= bound.slope * s {
                ahead = Some(v_far);
                t + s
            } else {
                relax = false;
                t + bound.step
            }
        } else {
            t + bound.step
        };
        if t_next >= t_end {
            // The field is zero on and beyond the end: nothing is left to hit.
            return (Crossing::None, out);
        }
        // After a curvature step the next is most likely one too: take the
        // gradient it will need with the value, for less than both apart.
        gradient = None;
        let v_next = ahead.unwrap_or_else(|| {
            out.evals += 1;
            if curved.is_some() {
                let (value, g) = field.value_and_gradient(ray.at(t_next));
                gradient = Some(g);
                value - iso
            } else {
                field.value(ray.at(t_next)) - iso
            }
        });
        let (t_next, v_next) = if v_next > 0.0 {
            let ((a, b), evals) = refine(field, ray, (t, v), (t_next, v_next), tol);
            let (snapped, snap_evals) = snap(field, ray, a, b, opts.quantum.unwrap_or(tol));
            out.evals += evals + snap_evals;
            match snapped {
                Snapped::Hit(root) => return (Crossing::At(root), out),
                // The surface was touched between lattice points only: march on.
                Snapped::Past(t_past, v_past) if t_past < t_end => (t_past, v_past),
                Snapped::Past(..) => return (Crossing::None, out),
            }
        } else {
            (t_next, v_next)
        };
        segment = opts.growth * (t_next - t);
        previous = Some((t, v));
        t = t_next;
        v = v_next;
    }
    (Crossing::None, out)
}

/// What the field's empty space allows from a point of a march.
enum Skip {
    /// Nothing: the point is not known to be in empty space.
    No,
    /// Empty space reaches the end of the stretch.
    ToEnd,
    /// A jump to this distance, with the field's value there less `T`.
    To(f32, f32),
}

/// Jumps from `t` over the empty space the field knows of, stopping `margin`
/// short of its end so that rounding cannot carry the jump past a face.
fn skip_empty<F: Field + ?Sized>(field: &F, ray: &Ray, (t, t_end): (f32, f32), margin: f32) -> Skip {
    let Some(end) = field.skip_empty(ray, t, t_end) else { return Skip::No };
    if end >= t_end {
        return Skip::ToEnd;
    }
    let to = end - margin;
    if to <= t {
        return Skip::No;
    }
    let v = field.value(ray.at(to)) - field.threshold();
    // Inside cannot happen in empty space; were rounding to disagree, step as usual.
    if v > 0.0 { Skip::No } else { Skip::To(to, v) }
}

/// The farthest lattice point `k · q` within a certified `step` from `t`, or,
/// when there is none, the first after `t`. The points passed over are inside
/// the step, so none is inside the surface; with a lattice finer than the
/// tolerance (after edits grew the model) the walk passes several at a time.
fn lattice_step(t: f32, step: f32, q: f32) -> f32 {
    let farthest = ((t + step) / q).floor() * q;
    if farthest > t && farthest <= t + step { farthest } else { next_lattice_point(t, q) }
}

/// The first point `k · q` after `t`. The quotient `t / q` may round up past
/// a lattice point an ulp above `t`; counting back first keeps that point.
fn next_lattice_point(t: f32, q: f32) -> f32 {
    let mut k = (t / q).floor();
    while k * q > t {
        k -= 1.0;
    }
    while k * q <= t {
        k += 1.0;
    }
    k * q
}

/// How far from a crossing the field can influence where the crossing is
/// snapped: a change farther than this from a hit cannot move it.
#[must_use]
pub(super) fn snap_reach(opts: &TraceOptions, diag: f32) -> f32 {
    // Refinement stays within a tolerance of the crossing; snapping walks up
    // to 2 × MAX_SNAP_WALK lattice steps from it. Doubled for rounding.
    let tol = opts.tolerance * diag;
    4.0 * (MAX_SNAP_WALK as f32 + 1.0) * opts.quantum.unwrap_or(tol).max(tol)
}

/// The longest step from `t` that a slope bound shows cannot reach the
/// surface, given the `margin` `T - f(t)` and the segment length `room` to
/// bound over, with the bound and segment that gave it. A bound over the
/// whole segment is as steep as its steepest part, so when the far part is
/// steep (the ray nears other primitives) the segment is halved while that
/// can lengthen the step: crossing empty space next to dense parts costs one
/// extra bound instead of restarting the segment's growth.
fn bounded_step<F: Field + ?Sized>(
    field: &F,
    ray: &Ray,
    t: f32,
    margin: f32,
    mut room: f32,
    max_bounds: u32,
) -> BoundedStep {
    let mut best = BoundedStep { step: 0.0, slope: 0.0, room, bounds: 0 };
    while room > best.step && best.bounds < max_bounds {
        let slope = field.lipschitz(&Region::Segment(ray.at(t), ray.at(t + room)));
        best.bounds += 1;
        let step = if slope > 0.0 { (margin / slope).min(room) } else { room };
        if step > best.step {
            (best.step, best.slope, best.room) = (step, slope, room);
        }
        room *= 0.5;
    }
    best
}

/// The longest step from `t` that a bound on the field's second derivative
/// along the ray shows cannot reach the surface, given the margin
/// `m = T - f(t)` and the segment length `room` to bound over; `None` where
/// the field has no such bound.
///
/// Along the ray `f(t + s) <= f(t) + g s + M s² / 2` with `g` the derivative
/// at `t` and `M` the bound, so no crossing comes before the root of
/// `m = g s + M s² / 2`. Approaching a surface, `g` is the true slope where a
/// Lipschitz bound takes the steepest anywhere near: the steps close in on
/// the surface quadratically instead of by a fixed fraction. The gradient
/// at `t` is taken from `gradient` when the march has it already.
fn curvature_step<F: Field + ?Sized>(
    field: &F,
    ray: &Ray,
    (t, gradient): (f32, Option<Vec3A>),
    m: f32,
    room: f32,
) -> Option<CurvedStep> {
    let curvature = field.curvature(&Region::Segment(ray.at(t), ray.at(t + room)));
    if !curvature.is_finite() {
        return None;
    }
    let g = gradient.unwrap_or_else(|| field.gradient(ray.at(t))).dot(ray.dir);
    if !g.is_finite() {
        return None;
    }
    // The positive root of M s²/2 + g s - m, in the form without
    // cancellation; none when the field cannot rise (g <= 0, M <= 0).
    let denominator = g + (g * g + 2.0 * curvature.max(0.0) * m).sqrt();
    // Shortened a little against rounding in f, g and the root.
    let step = if denominator > 0.0 { (CURVATURE_SAFETY * 2.0 * m / denominator).min(room) } else { room };
    // Counted as two evaluations: the bound and the gradient.
    Some(CurvedStep { bound: BoundedStep { step, slope: f32::INFINITY, room, bounds: 2 }, curvature, slope: g })
}

/// A step certified by a bound on the second derivative, with what it was
/// taken from.
#[derive(Clone, Copy)]
struct CurvedStep {
    /// The step.
    bound: BoundedStep,
    /// The bound `M` on the second derivative along the ray over `bound.room`.
    curvature: f32,
    /// The derivative along the ray at the step's start.
    slope: f32,
}

/// A step certified by a slope bound.
#[derive(Clone, Copy)]
struct BoundedStep {
    /// Its length.
    step: f32,
    /// The bound, valid over `room` from the start.
    slope: f32,
    /// The length the bound covers.
    room: f32,
    /// Bounds taken to find it.
    bounds: u32,
}

/// Curvature steps are tried where `T - f` is below this fraction of `T`:
/// near the surface, where the Lipschitz steps shrink by a fixed fraction.
const CURVATURE_MARGIN: f32 = 0.3;
/// The fraction of a curvature step taken.
const CURVATURE_SAFETY: f32 = 0.999;

/// How much longer than certified an over-relaxed step tries to be.
const OVER_RELAXATION: f32 = 1.4;

/// Most slope bounds taken for one step (each halving the segment).
const MAX_BOUNDS_PER_STEP: u32 = 3;
/// Segments are halved only where `T - f` exceeds this fraction of `T`:
/// nearly empty space. Approaching a surface the bound is steep all along the
/// segment, and halving would only spend bounds.
const HALVING_MARGIN: f32 = 0.9;

/// Illinois false position on a bracket `[a, b]` with `f(a) <= T < f(b)`, until
/// the bracket is narrower than `tol`. Returns the bracket and the evaluations spent.
fn refine<F: Field + ?Sized>(field: &F, ray: &Ray, a: (f32, f32), b: (f32, f32), tol: f32) -> ((f32, f32), u32) {
    let iso = field.threshold();
    let ((mut ta, mut va), (mut tb, mut vb)) = (a, b);
    let mut evals = 0;
    let mut side = 0i8;
    while tb - ta > tol && evals < 64 {
        let secant = ta + (tb - ta) * (va / (va - vb));
        // Fall back to bisection when the secant lands outside or on the ends.
        let tm = if secant > ta && secant < tb { secant } else { 0.5 * (ta + tb) };
        let vm = field.value(ray.at(tm)) - iso;
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

/// Probes past the Newton root are tried at most this often per march: one
/// that lands outside (the field bends away) is seldom followed by one that
/// lands inside soon.
const MAX_PROBES: u32 = 4;
/// A probe is tried once the Newton root is at most this many lattice steps
/// ahead: farther, the certified steps close in for fewer evaluations than
/// a search of the bracket takes.
const MAX_PROBE_LATTICE_STEPS: f32 = 2048.0;
/// The probe lands this fraction past the Newton root (and a lattice step
/// more), so that a field bending slightly away still puts it inside.
const PROBE_OVERSHOOT: f32 = 0.2;

/// What shows the field rising from a probe back to a certified point.
#[derive(Clone, Copy)]
enum Rise {
    /// The bound `M` on the second derivative along the ray, valid up to the
    /// probe's reach: `f'(s) >= f'(b) - M (b - s)`, with the derivative
    /// `f'(b)` taken at the probe.
    Curved { curvature: f32 },
    /// The field's own lower bound on its derivative along the stretch
    /// ([`Field::slope_floor`]).
    Floor,
}

/// A probe past the root the tangent (or secant) at `at` points to.
struct Probe {
    /// Where the march is, and the value there less `T`.
    at: (f32, f32),
    /// The field's derivative along the ray there, or an estimate of it.
    slope: f32,
    /// How far the march's current step shows the field outside.
    certified: f32,
    /// The farthest the probe may land: the end of the march's stretch, or
    /// of the curvature bound's segment.
    reach: f32,
    rise: Rise,
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
fn probe_past_root<F: Field + ?Sized>(field: &F, ray: &Ray, probe: &Probe, q: f32) -> (Option<f32>, u32) {
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

/// Most lattice steps `snap` walks outwards to re-establish its bracket.
const MAX_SNAP_WALK: u32 = 64;

/// Where a crossing snapped to on the ray's lattice.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Snapped {
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
fn snap<F: Field + ?Sized>(field: &F, ray: &Ray, a: f32, b: f32, q: f32) -> (Snapped, u32) {
    let iso = field.threshold();
    let mut evals = 0;
    let mut margin = |k: i64| {
        evals += 1;
        field.value(ray.at(k as f32 * q)) - iso
    };
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
            return (Snapped::Past(hi as f32 * q, at_hi), evals);
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
    (Snapped::Hit(hi as f32 * q), evals)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::AlongX;

    /// Along +x, a bump peaking `height` above `T = 0.5` at `peak`, and a wall
    /// inside from `wall` on.
    fn bump(peak: f32, height: f32, wall: f32) -> AlongX<impl Fn(f32) -> f32 + Sync> {
        AlongX(move |x: f32| if x >= wall { 1.0 } else { 0.5 + height - (x - peak).powi(2) })
    }

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

    #[test]
    fn lattice_walks_skip_no_lattice_point_they_do_not_certify() {
        let q = 8.608_999e-5;
        let mut just_below = 0;
        for k in 1..200_000 {
            let point = k as f32 * q;
            let below = f32::from_bits(point.to_bits() - 1);
            // From an ulp below a lattice point, that point is the next one.
            assert_eq!(next_lattice_point(below, q), point, "k = {k}");
            just_below += usize::from((below / q).floor() as i64 == k);
            // A step certifying several lattice points passes to the last of them.
            let t = below - 2.5 * q;
            let to = lattice_step(t, 3.0 * q, q);
            assert!(to > t && to <= t + 3.0 * q && (to / q).round() * q == to, "k = {k}: {t} -> {to}");
        }
        assert!(just_below > 1000, "the quotient rounded up only {just_below} times");
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
