//! The kernel tracer: for a model whose field is a sum of Wyvill points and
//! segments, each ray's first hit is found by isolating the first root of
//! the ray's piecewise polynomial, not by marching through field evaluations
//! (Nishita and Nakamae's Bézier clipping for metaballs, 1994).
//!
//! Along a ray each support's field is `w·s³` with `s` quadratic in `t`
//! (see [`supports`]), so between the places where the ray enters or leaves
//! a support the sum is one polynomial of degree 6. The ray's crossings are
//! gathered front to back, sorted by entry and swept; each stretch between
//! two events whose sum can reach `T` is put in Bernstein form and the first
//! place it can rise to `T` isolated ([`bernstein`]). That place is then
//! confirmed as the segment tracer confirms a hit: its snap to the ray's
//! lattice, which finds the first lattice point inside (or marches on past a
//! touch between lattice points), each lattice point's sign given by the
//! crossed supports' sum where it is clear of rounding and by the field
//! elsewhere, so hits mean what they mean for the segment tracer.
//!
//! **The margin.** A stretch is passed over only where every Bernstein
//! coefficient is below `T - m`, with `m` = [`outside_margin`]`(T)` plus,
//! for each support summed there, `|w| (3 e + 512 ε)`: `e` bounds how far
//! `s` computed from the ray's quadratic may stray from `s` computed by the
//! field at the same point (both round a position of magnitude up to the
//! ray's reach; see `supports::rounding`), `3 e` what that does to `s³`
//! (`|s| <= 1` inside a support), and `512 ε` the rounding of Bernstein
//! coefficients of magnitude at most 8 through the conversion and up to
//! forty halvings. So no lattice point whose computed field exceeds `T` is
//! passed over; what the polynomial only nearly reaches costs a snap that
//! finds nothing and marches on. The snap walks the lattice from where the
//! rise may begin (a stretch, or half of one, that starts within the margin
//! may begin at its start), so it passes no lattice point on the way.
//!
//! Screen tiles list the supports their rays can cross, nearest first
//! ([`tiles`]); a ray tests only those. Where the model is one large point
//! set, a ray instead walks the cells of the set's index, which list every
//! point reaching them, and takes each point once (see [`WALK_PER_PIXEL`]
//! for when). A ray's crossings are summed in one
//! order (entry, then support) and its sweep is cut at distances past its
//! entry into the model's bounds, whatever tile or cells hold it, so its hit
//! depends on the ray and the model alone: images are the same for any
//! thread count, and a dirty rectangle traced again equals a full render.

mod bernstein;
mod supports;
mod tiles;

use std::cell::RefCell;
use std::sync::Arc;

use crate::camera::Camera;
use crate::field::{EvalMode, Field, Model, TracerChoice, outside_margin};
use crate::geom::Ray;
use bernstein::{Bernstein, Rise, add_cube, first_rise};
use supports::LocalRay;
use supports::line_meets_point;
pub use supports::{Crossing, IndexedSet, KernelSupports, NotKernel};
pub use tiles::{TILE, TileLists};

use super::segment::{MAX_SNAP_WALK, Snapped, TraceOptions, TraceResult, snap_on};

/// A model's supports and how a ray finds those it crosses: the screen's
/// lists of them, or the cells of their index: what the kernel tracer
/// needs besides the field, for one camera.
#[derive(Clone, Debug)]
pub struct KernelTracer {
    /// Shared with the edit session, which keeps them from one camera to the next.
    supports: Arc<KernelSupports>,
    /// The tiles' lists; `None` where rays walk the index's cells instead.
    tiles: Option<TileLists>,
    size: (u32, u32),
}

/// Supports per pixel from which rays walk their index's cells rather than
/// tiles' lists, where the model is one point set (placed anyhow). Listing every support in
/// every tile it covers costs about 120 ns a support, however few of them
/// the rays reach; a walk costs a ray about 240 ns more than reading its
/// tile's list, where cells are about a support wide (as they are past
/// sixteen thousand points, see `field::index`). Measured at 500×500: a
/// million points render in 0.25 s walking against 0.34 s by tiles (their
/// lists 0.12 s of it), a hundred thousand in 0.185 s against 0.145 s; a
/// million at four samples a pixel, 0.97 s against 0.95 s (pixels, not
/// rays, are counted: the two are level there).
pub const WALK_PER_PIXEL: u64 = 2;

/// Fewest supports for which rays walk cells: fewer points get cells an
/// eighth of a support wide (see `field::index`), eight times the cells a walk.
pub const WALK_FROM: usize = 1 << 14;

impl KernelTracer {
    /// The tracer for `model` in `mode` seen through `camera` at `size`, or
    /// why the model is not a sum of polynomial kernels.
    pub fn new(model: &Model, mode: EvalMode, camera: &Camera, size: (u32, u32)) -> Result<Self, NotKernel> {
        Ok(Self::of_supports(Arc::new(KernelSupports::of(model, mode)?), camera, size))
    }

    /// The tracer for `supports` seen through `camera` at `size`.
    #[must_use]
    pub fn of_supports(supports: Arc<KernelSupports>, camera: &Camera, size: (u32, u32)) -> Self {
        let pixels = u64::from(size.0) * u64::from(size.1);
        let many = supports.len() >= WALK_FROM && supports.len() as u64 >= WALK_PER_PIXEL * pixels;
        Self::gathering(supports, camera, size, many)
    }

    /// The tracer whose rays walk the cells of the supports' index where
    /// `walk` asks it and they have one, else read tiles' lists.
    fn gathering(supports: Arc<KernelSupports>, camera: &Camera, size: (u32, u32), walk: bool) -> Self {
        let walks = walk && supports.indexed_set().is_some();
        let tiles = (!walks).then(|| TileLists::new(&supports, camera, size.0, size.1));
        Self { supports, tiles, size }
    }

    /// True when rays walk the cells of the supports' index.
    #[must_use]
    pub fn walks_cells(&self) -> bool {
        self.tiles.is_none()
    }

    /// True when no support can be crossed by the rays of pixel (`x`, `y`),
    /// known before tracing them (from the tiles' lists).
    #[inline]
    #[must_use]
    pub fn misses(&self, x: u32, y: u32) -> bool {
        self.tiles.as_ref().is_some_and(|tiles| tiles.at(x, y).is_empty())
    }

    /// The fraction of the pixels whose rays are known to miss before tracing.
    #[must_use]
    pub fn missed_fraction(&self) -> f64 {
        let (w, h) = self.size;
        let missed = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).filter(|&(x, y)| self.misses(x, y)).count();
        missed as f64 / (u64::from(w) * u64::from(h)).max(1) as f64
    }

    /// Traces `ray`, one of pixel (`x`, `y`)'s, through `field` (the model's
    /// field in the tracer's mode): the first entry into `f > T`, with the
    /// supports it crossed as its steps and the field evaluations spent
    /// confirming the hit as its evaluations.
    pub fn trace<F: Field + ?Sized>(
        &self,
        field: &F,
        ray: &Ray,
        (x, y): (u32, u32),
        opts: &TraceOptions,
    ) -> TraceResult {
        if self.misses(x, y) {
            return TraceResult::default();
        }
        let Some(span) = field.bounds().clip_ray(ray.origin, ray.dir.recip(), 0.0, f32::INFINITY) else {
            return TraceResult::default();
        };
        match &self.tiles {
            Some(tiles) => self.trace_listed(field, ray, (tiles, tiles.at(x, y)), opts, span),
            None => self.trace_walking(field, ray, opts, span),
        }
    }

    /// [`Self::trace`] from the list of the ray's tile, nearest first: its
    /// sweep reaches twice as far past the ray's entry each time.
    fn trace_listed<F: Field + ?Sized>(
        &self,
        field: &F,
        ray: &Ray,
        (tiles, entries): (&TileLists, &[tiles::Entry]),
        opts: &TraceOptions,
        span: (f32, f32),
    ) -> TraceResult {
        let dir = ray.dir.extend(0.0);
        let mut pos = 0;
        let gather = |bound: f32, local: &mut LocalRay, crossings: &mut Vec<Crossing>| {
            while pos < entries.len() && entries[pos].near <= bound {
                let e = &entries[pos];
                if tiles.may_cross(e, dir) {
                    self.supports.crossings(e.support as usize, ray, local, span, crossings);
                }
                pos += 1;
            }
            pos == entries.len()
        };
        self.sweep(field, ray, opts, span, |reach| 2.0 * reach, gather)
    }

    /// [`Self::trace`] walking the cells of the supports' index along the
    /// ray: its sweep reaches a cell further each time (a ray crosses cells
    /// about a support wide), and takes each support once.
    fn trace_walking<F: Field + ?Sized>(
        &self,
        field: &F,
        ray: &Ray,
        opts: &TraceOptions,
        span: (f32, f32),
    ) -> TraceResult {
        let supports = &*self.supports;
        let IndexedSet { index, set, to_local } = supports.indexed_set().expect("a tracer walking an index");
        // The ray in the set's frame, where its index lies, as the crossings
        // see it: an affine map keeps each point's distance along the ray.
        let local_ray = (to_local.transform_point3a(ray.origin), to_local.transform_vector3a(ray.dir));
        // A cell's edge as a distance along the ray.
        let cell = index.cell_size() / local_ray.1.length();
        let mut cells = index.lists_along(local_ray.0, local_ray.1, span).peekable();
        // Rounding in the walk's distances, and then some: gathering a cell
        // early costs nothing but its crossings sorted a little sooner.
        let slack = |bound: f32| 1e-4 * bound.abs() + 1e-2 * cell;
        STAMPS.with_borrow_mut(|stamps| {
            stamps.begin(supports.len());
            let gather = |bound: f32, local: &mut LocalRay, crossings: &mut Vec<Crossing>| {
                while let Some(&(_, entry, _)) = cells.peek() {
                    if entry > bound + slack(bound) {
                        return false;
                    }
                    for &i in cells.next().map_or(&[][..], |(list, ..)| list) {
                        if line_meets_point(set, i as usize, local_ray) && stamps.first_visit(i) {
                            supports.crossings(i as usize, ray, local, span, crossings);
                        }
                    }
                }
                true
            };
            self.sweep(field, ray, opts, span, |reach| reach + cell, gather)
        })
    }

    /// Sweeps `ray`'s crossings front to back from where it enters the
    /// field's bounds (`span`), as far each time as the next of the
    /// distances past that entry `schedule` makes from the last.
    /// `gather(bound, local, crossings)` appends at least every crossing
    /// that starts before distance `bound` not given yet (each support
    /// once), and says whether none is left.
    fn sweep<F: Field + ?Sized>(
        &self,
        field: &F,
        ray: &Ray,
        opts: &TraceOptions,
        span: (f32, f32),
        schedule: impl Fn(f32) -> f32,
        mut gather: impl FnMut(f32, &mut LocalRay, &mut Vec<Crossing>) -> bool,
    ) -> TraceResult {
        SCRATCH.with_borrow_mut(|crossings| {
            crossings.clear();
            let mut local = LocalRay::new(span.1);
            let mut sweep = Sweep::new(field, ray, opts, span);
            let mut state = SweepState::new(span.0);
            // Crossings are gathered front to back, up to distances past the
            // ray's entry into the model's bounds that grow each time; the
            // sweep goes as far as the crossings known cover, short of a snap's
            // reach. Those limits come from the ray and the model's bounds,
            // whatever its tile lists or cells, so a ray's hit still depends on
            // the ray and the model alone. (Doubling distances from the eye
            // would gather up to twice as deep as the ray's entry: through a
            // million points a ray would read 207 listed supports, not 112.)
            let guard = SNAP_REACH * sweep.quantum;
            let mut reach = FIRST_BOUND * sweep.quantum;
            loop {
                let bound = span.0 + reach;
                let exhausted = gather(bound, &mut local, crossings);
                sort_by_entry(&mut crossings[state.next..]);
                let hit = sweep.advance(&self.supports, crossings, &mut state, bound - guard);
                let swept = exhausted && state.next == crossings.len() && state.active.is_empty();
                if hit.is_some() || swept || bound - guard >= span.1 {
                    return TraceResult { hit, steps: crossings.len() as u32, evals: sweep.evals };
                }
                reach = schedule(reach);
            }
        })
    }
}

/// Which supports the ray a thread traces has gathered: a ray walking cells
/// meets a support in each cell that lists it (two or three on average),
/// and takes its crossings once. (Taken twice, a support would count twice
/// in its stretches' sums: no wrong hit, since a snap asks the supports'
/// own values, but rises that are not there, and snaps for nothing.) Each
/// support keeps the number of the last ray that met it.
#[derive(Debug, Default)]
struct Stamps {
    marks: Vec<u32>,
    ray: u32,
}

impl Stamps {
    /// Starts a ray among `supports` supports.
    fn begin(&mut self, supports: usize) {
        if self.marks.len() < supports {
            self.marks.resize(supports, 0);
        }
        self.ray = self.ray.wrapping_add(1);
        if self.ray == 0 {
            self.marks.fill(0);
            self.ray = 1;
        }
    }

    /// True the first time this ray meets support `i`.
    #[inline]
    fn first_visit(&mut self, i: u32) -> bool {
        let mark = &mut self.marks[i as usize];
        let first = *mark != self.ray;
        *mark = self.ray;
        first
    }
}

/// How far past the ray's entry into the model's bounds the crossings are
/// first gathered, in lattice steps.
const FIRST_BOUND: f32 = 1024.0;

/// How far past a stretch a snap may look (up to twice its walk of lattice
/// steps, and a step for rounding), in lattice steps: the crossings a ray
/// has gathered must reach this far past where its sweep stops.
const SNAP_REACH: f32 = 2.0 * MAX_SNAP_WALK as f32 + 4.0;

/// Sorts crossings by entry, then by support: one total order, whatever
/// order they were gathered in; by insertion where a ray crosses few.
fn sort_by_entry(crossings: &mut [Crossing]) {
    let order = |a: &Crossing, b: &Crossing| a.t_in.total_cmp(&b.t_in).then(a.support.cmp(&b.support));
    if crossings.len() > 32 {
        crossings.sort_unstable_by(order);
        return;
    }
    for i in 1..crossings.len() {
        let mut j = i;
        while j > 0 && order(&crossings[j - 1], &crossings[j]).is_gt() {
            crossings.swap(j - 1, j);
            j -= 1;
        }
    }
}

/// Above this many supports overlapping on average (see
/// [`KernelSupports::overlap`]) `auto` leaves a model to the segment
/// tracer: a ray through it crosses hundreds, and sums them stretch by
/// stretch, where the segment tracer's few evaluations each sum the
/// supports at a point eight at a time. Measured with `bench eval`: the
/// particles (overlap 4.9) trace 3.2× faster by kernels, Medusa (overlap
/// 796) 20–30× slower.
pub const MAX_AUTO_OVERLAP: f32 = 24.0;

/// Which tracer renders a model, and why: `info` prints it, `render --json` reports it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TracerDecision {
    /// `kernel` or `segment`.
    pub tracer: &'static str,
    /// The model's kernel supports, where it is a sum of them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub supports: Option<usize>,
    /// Their mean overlap (see [`KernelSupports::overlap`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub overlap: Option<f32>,
    /// Why, in words.
    pub reason: String,
}

/// The supports of `model` in `mode` when its tracer choice lets the kernel
/// tracer render it, with the decision behind that.
#[must_use]
pub fn decide(model: &Model, mode: EvalMode) -> (Option<KernelSupports>, TracerDecision) {
    let segment = |reason: String, counted: Option<(usize, f32)>| TracerDecision {
        tracer: "segment",
        supports: counted.map(|c| c.0),
        overlap: counted.map(|c| c.1),
        reason,
    };
    if model.tracer() == TracerChoice::Segment {
        return (None, segment("--tracer segment".into(), None));
    }
    let supports = match KernelSupports::of(model, mode) {
        Ok(s) => s,
        Err(why) => return (None, segment(why.0, None)),
    };
    let overlap = supports.overlap();
    if model.tracer() == TracerChoice::Auto && overlap > MAX_AUTO_OVERLAP {
        let why = format!(
            "supports overlap {overlap:.0} deep, past {MAX_AUTO_OVERLAP:.0}: summing each ray's crossings costs more than marching"
        );
        return (None, segment(why, Some((supports.len(), overlap))));
    }
    let reason = if model.tracer() == TracerChoice::Kernel {
        "--tracer kernel".to_string()
    } else {
        format!("a sum of {} polynomial kernels overlapping {overlap:.1} deep", supports.len())
    };
    let decision = TracerDecision { tracer: "kernel", supports: Some(supports.len()), overlap: Some(overlap), reason };
    (Some(supports), decision)
}

thread_local! {
    /// Each thread's crossings of the ray it traces.
    static SCRATCH: RefCell<Vec<supports::Crossing>> = const { RefCell::new(Vec::new()) };
    /// Each thread's marks of the supports its ray has met.
    static STAMPS: RefCell<Stamps> = RefCell::new(Stamps::default());
}

/// Most supports a lattice point's sign is summed over from the ray's
/// crossings; past them the field answers.
const MAX_SUMMED: usize = 32;

/// What each support summed over a stretch adds to the margin, per unit of
/// weight, besides three times its own rounding bound (see the module doc).
const BERNSTEIN_ROUNDING: f32 = 512.0 * f32::EPSILON;

/// The margin below `T` of a stretch summing `c`'s support.
#[inline]
fn slack(c: &Crossing) -> f32 {
    c.weight.abs() * (3.0 * c.err + BERNSTEIN_ROUNDING)
}

/// A sweep along one ray's sorted crossings.
struct Sweep<'a, F: ?Sized> {
    field: &'a F,
    ray: &'a Ray,
    iso: f32,
    /// Where the ray enters and leaves the field's bounds.
    span: (f32, f32),
    /// The step of the ray's lattice.
    quantum: f32,
    /// Field evaluations spent.
    evals: u32,
}

/// Where a sweep stands, to go on from once more crossings are known.
struct SweepState {
    /// The first crossing not yet entered.
    next: usize,
    /// The crossings the sweep is inside.
    active: Vec<usize>,
    /// Where the sweep is.
    t0: f32,
}

impl SweepState {
    fn new(t0: f32) -> Self {
        Self { next: 0, active: Vec::with_capacity(16), t0 }
    }
}

impl<'a, F: Field + ?Sized> Sweep<'a, F> {
    fn new(field: &'a F, ray: &'a Ray, opts: &TraceOptions, span: (f32, f32)) -> Self {
        let quantum = opts.hit_quantum(field.bounds().diagonal(), span.1);
        Self { field, ray, iso: field.threshold(), span, quantum, evals: 0 }
    }

    /// Sweeps `crossings` (sorted by entry from `state.next` on) from where
    /// `state` stands up to `limit`, past which crossings may be missing:
    /// the first hit there, or `None` with `state` where it stopped.
    fn advance(
        &mut self,
        supports: &KernelSupports,
        crossings: &[Crossing],
        state: &mut SweepState,
        limit: f32,
    ) -> Option<f32> {
        loop {
            let t0 = state.t0;
            while state.next < crossings.len() && crossings[state.next].t_in <= t0 {
                state.active.push(state.next);
                state.next += 1;
            }
            state.active.retain(|&i| crossings[i].t_out > t0);
            if t0 >= limit {
                return None;
            }
            let entry = crossings.get(state.next).map_or(f32::INFINITY, |c| c.t_in);
            if state.active.is_empty() {
                // Over the gap to the next crossing known, but no farther than
                // the limit: crossings not gathered yet may start after it.
                state.t0 = entry.min(limit);
                continue;
            }
            let t1 = state.active.iter().map(|&i| crossings[i].t_out).fold(entry.min(limit), f32::min);
            match self.stretch(supports, crossings, &state.active, (t0, t1)) {
                Ok(Some(hit)) => return Some(hit),
                // A touch between lattice points: go on past where the snap
                // left off (at least a float further on, where lattice steps
                // are finer than the floats this far out resolve).
                Err(t_past) => state.t0 = if t_past > t0 { t_past } else { t0.next_up() },
                Ok(None) => state.t0 = t1,
            }
        }
    }

    /// The hit on stretch `[t0, t1]` summing the `active` crossings:
    /// `Ok(None)` where the sum stays below `T`, `Err` with where to go on
    /// from where the snap found no lattice point inside.
    fn stretch(
        &mut self,
        supports: &KernelSupports,
        crossings: &[Crossing],
        active: &[usize],
        (t0, t1): (f32, f32),
    ) -> Result<Option<f32>, f32> {
        let mut peak = 0.0f32;
        let mut margin = outside_margin(self.iso);
        for &i in active {
            let c = &crossings[i];
            let s = c.s_max(t0, t1);
            peak += c.weight.max(0.0) * s * s * s;
            margin += slack(c);
        }
        if peak < self.iso - margin {
            return Ok(None);
        }
        let mut sum: Bernstein = [-self.iso; 7];
        for &i in active {
            add_cube(&mut sum, &crossings[i], t0, t1);
        }
        // Half a lattice step: the snap then settles which lattice point in a sign or three.
        match first_rise(&sum, (t0, t1), margin, 0.5 * self.quantum) {
            Rise::Never => Ok(None),
            Rise::Within(a, _) => self.confirm(supports, crossings, a),
        }
    }

    /// Confirms a rise from `a` on (the field below `T` before it): the first
    /// lattice point inside after it, or where to go on from. The snap walks
    /// the lattice from `a` point by point, so it passes none: handed the
    /// rise's narrow bracket instead, it would try the bracket's far end and
    /// could march on past a lattice point inside the bracket. The snap asks
    /// the sign of `f - T` at lattice points; the sum of the crossed supports
    /// at the point, computed as the field computes each, answers where it
    /// is farther from `T` than two evaluations' rounding (the field,
    /// computed, has the same sign there), the field elsewhere.
    fn confirm(&mut self, supports: &KernelSupports, crossings: &[Crossing], a: f32) -> Result<Option<f32>, f32> {
        if a <= self.span.0 {
            // Inside where the ray enters the field's bounds, as the segment tracer says it.
            self.evals += 1;
            if self.field.value(self.ray.at(self.span.0)) > self.iso {
                return Ok(Some(self.span.0));
            }
        }
        let quantum = self.quantum;
        let snapped = snap_on(|t| self.sign_at(supports, crossings, t), a, a, quantum);
        match snapped {
            Snapped::Hit(t) => Ok(Some(t)),
            Snapped::Past(t, _) if t < self.span.1 => Err(t),
            Snapped::Past(..) => Err(f32::INFINITY),
        }
    }

    /// `f - T` at distance `t`, or a value of its sign: the crossed
    /// supports' sum where it decides, else the field's value (an evaluation).
    fn sign_at(&mut self, supports: &KernelSupports, crossings: &[Crossing], t: f32) -> f32 {
        let p = self.ray.at(t);
        let (mut sum, mut margin) = (-f64::from(self.iso), outside_margin(self.iso));
        // A segment's stretches share one support: its value counts once.
        let mut counted = [u32::MAX; MAX_SUMMED];
        let mut n = 0;
        for c in crossings.iter().take_while(|c| c.t_in <= t + self.quantum) {
            if t > c.t_out + self.quantum || counted[..n].contains(&c.support) {
                continue;
            }
            if n == MAX_SUMMED {
                (sum, margin) = (0.0, f32::INFINITY);
                break;
            }
            counted[n] = c.support;
            n += 1;
            sum += f64::from(supports.value(c.support as usize, p));
            if c.placed {
                margin += slack(c);
            }
        }
        if sum.abs() > f64::from(margin) {
            return sum as f32;
        }
        self.evals += 1;
        self.field.value(p) - self.iso
    }
}

#[cfg(test)]
mod tests;
