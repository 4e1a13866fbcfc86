//! Small geometric building blocks shared by every pipeline stage: axis-aligned
//! boxes, closed intervals of field values, and rays.

mod aabb;
mod grid;
mod interval;
mod ray;

pub use aabb::Aabb;
pub use grid::{UniformGrid, cell_coords, linear_index};
pub use interval::Interval;
pub use ray::Ray;
