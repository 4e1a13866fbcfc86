//! `blobtrace edit`: replay an edit script, updating per frame only what the
//! edit changed — the dirty rectangles of the field image, the mesh cells near
//! the change, their triangles in the BVH2, the mesh image and the diff in
//! those rectangles — timing each stage; `--verify` checks every frame against
//! a render and a polygonization from scratch.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::Args;
use serde::Serialize;

use super::mesh::{MAX_RES, PolygonizeArgs};
use super::{EvalOptions, with_threads};
use crate::bvh::{BvhUpdate, DynamicMesh, render_mesh, rerender_mesh};
use crate::compare::{Metric, Rgb8Image, difference_at, differences, frame_image, line_plot};
use crate::field::{Edit, EmptySpace, EvalMode, ModelField};
use crate::frame::Frame;
use crate::geom::{Aabb, Support};
use crate::mesh::{Polygonizer, canonical_triangles, skeleton_seeds};
use crate::scene::{Scene, Script, Size, load_script};
use crate::trace::{
    PixelRect, RenderSettings, changed_space, merge_rects, render, render_model, rerender, screen_rect,
};

/// Options of `blobtrace edit`.
#[derive(Debug, Args)]
pub struct EditArgs {
    /// Scene file (RON).
    pub scene: PathBuf,
    /// Edit script (RON), e.g. scenes/medusa-head.ron.
    #[arg(long)]
    pub script: PathBuf,
    /// Image size WIDTHxHEIGHT (default: the scene's).
    #[arg(long, value_parser = super::parse_size)]
    pub size: Option<Size>,
    /// Polygonizer options.
    #[command(flatten)]
    pub polygonize: PolygonizeArgs,
    /// Field evaluation.
    #[command(flatten)]
    pub field: EvalOptions,
    /// Directory for frames.csv, timing.png and, with --save-frames, every frame.
    #[arg(long, default_value = "edit")]
    pub out_dir: PathBuf,
    /// Render and polygonize every frame from scratch too, and check the
    /// incremental field image is bit-identical and the mesh has the same triangles.
    #[arg(long)]
    pub verify: bool,
    /// Write every frame's field image with its dirty rectangles outlined.
    #[arg(long)]
    pub save_frames: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

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
    /// Seconds of a full render plus a full polygonization (with --verify).
    pub full_s: Option<f64>,
    /// Of which the full render of the field (with --verify).
    pub full_render_s: Option<f64>,
    /// Cached samples the edits cleared.
    pub samples_cleared: u64,
    /// Triangles after the frame.
    pub triangles: usize,
}

/// What `edit --json` prints.
#[derive(Debug, Serialize)]
pub struct EditReport {
    /// Frames replayed.
    pub frames: usize,
    /// Frames checked against from-scratch results (with --verify).
    pub verified_frames: usize,
    /// Total seconds of the from-scratch renders and polygonizations (with --verify).
    pub full_s: Option<f64>,
    /// Total seconds of the incremental updates.
    pub incremental_s: f64,
    /// Mean fraction of the pixels inside the dirty rectangles per frame.
    pub dirty_fraction: f64,
    /// Mean fraction of the pixels whose rays were traced again per frame.
    pub retraced_fraction: f64,
    /// Evaluation mode.
    pub eval: String,
    /// Each frame.
    pub per_frame: Vec<FrameRow>,
}

/// Everything kept between frames.
pub(super) struct EditState {
    pub(super) settings: RenderSettings,
    mode: EvalMode,
    pub(super) polygonizer: Polygonizer,
    pub(super) dynamic: DynamicMesh,
    pub(super) field_frame: Frame,
    /// The field's empty space, updated where each edit changed the field.
    empty: EmptySpace,
    pub(super) mesh_frame: Frame,
    /// Mesh depth less field depth, per pixel.
    pub(super) depth_diff: Vec<f32>,
}

/// Runs `blobtrace edit`.
pub fn run(a: &EditArgs) -> anyhow::Result<()> {
    let mut scene = Scene::load(&a.scene)?;
    let mode = a.field.apply(&mut scene.model)?;
    let script = load_script(&a.script)?;
    check_names(&scene, &script)?;
    let size = a.size.unwrap_or(scene.size);
    let report = with_threads(a.threads, || -> anyhow::Result<EditReport> {
        a.polygonize.check_unrefined(&scene, "edit")?;
        std::fs::create_dir_all(&a.out_dir).with_context(|| format!("creating {}", a.out_dir.display()))?;
        let (rows, verified) = replay(&mut scene, mode, &script, &a.polygonize, size, a.verify, |i, frame, rects| {
            if a.save_frames { save_frame(&a.out_dir, i, frame, rects) } else { Ok(()) }
        })?;
        Ok(summarize(rows, verified, mode))
    })??;
    write_outputs(a, &report)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&report).context("encoding the report")?);
    } else {
        eprintln!(
            "{}: {} frames, {:.3} s incremental{}, {:.1}% of the pixels in dirty rectangles and {:.1}% re-traced per frame",
            a.out_dir.display(),
            report.frames,
            report.incremental_s,
            report.full_s.map_or(String::new(), |f| format!(
                " against {f:.3} s from scratch ({} verified)",
                report.verified_frames
            )),
            100.0 * report.dirty_fraction,
            100.0 * report.retraced_fraction
        );
    }
    Ok(())
}

/// Checks before any work that every edit names a node that exists by then
/// (names added and removed by earlier edits of the script count).
pub(super) fn check_names(scene: &Scene, script: &Script) -> anyhow::Result<()> {
    let mut known: std::collections::HashSet<String> = scene.model.names().into_iter().map(String::from).collect();
    for (i, edits) in script.frames.iter().enumerate() {
        for e in edits {
            if !known.contains(e.node()) {
                anyhow::bail!("{}: no node is named {:?}", script.frame_label(i), e.node());
            }
            match e {
                Edit::AddPoint { name, .. } => known.insert(name.clone()),
                Edit::Remove { node } => known.remove(node),
                _ => true,
            };
        }
    }
    Ok(())
}

/// Seconds one frame takes from scratch: a full render, a full polygonization.
#[derive(Clone, Copy, Debug, Default)]
pub struct ScratchFrame {
    /// Rendering the field.
    pub render_s: f64,
    /// Polygonizing the field.
    pub polygonize_s: f64,
    /// The full render's field evaluations.
    pub evaluations: f64,
    /// Those of them spent on pixels that differ from the frame before's:
    /// what a dirty-rectangle frame, bit-identical to this one, must at least
    /// trace again.
    pub changed_evaluations: f64,
}

/// Replays the frames of `script` on `scene`, rendering and polygonizing every frame
/// from scratch: the baseline of the incremental updates, with caches that only
/// its own work has filled (a from-scratch frame run after an incremental one
/// would find the samples that frame filled). Like the incremental replay, it
/// starts from the scene rendered and polygonized once, untimed.
pub fn replay_from_scratch(
    scene: &mut Scene,
    mode: EvalMode,
    script: &Script,
    polygonize: &PolygonizeArgs,
    size: Size,
) -> anyhow::Result<Vec<ScratchFrame>> {
    let settings = RenderSettings::for_scene(scene, size);
    let lattice = crate::mesh::Lattice::for_model(&scene.model, polygonize.res);
    let polygonize_from_scratch = |scene: &Scene| {
        let mut fresh = Polygonizer::new(lattice, polygonize.options());
        fresh.polygonize(&ModelField::new(&scene.model, mode), &skeleton_seeds(&scene.model, scene.model.root()));
    };
    let mut before = render_model(&scene.model, mode, &settings, &|_| {}).0;
    polygonize_from_scratch(scene);
    let mut rows = vec![];
    for (i, edits) in script.frames.iter().enumerate() {
        for edit in edits {
            scene.model.apply(edit).with_context(|| script.frame_label(i))?;
        }
        let clock = Instant::now();
        let after = render_model(&scene.model, mode, &settings, &|_| {}).0;
        let render_s = clock.elapsed().as_secs_f64();
        let clock = Instant::now();
        polygonize_from_scratch(scene);
        let polygonize_s = clock.elapsed().as_secs_f64();
        let (evaluations, changed_evaluations) = evaluations_where_changed(&before, &after);
        rows.push(ScratchFrame { render_s, polygonize_s, evaluations, changed_evaluations });
        before = after;
    }
    Ok(rows)
}

/// The field evaluations of `after`'s pixels, all of them and those whose
/// colour, depth or normal differ from `before`'s.
fn evaluations_where_changed(before: &Frame, after: &Frame) -> (f64, f64) {
    let Some(evals) = after.aov("evals.Y") else { return (0.0, 0.0) };
    let differs = |i: usize| {
        after.depth[i].to_bits() != before.depth[i].to_bits()
            || after.color[i] != before.color[i]
            || after.normal[i] != before.normal[i]
    };
    (0..evals.len()).fold((0.0, 0.0), |(all, changed), i| {
        let e = f64::from(evals[i]);
        (all + e, if differs(i) { changed + e } else { changed })
    })
}

/// Replays the frames of `script` on `scene`, updating incrementally and timing each
/// frame; with `verify`, checks each frame against from-scratch results.
/// `after_frame` sees each frame's field image and dirty rectangles. Returns
/// the rows and the number of verified frames.
pub fn replay(
    scene: &mut Scene,
    mode: EvalMode,
    script: &Script,
    polygonize: &PolygonizeArgs,
    size: Size,
    verify_frames: bool,
    mut after_frame: impl FnMut(usize, &Frame, &[PixelRect]) -> anyhow::Result<()>,
) -> anyhow::Result<(Vec<FrameRow>, usize)> {
    let mut state = initial_state(scene, mode, size, polygonize);
    let mut rows = vec![];
    let mut verified = 0;
    for (i, edits) in script.frames.iter().enumerate() {
        let (mut row, rects) = step(scene, &mut state, edits, i).with_context(|| script.frame_label(i))?;
        if verify_frames {
            let (render_s, full_s, mismatch) = verify(scene, &state, polygonize);
            if let Some(what) = mismatch {
                anyhow::bail!("{}: the incremental result differs from the full one: {what}", script.frame_label(i));
            }
            row.full_s = Some(full_s);
            row.full_render_s = Some(render_s);
            verified += 1;
        }
        after_frame(i, &state.field_frame, &rects)?;
        rows.push(row);
    }
    Ok((rows, verified))
}

pub(super) fn initial_state(scene: &Scene, mode: EvalMode, size: Size, polygonize: &PolygonizeArgs) -> EditState {
    let settings = RenderSettings::for_scene(scene, size);
    let (field_frame, _, empty) = render_model(&scene.model, mode, &settings, &|_| {});
    let field = ModelField::new(&scene.model, mode);
    let lattice = crate::mesh::Lattice::for_model(&scene.model, polygonize.res);
    let mut polygonizer = Polygonizer::new(lattice, polygonize.options());
    polygonizer.polygonize(&field, &skeleton_seeds(&scene.model, scene.model.root()));
    let dynamic = DynamicMesh::build(&polygonizer);
    let mesh_frame = render_mesh(&dynamic, &settings, &|_| {}).0;
    let depth_diff = differences(&mesh_frame, &field_frame, Metric::Depth);
    EditState { settings, mode, polygonizer, dynamic, field_frame, empty, mesh_frame, depth_diff }
}

/// Looks through `camera` from now on: the field, the mesh and their
/// difference are rendered again whole (the empty space and the mesh keep).
pub(super) fn set_camera(scene: &Scene, s: &mut EditState, camera: crate::camera::Camera) {
    s.settings.camera = camera;
    let field = ModelField::new(&scene.model, s.mode);
    s.field_frame = render(&field.skipping(&s.empty), &s.settings, &|_| {}).0;
    s.mesh_frame = render_mesh(&s.dynamic, &s.settings, &|_| {}).0;
    s.depth_diff = differences(&s.mesh_frame, &s.field_frame, Metric::Depth);
}

/// Applies one frame's edits and updates everything incrementally.
pub(super) fn step(
    scene: &mut Scene,
    s: &mut EditState,
    edits: &[Edit],
    frame: usize,
) -> anyhow::Result<(FrameRow, Vec<PixelRect>)> {
    let mut row = FrameRow { frame, ..Default::default() };
    let clock = Instant::now();
    let (mut regions, mut support_regions) = (vec![], vec![]);
    let cached = s.mode == EvalMode::Cached;
    for edit in edits {
        let change = scene.model.apply(edit)?;
        row.samples_cleared += change.samples_cleared;
        regions.push(scene.model.change_region(&change, cached));
        support_regions.extend(scene.model.change_support_regions(&change, cached));
    }
    let supports: Vec<Aabb> = support_regions.iter().map(Support::bounds).collect();
    row.apply_s = clock.elapsed().as_secs_f64();
    check_edited_model(&scene.model, s.polygonizer.lattice())?;
    let (w, h) = (s.settings.width, s.settings.height);
    let field = ModelField::new(&scene.model, s.mode);
    let clock = Instant::now();
    s.empty.update(&supports);
    let changed = changed_space(&field, &s.settings, &support_regions);
    let rects: Vec<PixelRect> = changed.screen_rect(&s.settings.camera, w, h).into_iter().collect();
    row.dirty_fraction = rects.iter().map(PixelRect::area).sum::<u64>() as f64 / f64::from(w * h);
    let retraced = rerender(&field.skipping(&s.empty), &s.settings, &mut s.field_frame, &changed);
    row.field_s = clock.elapsed().as_secs_f64();
    row.retraced_fraction = retraced.rays as f64 / f64::from(w * h);
    row.field_evals = retraced.field_evals;
    let clock = Instant::now();
    let seeds = skeleton_seeds(&scene.model, scene.model.root());
    let remeshed = s.polygonizer.repolygonize_within(&field, &support_regions, &seeds);
    row.polygonize_s = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    row.bvh_rebuilt = s.dynamic.update(&s.polygonizer, &remeshed) == BvhUpdate::Rebuilt;
    row.bvh_s = clock.elapsed().as_secs_f64();
    // Triangles change only within two lattice cells of each edit's region.
    let margin = 2.0 * s.polygonizer.lattice().cell;
    let mesh_rects =
        merge_rects(regions.iter().filter_map(|r| screen_rect(&s.settings.camera, w, h, &r.padded(margin))).collect());
    let clock = Instant::now();
    rerender_mesh(&s.dynamic, &s.settings, &mut s.mesh_frame, &mesh_rects);
    row.mesh_render_s = clock.elapsed().as_secs_f64();
    let clock = Instant::now();
    update_depth_diff(&mut s.depth_diff, &s.mesh_frame, &s.field_frame, &mesh_rects);
    row.diff_s = clock.elapsed().as_secs_f64();
    row.incremental_s = row.apply_s + row.field_s + row.polygonize_s + row.bvh_s + row.mesh_render_s + row.diff_s;
    row.triangles = s.dynamic.triangle_count();
    Ok((row, rects))
}

/// Refuses an edited model the frame's work cannot handle: one too far from
/// the origin for single precision, or one grown past the largest mesh the
/// lattice (fixed by `--res` over the first frame's bounds) may make.
fn check_edited_model(model: &crate::field::Model, lattice: crate::mesh::Lattice) -> anyhow::Result<()> {
    model.check_reach()?;
    let cells = model.bounds().size().max_element() / lattice.cell;
    anyhow::ensure!(
        cells <= MAX_RES as f32,
        "the edited model spans {cells:.0} cells of the mesh lattice, more than {MAX_RES}: the edits grow it too far for --res"
    );
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

/// Renders and polygonizes from scratch, on a copy of the model with cold
/// caches on the same lattices (so a sample an edit should have cleared and
/// did not shows); returns the seconds rendering, the seconds in all, and how
/// the incremental image or mesh differ from them, if they do.
fn verify(scene: &Scene, s: &EditState, polygonize: &PolygonizeArgs) -> (f64, f64, Option<String>) {
    let fresh_model = scene.model.clone();
    let clock = Instant::now();
    let full = render_model(&fresh_model, s.mode, &s.settings, &|_| {}).0;
    let render_s = clock.elapsed().as_secs_f64();
    let field = ModelField::new(&fresh_model, s.mode);
    let mut fresh = Polygonizer::new(s.polygonizer.lattice(), polygonize.options());
    fresh.polygonize(&field, &skeleton_seeds(&fresh_model, fresh_model.root()));
    let mesh = fresh.mesh();
    let seconds = clock.elapsed().as_secs_f64();
    let mut mismatch = image_mismatch(&full, &s.field_frame);
    if mesh.triangle_set() != canonical_triangles(s.dynamic.triangles()) {
        mismatch = Some(mismatch.map_or(String::new(), |m| m + "; ") + "the meshes differ");
    }
    (render_s, seconds, mismatch)
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

fn save_frame(dir: &std::path::Path, i: usize, frame: &Frame, rects: &[PixelRect]) -> anyhow::Result<()> {
    let mut img = frame_image(frame);
    outline(&mut img, rects);
    img.save_png(&dir.join(format!("frame-{i:04}.png")))
}

/// Draws the edges of `rects` on `img`, in yellow.
pub(super) fn outline(img: &mut Rgb8Image, rects: &[PixelRect]) {
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

fn summarize(rows: Vec<FrameRow>, verified: usize, mode: EvalMode) -> EditReport {
    let n = rows.len().max(1) as f64;
    EditReport {
        frames: rows.len(),
        verified_frames: verified,
        full_s: rows.iter().map(|r| r.full_s).sum::<Option<f64>>(),
        incremental_s: rows.iter().map(|r| r.incremental_s).sum(),
        dirty_fraction: rows.iter().map(|r| r.dirty_fraction).sum::<f64>() / n,
        retraced_fraction: rows.iter().map(|r| r.retraced_fraction).sum::<f64>() / n,
        eval: format!("{mode:?}").to_lowercase(),
        per_frame: rows,
    }
}

fn write_outputs(a: &EditArgs, r: &EditReport) -> anyhow::Result<()> {
    let mut csv = String::from(
        "frame,dirty_fraction,retraced_fraction,field_evals,apply_s,field_s,polygonize_s,bvh_s,bvh_rebuilt,mesh_render_s,diff_s,incremental_s,full_s,samples_cleared,triangles\n",
    );
    for f in &r.per_frame {
        let full = f.full_s.map_or(String::new(), |v| format!("{v:.6}"));
        let _ = writeln!(
            csv,
            "{},{:.5},{:.5},{},{:.6},{:.6},{:.6},{:.6},{},{:.6},{:.6},{:.6},{full},{},{}",
            f.frame,
            f.dirty_fraction,
            f.retraced_fraction,
            f.field_evals,
            f.apply_s,
            f.field_s,
            f.polygonize_s,
            f.bvh_s,
            f.bvh_rebuilt,
            f.mesh_render_s,
            f.diff_s,
            f.incremental_s,
            f.samples_cleared,
            f.triangles
        );
    }
    crate::output::write_atomic(&a.out_dir.join("frames.csv"), csv.as_bytes()).context("writing frames.csv")?;
    let incremental: Vec<f64> = r.per_frame.iter().map(|f| f.incremental_s).collect();
    let field: Vec<f64> = r.per_frame.iter().map(|f| f.field_s).collect();
    let mesh: Vec<f64> = r.per_frame.iter().map(|f| f.polygonize_s + f.bvh_s + f.mesh_render_s).collect();
    let full: Vec<f64> = r.per_frame.iter().map(|f| f.full_s.unwrap_or(f64::NAN)).collect();
    let mut series: Vec<(&str, &[f64])> = vec![("incremental", &incremental), ("field", &field), ("mesh", &mesh)];
    if r.full_s.is_some() {
        series.push(("from scratch", &full));
    }
    let title = format!("seconds per frame ({})", r.eval);
    line_plot(&title, "s", &series, 720, 360).save_png(&a.out_dir.join("timing.png"))
}
