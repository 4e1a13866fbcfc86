//! Tests of a cache's lattice as a whole: warm and cold lookups, sampled
//! slope bounds and floors, and the sample differences they come from.

use glam::{IVec3, Vec3A};

use super::CacheGrid;
use crate::cache::filter::Filter;
use crate::cache::pool::SamplePool;
use crate::cache::{CacheSpec, Storage};
use crate::geom::{Aabb, Interval, Region};

/// Deterministic points in `[-r, r]³`.
fn points(n: usize, r: f32) -> Vec<Vec3A> {
    crate::geom::scattered_points(n, r, 0x2545_f491_4f6c_dd1d)
}

/// A ball's field, zero outside it: cubes across block faces, in zero
/// parts and past the subtree's bounds.
fn ball(p: Vec3A) -> f32 {
    0.9 * (1.0 - p.length_squared()).max(0.0).powi(3)
}

/// An empty cache of [`ball`] at resolution 20 with `value` for values.
fn ball_cache(value: Filter, pool: &SamplePool) -> CacheGrid {
    let spec =
        CacheSpec { res: 20, value, gradient: Filter::Triquadratic, storage: Storage::F32, usage: Default::default() };
    CacheGrid::new(spec, Aabb::new(Vec3A::splat(-1.0), Vec3A::splat(1.0)), pool)
}

/// [`CacheGrid::lipschitz`] over a segment short enough to be bounded from samples alone.
fn sampled_slope(grid: &CacheGrid, (a, b): (Vec3A, Vec3A), pool: &SamplePool) -> f32 {
    let (no_slope, no_range) = (|_: &Aabb| f32::INFINITY, |_: &Aabb| Interval::new(0.0, 1.0));
    grid.lipschitz(&Region::Segment(a, b), &no_slope, &no_range, (pool, &ball))
}

/// Warm lookups read held samples straight from their blocks; cold ones
/// gather part by part, asking which parts are zero. Each warm answer
/// must equal, to the bit, what a fresh cache computes for that point alone.
#[test]
fn warm_lookups_and_slope_walks_read_what_a_fresh_cache_computes() {
    for value in [Filter::Trilinear, Filter::Triquadratic] {
        let pool = SamplePool::default();
        let warm = ball_cache(value, &pool);
        let answers = |grid: &CacheGrid, p: Vec3A| {
            let slope = sampled_slope(grid, (p, p + Vec3A::new(0.21, -0.13, 0.17)), &pool);
            let (v, g) = grid.value_and_gradient(p, &pool, &ball);
            [grid.value(p, &pool, &ball), slope, v, g.x, g.y, g.z].map(f32::to_bits)
        };
        let points = points(1500, 1.25);
        for &p in &points {
            answers(&warm, p);
        }
        for &p in &points {
            let fresh = ball_cache(value, &pool);
            assert_eq!(answers(&warm, p), answers(&fresh, p), "{value:?} at {p}");
        }
    }
}

/// The sampled slope bound over a short segment holds for the
/// reconstruction along it, for both value filters (the quadratic one
/// reads a 4×4×4 cube per cell, often inside one block), and so does
/// the floor on its derivative along the segment.
#[test]
fn sampled_slope_bounds_hold_along_their_segments() {
    for value in [Filter::Trilinear, Filter::Triquadratic] {
        let pool = SamplePool::default();
        let grid = ball_cache(value, &pool);
        let ends = points(800, 1.1);
        for pair in ends.chunks(2) {
            let (a, b) = (pair[0], pair[0] + (pair[1] - pair[0]).normalize() * 0.25);
            let slope = sampled_slope(&grid, (a, b), &pool);
            let dir = (b - a).normalize();
            let floor = grid.slope_floor((a, b), dir, &pool, &ball);
            let steps = 400;
            let h = (b - a).length() / steps as f32;
            let at = |k: usize| grid.value(a + (b - a) * (k as f32 / steps as f32), &pool, &ball);
            for k in 0..steps {
                let rise = at(k + 1) - at(k);
                assert!(
                    rise.abs() <= slope * h * 1.001 + 1e-6,
                    "{value:?} {a}..{b}: rise {rise} over {h}, bound {slope}"
                );
                assert!(rise >= floor * h * 1.001 - 1e-6, "{value:?} {a}..{b}: rise {rise} over {h}, floor {floor}");
            }
        }
    }
}

/// A cell's sample differences are those of the samples its value
/// filter reads (the quadratic filter's 4×4×4 cube around it), whether
/// that cube lies inside one block or across several, cold or warm.
#[test]
fn cell_differences_are_those_of_the_cells_samples() {
    let pool = SamplePool::default();
    let grid = ball_cache(Filter::Triquadratic, &pool);
    let sample = |i: IVec3| {
        let p = i.as_vec3a() * grid.cell();
        if grid.child_bounds.contains(p) { ball(p) } else { 0.0 }
    };
    for round in 0..2 {
        for p in points(300, 1.0) {
            let i = (p / grid.cell()).floor().as_ivec3();
            let (mut lo, mut hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
            for o in (0..64).map(|m| IVec3::new(m % 4, m / 4 % 4, m / 16) - IVec3::ONE) {
                for axis in 0..3 {
                    if o[axis] < 2 {
                        let d = sample(i + o + IVec3::AXES[axis]) - sample(i + o);
                        (lo[axis], hi[axis]) = (lo[axis].min(d), hi[axis].max(d));
                    }
                }
            }
            let (got_lo, got_hi) = grid.cell_differences(i, &pool, &ball);
            assert_eq!((got_lo, got_hi), (lo, hi), "cell {i}, round {round}");
        }
    }
}
