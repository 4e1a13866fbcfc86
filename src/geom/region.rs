//! Regions over which Lipschitz bounds are taken: segments (for segment
//! tracing) and boxes (for per-cell bounds and interval culling).

use glam::{Affine3A, Vec3A};

use super::Aabb;

/// A segment or a box: the set of points a gradient bound must cover.
#[derive(Clone, Copy, Debug)]
pub enum Region {
    /// The segment `a..b`.
    Segment(Vec3A, Vec3A),
    /// An axis-aligned box.
    Box(Aabb),
}

impl Region {
    /// True when the region touches the box `b`.
    #[must_use]
    pub fn meets(&self, b: &Aabb) -> bool {
        match self {
            Region::Segment(p, q) => b.meets_segment(*p, *q),
            Region::Box(r) => r.overlaps(b),
        }
    }

    /// The image of the region under an affine map (a box maps to its image's bounds).
    #[must_use]
    pub fn transformed(&self, m: &Affine3A) -> Region {
        match self {
            Region::Segment(p, q) => Region::Segment(m.transform_point3a(*p), m.transform_point3a(*q)),
            Region::Box(r) => Region::Box(r.transformed(m)),
        }
    }

    /// The smallest box holding the region.
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        match self {
            Region::Segment(p, q) => Aabb::from_points(*p, *q),
            Region::Box(r) => *r,
        }
    }
}
