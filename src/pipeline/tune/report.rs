//! Pictures of tuning: for each cache tuning changed, error_C = |f_C − f| on
//! a plane through it, before and after, side by side on one scale (`4E`,
//! the largest error a vertex may have), so the two can be compared.

use glam::Vec3A;

use super::TuneReport;
use crate::draw::{Rgb8Image, Scale, heat_map, panel};
use crate::field::{EvalMode, Field, ModelField, NodeKind};
use crate::geom::Aabb;
use crate::pipeline::error::{PipelineError, Result};
use crate::scene::{NodeDesc, Scene, SceneDesc};
use crate::slice::{SlicePlane, sample};

use super::measure::preorder;

/// A scene with its caches' lattice numbers, node ids and labels.
struct Labelled {
    scene: Scene,
    /// (label, lattice, node) per cache.
    caches: Vec<(String, usize, crate::field::NodeId)>,
}

fn labelled(desc: &SceneDesc, labels: &[String]) -> Result<Labelled> {
    let (scene, ids) = Scene::from_desc_with_ids(desc).map_err(|e| PipelineError::Unsuitable(e.to_string()))?;
    let mut caches = vec![];
    let cache_places =
        preorder(&desc.model).into_iter().enumerate().filter(|(_, n)| matches!(n, NodeDesc::Cache { .. }));
    for ((at, _), label) in cache_places.zip(labels) {
        if let NodeKind::Cache { grid, .. } = scene.model.node(ids[at]).kind {
            caches.push((label.clone(), grid, ids[at]));
        }
    }
    Ok(Labelled { scene, caches })
}

/// One `(file stem, picture)` per changed cache of `report`: error_C before
/// (in `before`, labelled `before_labels`) and after (in `after`), on a
/// plane of constant z through the cache's centre, at most `size` pixels a side.
pub fn error_slices(
    before: (&SceneDesc, &[String]),
    after: (&SceneDesc, &[String]),
    report: &TuneReport,
    size: u32,
) -> Result<Vec<(String, Rgb8Image)>> {
    let (mut old, mut new) = (labelled(before.0, before.1)?, labelled(after.0, after.1)?);
    let scale = 4.0 * report.tolerance;
    let mut out = vec![];
    for row in report.rows.iter().filter(|r| !r.decision.starts_with("kept")) {
        let mine = |l: &str| l == row.cache || l.starts_with(&format!("{}/", row.cache));
        let bounds = old.region(&mine).union(&new.region(&mine));
        if bounds.is_empty() {
            continue;
        }
        let plane = SlicePlane::through(bounds.center(), Vec3A::Z, &bounds, size, size);
        let title = |res: Option<u32>, when: &str| match res {
            Some(r) => format!("error_C = |f_C - f| {when}: res {r}"),
            None => format!("error_C {when}: no cache (exact)"),
        };
        let images = [
            (title(row.res_before, "before"), old.error_image(&mine, &plane, scale)),
            (format!("{} ({})", title(row.res_after, "after"), row.decision), new.error_image(&mine, &plane, scale)),
        ];
        let stem: String = row.cache.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '_' }).collect();
        out.push((format!("tune-{stem}"), panel(&images, 2)));
    }
    Ok(out)
}

impl Labelled {
    /// World box of the caches `mine` picks.
    fn region(&self, mine: &impl Fn(&str) -> bool) -> Aabb {
        let picked = self.caches.iter().filter(|c| mine(&c.0));
        picked.fold(Aabb::EMPTY, |b, c| b.union(&self.scene.model.world_bounds(c.2)))
    }

    /// error_C on `plane` with only the caches `mine` picks answering (zero
    /// everywhere where it picks none), on magma over `0..=scale`.
    fn error_image(&mut self, mine: &impl Fn(&str) -> bool, plane: &SlicePlane, scale: f32) -> Rgb8Image {
        let mut in_use = vec![false; self.scene.model.grid_count()];
        self.caches.iter().filter(|c| mine(&c.0)).for_each(|c| in_use[c.1] = true);
        let errors = self.scene.model.with_lattices(&in_use, |m| {
            let (exact, cached) = (ModelField::new(m, EvalMode::Indexed), ModelField::new(m, EvalMode::Cached));
            sample(plane, |p| (cached.value(p) - exact.value(p)).abs())
        });
        heat_map(&errors, plane.width, plane.height, Scale::Magnitude { max: scale }, "error_C = |f_C - f|", "")
    }
}
