//! Segment tracing (Galin et al. 2020, *Segment Tracing Using Local Lipschitz
//! Bounds*): march along a ray with steps bounded by `|f - T| / λ`, where λ
//! bounds the slope of `f` over the next segment only, then refine the root.
//!
//! A step of `|f - T| / λ` cannot cross the iso-surface, because on that
//! segment `f` moves by at most `λ` per unit length: no crossing is skipped.
//!
//! - `probe`: probes past the root a tangent or secant points to, which may
//!   settle a hit without further steps;
//! - `refine`: root refinement on a bracket, and snapping to the ray's lattice.

mod probe;
mod refine;

use glam::Vec3A;

use crate::field::{Field, outside_margin};
use crate::geom::{Ray, Region};
use probe::{MAX_PROBES, Probe, Rise, probe_past_root};
pub(crate) use refine::MAX_SNAP_WALK;
use refine::refine;
pub(crate) use refine::{Snapped, false_position, snap, snap_on};

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
    /// The hit tolerance for a model `diag` across, on a stretch of a ray
    /// ending at `t_end` (never below what single precision resolves there).
    #[must_use]
    pub fn hit_tolerance(&self, diag: f32, t_end: f32) -> f32 {
        (self.tolerance * diag).max(f32::EPSILON * t_end.abs())
    }

    /// The step of the lattice hits are snapped to (see [`TraceOptions::quantum`]).
    #[must_use]
    pub fn hit_quantum(&self, diag: f32, t_end: f32) -> f32 {
        self.quantum.unwrap_or_else(|| self.hit_tolerance(diag, t_end))
    }

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
    trace_ray_from(field, ray, opts, 0.0)
}

/// [`trace_ray`], knowing the ray holds no crossing before distance `near`
/// (see [`crate::trace::Coverage`]): the march starts there, and finds the
/// same hit.
pub fn trace_ray_from<F: Field + ?Sized>(field: &F, ray: &Ray, opts: &TraceOptions, near: f32) -> TraceResult {
    let Some((t_enter, t_exit)) = field.bounds().clip_ray(ray.origin, ray.dir.recip(), 0.0, f32::INFINITY) else {
        return TraceResult::default();
    };
    let start = near.max(t_enter);
    let (found, mut out) = march(field, ray, opts, (start, t_exit));
    out.hit = match found {
        Crossing::At(t) => Some(t),
        Crossing::None => None,
        // The eye (or the entry point) is already inside.
        Crossing::InsideAtStart if start == t_enter => Some(t_enter),
        // Inside at `near`, against the proof (within rounding): trace the ray whole.
        Crossing::InsideAtStart => {
            let whole = trace_ray(field, ray, opts);
            return TraceResult { steps: out.steps + whole.steps, evals: out.evals + whole.evals, ..whole };
        }
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
    span: (f32, f32),
) -> (Crossing, TraceResult) {
    let mut march = match March::start(field, ray, opts, span) {
        Ok(march) => march,
        Err(ended) => return ended,
    };
    while march.out.steps < opts.max_steps {
        if let Some(found) = march.step() {
            return (found, march.out);
        }
    }
    (Crossing::None, march.out)
}

/// A march in progress along one stretch of a ray: where it is, what it
/// knows there, and the work spent so far.
struct March<'a, F: ?Sized> {
    field: &'a F,
    ray: &'a Ray,
    opts: &'a TraceOptions,
    /// The end of the stretch.
    t_end: f32,
    /// The hit tolerance (and the lattice step, where the options fix none).
    tol: f32,
    /// The iso-value `T`.
    iso: f32,
    /// How far below `T` a value counts as outside (see [`outside_margin`]).
    outside: f32,
    /// Where the march is.
    t: f32,
    /// The value there, less `T`.
    v: f32,
    /// The length the next step's bounds cover.
    segment: f32,
    /// Whether over-relaxed steps are still tried.
    relax: bool,
    /// Whether the march has just jumped over empty space.
    skipped: bool,
    probes_left: u32,
    /// The point the last step started from, and the value there less `T`.
    previous: Option<(f32, f32)>,
    /// The gradient at `t`, when the value there came with it.
    gradient: Option<Vec3A>,
    out: TraceResult,
}

impl<'a, F: Field + ?Sized> March<'a, F> {
    /// The march over `t_start..t_end`, or what it found where it ends before
    /// its first step: an empty stretch, or one starting inside.
    #[inline]
    fn start(
        field: &'a F,
        ray: &'a Ray,
        opts: &'a TraceOptions,
        (t_start, t_end): (f32, f32),
    ) -> Result<Self, (Crossing, TraceResult)> {
        let mut out = TraceResult::default();
        if t_start >= t_end {
            return Err((Crossing::None, out));
        }
        let diag = field.bounds().diagonal();
        let tol = opts.hit_tolerance(diag, t_end);
        let iso = field.threshold();
        let v = field.value(ray.at(t_start)) - iso;
        out.evals = 1;
        if v > 0.0 {
            return Err((Crossing::InsideAtStart, out));
        }
        Ok(Self {
            field,
            ray,
            opts,
            t_end,
            tol,
            iso,
            outside: outside_margin(iso),
            t: t_start,
            v,
            segment: opts.first_segment * diag,
            relax: true,
            skipped: false,
            probes_left: MAX_PROBES,
            previous: None,
            gradient: None,
            out,
        })
    }

    /// The step of a ray's lattice snapped hits lie on.
    #[inline]
    fn quantum(&self) -> f32 {
        self.opts.quantum.unwrap_or(self.tol)
    }

    /// One step of the march: a jump over the empty space the field knows
    /// of, or a certified step, which a probe past the root or a crossing it
    /// brackets may end the march with. `Some` with what the march found
    /// where it ends.
    #[inline]
    fn step(&mut self) -> Option<Crossing> {
        if !self.skipped {
            match skip_empty(self.field, self.ray, (self.t, self.t_end), self.tol) {
                Skip::ToEnd => return Some(Crossing::None),
                Skip::To(t_skip, v_skip) => {
                    self.skip_to(t_skip, v_skip);
                    return None;
                }
                Skip::No => {}
            }
        }
        self.skipped = false;
        self.out.steps += 1;
        let room = (self.t + self.segment).min(self.t_end) - self.t;
        // Steps are certified for the field as computed: `-v` less the
        // evaluation's rounding (see `outside_margin`).
        let margin = (-self.v - self.outside).max(0.0);
        let (curved, bound) = self.certified_step(margin, room);
        self.out.evals += bound.bounds;
        if let Some(root) = self.probe(curved, &bound) {
            return Some(Crossing::At(root));
        }
        let (t_next, ahead) = self.next_point(curved.is_some(), &bound, margin);
        if t_next >= self.t_end {
            // The field is zero on and beyond the end: nothing is left to hit.
            return Some(Crossing::None);
        }
        self.gradient = None;
        let v_next = ahead.unwrap_or_else(|| self.value_at(t_next, curved.is_some()));
        match self.settle(t_next, v_next) {
            Ok((t_next, v_next)) => {
                self.advance(t_next, v_next);
                None
            }
            Err(found) => Some(found),
        }
    }

    /// Jumps to `t` (value `v` less `T`) past empty space: what the march
    /// knew of the point it left holds no more.
    #[inline]
    fn skip_to(&mut self, t: f32, v: f32) {
        (self.t, self.v, self.skipped, self.gradient, self.previous) = (t, v, true, None, None);
        self.out.evals += 1;
    }

    /// The step from `t` its bounds over `room` certify, given the `margin`
    /// `T - f(t)` less rounding, with the curvature step it came from, if any.
    #[inline]
    fn certified_step(&self, margin: f32, room: f32) -> (Option<CurvedStep>, BoundedStep) {
        let (field, ray, t, v, iso) = (self.field, self.ray, self.t, self.v, self.iso);
        // Near the surface a curvature step is longer than a Lipschitz one
        // in all but one step in two hundred on Medusa: take it alone
        // where the field's gradient is smooth enough to have one.
        let curved = if -v < CURVATURE_MARGIN * iso {
            curvature_step(field, ray, (t, self.gradient), margin, room)
        } else {
            None
        };
        let bound = curved.map_or_else(
            || {
                let halvings = if -v > HALVING_MARGIN * iso { MAX_BOUNDS_PER_STEP } else { 1 };
                bounded_step(field, ray, t, margin, room, halvings)
            },
            |c| c.bound,
        );
        (curved, bound)
    }

    /// Near enough, a probe past the root the tangent points to (or, where
    /// slope bounds alone step and close in by a fixed fraction, as on
    /// cached lattices, the secant through the last two values) may settle
    /// the hit at once: the first lattice point inside, where it finds one.
    #[inline]
    fn probe(&mut self, curved: Option<CurvedStep>, bound: &BoundedStep) -> Option<f32> {
        let (t, v) = (self.t, self.v);
        let (slope, reach, rise) = match (curved, self.previous) {
            (Some(c), _) => (c.slope, t + c.bound.room, Rise::Curved { curvature: c.curvature }),
            (None, Some((t_before, v_before))) if -v < CURVATURE_MARGIN * self.iso && v > v_before => {
                ((v - v_before) / (t - t_before), self.t_end, Rise::Floor)
            }
            _ => return None,
        };
        if self.probes_left == 0 {
            return None;
        }
        self.probes_left -= 1;
        let probe = Probe { at: (t, v), slope, certified: t + bound.step, reach, rise };
        let (found, evals) = probe_past_root(self.field, self.ray, &probe, self.quantum());
        self.out.evals += evals;
        found
    }

    /// Where the certified step `bound` takes the march, and the value
    /// there less `T` when it is known already.
    #[inline]
    fn next_point(&mut self, curved: bool, bound: &BoundedStep, margin: f32) -> (f32, Option<f32>) {
        if bound.step < self.tol && bound.step < bound.room {
            // Near the surface the bound's steps shrink towards the crossing:
            // walk the ray's lattice instead, which keeps grazing rays moving
            // and finds the first lattice point inside whatever stretch a
            // march starts from (a feature between two lattice points is
            // below the precision asked for). A step cut short by its segment
            // alone is taken whole, so that the segment grows again after a
            // walk on a lattice finer than the tolerance (the lattice is fixed
            // by the first frame's bounds; edits may grow the tolerance past it).
            (lattice_step(self.t, bound.step, self.quantum()), None)
        } else if self.relax && !curved && bound.step < bound.room {
            self.over_relaxed(bound, margin)
        } else {
            (self.t + bound.step, None)
        }
    }

    /// Tries a longer step than `bound` certifies and keeps it, with the value
    /// at its end, if the slope bound still shows, from both of its ends,
    /// that it crosses nothing (Keinert et al. 2014); after the first miss
    /// the march stays conservative.
    #[inline]
    fn over_relaxed(&mut self, bound: &BoundedStep, margin: f32) -> (f32, Option<f32>) {
        let t = self.t;
        let s = (OVER_RELAXATION * bound.step).min(bound.room);
        let v_far = self.field.value(self.ray.at(t + s)) - self.iso;
        self.out.evals += 1;
        if v_far <= 0.0 && margin + (-v_far - self.outside) >= bound.slope * s {
            (t + s, Some(v_far))
        } else {
            self.relax = false;
            (t + bound.step, None)
        }
    }

    /// The value less `T` at `t_next`. After a curvature step the next is
    /// most likely one too: the gradient it will need is taken with the
    /// value, for less than both apart.
    #[inline]
    fn value_at(&mut self, t_next: f32, curved: bool) -> f32 {
        self.out.evals += 1;
        if curved {
            let (value, g) = self.field.value_and_gradient(self.ray.at(t_next));
            self.gradient = Some(g);
            value - self.iso
        } else {
            self.field.value(self.ray.at(t_next)) - self.iso
        }
    }

    /// Where the march goes on from after stepping to `t_next` (value
    /// `v_next` less `T`): there, or, where the step crossed into the
    /// surface, past a touch between lattice points; `Err` with what the
    /// march found where it ends.
    #[inline]
    fn settle(&mut self, t_next: f32, v_next: f32) -> Result<(f32, f32), Crossing> {
        if v_next > 0.0 {
            let ((a, b), evals) = refine(self.field, self.ray, (self.t, self.v), (t_next, v_next), self.tol);
            let (snapped, snap_evals) = snap(self.field, self.ray, a, b, self.quantum());
            self.out.evals += evals + snap_evals;
            match snapped {
                Snapped::Hit(root) => Err(Crossing::At(root)),
                // The surface was touched between lattice points only: march on.
                Snapped::Past(t_past, v_past) if t_past < self.t_end => Ok((t_past, v_past)),
                Snapped::Past(..) => Err(Crossing::None),
            }
        } else {
            Ok((t_next, v_next))
        }
    }

    /// Moves the march to `t_next`, the next segment grown from the step taken.
    #[inline]
    fn advance(&mut self, t_next: f32, v_next: f32) {
        self.segment = self.opts.growth * (t_next - self.t);
        self.previous = Some((self.t, self.v));
        (self.t, self.v) = (t_next, v_next);
    }
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
/// Past 2²⁴ steps from the eye (a camera hundreds of model sizes away) the
/// floats hold only some of the `k`, and the count goes from one to the
/// next: counting by ones there would stand still, and the march not end.
fn next_lattice_point(t: f32, q: f32) -> f32 {
    let mut k = (t / q).floor();
    while k * q > t {
        k = if k - 1.0 < k { k - 1.0 } else { k.next_down() };
    }
    while k * q <= t {
        k = if k + 1.0 > k { k + 1.0 } else { k.next_up() };
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

#[cfg(test)]
mod tests {
    use super::*;

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
    fn lattice_points_are_found_past_two_to_the_twenty_four_steps() {
        // A camera thousands of model sizes away: `t / q` near 10⁹, where
        // adding one to a float count changes nothing. Counted on a thread,
        // so a count that never ends fails instead of hanging.
        let q = 4e-5;
        let (sent, received) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let found: Vec<(f32, f32)> =
                [1000.0f32, 29_999.998, 30_000.0, 123_456.79].iter().map(|&t| (t, next_lattice_point(t, q))).collect();
            sent.send(found).ok();
        });
        let found = received.recv_timeout(std::time::Duration::from_secs(20)).expect("the count ends");
        for (t, point) in found {
            assert!(point > t, "{point} after {t}");
            // The next float that is a multiple of q as the lattice computes them.
            let k = (point / q).floor();
            assert!([k - 2.0, k - 1.0, k, k + 1.0, k + 2.0].iter().any(|&k| k * q == point), "{point} is k·q");
            assert!(point - t <= 4.0 * q.max(t * f32::EPSILON), "{point} is near {t}");
        }
    }
}
