//! Small geometric building blocks shared by every pipeline stage: axis-aligned
//! boxes, closed intervals of field values, rays, the regions slope bounds are
//! taken over, and the supports edits bound their changes by.

mod aabb;
mod grid;
mod interval;
mod ray;
mod region;
mod support;

pub use aabb::Aabb;
pub use grid::{CellWalk, UniformGrid, cell_coords, linear_index};
pub use interval::Interval;
pub use ray::Ray;
pub use region::Region;
pub use support::Support;

/// Deterministic points in `[-r, r]³`, a xorshift sequence from `seed`: the
/// tests' scattered queries.
#[cfg(test)]
pub(crate) fn scattered_points(n: usize, r: f32, seed: u64) -> Vec<glam::Vec3A> {
    let mut state = seed;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 * r - r
    };
    (0..n).map(|_| glam::Vec3A::new(next(), next(), next())).collect()
}
