//! Small geometric building blocks shared by every pipeline stage: axis-aligned
//! boxes, closed intervals of field values, rays, and the supports edits bound
//! their changes by.

mod aabb;
mod grid;
mod interval;
mod ray;
mod support;

pub use aabb::Aabb;
pub use grid::{UniformGrid, cell_coords, linear_index};
pub use interval::Interval;
pub use ray::Ray;
pub use support::Support;
