//! The first cells of a polygonization: marches from the skeletons' seeds to
//! the surface, and in a local update only those that can find something new.

use glam::{IVec3, Vec3A};
use rayon::prelude::*;

use super::Polygonizer;
use super::hole::HoleShape;
use crate::field::Field;
use crate::mesh::lattice::{Cell, LatticePoint};
use crate::mesh::seeds::{Marched, Rejoin, RowSpans, RowStarts, Seed, SeedMarch, Start};

impl Polygonizer {
    /// Marches from each seed along +x to the first sign change and returns
    /// the unvisited cells around it.
    ///
    /// Seeds start at their nearest lattice corner. Seeds starting outside the
    /// surface march no farther than their primitive's support reaches. Starts
    /// in one lattice row march in order, and a start lying on a stretch an
    /// earlier march crossed to a sign change is skipped, since it would find
    /// that same change; rows march in parallel. A start outside the surface
    /// then walks uphill to the first sign change within its reach (see
    /// [`crate::mesh::seeds`]).
    ///
    /// With `hole`, a region holding every corner just dropped, only
    /// marches that can come within a cell of it run: every other march
    /// reads only corners kept from before and finds the crossings it found
    /// then, whose cells (all within a cell of the march) are kept and
    /// visited already.
    pub(super) fn seed<F: Field + ?Sized>(&mut self, field: &F, seeds: &[Seed], hole: Option<&HoleShape>) -> Vec<Cell> {
        let lattice = self.lattice;
        // A cell on either side, and half a cell against rounding in positions.
        let near_hole = hole.map(|h| h.padded(1.5 * lattice.cell));
        // Marches past the hole find what they found, but which of them run
        // depends on the marches before them: rows keep their starts there.
        let in_row = |q: LatticePoint| {
            let p = lattice.position(q);
            near_hole.as_ref().is_none_or(|h| h.row_span(p.y, p.z).is_some())
        };
        // An uphill walk goes no farther than its reach (plus a cell, the
        // staircase's offset from its ray).
        let walks_near_hole = |q: LatticePoint, reach: i32| {
            near_hole.as_ref().is_none_or(|h| h.within(lattice.position(q), (reach + 1) as f32 * lattice.cell))
        };
        // Only starts that can come near the hole are kept (in a local update,
        // a few of thousands); neither test fails for a longer reach where it
        // passes for a shorter one.
        self.starts.update(lattice, seeds);
        let starts = self.starts.kept(|(q, reach)| in_row(q) || walks_near_hole(q, reach));
        let along_x: Vec<Start> = starts.iter().copied().filter(|&(q, _)| in_row(q)).collect();
        let rows: Vec<(&RowStarts, Option<Rejoin>)> = along_x
            .chunk_by(|a, b| (a.0.y, a.0.z) == (b.0.y, b.0.z))
            .filter_map(|row| match &near_hole {
                None => Some((row, None)),
                Some(near) => self.changed_part(row, near),
            })
            .collect();
        let marched: Vec<Marched> = rows
            .par_iter()
            .map(|&(row, rejoin)| SeedMarch::new(field, lattice, &self.corners).row(row, rejoin))
            .collect();
        let mut cells = vec![];
        self.take_marched(marched, &mut cells);
        // The second round sees the corners the first evaluated. A walk from a
        // corner known to be inside ends where it starts (most of them: 82% of
        // a point/hair update's).
        let known_inside = |q: LatticePoint| self.corners.get(q).is_some_and(|v| v > self.threshold);
        let marched: Vec<Marched> = starts
            .par_iter()
            .filter(|&&(q, reach)| walks_near_hole(q, reach) && !known_inside(q))
            .map(|&(q, reach)| SeedMarch::new(field, lattice, &self.corners).uphill(q, reach))
            .collect();
        self.take_marched(marched, &mut cells);
        self.claim(cells)
    }

    /// The starts of `row` (sorted by `x`) whose marches may find something
    /// new: from the first that lies near the hole, or that an earlier march
    /// whose span meets the hole started or skipped. Every march from before
    /// it read only values kept (the field changed only in the hole) and
    /// finds what it found; only starts of changed primitives are new, and
    /// those lie in the hole. Past the hole the marches may stop where they
    /// rejoin the ones recorded before. A row never marched before is
    /// marched whole.
    fn changed_part<'s>(
        &'s self,
        row: &'s RowStarts,
        near_hole: &HoleShape,
    ) -> Option<(&'s RowStarts, Option<Rejoin<'s>>)> {
        let (y, z) = (row[0].0.y, row[0].0.z);
        let Some(spans) = self.row_spans.get(&(y, z)) else {
            return Some((row, None));
        };
        let at = |x: i32| self.lattice.position(IVec3::new(x, y, z));
        // The stretch of the row the hole reaches: its values changed only there.
        let row_point = at(0);
        let (x0, x1) = near_hole.row_span(row_point.y, row_point.z)?;
        let near = |x: i32| (x0..=x1).contains(&at(x).x);
        let from_spans = spans.iter().filter(|&&(lo, hi)| at(lo).x <= x1 && at(hi).x >= x0).map(|s| s.0);
        let from_starts = row.iter().map(|&(q, _)| q.x).filter(|&x| near(x));
        let first = from_spans.chain(from_starts).min()?;
        // A lattice step (two half cells) past the corner nearest the stretch's end.
        let past = self.lattice.nearest_corner(Vec3A::new(x1, row_point.y, row_point.z)).x + 2;
        let part = &row[row.partition_point(|&(q, _)| q.x < first)..];
        (!part.is_empty()).then_some((part, Some(Rejoin { first, past, before: spans })))
    }

    /// Keeps the corners `marched` evaluated and lists the cells around its
    /// crossings; a row marched again from some start on keeps the spans of
    /// the marches before it and takes the new ones.
    fn take_marched(&mut self, marched: Vec<Marched>, cells: &mut Vec<Cell>) {
        for Marched { crossings, evaluated, gradients, row_spans } in marched {
            if let Some(RowSpans { row, spans: new, from, kept_from }) = row_spans {
                // Sorted by start: the spans before the marches, theirs (in
                // place of those of starts now gone or skipped), and those
                // they rejoined.
                let spans = self.row_spans.entry(row).or_default();
                let rejoined = kept_from.map_or(spans.len(), |x| spans.partition_point(|s| s.0 < x));
                let redone = spans.partition_point(|s| s.0 < from);
                spans.splice(redone..rejoined, new);
            }
            self.stats.corner_evals += evaluated.len() as u64;
            self.stats.gradient_evals += gradients;
            self.corners.extend(evaluated);
            for q in crossings {
                self.options.cells.cells_touching(q, cells);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::{EvalMode, ModelField};
    use crate::geom::{Aabb, Support};
    use crate::mesh::{Lattice, PolygonizeOptions, skeleton_seeds};
    use crate::scene::Scene;

    /// Two blobs on one lattice row: the left one's march ends near it, so a
    /// change around the right one marches the row only from the right
    /// one's start, a change around the left one marches it all, and a
    /// change between them, which no march reached, marches none of it.
    #[test]
    fn a_local_update_marches_a_row_from_where_its_spans_meet_the_hole() {
        let scene = Scene::parse(
            "Scene(camera: Camera(eye: (0.0, 0.0, 9.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (8, 8),
                   model: Blend([Point(center: (-2.0, 0.0, 0.0), radius: 0.8), Point(center: (2.0, 0.0, 0.0), radius: 0.8)]))",
            "two blobs",
        )
        .expect("test scene parses");
        let field = ModelField::new(&scene.model, EvalMode::Indexed);
        let lattice = Lattice { cell: 0.1 };
        let mut polygonizer = Polygonizer::new(lattice, PolygonizeOptions::default());
        let seeds = skeleton_seeds(&scene.model, scene.model.root());
        polygonizer.polygonize(&field, &seeds);
        let mut row: Vec<Start> = seeds.iter().map(|s| (lattice.nearest_corner(s.point), 9)).collect();
        row.sort_by_key(|(q, _)| q.x);
        let boxed = |x: f32| HoleShape::new(&[Support::Box(Aabb::around(Vec3A::new(x, 0.0, 0.0), 0.3))]);
        let ball = |x: f32| HoleShape::new(&[Support::ball(Vec3A::new(x, 0.0, 0.0), 0.3)]);
        for around in [&boxed as &dyn Fn(f32) -> HoleShape, &ball] {
            let part = |x: f32| polygonizer.changed_part(&row, &around(x)).map(|(part, _)| part);
            assert_eq!(part(2.0), Some(&row[1..]));
            assert_eq!(part(-2.0), Some(&row[..]));
            assert_eq!(part(0.0), None);
        }
    }
}
