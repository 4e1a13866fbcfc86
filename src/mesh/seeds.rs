//! Where continuation starts: points on every primitive's skeleton, in world
//! space, and the marches from them along lattice lines to the surface.
//!
//! The polygonizer marches from each along +x to where it leaves the surface,
//! so every connected component that holds a skeleton is found, not just the
//! first, and the outside of a hollow whose skeletons lie in its cavity too.
//! A start outside the surface also walks uphill, along the field's gradient,
//! to the first sign change within its reach: that finds components that hold
//! no skeleton, which a negatively weighted neighbour, a carving or an
//! intersection leaves beside a swallowed skeleton (a crescent, a lens), or
//! that primitives too weak to reach the surface alone make where they blend.
//!
//! Marches along +x jump over the lattice points a slope bound shows to be on
//! their own side, and a march from outside whose whole reach the field's
//! range shows outside takes no step at all: what a march finds (the sign
//! changes between consecutive lattice points) is the same, for fewer
//! evaluations.

use glam::{Affine3A, IVec3, Vec3A};
use rustc_hash::FxHashMap;

use super::corners::CornerValues;
use super::lattice::{Lattice, LatticePoint, sort_key};
use crate::field::{Field, Model, NodeId, NodeKind, Skeleton, outside_margin};
use crate::geom::{Aabb, Region};

/// A point on a skeleton and how far its primitive's support reaches from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Seed {
    /// World position.
    pub point: Vec3A,
    /// A bound on the world distance from `point` to the edge of the support.
    pub reach: f32,
}

/// Seeds on the skeletons of the primitives under `id`, mapped to world space.
#[must_use]
pub fn skeleton_seeds(model: &Model, id: NodeId) -> Vec<Seed> {
    let mut out = vec![];
    collect(model, id, Placed::at(Affine3A::IDENTITY), &mut out);
    out
}

/// A subtree's map to world space, and a bound on how far it stretches any
/// length: the Frobenius norm of its linear part, computed once per
/// transform rather than once per primitive (seeds are listed again for
/// every local update, and a dense model has thousands of primitives).
#[derive(Clone, Copy)]
struct Placed {
    to_world: Affine3A,
    stretch: f32,
}

impl Placed {
    fn at(to_world: Affine3A) -> Self {
        let m = to_world.matrix3;
        let stretch = (m.x_axis.length_squared() + m.y_axis.length_squared() + m.z_axis.length_squared()).sqrt();
        Self { to_world, stretch }
    }

    fn then(self, placement: Affine3A) -> Self {
        Self::at(self.to_world * placement)
    }
}

fn collect(model: &Model, id: NodeId, placed: Placed, out: &mut Vec<Seed>) {
    match &model.node(id).kind {
        NodeKind::Primitive(p) => {
            let reach = p.radius * placed.stretch;
            let mut seed = |x: Vec3A| out.push(Seed { point: placed.to_world.transform_point3a(x), reach });
            // The point; along a segment or around a circle, starts no farther
            // apart than half the radius (at least a segment's ends and
            // middle, eight on a circle), so that each piece a carving or an
            // intersection leaves of the tube around the skeleton holds one.
            let spacing = 0.5 * p.radius;
            match p.skeleton {
                Skeleton::Point { center } => seed(center),
                Skeleton::Segment { a, b } => segment_samples(a, b, spacing).for_each(seed),
                Skeleton::Circle { center, normal, ring } => {
                    circle_samples(center, normal, ring, spacing).for_each(seed)
                }
            }
        }
        NodeKind::Points { set, .. } => out.extend((0..set.len()).map(|i| {
            let (center, radius) = set.ball(i);
            Seed { point: placed.to_world.transform_point3a(center), reach: radius * placed.stretch }
        })),
        NodeKind::Transform { placement, child } => collect(model, *child, placed.then(placement.to_world), out),
        NodeKind::Warp { warp, child } => {
            // The child's seeds in its own frame, carried by the warp, then by the frames above.
            let mut inner = vec![];
            collect(model, *child, Placed::at(Affine3A::IDENTITY), &mut inner);
            let stretch = warp.forward_stretch_over(&model.node(*child).bounds);
            out.extend(inner.into_iter().map(|s| Seed {
                point: placed.to_world.transform_point3a(warp.forward(s.point)),
                reach: s.reach * stretch * placed.stretch,
            }));
        }
        kind => kind.children().into_iter().for_each(|c| collect(model, c, placed, out)),
    }
}

/// Evenly spaced points from `a` to `b`, both ends and the middle among
/// them, no farther apart than `spacing`.
fn segment_samples(a: Vec3A, b: Vec3A, spacing: f32) -> impl Iterator<Item = Vec3A> {
    // `2 · halves + 1` points, at most the most starts a skeleton gets.
    let halves = (((b - a).length() / (2.0 * spacing)).ceil() as usize).clamp(1, (MAX_SKELETON_STARTS - 1) / 2);
    let n = 2 * halves;
    (0..=n).map(move |i| a.lerp(b, i as f32 / n as f32))
}

/// Evenly spaced points on a circle skeleton, at least eight, no farther
/// apart than `spacing` along it.
fn circle_samples(center: Vec3A, normal: Vec3A, ring: f32, spacing: f32) -> impl Iterator<Item = Vec3A> {
    let u = normal.any_orthonormal_vector();
    let v = normal.cross(u);
    let n = ((std::f32::consts::TAU * ring / spacing).ceil() as usize).clamp(8, MAX_SKELETON_STARTS);
    (0..n).map(move |i| {
        let a = i as f32 * std::f32::consts::TAU / n as f32;
        center + (u * a.cos() + v * a.sin()) * ring
    })
}

/// The most starts one segment or circle gets: a skeleton hundreds of radii
/// long is a modelling slip, not a reason to march ten thousand times.
const MAX_SKELETON_STARTS: usize = 64;

/// Lattice points evaluated on a walk, with their values.
pub(super) type Evaluated = Vec<(LatticePoint, f32)>;

/// One step along +x, in half cells: the direction every start marches.
const ROW_STEP: IVec3 = IVec3::new(2, 0, 0);

/// The fraction of a slope-certified jump taken, against rounding in the bound.
const JUMP_SAFETY: f32 = 0.999;

/// What some marches found.
pub(super) struct Marched {
    /// Corners followed by a sign change one step along their march.
    pub crossings: Vec<LatticePoint>,
    /// Corners evaluated on the way, in lattice order (so the maps they go
    /// into fill the same way whatever order the marches ran in).
    pub evaluated: Evaluated,
    /// Gradients evaluated (one per uphill walk).
    pub gradients: u64,
    /// For the marches of one row: the row, and for each march the span of
    /// it whose values decided what the march found.
    pub row_spans: Option<RowSpans>,
}

/// The marches along one lattice row (by its `y` and `z`): for each, the span
/// `start..=farthest` of `x` (in half cells) its outcome depended on.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct RowSpans {
    pub row: (i32, i32),
    pub spans: Vec<(i32, i32)>,
    /// The first `x` from which these spans replace those recorded before.
    pub from: i32,
    /// Where the marches stopped, the spans recorded before from here on
    /// still standing (see [`Rejoin`]).
    pub kept_from: Option<i32>,
}

/// A seed's start: its nearest lattice corner and its reach in lattice steps.
pub(super) type Start = (LatticePoint, i32);

/// The starts of seed marches along one lattice row, by `x`.
pub(super) type RowStarts = [Start];

/// Every seed's start, in the order rows are marched (by `z`, `y`, then `x`,
/// the longest reach first), kept from one call to the next with the seeds
/// it came from. A local update's seeds differ from the last call's in the
/// primitives an edit moved (one point, or a head of hundreds): those starts
/// are taken out in one pass and merged back in, instead of thousands being
/// sorted again each frame.
#[derive(Clone, Debug, Default)]
pub(super) struct SeedStarts {
    seeds: Vec<Seed>,
    sorted: Vec<Start>,
}

impl SeedStarts {
    /// Brings the starts up to date with `seeds` on `lattice` (the same lattice
    /// at every call).
    pub fn update(&mut self, lattice: Lattice, seeds: &[Seed]) {
        let start = |s: &Seed| (lattice.nearest_corner(s.point), (s.reach / lattice.cell).ceil() as i32 + 1);
        if self.seeds.len() == seeds.len() {
            let moved: Vec<usize> = (0..seeds.len()).filter(|&i| self.seeds[i] != seeds[i]).collect();
            if moved.is_empty() {
                return;
            }
            let mut gone: Vec<Start> = moved.iter().map(|&i| start(&self.seeds[i])).collect();
            gone.sort_unstable_by_key(march_order);
            if let Some(mut kept) = without(&self.sorted, &gone) {
                kept.extend(moved.iter().map(|&i| start(&seeds[i])));
                // A stable sort finds the kept run and merges the moved starts into it.
                kept.sort_by_key(march_order);
                self.sorted = kept;
                for i in moved {
                    self.seeds[i] = seeds[i];
                }
                return;
            }
        }
        self.seeds = seeds.to_vec();
        self.sorted = seeds.iter().map(start).collect();
        self.sorted.sort_unstable_by_key(march_order);
    }

    /// One start per corner, the one with the longest reach, among those
    /// `keep` passes, in march order. `keep` must not fail for a longer reach
    /// where it passes for a shorter one: then keeping each corner's longest
    /// reach first and filtering after keeps the starts filtering first would.
    pub fn kept(&self, keep: impl Fn(Start) -> bool) -> Vec<Start> {
        self.sorted.chunk_by(|a, b| a.0 == b.0).map(|same_corner| same_corner[0]).filter(|&s| keep(s)).collect()
    }
}

/// `sorted` without one copy of each start of `gone` (both in march order);
/// `None` if one is missing.
fn without(sorted: &[Start], gone: &[Start]) -> Option<Vec<Start>> {
    let mut kept = Vec::with_capacity(sorted.len());
    let mut gone = gone.iter().peekable();
    for s in sorted {
        match gone.peek() {
            Some(g) if march_order(g) < march_order(s) => return None,
            Some(g) if *g == s => _ = gone.next(),
            _ => kept.push(*s),
        }
    }
    gone.peek().is_none().then_some(kept)
}

/// Rows of equal `(z, y)` by `x`; at one corner, the longest reach first.
fn march_order(&(q, reach): &Start) -> (i32, i32, i32, std::cmp::Reverse<i32>) {
    (q.z, q.y, q.x, std::cmp::Reverse(reach))
}

/// What a row marched again after an edit knows of its marches before it.
#[derive(Clone, Copy, Debug)]
pub(super) struct Rejoin<'a> {
    /// Where the marches start again: the starts from here on are marched
    /// (or skipped) anew, and spans recorded from here on are replaced.
    pub first: i32,
    /// The last `x` whose value may have changed.
    pub past: i32,
    /// The spans the row's marches recorded before, sorted by start.
    pub before: &'a [(i32, i32)],
}

impl Rejoin<'_> {
    /// True when a march from `x`, marched now, would find and record what
    /// it did before: it starts past every change and was marched then.
    fn rejoins_at(&self, x: i32) -> bool {
        x > self.past && self.before.binary_search_by_key(&x, |s| s.0).is_ok()
    }
}

/// Marches from seed starts (with their reach, in lattice steps) along
/// lattice lines, reading corner values known before seeding or evaluating them.
pub(super) struct SeedMarch<'a, F: ?Sized> {
    field: &'a F,
    lattice: Lattice,
    threshold: f32,
    known: &'a CornerValues,
    fresh: FxHashMap<LatticePoint, f32>,
    crossings: Vec<LatticePoint>,
    gradients: u64,
    /// The farthest `x` whose value (or whose place in a march's reach) a row
    /// march's outcome depended on.
    farthest: i32,
}

impl<'a, F: Field + ?Sized> SeedMarch<'a, F> {
    pub fn new(field: &'a F, lattice: Lattice, known: &'a CornerValues) -> Self {
        let threshold = field.threshold();
        Self {
            field,
            lattice,
            threshold,
            known,
            fresh: FxHashMap::default(),
            crossings: vec![],
            gradients: 0,
            farthest: i32::MIN,
        }
    }

    /// Marches the starts of one lattice row, in x order, along +x.
    ///
    /// A march starting inside stops where it leaves the surface. One
    /// starting outside goes no farther than its reach unless it enters the
    /// surface, and then on to where it leaves it: a negatively weighted
    /// primitive or a carving operator can hide the outside of a hollow
    /// behind the wall of its cavity, where every skeleton lies. A start on a
    /// stretch an earlier march crossed to its last change would find the
    /// same changes, and is skipped.
    ///
    /// The result records, for each march, the span of the row its outcome
    /// depended on: the values it read, and from a start outside its whole
    /// reach (how far it goes depends on the field's bounds too, which other
    /// edits move). Where no value in a march's span changes, marching again
    /// finds the same changes; a start it skipped finds some of them.
    ///
    /// With `rejoin`, the row was marched before and changed only up to
    /// `rejoin.past`: a start beyond it that is marched now and was marched
    /// then (it has a span in `rejoin.before`) reads only values kept, and
    /// every later start is skipped or marched as it was then (a march
    /// leaves `crossed_up_to` either at what it found, or below its start
    /// and so below every later one), so the marches stop there and the
    /// result's `kept_from` says the spans recorded from it on stand.
    pub fn row(mut self, starts: &RowStarts, rejoin: Option<Rejoin>) -> Marched {
        let mut crossed_up_to = i32::MIN;
        let mut spans = vec![];
        let mut kept_from = None;
        for &(start, reach) in starts {
            if start.x > crossed_up_to {
                if rejoin.is_some_and(|r| r.rejoins_at(start.x)) {
                    kept_from = Some(start.x);
                    break;
                }
                self.farthest = start.x;
                let last = self.row_line(start, reach);
                spans.push((start.x, self.farthest));
                if let Some(last) = last {
                    crossed_up_to = last.x;
                }
            }
        }
        let row = starts.first().map(|&(q, _)| (q.y, q.z));
        let mut marched = self.finish();
        let from = rejoin.map_or(i32::MIN, |r| r.first);
        marched.row_spans = row.map(|row| RowSpans { row, spans, from, kept_from });
        marched
    }

    /// Walks uphill from `start`, if it is outside the surface: along the
    /// staircase of lattice edges nearest the ray up the field's gradient
    /// there, at most `reach` cells along the ray, to the first sign change.
    /// (No bound on the field's range over the walk is taken first: through
    /// caches one costs more than the few values the walk reads.)
    pub fn uphill(mut self, start: LatticePoint, reach: i32) -> Marched {
        if self.value(start) > self.threshold {
            return self.finish();
        }
        let at = self.lattice.position(start);
        let dir = self.field.uphill(at).normalize_or_zero();
        self.gradients += 1;
        if dir != Vec3A::ZERO {
            self.staircase(start, dir, reach);
        }
        self.finish()
    }

    /// [`Self::uphill`]'s walk: each step crosses to the lattice corner the ray
    /// comes nearest next (Amanatides–Woo on the cells around corners), so
    /// consecutive corners share a lattice edge and a sign change between them
    /// is one the cells around the first hold.
    fn staircase(&mut self, start: LatticePoint, dir: Vec3A, reach: i32) {
        let step = dir.signum().as_ivec3() * 2;
        let per_cell = dir.abs().recip();
        // Ray length, in cells, at which the nearest corner next changes on each axis.
        let mut next_change = 0.5 * per_cell;
        // From outside, the first sign change is an entry.
        let mut q = start;
        loop {
            let axis = next_change.min_position();
            if next_change[axis] > reach as f32 {
                return;
            }
            let next = q + IVec3::AXES[axis] * step[axis];
            if self.value(next) > self.threshold {
                self.crossings.push(q);
                return;
            }
            q = next;
            next_change[axis] += per_cell[axis];
        }
    }

    fn finish(self) -> Marched {
        let mut evaluated: Evaluated = self.fresh.into_iter().collect();
        evaluated.sort_unstable_by_key(|&(q, _)| sort_key(q));
        Marched { crossings: self.crossings, evaluated, gradients: self.gradients, row_spans: None }
    }

    /// The value at corner `q`: known before seeding, or evaluated now and kept.
    fn value(&mut self, q: LatticePoint) -> f32 {
        self.farthest = self.farthest.max(q.x);
        match self.known.get(q) {
            Some(v) => v,
            None => *self.fresh.entry(q).or_insert_with(|| self.field.value(self.lattice.position(q))),
        }
    }

    /// Walks from `start` along +x: at most `reach` steps while outside, and
    /// once inside on to where it leaves the surface, never past the field's
    /// bounds. Records the corner before each sign change in `crossings` and
    /// returns the last.
    fn row_line(&mut self, start: LatticePoint, reach: i32) -> Option<LatticePoint> {
        let max_steps = self.steps_to_leave_bounds(start);
        let (mut q, mut v, mut taken) = (start, self.value(start), 0);
        if v <= self.threshold {
            self.farthest = self.farthest.max((start + ROW_STEP * reach).x);
        }
        let end = self.lattice.position(start + ROW_STEP * reach.min(max_steps));
        let at = self.lattice.position(start);
        if v <= self.threshold && self.stays_outside(&Aabb::new(at.min(end), at.max(end))) {
            return None;
        }
        let mut last = None;
        // Until this many steps are taken, no jumps are tried: the bound
        // allowed none lately (where it is loose, trying every step would
        // cost a bound per evaluation saved), or rounding contradicted it.
        let (mut plain_until, mut backoff) = (0, 1);
        loop {
            let inside = v > self.threshold;
            let limit = if inside { max_steps } else { reach.min(max_steps) };
            if taken >= limit {
                return last;
            }
            let jump = if taken >= plain_until { self.certified_steps(q, v, limit - taken) } else { 0 };
            if jump <= 1 && taken >= plain_until {
                (plain_until, backoff) = (taken + backoff, 2 * backoff);
            }
            if jump > 1 {
                if !inside && taken + jump >= limit {
                    // The rest of the reach is outside.
                    return last;
                }
                let landing = q + ROW_STEP * jump;
                let v_landing = self.value(landing);
                if (v_landing > self.threshold) == inside {
                    (q, v, taken) = (landing, v_landing, taken + jump);
                } else {
                    plain_until = taken + jump;
                }
                continue;
            }
            let next = q + ROW_STEP;
            let v_next = self.value(next);
            if (v_next > self.threshold) != inside {
                self.crossings.push(q);
                last = Some(q);
                if inside {
                    return last;
                }
            }
            (q, v, taken) = (next, v_next, taken + 1);
        }
    }

    /// How many of the next `limit` corners along +x from `q` (value `v`) a
    /// slope bound over them shows to be on `q`'s side of the surface.
    fn certified_steps(&self, q: LatticePoint, v: f32, limit: i32) -> i32 {
        let (a, b) = (self.lattice.position(q), self.lattice.position(q + ROW_STEP * limit));
        // Past the evaluation's rounding, as segment tracing certifies its steps.
        let margin = (v - self.threshold).abs() - outside_margin(self.threshold);
        if margin <= 0.0 {
            return 0;
        }
        let slope = self.field.lipschitz(&Region::Segment(a, b));
        // An infinite or undefined bound (a crease) certifies nothing: `k` is 0 or NaN.
        let k = (JUMP_SAFETY * margin / (slope * self.lattice.cell)).floor();
        if k >= limit as f32 { limit } else { k.max(0.0) as i32 }
    }

    /// True when the field's range over `region` shows every lattice point in
    /// it outside: where most marches from outside the surface end, without
    /// an evaluation.
    fn stays_outside(&self, region: &Aabb) -> bool {
        self.field.interval(region).hi < self.threshold - outside_margin(self.threshold)
    }

    /// Steps along +x from `start` until past the field's bounds, where it is zero.
    fn steps_to_leave_bounds(&self, start: LatticePoint) -> i32 {
        let bounds = self.field.bounds();
        if bounds.is_empty() {
            // The field is zero everywhere.
            return 0;
        }
        let end_x = self.lattice.nearest_corner(bounds.max).x + 2;
        ((end_x - start.x) / 2).max(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Seeds on a few lattice rows, several sharing a corner with different reaches.
    fn seeds(shift: f32) -> Vec<Seed> {
        (0..200)
            .map(|i| {
                let f = i as f32;
                let point = Vec3A::new((f * 0.37).sin(), ((i % 5) as f32) * 0.1, ((i % 3) as f32) * 0.1) + shift;
                Seed { point, reach: 0.05 + 0.01 * (i % 7) as f32 }
            })
            .collect()
    }

    #[test]
    fn starts_kept_after_seeds_move_equal_starts_sorted_afresh() {
        let lattice = Lattice { cell: 0.1 };
        let mut kept = SeedStarts::default();
        let mut current = seeds(0.0);
        kept.update(lattice, &current);
        let moved = seeds(0.23);
        // Moves of one seed at a time, onto other seeds' corners and back,
        // of a run of fifty (a component), and of all of them.
        for i in [3, 17, 17, 150, 3, 199, 0, 1000, 1000, 2000] {
            match i {
                1000 => {
                    let shift = if current[40] == moved[40] { 0.0 } else { 0.23 };
                    current[40..90].copy_from_slice(&seeds(shift)[40..90]);
                }
                2000 => current = moved.clone(),
                _ => current[i] = if current[i] == moved[i] { seeds(0.0)[i] } else { moved[i] },
            }
            kept.update(lattice, &current);
            let mut fresh = SeedStarts::default();
            fresh.update(lattice, &current);
            assert_eq!(kept.sorted, fresh.sorted, "after moving seed {i}");
            assert_eq!(kept.seeds, current);
            assert_eq!(kept.kept(|_| true), fresh.kept(|_| true));
        }
        // One start per corner, the longest reach.
        let all = kept.kept(|_| true);
        assert!(all.windows(2).all(|w| march_order(&w[0]) < march_order(&w[1]) && w[0].0 != w[1].0));
        for &(q, reach) in &all {
            assert!(kept.sorted.iter().all(|&(p, r)| p != q || r <= reach));
        }
    }

    #[test]
    fn taking_starts_out_takes_one_copy_of_each_and_refuses_a_missing_one() {
        let q = |x: i32| IVec3::new(x, 0, 0);
        let sorted = [(q(0), 3), (q(2), 5), (q(2), 5), (q(2), 1), (q(4), 2)];
        assert_eq!(without(&sorted, &[(q(2), 5), (q(4), 2)]), Some(vec![(q(0), 3), (q(2), 5), (q(2), 1)]));
        assert_eq!(without(&sorted, &[]), Some(sorted.to_vec()));
        assert_eq!(without(&sorted, &[(q(2), 4)]), None);
        assert_eq!(without(&sorted, &[(q(6), 1)]), None);
    }
}
