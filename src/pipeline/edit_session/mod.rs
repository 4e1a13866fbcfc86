//! The edit session: a scene rendered by field and by mesh, kept up to date
//! edit by edit, each edit updating only what it changed — the dirty
//! rectangles of the field image, the mesh cells near the change, their
//! triangles in the BVH2, the mesh image and the depth difference in those
//! rectangles — and checkable, frame by frame, against work from scratch.
//! Its parts beside this file: `samples` (smoothing a still image while
//! idle), `tidy` (keeping a long session's cost a fresh one's) and `verify`
//! (the check against work from scratch).

mod samples;
mod tidy;
mod verify;

pub use samples::IDLE_SAMPLES;
use samples::Samples;
pub use verify::Verification;

use std::borrow::Cow;
use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;

use super::error::{PipelineError, Result};
use super::polygonize::{MAX_RES, PolygonizeSettings, polygonizer_on};
use crate::bvh::{BvhUpdate, DynamicMesh, blank_mesh_frame, refine_mesh};
use crate::camera::Camera;
use crate::compare::{Metric, difference_at, differences};
use crate::draw::Rgb8Image;
use crate::field::{Edit, EmptySpace, EvalMode, Model, ModelField};
use crate::frame::{Frame, Size};
use crate::geom::{Aabb, Support};
use crate::mesh::{Lattice, Polygonizer, skeleton_seeds};
use crate::scene::Scene;
use crate::trace::{
    ChangedSpace, Coverage, PixelRect, PixelState, Refinement, RenderSettings, blank_field_frame, changed_space,
    kernel::{self, KernelSupports, KernelTracer},
    merge_rects, refine, screen_rect,
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
    /// What the last edits and camera moves left to do.
    work: WorkLeft,
    /// The samples added to the field image since it was last refined.
    samples: Option<Samples>,
    /// The pixels to trace again once idle, so their counts are a fresh session's.
    tidy: tidy::Tidy,
    /// The model's kernel supports where the kernel tracer traces it, kept
    /// from one camera move to the next and gathered again after each edit.
    kernel: Option<Arc<KernelSupports>>,
}

/// What the last edits and camera moves left to do, in the order
/// [`EditSession::refine`] does it: the field image's stale pixels, the
/// mesh near the edits, the mesh image's stale pixels, the depth difference.
struct WorkLeft {
    field: Refinement,
    /// The change the field's pixels to retrace are traced against.
    changed: Option<ChangedSpace>,
    /// Where the rays of the field's pixels to trace whole can first meet
    /// the surface, since the last camera move (and edit).
    coverage: Option<Coverage>,
    /// The edits' regions and support regions, not yet re-polygonized.
    remesh: Option<(Vec<Aabb>, Vec<Support>)>,
    mesh: Refinement,
    /// Where the depth difference is to be computed again.
    diff: Vec<PixelRect>,
    /// The measurements of the frame under way.
    row: FrameRow,
    /// Field rays traced per second in the last batch of refinement, to size the next.
    rays_per_second: f64,
    /// The same for the idle samples, most of which coverage settles at once.
    sample_rays_per_second: f64,
    /// Field rays traced and seconds tracing them since the last event began.
    traced: (u64, f64),
}

/// The work a session has left, as the previewer's status says it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pending {
    /// The field image, in the pass of this block edge.
    Field(u32),
    /// The mesh near the edits.
    Remesh,
    /// The mesh image, in the pass of this block edge.
    Mesh(u32),
    /// The depth difference.
    Difference,
}

impl std::fmt::Display for Pending {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Pending::Field(step) => write!(f, "refining the field, {step}x{step} pass"),
            Pending::Remesh => write!(f, "meshing the edit"),
            Pending::Mesh(step) => write!(f, "refining the mesh, {step}x{step} pass"),
            Pending::Difference => write!(f, "updating the difference"),
        }
    }
}

impl EditSession {
    /// Renders `scene` at `size` by field and by mesh, evaluating in `mode`,
    /// and polygonizes it on the lattice of `polygonize.res`.
    pub fn new(scene: Scene, mode: EvalMode, size: Size, polygonize: &PolygonizeSettings) -> Result<Self> {
        let mut session = Self::begin(scene, mode, size, polygonize)?;
        session.finish();
        Ok(session)
    }

    /// [`Self::new`] up to the first, coarse pass over the field and mesh
    /// images (the mesh and its BVH whole); [`Self::refine`] does the rest.
    pub fn begin(scene: Scene, mode: EvalMode, size: Size, polygonize: &PolygonizeSettings) -> Result<Self> {
        polygonize.check_unrefined(&scene.model)?;
        let settings = scene.render_settings(size);
        let empty = EmptySpace::build(&ModelField::new(&scene.model, mode));
        let lattice = Lattice::for_model(&scene.model, polygonize.res);
        let polygonizer = polygonizer_on(&scene.model, mode, lattice, polygonize.options());
        let dynamic = DynamicMesh::build(&polygonizer);
        let work = WorkLeft {
            field: Refinement::new(size.0, size.1),
            changed: None,
            coverage: None,
            remesh: None,
            mesh: Refinement::new(size.0, size.1),
            diff: vec![],
            row: FrameRow::default(),
            rays_per_second: 1e6,
            sample_rays_per_second: 1e6,
            traced: (0, 0.0),
        };
        let mut session = Self {
            field_frame: blank_field_frame(&settings),
            mesh_frame: blank_mesh_frame(&settings),
            depth_diff: vec![f32::NAN; (size.0 as usize) * (size.1 as usize)],
            scene,
            mode,
            settings,
            polygonize: *polygonize,
            polygonizer,
            dynamic,
            empty,
            frames: 0,
            work,
            samples: None,
            tidy: tidy::Tidy::default(),
            kernel: None,
        };
        session.kernel = session.kernel_supports();
        session.begin_camera(session.settings.camera);
        Ok(session)
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

    /// The traced field as it stands: up to date once [`Self::is_refined`]
    /// (meanwhile, [`Self::field_preview`] is what to show).
    #[must_use]
    pub fn field_frame(&self) -> &Frame {
        &self.field_frame
    }

    /// The ray-cast mesh as it stands: up to date once [`Self::is_refined`].
    #[must_use]
    pub fn mesh_frame(&self) -> &Frame {
        &self.mesh_frame
    }

    /// Mesh depth less field depth per pixel: up to date once [`Self::is_refined`].
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
        self.begin_camera(camera);
        self.finish();
    }

    /// [`Self::set_camera`] up to the first, coarse pass over the field and
    /// mesh images; [`Self::refine`] does the rest.
    pub fn begin_camera(&mut self, camera: Camera) {
        self.settings.camera = camera;
        self.samples = None;
        // The camera's work is its own, not the last edit's.
        (self.work.traced, self.work.row) = ((0, 0.0), FrameRow { frame: self.frames, ..Default::default() });
        self.work.coverage = Some(self.coverage());
        let exact = self.empty_space_exact();
        self.tidy.camera_moved(exact, self.settings.width, self.settings.height);
        let work = &mut self.work;
        work.field.mark_all();
        work.changed = None;
        work.mesh.mark_all();
        work.diff = vec![PixelRect::full(self.settings.width, self.settings.height)];
        self.coarse_passes();
    }

    /// Applies one frame's edits and updates everything incrementally. An edit
    /// the model refuses (which leaves the model as it was) ends the frame:
    /// the edits before it stay applied, the images and mesh follow them, and
    /// the refusal is returned. An edited model the frame's work cannot handle
    /// (grown too far for the lattice) is reported with its edits applied and
    /// the images not updated.
    pub fn apply(&mut self, edits: &[Edit]) -> Result<FrameUpdate> {
        let begun = self.begin_apply(edits);
        let row = self.finish();
        begun.map(|update| FrameUpdate { row, dirty: update.dirty })
    }

    /// [`Self::apply`] up to the first, coarse pass over the field image's
    /// dirty rectangles, so no pixel there shows the field before the edits;
    /// [`Self::refine`] does the rest. The row holds the work so far.
    pub fn begin_apply(&mut self, edits: &[Edit]) -> Result<FrameUpdate> {
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
        self.samples = None;
        // The empty space follows the model even where the frame's work is refused.
        let supports: Vec<Aabb> = support_regions.iter().map(Support::bounds).collect();
        self.empty.update(&supports);
        check_edited_model(&self.scene.model, self.polygonizer.lattice())?;
        self.kernel = self.kernel_supports();
        let dirty = self.mark_changed(&support_regions, &mut row);
        // Traced while the edit's marks are stale.
        self.tidy.traced(&dirty);
        let remesh = self.work.remesh.get_or_insert_default();
        remesh.0.extend(regions);
        remesh.1.extend(support_regions);
        self.work.diff.extend(&dirty);
        self.work.row = row;
        self.work.traced = (0, 0.0);
        self.frames += 1;
        self.coarse_passes();
        match refused {
            Some(e) => Err(e.into()),
            None => Ok(FrameUpdate { row: self.work.row.clone(), dirty }),
        }
    }

    /// Marks stale the field pixels whose rays the change may alter; returns
    /// the dirty rectangles.
    fn mark_changed(&mut self, support_regions: &[Support], row: &mut FrameRow) -> Vec<PixelRect> {
        let (w, h) = (self.settings.width, self.settings.height);
        let field = ModelField::new(&self.scene.model, self.mode);
        let clock = Instant::now();
        let changed = changed_space(&field, &self.settings, support_regions);
        let rects: Vec<PixelRect> = changed.screen_rect(&self.settings.camera, w, h).into_iter().collect();
        row.dirty_fraction = rects.iter().map(PixelRect::area).sum::<u64>() as f64 / f64::from(w * h);
        self.work.field.mark(&rects, PixelState::Retrace);
        self.work.changed = Some(changed);
        // Pixels to trace whole may be left from a camera move: the edit may
        // have moved the surface nearer. The kernel tracer's lists follow the
        // supports wherever they moved, for every pixel it traces again.
        if let Some(kernel) = self.kernel_tracer() {
            self.work.coverage = Some(Coverage::of_kernels(kernel, w));
        } else if self.work.coverage.is_some() {
            self.work.coverage = Some(self.coverage());
        }
        row.field_s = clock.elapsed().as_secs_f64();
        rects
    }

    /// The coarse passes over the images' stale pixels: after them no pixel
    /// of the previews is stale.
    fn coarse_passes(&mut self) {
        while !self.work.field.coarse_pass_done() {
            self.refine_field(usize::MAX);
        }
        while !self.work.mesh.coarse_pass_done() {
            self.refine_mesh(usize::MAX);
        }
    }

    /// Finishes what the last edits and camera moves left; returns the
    /// measurements of the last edit's frame, whole.
    pub fn finish(&mut self) -> FrameRow {
        while self.step(usize::MAX) {}
        let row = &mut self.work.row;
        row.incremental_s = row.apply_s + row.field_s + row.polygonize_s + row.bvh_s + row.mesh_render_s + row.diff_s;
        row.triangles = self.dynamic.triangle_count();
        row.clone()
    }

    /// Does what is left, pass by pass, for about `budget` (at least one
    /// batch of rays or one re-polygonization); returns whether work remains.
    pub fn refine(&mut self, budget: std::time::Duration) -> bool {
        let start = Instant::now();
        loop {
            let left = budget.saturating_sub(start.elapsed()).as_secs_f64();
            let rays = (self.work.rays_per_second * left) as usize;
            let field_stale = self.work.field.pending() > 0;
            if !self.step(rays.max(MIN_BATCH_RAYS)) {
                self.finish();
                return false;
            }
            // A field image just refined is worth showing before the mesh's work.
            if start.elapsed() >= budget || (field_stale && self.work.field.is_done()) {
                return true;
            }
        }
    }

    /// Field rays traced, whole or in part, per second of tracing since the
    /// last edit or camera move began.
    #[must_use]
    pub fn rays_per_second(&self) -> f64 {
        self.work.traced.0 as f64 / self.work.traced.1.max(1e-9)
    }

    /// The work left, `None` once everything is up to date.
    #[must_use]
    pub fn pending(&self) -> Option<Pending> {
        let work = &self.work;
        if let Some(step) = work.field.level() {
            Some(Pending::Field(step))
        } else if work.remesh.is_some() {
            Some(Pending::Remesh)
        } else if let Some(step) = work.mesh.level() {
            Some(Pending::Mesh(step))
        } else {
            (!work.diff.is_empty()).then_some(Pending::Difference)
        }
    }

    /// One piece of the work left (a batch of about `max_rays`); false when none was left.
    fn step(&mut self, max_rays: usize) -> bool {
        match self.pending() {
            Some(Pending::Field(_)) => self.refine_field(max_rays),
            Some(Pending::Remesh) => {
                let (regions, support_regions) = self.work.remesh.take().unwrap_or_default();
                self.remesh(&regions, &support_regions);
            }
            Some(Pending::Mesh(_)) => self.refine_mesh(max_rays),
            Some(Pending::Difference) => {
                let clock = Instant::now();
                let rects = merge_rects(std::mem::take(&mut self.work.diff));
                update_depth_diff(&mut self.depth_diff, &self.mesh_frame, &self.field_frame, &rects);
                self.work.row.diff_s += clock.elapsed().as_secs_f64();
            }
            None => return false,
        }
        true
    }

    /// Traces a batch of the field image's stale pixels.
    fn refine_field(&mut self, max_rays: usize) {
        let field = ModelField::new(&self.scene.model, self.mode);
        let clock = Instant::now();
        let work = &mut self.work;
        let field = field.skipping(&self.empty);
        let known = (work.changed.as_ref(), work.coverage.as_ref());
        let stats = refine(&field, &self.settings, &mut self.field_frame, &mut work.field, known, max_rays);
        let seconds = clock.elapsed().as_secs_f64();
        work.row.field_s += seconds;
        work.traced = (work.traced.0 + stats.rays, work.traced.1 + seconds);
        work.row.field_evals += stats.field_evals;
        work.row.retraced_fraction += stats.rays as f64 / f64::from(self.settings.width * self.settings.height);
        if stats.rays >= MIN_BATCH_RAYS as u64 {
            work.rays_per_second = stats.rays as f64 / seconds.max(1e-6);
        }
        if work.field.is_done() {
            (work.changed, work.coverage) = (None, None);
        }
    }

    /// The coverage of the model's possible surface, as the camera sees it
    /// now: the kernel tracer's lists where it traces the model.
    fn coverage(&self) -> Coverage {
        let (w, h) = (self.settings.width, self.settings.height);
        match self.kernel_tracer() {
            Some(kernel) => Coverage::of_kernels(kernel, w),
            None => Coverage::of(&self.empty, &self.scene.model.bounds(), &self.settings.camera, w, h),
        }
    }

    /// The kernel tracer for the model as it stands and the camera, where it traces the model.
    fn kernel_tracer(&self) -> Option<KernelTracer> {
        let size = (self.settings.width, self.settings.height);
        self.kernel.clone().map(|supports| KernelTracer::of_supports(supports, &self.settings.camera, size))
    }

    /// The model's kernel supports as it stands, where the kernel tracer traces it.
    fn kernel_supports(&self) -> Option<Arc<KernelSupports>> {
        kernel::decide(&self.scene.model, self.mode).0.map(Arc::new)
    }

    /// Which tracer renders the field: `kernel` or `segment`.
    #[must_use]
    pub fn tracer(&self) -> &'static str {
        if self.kernel.is_some() { "kernel" } else { "segment" }
    }

    /// Casts a batch of the mesh image's stale pixels.
    fn refine_mesh(&mut self, max_rays: usize) {
        let clock = Instant::now();
        refine_mesh(&self.dynamic, &self.settings, &mut self.mesh_frame, &mut self.work.mesh, max_rays);
        self.work.row.mesh_render_s += clock.elapsed().as_secs_f64();
    }

    /// The field image as it stands: stale pixels show the nearest traced one.
    #[must_use]
    pub fn field_preview(&self) -> Cow<'_, Frame> {
        self.work.field.preview(&self.field_frame)
    }

    /// The mesh image as it stands: stale pixels show the nearest cast one.
    #[must_use]
    pub fn mesh_preview(&self) -> Cow<'_, Frame> {
        self.work.mesh.preview(&self.mesh_frame)
    }

    /// The field image's stale pixels, to preview a channel of it alone.
    #[must_use]
    pub fn field_refinement(&self) -> &Refinement {
        &self.work.field
    }

    /// The mesh image's stale pixels.
    #[must_use]
    pub fn mesh_refinement(&self) -> &Refinement {
        &self.work.mesh
    }

    /// The depth difference of the two previews.
    #[must_use]
    pub fn depth_diff_preview(&self) -> Cow<'_, [f32]> {
        match self.pending() {
            None => Cow::Borrowed(&self.depth_diff),
            Some(_) => Cow::Owned(differences(&self.mesh_preview(), &self.field_preview(), Metric::Depth)),
        }
    }

    /// Re-polygonizes near the change and updates the BVH2; the mesh image
    /// and the depth difference are then stale in the rectangles the
    /// triangles moved in.
    fn remesh(&mut self, regions: &[Aabb], support_regions: &[Support]) {
        let (w, h) = (self.settings.width, self.settings.height);
        let field = ModelField::new(&self.scene.model, self.mode);
        let row = &mut self.work.row;
        let clock = Instant::now();
        let seeds = skeleton_seeds(&self.scene.model, self.scene.model.root());
        let remeshed = self.polygonizer.repolygonize_within(&field, support_regions, &seeds);
        row.polygonize_s += clock.elapsed().as_secs_f64();
        let clock = Instant::now();
        row.bvh_rebuilt = self.dynamic.update(&self.polygonizer, &remeshed) == BvhUpdate::Rebuilt;
        row.bvh_s += clock.elapsed().as_secs_f64();
        // Triangles change only within two lattice cells of each edit's region.
        let margin = 2.0 * self.polygonizer.lattice().cell;
        let camera = &self.settings.camera;
        let mesh_rects =
            merge_rects(regions.iter().filter_map(|r| screen_rect(camera, w, h, &r.padded(margin))).collect());
        self.work.mesh.mark(&mesh_rects, PixelState::Trace);
        self.work.diff.extend(mesh_rects);
    }

    /// Whether the images, the mesh and the difference are up to date.
    #[must_use]
    pub fn is_refined(&self) -> bool {
        self.pending().is_none()
    }
}

/// The fewest field rays a batch of [`EditSession::refine`] traces: fewer
/// would cost more in set-up than in tracing.
const MIN_BATCH_RAYS: usize = 1024;

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
