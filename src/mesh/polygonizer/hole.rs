//! The local update: everything within a cell of the space an edit changed
//! is dropped, and the polygonization grows back from the hole's border and
//! from the seeds that can reach it.

use glam::{IVec3, Vec3A};

use super::{CellShape, Polygonizer, crossed};
use crate::field::Field;
use crate::geom::{Aabb, Support};
use crate::mesh::lattice::Cell;
use crate::mesh::seeds::Seed;
use crate::mesh::visited::VisitedCells;

/// What a local re-polygonization changed, cell by cell.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Repolygonized {
    /// Crossed cells dropped (their triangles are gone).
    pub removed: Vec<Cell>,
    /// Crossed cells grown back or newly found (their triangles are new).
    pub added: Vec<Cell>,
}

impl Polygonizer {
    /// Re-polygonizes after the field changed inside `region` (and nowhere
    /// else): see [`Self::repolygonize_within`].
    pub fn repolygonize<F: Field + ?Sized>(&mut self, field: &F, region: &Aabb, seeds: &[Seed]) -> Repolygonized {
        self.repolygonize_within(field, &[Support::Box(*region)], seeds)
    }

    /// Re-polygonizes after the field changed inside the regions `changed`
    /// (and nowhere else): forgets every corner, vertex and cell within one
    /// cell of them, then grows back from the surface around the hole and
    /// from the `seeds`. The result equals a fresh polygonization of the
    /// changed field.
    pub fn repolygonize_within<F: Field + ?Sized>(
        &mut self,
        field: &F,
        changed: &[Support],
        seeds: &[Seed],
    ) -> Repolygonized {
        self.with_colors = field.varies_in_color();
        self.threshold = field.threshold();
        let cell = self.lattice.cell;
        let near = HoleShape::new(changed).padded(cell);
        let lattice = self.lattice;
        // An edge meeting `near` has its midpoint within one cell of it.
        let midpoints = near.padded(cell);
        // A cell with a vertex in `near` has its cube (or, for a tetrahedron, its
        // owning cube) within one cube of it.
        let dropped = near.padded(cell);
        let (lo, hi) = lattice.cubes_overlapping(&dropped.bounds);
        let meets = |cube: IVec3, margin: f32| {
            let min = cube.as_vec3a() * cell;
            dropped.meets(&Aabb::new(min, min + Vec3A::splat(cell)).padded(margin * cell))
        };
        // The three maps are dropped from in parallel, each in one pass.
        let (corners, vertices, cells) = (&mut self.corners, &mut self.vertices, &mut self.cells);
        let ((), ((), hole_cells)) = rayon::join(
            || corners.forget_within(&near.bounds, |q| lattice.position(q), |p| near.contains(p)),
            || {
                rayon::join(
                    || vertices.retain(|k| !midpoints.contains(lattice.position(k) * 0.5)),
                    || HoleCells::drop_from(cells, self.options.cells, (lo, hi), meets),
                )
            },
        );
        let HoleCells { removed, mut border, around } = hole_cells;
        let mut frontier = self.claim(around);
        // `dropped` holds every corner dropped (those in `near`).
        frontier.extend(self.seed(field, seeds, Some(&dropped)));
        let added = self.grow(field, frontier, true);
        // Every other crossed cell kept all its vertices.
        border.extend(added.iter().map(|&c| (c, self.cells.get(c).expect("a grown cell is visited"))));
        self.place_vertices(field, &border);
        Repolygonized { removed, added }
    }
}

/// What dropping a local update's cells leaves to do.
struct HoleCells {
    /// The crossed cells dropped, whose triangles go.
    removed: Vec<Cell>,
    /// The crossed cells kept within two cubes of the dropped ones: growth
    /// restarts from their neighbours, and they may have lost vertices on
    /// the hole's faces.
    border: Vec<(Cell, u8)>,
    /// The border cells' neighbours across crossed faces.
    around: Vec<Cell>,
}

impl HoleCells {
    /// Drops from `cells` those whose cube lies in `lo..=hi` and meets the
    /// hole (`meets(cube, 0.0)`), in one pass; the border is the crossed
    /// cells kept within two cubes of it (`meets(cube, 2.0)`).
    fn drop_from(
        cells: &mut VisitedCells,
        shape: CellShape,
        (lo, hi): (IVec3, IVec3),
        meets: impl Fn(IVec3, f32) -> bool,
    ) -> Self {
        let inside =
            |c: IVec3, margin: i32| c.cmpge(lo - margin).all() && c.cmple(hi + margin).all() && meets(c, margin as f32);
        let mut hole = Self { removed: vec![], border: vec![], around: vec![] };
        // Only cells within two cubes of `lo..=hi` can be dropped or border the hole.
        cells.retain_near((lo - 2, hi + 2), |c, mask| {
            let keep = !inside(c.cube, 0);
            if crossed(mask, shape) {
                if !keep {
                    hole.removed.push(c);
                } else if inside(c.cube, 2) {
                    shape.neighbours(c, mask, &mut hole.around);
                    hole.border.push((c, mask));
                }
            }
            keep
        });
        hole
    }
}

/// Most supports a local update tests each cell against; past it, their
/// bounding box stands for them (every test tries every part, and a moved
/// subtree has hundreds: Medusa's head 1 400).
const MAX_HOLE_SUPPORTS: usize = 8;

/// The space a local update redoes: the changed supports, grown alike, and
/// a box holding them (which most tests need go no further than).
#[derive(Clone, Debug)]
pub(super) struct HoleShape {
    parts: Vec<Support>,
    bounds: Aabb,
}

impl HoleShape {
    pub(super) fn new(changed: &[Support]) -> Self {
        let parts: Vec<Support> = changed.iter().filter(|s| !s.bounds().is_empty()).copied().collect();
        let bounds = parts.iter().fold(Aabb::EMPTY, |u, s| u.union(&s.bounds()));
        let parts = if parts.len() > MAX_HOLE_SUPPORTS { vec![Support::Box(bounds)] } else { parts };
        Self { parts, bounds }
    }

    /// The shape grown by a cube of half-side `r`.
    pub(super) fn padded(&self, r: f32) -> Self {
        Self { parts: self.parts.iter().map(|s| s.padded(r)).collect(), bounds: self.bounds.padded(r) }
    }

    fn contains(&self, p: Vec3A) -> bool {
        self.bounds.contains(p) && self.parts.iter().any(|s| s.contains(p))
    }

    /// Whether some point of the shape lies within `d` of `p`.
    pub(super) fn within(&self, p: Vec3A, d: f32) -> bool {
        self.bounds.distance_squared(p) <= d * d && self.parts.iter().any(|s| s.within(p, d))
    }

    /// The stretch of the row through `(·, y, z)` holding every point it
    /// shares with the shape (see [`Support::row_span`]).
    pub(super) fn row_span(&self, y: f32, z: f32) -> Option<(f32, f32)> {
        let spans = self.parts.iter().filter_map(|s| s.row_span(y, z));
        spans.reduce(|(a0, a1), (b0, b1)| (a0.min(b0), a1.max(b1)))
    }

    fn meets(&self, b: &Aabb) -> bool {
        self.bounds.overlaps(b) && self.parts.iter().any(|s| s.meets(b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::{EvalMode, ModelField};
    use crate::mesh::{Lattice, PolygonizeOptions, skeleton_seeds};
    use crate::scene::Scene;

    /// Three blobs on one lattice row, the middle one moved a little: the
    /// local update marches the row from the middle blob's start, and the
    /// marches past the hole, which read only values kept, must keep their
    /// spans, so that later updates see where they reached. The records then
    /// equal a fresh polygonization's.
    #[test]
    fn a_local_update_keeps_the_spans_of_the_marches_past_the_hole() {
        let mut scene = Scene::parse(
            "Scene(camera: Camera(eye: (0.0, 0.0, 9.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (8, 8),
                   model: Blend([Point(center: (-3.0, 0.0, 0.0), radius: 0.8),
                                 Named(\"mid\", Point(center: (0.0, 0.0, 0.0), radius: 0.8)),
                                 Point(center: (3.0, 0.0, 0.0), radius: 0.8), Point(center: (3.5, 0.0, 0.0), radius: 0.8)]))",
            "three blobs",
        )
        .expect("test scene parses");
        let lattice = Lattice { cell: 0.1 };
        let mut local = Polygonizer::new(lattice, PolygonizeOptions::default());
        local.polygonize(
            &ModelField::new(&scene.model, EvalMode::Indexed),
            &skeleton_seeds(&scene.model, scene.model.root()),
        );
        let mut within_balls = local.clone();
        for by in [Vec3A::new(0.0, 0.0, 0.03), Vec3A::new(0.45, 0.0, -0.03)] {
            let change =
                scene.model.apply(&crate::field::Edit::Translate { node: "mid".into(), by: by.into() }).unwrap();
            let region = scene.model.change_region(&change, false);
            let field = ModelField::new(&scene.model, EvalMode::Indexed);
            let seeds = skeleton_seeds(&scene.model, scene.model.root());
            local.repolygonize(&field, &region, &seeds);
            within_balls.repolygonize_within(&field, &scene.model.change_support_regions(&change, false), &seeds);
            let mut fresh = Polygonizer::new(lattice, PolygonizeOptions::default());
            fresh.polygonize(&field, &seeds);
            let row = |p: &Polygonizer| {
                p.row_spans.get(&(0, 0)).cloned().map(|mut s| {
                    s.sort_unstable();
                    s
                })
            };
            assert!(fresh.row_spans[&(0, 0)].len() >= 3, "{:?}", fresh.row_spans[&(0, 0)]);
            assert_eq!(row(&local), row(&fresh), "moved by {by}");
            assert_eq!(row(&within_balls), row(&fresh), "moved by {by}, within the balls");
        }
    }
}
