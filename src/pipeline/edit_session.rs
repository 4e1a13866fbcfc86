//! The edit session: a scene rendered by field and by mesh, kept up to date
//! edit by edit, each edit updating only what it changed — the dirty
//! rectangles of the field image, the mesh cells near the change, their
//! triangles in the BVH2, the mesh image and the depth difference in those
//! rectangles — and checkable, frame by frame, against work from scratch.

use std::time::Instant;

use serde::Serialize;

use super::error::{PipelineError, Result};
use super::polygonize::{MAX_RES, PolygonizeSettings, polygonizer_on};
use crate::bvh::{BvhUpdate, DynamicMesh, render_mesh, rerender_mesh};
use crate::camera::Camera;
use crate::compare::{Metric, Rgb8Image, difference_at, differences};
use crate::field::{Edit, EmptySpace, EvalMode, Model, ModelField};
use crate::frame::{Frame, Size};
use crate::geom::{Aabb, Support};
use crate::mesh::{Lattice, Polygonizer, canonical_triangles, skeleton_seeds};
use crate::scene::Scene;
use crate::trace::{
    PixelRect, RenderSettings, changed_space, merge_rects, render, render_model, rerender, screen_rect,
};

/// One frame's measurements.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FrameRow {
    /// Frame number from 0.
    pub frame: usize,
    /// Fraction of the pixels inside the dirty rectangles.
    pub dirty_fraction: f64,
    /// Fraction of the pixels whose rays were traced again, whole or in part:
    /// those in the rectangles whose rays meet the change before their old hit.
    pub retraced_fraction: f64,
    /// Field evaluations re-tracing them.
    pub field_evals: u64,
    /// Seconds applying the edits (caches invalidated, bounds refitted).
    pub apply_s: f64,
    /// Seconds re-tracing the field in the dirty rectangles.
    pub field_s: f64,
    /// Seconds re-polygonizing near the change.
    pub polygonize_s: f64,
    /// Seconds updating the BVH2.
    pub bvh_s: f64,
    /// Whether the BVH2 was rebuilt rather than updated in place (predicted cheaper).
    pub bvh_rebuilt: bool,
    /// Seconds re-casting the mesh image in its dirty rectangles.
    pub mesh_render_s: f64,
    /// Seconds updating the field–mesh depth difference in the rectangles.
    pub diff_s: f64,
    /// Sum of the incremental stages.
    pub incremental_s: f64,
    /// Seconds of a full render plus a full polygonization (when verified).
    pub full_s: Option<f64>,
    /// Of which the full render of the field (when verified).
    pub full_render_s: Option<f64>,
    /// Cached samples the edits cleared.
    pub samples_cleared: u64,
    /// Triangles after the frame.
    pub triangles: usize,
}

/// What one frame of edits changed on the screen, and what it cost.
#[derive(Clone, Debug)]
pub struct FrameUpdate {
    /// The frame's measurements.
    pub row: FrameRow,
    /// The field image's dirty rectangles: every pixel that changed lies in one.
    pub dirty: Vec<PixelRect>,
}

/// A check of the session against a render and a polygonization from scratch.
#[derive(Clone, Debug)]
pub struct Verification {
    /// Seconds the full render took.
    pub render_s: f64,
    /// Seconds the full render and polygonization took together.
    pub full_s: f64,
    /// How the session's field image or mesh differ from them, if they do.
    pub mismatch: Option<String>,
}

/// A scene with its field render, mesh, BVH2, mesh render and depth
/// difference, updated incrementally by each edit.
pub struct EditSession {
    scene: Scene,
    mode: EvalMode,
    settings: RenderSettings,
    polygonize: PolygonizeSettings,
    polygonizer: Polygonizer,
    dynamic: DynamicMesh,
    field_frame: Frame,
    /// The field's empty space, updated where each edit changed the field.
    empty: EmptySpace,
    mesh_frame: Frame,
    /// Mesh depth less field depth, per pixel.
    depth_diff: Vec<f32>,
    frames: usize,
}

impl EditSession {
    /// Renders `scene` at `size` by field and by mesh, evaluating in `mode`,
    /// and polygonizes it on the lattice of `polygonize.res`.
    pub fn new(scene: Scene, mode: EvalMode, size: Size, polygonize: &PolygonizeSettings) -> Result<Self> {
        polygonize.check_unrefined(&scene.model)?;
        let settings = scene.render_settings(size);
        let (field_frame, _, empty) = render_model(&scene.model, mode, &settings, &|_| {});
        let lattice = Lattice::for_model(&scene.model, polygonize.res);
        let polygonizer = polygonizer_on(&scene.model, mode, lattice, polygonize.options());
        let dynamic = DynamicMesh::build(&polygonizer);
        let mesh_frame = render_mesh(&dynamic, &settings, &|_| {}).0;
        let depth_diff = differences(&mesh_frame, &field_frame, Metric::Depth);
        Ok(Self {
            scene,
            mode,
            settings,
            polygonize: *polygonize,
            polygonizer,
            dynamic,
            field_frame,
            empty,
            mesh_frame,
            depth_diff,
            frames: 0,
        })
    }

    /// The scene as edited so far.
    #[must_use]
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The evaluation mode.
    #[must_use]
    pub fn mode(&self) -> EvalMode {
        self.mode
    }

    /// The render settings: camera, size, background, lights.
    #[must_use]
    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// The traced field, up to date.
    #[must_use]
    pub fn field_frame(&self) -> &Frame {
        &self.field_frame
    }

    /// The ray-cast mesh, up to date.
    #[must_use]
    pub fn mesh_frame(&self) -> &Frame {
        &self.mesh_frame
    }

    /// Mesh depth less field depth per pixel, up to date.
    #[must_use]
    pub fn depth_diff(&self) -> &[f32] {
        &self.depth_diff
    }

    /// The mesh in its BVH2, up to date.
    #[must_use]
    pub fn mesh(&self) -> &DynamicMesh {
        &self.dynamic
    }

    /// The mesh lattice.
    #[must_use]
    pub fn lattice(&self) -> Lattice {
        self.polygonizer.lattice()
    }

    /// Frames applied so far.
    #[must_use]
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Looks through `camera` from now on: the field, the mesh and their
    /// difference are rendered again whole (the empty space and the mesh keep).
    pub fn set_camera(&mut self, camera: Camera) {
        self.settings.camera = camera;
        let field = ModelField::new(&self.scene.model, self.mode);
        self.field_frame = render(&field.skipping(&self.empty), &self.settings, &|_| {}).0;
        self.mesh_frame = render_mesh(&self.dynamic, &self.settings, &|_| {}).0;
        self.depth_diff = differences(&self.mesh_frame, &self.field_frame, Metric::Depth);
    }

    /// Applies one frame's edits and updates everything incrementally. An edit
    /// the model refuses (which leaves the model as it was) ends the frame:
    /// the edits before it stay applied, the images and mesh follow them, and
    /// the refusal is returned. An edited model the frame's work cannot handle
    /// (grown too far for the lattice) is reported with its edits applied and
    /// the images not updated.
    pub fn apply(&mut self, edits: &[Edit]) -> Result<FrameUpdate> {
        let mut row = FrameRow { frame: self.frames, ..Default::default() };
        let clock = Instant::now();
        let (mut regions, mut support_regions, mut refused) = (vec![], vec![], None);
        let cached = self.mode == EvalMode::Cached;
        for edit in edits {
            let change = match self.scene.model.apply(edit) {
                Ok(change) => change,
                Err(e) => {
                    refused = Some(e);
                    break;
                }
            };
            row.samples_cleared += change.samples_cleared;
            regions.push(self.scene.model.change_region(&change, cached));
            support_regions.extend(self.scene.model.change_support_regions(&change, cached));
        }
        row.apply_s = clock.elapsed().as_secs_f64();
        if let Some(e) = refused.take_if(|_| regions.is_empty()) {
            return Err(e.into());
        }
        check_edited_model(&self.scene.model, self.polygonizer.lattice())?;
        let dirty = self.retrace(&support_regions, &mut row);
        self.remesh(&regions, &support_regions, &mut row);
        row.incremental_s = row.apply_s + row.field_s + row.polygonize_s + row.bvh_s + row.mesh_render_s + row.diff_s;
        row.triangles = self.dynamic.triangle_count();
        self.frames += 1;
        match refused {
            Some(e) => Err(e.into()),
            None => Ok(FrameUpdate { row, dirty }),
        }
    }

    /// Re-traces the rays the change may have altered; returns the dirty rectangles.
    fn retrace(&mut self, support_regions: &[Support], row: &mut FrameRow) -> Vec<PixelRect> {
        let (w, h) = (self.settings.width, self.settings.height);
        let supports: Vec<Aabb> = support_regions.iter().map(Support::bounds).collect();
        let field = ModelField::new(&self.scene.model, self.mode);
        let clock = Instant::now();
        self.empty.update(&supports);
        let changed = changed_space(&field, &self.settings, support_regions);
        let rects: Vec<PixelRect> = changed.screen_rect(&self.settings.camera, w, h).into_iter().collect();
        row.dirty_fraction = rects.iter().map(PixelRect::area).sum::<u64>() as f64 / f64::from(w * h);
        let retraced = rerender(&field.skipping(&self.empty), &self.settings, &mut self.field_frame, &changed);
        row.field_s = clock.elapsed().as_secs_f64();
        row.retraced_fraction = retraced.rays as f64 / f64::from(w * h);
        row.field_evals = retraced.field_evals;
        rects
    }

    /// Re-polygonizes near the change, updates the BVH2, re-casts the mesh
    /// image and the depth difference in the rectangles the triangles moved in.
    fn remesh(&mut self, regions: &[Aabb], support_regions: &[Support], row: &mut FrameRow) {
        let (w, h) = (self.settings.width, self.settings.height);
        let field = ModelField::new(&self.scene.model, self.mode);
        let clock = Instant::now();
        let seeds = skeleton_seeds(&self.scene.model, self.scene.model.root());
        let remeshed = self.polygonizer.repolygonize_within(&field, support_regions, &seeds);
        row.polygonize_s = clock.elapsed().as_secs_f64();
        let clock = Instant::now();
        row.bvh_rebuilt = self.dynamic.update(&self.polygonizer, &remeshed) == BvhUpdate::Rebuilt;
        row.bvh_s = clock.elapsed().as_secs_f64();
        // Triangles change only within two lattice cells of each edit's region.
        let margin = 2.0 * self.polygonizer.lattice().cell;
        let camera = &self.settings.camera;
        let mesh_rects =
            merge_rects(regions.iter().filter_map(|r| screen_rect(camera, w, h, &r.padded(margin))).collect());
        let clock = Instant::now();
        rerender_mesh(&self.dynamic, &self.settings, &mut self.mesh_frame, &mesh_rects);
        row.mesh_render_s = clock.elapsed().as_secs_f64();
        let clock = Instant::now();
        update_depth_diff(&mut self.depth_diff, &self.mesh_frame, &self.field_frame, &mesh_rects);
        row.diff_s = clock.elapsed().as_secs_f64();
    }

    /// Renders and polygonizes from scratch, on a copy of the model with cold
    /// caches on the same lattices (so a sample an edit should have cleared and
    /// did not shows), and compares the session's images and mesh with them.
    #[must_use]
    pub fn verify(&self) -> Verification {
        let fresh_model = self.scene.model.clone();
        let clock = Instant::now();
        let full = render_model(&fresh_model, self.mode, &self.settings, &|_| {}).0;
        let render_s = clock.elapsed().as_secs_f64();
        let mesh =
            polygonizer_on(&fresh_model, self.mode, self.polygonizer.lattice(), self.polygonize.options()).mesh();
        let full_s = clock.elapsed().as_secs_f64();
        let mut mismatch = image_mismatch(&full, &self.field_frame);
        if mesh.triangle_set() != canonical_triangles(self.dynamic.triangles()) {
            mismatch = Some(mismatch.map_or(String::new(), |m| m + "; ") + "the meshes differ");
        }
        Verification { render_s, full_s, mismatch }
    }
}

/// Refuses an edited model the frame's work cannot handle: one too far from
/// the origin for single precision, or one grown past the largest mesh the
/// lattice (fixed by `res` over the first frame's bounds) may make.
fn check_edited_model(model: &Model, lattice: Lattice) -> Result<()> {
    model.check_reach()?;
    let cells = model.bounds().size().max_element() / lattice.cell;
    if cells > MAX_RES as f32 {
        return Err(PipelineError::EditedTooLarge { cells, max: MAX_RES });
    }
    Ok(())
}

/// Recomputes the mesh − field depth difference inside `rects` (which hold the
/// field's dirty rectangles too, the mesh's being the wider).
fn update_depth_diff(diff: &mut [f32], mesh: &Frame, field: &Frame, rects: &[PixelRect]) {
    for r in rects {
        for y in r.y0..r.y1 {
            for x in r.x0..r.x1 {
                let i = (y * mesh.width + x) as usize;
                diff[i] = difference_at(mesh, field, i, Metric::Depth);
            }
        }
    }
}

/// How the incremental image `kept` differs from the full render `full`, if it does.
fn image_mismatch(full: &Frame, kept: &Frame) -> Option<String> {
    if full.same_image(kept) {
        return None;
    }
    let differs = |i: usize| {
        full.color[i] != kept.color[i]
            || full.depth[i].to_bits() != kept.depth[i].to_bits()
            || full.normal[i] != kept.normal[i]
    };
    let pixels: Vec<usize> = (0..full.len()).filter(|&i| differs(i)).collect();
    let first = pixels.first().copied().unwrap_or(0);
    let (x, y) = (first as u32 % full.width, first as u32 / full.width);
    Some(format!(
        "{} pixels, the first at ({x}, {y}) with depth {} incrementally against {}",
        pixels.len(),
        kept.depth[first],
        full.depth[first]
    ))
}

/// Draws the edges of `rects` on `img`, in yellow.
pub fn outline_dirty(img: &mut Rgb8Image, rects: &[PixelRect]) {
    for r in rects {
        for x in r.x0..r.x1 {
            img.put(i64::from(x), i64::from(r.y0), [255, 220, 0]);
            img.put(i64::from(x), i64::from(r.y1) - 1, [255, 220, 0]);
        }
        for y in r.y0..r.y1 {
            img.put(i64::from(r.x0), i64::from(y), [255, 220, 0]);
            img.put(i64::from(r.x1) - 1, i64::from(y), [255, 220, 0]);
        }
    }
}
