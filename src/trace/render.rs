//! Rendering a frame by tracing one primary ray per pixel through a field,
//! rows in parallel. Each pixel depends only on its own ray, so the image is
//! bit-identical for any number of threads.

use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{Vec2, Vec3, Vec3A};
use rayon::prelude::*;

use super::changed_space::ChangedSpace;
use super::coverage::Coverage;
use super::kernel::KernelTracer;
use super::progressive::{PixelState, Refinement};
use super::samples::{PixelSample, PixelTotals, combine, sample_offset};
use super::segment::{Crossing, TraceOptions, march, snap_reach, trace_ray_from};
use super::shade::Lighting;
use crate::camera::Camera;
use crate::field::{EmptySpace, EvalMode, Field, Model, ModelField};
use crate::frame::{Frame, Size};
use crate::geom::{Ray, Support};

/// Everything a field render needs besides the field.
#[derive(Clone, Copy, Debug)]
pub struct RenderSettings {
    /// Camera.
    pub camera: Camera,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Colour of missed pixels (linear RGB).
    pub background: Vec3,
    /// Lights.
    pub lighting: Lighting,
    /// Tracer knobs.
    pub trace: TraceOptions,
    /// Rays per pixel (see [`super::samples`]); 1 is the pixel's centre alone.
    pub samples: u32,
}

impl RenderSettings {
    /// `model` seen through `camera` at `size` on `background`, with default
    /// lights and the tracer knobs sized to the model.
    #[must_use]
    pub fn new(camera: Camera, size: Size, background: Vec3, model: &Model) -> Self {
        Self {
            camera,
            width: size.0,
            height: size.1,
            background,
            lighting: Lighting::default(),
            trace: TraceOptions::for_bounds(&model.sizing_bounds()),
            samples: 1,
        }
    }
}

/// Totals over a render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct RenderStats {
    /// Primary rays traced.
    pub rays: u64,
    /// Rays that hit the surface.
    pub hits: u64,
    /// Field evaluations (values, gradients, colours and slope bounds).
    pub field_evals: u64,
    /// Segment-tracing steps.
    pub steps: u64,
}

impl RenderStats {
    /// The field tracer's totals, whose counters are steps and evaluations.
    fn of(t: PixelTotals) -> Self {
        RenderStats { rays: t.rays, hits: t.hits, steps: t.counts[0], field_evals: t.counts[1] }
    }
}

/// Names of the frame channels holding the field tracer's counters.
const FIELD_COUNTERS: [&str; 2] = ["steps.Y", "evals.Y"];

/// The name a render by kernels gives its steps: the supports each ray crossed.
pub const KERNEL_STEPS: &str = "supports.Y";

/// Renders `field` with `settings`; `progress` is called with the number of
/// finished rows (from worker threads).
pub fn render<F: Field + ?Sized>(
    field: &F,
    settings: &RenderSettings,
    progress: &(dyn Fn(usize) + Sync),
) -> (Frame, RenderStats) {
    render_covered(field, settings, None, progress)
}

/// [`render`], each ray's march starting where `coverage` says the surface
/// can first be (the same image, for less work).
pub fn render_covered<F: Field + ?Sized>(
    field: &F,
    settings: &RenderSettings,
    coverage: Option<&Coverage>,
    progress: &(dyn Fn(usize) + Sync),
) -> (Frame, RenderStats) {
    render_covered_into(blank_field_frame(settings), field, settings, coverage, progress)
}

/// [`render_covered`] into `frame`, a blank frame of the settings' (see [`blank_field_frame`]).
fn render_covered_into<F: Field + ?Sized>(
    frame: Frame,
    field: &F,
    settings: &RenderSettings,
    coverage: Option<&Coverage>,
    progress: &(dyn Fn(usize) + Sync),
) -> (Frame, RenderStats) {
    let (frame, totals) =
        render_pixels(frame, settings, progress, |x, y, at| trace_pixel(field, settings, (x, y, at), coverage));
    (frame, RenderStats::of(totals))
}

/// Renders `model` in `mode`: by kernels where the model's tracer choice
/// allows and its field is a sum of them; else by segments, marking its
/// empty space first to skip it and to start each ray where it can first
/// meet the surface. Returns the marks too, to update after edits (none
/// for the kernel tracer, which needs none).
pub fn render_model(
    model: &Model,
    mode: EvalMode,
    settings: &RenderSettings,
    progress: &(dyn Fn(usize) + Sync),
) -> (Frame, RenderStats, Option<EmptySpace>) {
    render_model_into(blank_field_frame(settings), model, mode, settings, progress)
}

/// [`render_model`] into `frame`, a blank frame of the settings' (see
/// [`blank_field_frame`]), made beforehand: a caller timing the rendering
/// alone makes its frame first, as it makes the model (a fresh frame's
/// pages are faulted in as it is filled).
pub fn render_model_into(
    frame: Frame,
    model: &Model,
    mode: EvalMode,
    settings: &RenderSettings,
    progress: &(dyn Fn(usize) + Sync),
) -> (Frame, RenderStats, Option<EmptySpace>) {
    let field = ModelField::new(model, mode);
    if let Some(kernel) = kernel_tracer(model, mode, settings) {
        let coverage = Coverage::of_kernels(kernel, settings.width);
        let (mut frame, stats) = render_covered_into(frame, &field, settings, Some(&coverage), progress);
        // The kernel tracer's steps are the supports each ray crossed.
        if let Some(steps) = frame.extra.iter_mut().find(|(name, _)| name == FIELD_COUNTERS[0]) {
            steps.0 = KERNEL_STEPS.into();
        }
        return (frame, stats, None);
    }
    let empty = EmptySpace::build(&field);
    let coverage = Coverage::of(&empty, &model.bounds(), &settings.camera, settings.width, settings.height);
    let (frame, stats) = render_covered_into(frame, &field.skipping(&empty), settings, Some(&coverage), progress);
    (frame, stats, Some(empty))
}

/// The kernel tracer for `model` in `mode` seen with `settings`, where the
/// model's tracer choice allows it and it applies.
#[must_use]
pub fn kernel_tracer(model: &Model, mode: EvalMode, settings: &RenderSettings) -> Option<KernelTracer> {
    let (supports, _) = super::kernel::decide(model, mode);
    let supports = std::sync::Arc::new(supports?);
    Some(KernelTracer::of_supports(supports, &settings.camera, (settings.width, settings.height)))
}

/// The space an edit changed, as the tracer must see it: `regions` (holding
/// every change of the field, world frame) padded by how far a change can
/// reach to move a snapped hit.
#[must_use]
pub fn changed_space<F: Field + ?Sized>(field: &F, settings: &RenderSettings, regions: &[Support]) -> ChangedSpace {
    ChangedSpace::new(regions, snap_reach(&settings.trace, field.bounds().diagonal()))
}

/// Updates `frame`, a render of `field` with `settings` before an edit that
/// changed the field inside `changed` only (see [`changed_space`]), within
/// the rectangle of pixels whose rays can meet it.
///
/// Every pixel depends on its own ray only, and a snapped hit on the field
/// near it only, so a ray is traced over its stretch inside the changed space
/// alone: before the stretch the field is unchanged and held no crossing (or
/// the old hit stands), and after it the old hit stands. The result equals a
/// full render. The stats count the rays traced, whole or in part.
pub fn rerender<F: Field + ?Sized>(
    field: &F,
    settings: &RenderSettings,
    frame: &mut Frame,
    changed: &ChangedSpace,
) -> RenderStats {
    let rect = changed.screen_rect(&settings.camera, settings.width, settings.height);
    rerender_pixels(frame, rect.as_slice(), FIELD_COUNTERS, |x, y, depth| {
        retrace_pixel(field, settings, x, y, depth, changed)
    })
    .stats()
}

/// What re-rendering a pixel whose ray can meet the change did.
#[derive(Clone, Copy, Debug)]
pub enum Retrace {
    /// Its ray was traced again, whole or in part, and the pixel stands.
    Kept(KeptPixel),
    /// The pixel now shows this.
    Changed(PixelSample),
}

/// A pixel traced again that stands as it was.
#[derive(Clone, Copy, Debug)]
pub struct KeptPixel {
    /// Whether it shows a hit.
    pub hit: bool,
    /// The work counters of tracing it again.
    pub counts: [u32; 2],
}

/// What pixel (`x`, `y`) shows after the field changed inside `changed`,
/// given the hit distance `before` it had; `None` when its ray cannot meet the change.
fn retrace_pixel<F: Field + ?Sized>(
    field: &F,
    s: &RenderSettings,
    x: u32,
    y: u32,
    before: f32,
    changed: &ChangedSpace,
) -> Option<Retrace> {
    let ray = s.camera.ray(x, y, s.width, s.height);
    let (t_in, t_out) = changed.span(&ray)?;
    if before < t_in {
        // The old hit lies in front of the change.
        return None;
    }
    let Some((t_start, t_end)) = field.bounds().clip_ray(ray.origin, ray.dir.recip(), 0.0, f32::INFINITY) else {
        return Some(Retrace::Changed(PixelSample::miss(s.background, [0, 0])));
    };
    if t_in <= t_start {
        return Some(Retrace::Changed(trace_pixel(field, s, (x, y, CENTRE), None)));
    }
    let (found, inside) = march(field, &ray, &s.trace, (t_in, t_out.min(t_end)));
    let mut work = [inside.steps, inside.evals];
    let hit = match found {
        Crossing::At(t) => Some(t),
        // Entering the surface exactly where the stretch starts: trace it whole.
        Crossing::InsideAtStart => return Some(Retrace::Changed(trace_pixel(field, s, (x, y, CENTRE), None))),
        Crossing::None if before > t_out => {
            return Some(Retrace::Kept(KeptPixel { hit: before.is_finite(), counts: work }));
        }
        Crossing::None => {
            // The old hit lay in the stretch and is gone: go on past it.
            let (found, after) = march(field, &ray, &s.trace, (t_out, t_end));
            work = [work[0] + after.steps, work[1] + after.evals];
            match found {
                Crossing::At(t) => Some(t),
                Crossing::InsideAtStart => {
                    return Some(Retrace::Changed(trace_pixel(field, s, (x, y, CENTRE), None)));
                }
                Crossing::None => None,
            }
        }
    };
    Some(Retrace::Changed(match hit {
        Some(t) => shade_hit(field, s, &ray, t, work),
        None => PixelSample::miss(s.background, work),
    }))
}

/// True when the ray of pixel (`x`, `y`), which hit at distance `before`,
/// can meet `changed` before or at that hit: what it shows may change.
fn reaches(changed: &ChangedSpace, s: &RenderSettings, (x, y): (u32, u32), before: f32) -> bool {
    let ray = s.camera.ray(x, y, s.width, s.height);
    changed.span(&ray).is_some_and(|(t_in, _)| before >= t_in)
}

/// Calls `pixel` with the hit distance each pixel inside `rects` had (in
/// parallel) and writes the samples it changes into `frame`, counters into the
/// extra channels named `counters`; returns what it traced again.
pub fn rerender_pixels(
    frame: &mut Frame,
    rects: &[super::PixelRect],
    counters: [&str; 2],
    pixel: impl Fn(u32, u32, f32) -> Option<Retrace> + Sync,
) -> Rerendered {
    let pixels: Vec<(u32, u32, PixelState)> = rects
        .iter()
        .flat_map(|r| (r.y0..r.y1).flat_map(move |y| (r.x0..r.x1).map(move |x| (x, y, PixelState::Retrace))))
        .collect();
    retrace_listed(frame, &pixels, counters, |x, y, _, depth| pixel(x, y, depth))
}

/// Traces the next batch of about `max_rays` stale pixels of `refinement`
/// into `frame`, a render of `field` with `settings` that was up to date
/// before the field changed inside `changed` (for the pixels to retrace)
/// or the camera moved (for those to trace whole, from where `coverage`
/// says). Once the refinement is done, `frame` equals a full render (see
/// [`crate::trace::progressive`]).
pub fn refine<F: Field + ?Sized>(
    field: &F,
    settings: &RenderSettings,
    frame: &mut Frame,
    refinement: &mut Refinement,
    (changed, coverage): (Option<&ChangedSpace>, Option<&Coverage>),
    max_rays: usize,
) -> RenderStats {
    let batch = refinement.next_batch(max_rays);
    let kernel = coverage.and_then(Coverage::kernel).is_some();
    let done = retrace_listed(frame, &batch, FIELD_COUNTERS, |x, y, state, before| match (state, changed) {
        // A kernel-traced ray's hit depends on the ray and the model alone:
        // traced again whole, it is what a full render finds.
        (PixelState::Retrace, Some(changed)) if kernel => reaches(changed, settings, (x, y), before)
            .then(|| Retrace::Changed(trace_pixel(field, settings, (x, y, CENTRE), coverage))),
        (PixelState::Retrace, Some(changed)) => retrace_pixel(field, settings, x, y, before, changed),
        _ => Some(Retrace::Changed(trace_pixel(field, settings, (x, y, CENTRE), coverage))),
    });
    refinement.finish(&batch);
    done.stats()
}

/// Traces each of `pixels` of `frame` (a render of `field` with `settings`)
/// again whole, its march starting where `coverage` says, and writes what
/// it finds with its counters: the image stays as it was (a pixel traced
/// whole is the same however it was traced before); its counts become
/// those of a render from scratch with that coverage.
pub fn retrace_whole<F: Field + ?Sized>(
    field: &F,
    settings: &RenderSettings,
    frame: &mut Frame,
    pixels: &[(u32, u32, PixelState)],
    coverage: &Coverage,
) -> RenderStats {
    let done = retrace_listed(frame, pixels, FIELD_COUNTERS, |x, y, _, _| {
        Some(Retrace::Changed(trace_pixel(field, settings, (x, y, CENTRE), Some(coverage))))
    });
    done.stats()
}

/// Calls `pixel` on each of `pixels` with its state and the hit distance it
/// had (in parallel) and writes the samples it changes into `frame`,
/// counters into the extra channels named `counters`.
pub fn retrace_listed(
    frame: &mut Frame,
    pixels: &[(u32, u32, PixelState)],
    counters: [&str; 2],
    pixel: impl Fn(u32, u32, PixelState, f32) -> Option<Retrace> + Sync,
) -> Rerendered {
    let depth = &frame.depth;
    let width = frame.width;
    let done: Vec<(usize, Retrace)> = pixels
        .par_iter()
        .filter_map(|&(x, y, state)| {
            let i = (y * width + x) as usize;
            pixel(x, y, state, depth[i]).map(|r| (i, r))
        })
        .collect();
    let channels = counters.map(|name| frame.extra.iter().position(|(n, _)| n == name));
    let mut out = Rerendered { changed: vec![], kept: vec![] };
    for (i, r) in done {
        let p = match r {
            Retrace::Changed(p) => p,
            Retrace::Kept(k) => {
                out.kept.push(k);
                continue;
            }
        };
        write_sample(frame, i, &p);
        for (k, channel) in channels.iter().enumerate() {
            if let Some(c) = *channel {
                frame.extra[c].1[i] = p.counts[k] as f32;
            }
        }
        out.changed.push(p);
    }
    out
}

/// The pixels [`rerender_pixels`] traced again.
#[derive(Debug, Default)]
pub struct Rerendered {
    /// Those that show something new (or the same, drawn again).
    pub changed: Vec<PixelSample>,
    /// Those traced again that stand as they were.
    pub kept: Vec<KeptPixel>,
}

impl Rerendered {
    /// The field tracer's totals over every pixel traced again.
    fn stats(&self) -> RenderStats {
        let mut stats = RenderStats::of(PixelTotals::of(&self.changed, 1));
        for kept in &self.kept {
            stats.rays += 1;
            stats.hits += u64::from(kept.hit);
            stats.steps += u64::from(kept.counts[0]);
            stats.field_evals += u64::from(kept.counts[1]);
        }
        stats
    }
}

/// Stores what pixel `i` shows: colour, depth, normal, coverage.
fn write_sample(frame: &mut Frame, i: usize, p: &PixelSample) {
    frame.color[i] = p.color;
    frame.depth[i] = p.depth;
    frame.normal[i] = p.normal;
    frame.alpha[i] = p.alpha;
}

/// A pixel's centre, in pixel units from its top-left corner: where its one ray goes.
pub const CENTRE: Vec2 = Vec2::splat(0.5);

/// Calls `pixel` for every pixel, rows in parallel, at each of the
/// settings' samples in it (see [`super::samples`]), combines each pixel's
/// samples and writes them in place into `frame` (of the settings' size,
/// with two counter channels: see [`blank_frame`]), the two counters into
/// its extra channels; returns the frame and the totals.
///
/// # Panics
/// Where `frame` is not of the settings' size or has not two extra channels.
pub fn render_pixels(
    mut frame: Frame,
    settings: &RenderSettings,
    progress: &(dyn Fn(usize) + Sync),
    pixel: impl Fn(u32, u32, Vec2) -> PixelSample + Sync,
) -> (Frame, PixelTotals) {
    // A row's chunk; at least one, so a frame with no pixels has no rows.
    let w = (settings.width as usize).max(1);
    assert!(
        (frame.width, frame.height) == (settings.width, settings.height) && frame.extra.len() == 2,
        "render_pixels fills a blank frame of the settings' size with two counter channels"
    );
    let done = AtomicUsize::new(0);
    let samples = settings.samples.max(1);
    let Frame { color, depth, normal, alpha, extra, .. } = &mut frame;
    let [(_, first), (_, second)] = &mut extra[..] else { unreachable!("checked above") };
    let rows = (
        color.par_chunks_mut(w),
        depth.par_chunks_mut(w),
        normal.par_chunks_mut(w),
        alpha.par_chunks_mut(w),
        first.par_chunks_mut(w),
        second.par_chunks_mut(w),
    );
    let totals = rows
        .into_par_iter()
        .enumerate()
        .map(|(y, row)| {
            let totals = fill_row(y as u32, row, samples, &pixel);
            progress(done.fetch_add(1, Ordering::Relaxed) + 1);
            totals
        })
        .reduce(PixelTotals::default, PixelTotals::plus);
    (frame, totals)
}

/// One row of a frame's channels: colour, depth, normal, coverage and the two counters.
type RowChannels<'a> = (&'a mut [Vec3], &'a mut [f32], &'a mut [Vec3], &'a mut [f32], &'a mut [f32], &'a mut [f32]);

/// Fills row `y` with `pixel`'s samples, `samples` rays a pixel combined;
/// returns the row's totals.
fn fill_row(
    y: u32,
    (color, depth, normal, alpha, first, second): RowChannels,
    samples: u32,
    pixel: &impl Fn(u32, u32, Vec2) -> PixelSample,
) -> PixelTotals {
    let mut totals = PixelTotals::default();
    for x in 0..color.len() {
        let px = x as u32;
        let p = match samples {
            1 => pixel(px, y, CENTRE),
            n => combine(&(0..n).map(|k| pixel(px, y, sample_offset(px, y, k))).collect::<Vec<_>>()),
        };
        (color[x], depth[x], normal[x], alpha[x]) = (p.color, p.depth, p.normal, p.alpha);
        (first[x], second[x]) = (p.counts[0] as f32, p.counts[1] as f32);
        totals = totals.with(&p, samples);
    }
    totals
}

/// Traces sample `k` (see [`super::samples`]) of every pixel of `rows`,
/// rows in parallel, each ray's march starting where `coverage` says;
/// row-major.
pub fn trace_sample_rows<F: Field + ?Sized>(
    field: &F,
    settings: &RenderSettings,
    coverage: Option<&Coverage>,
    k: u32,
    rows: std::ops::Range<u32>,
) -> Vec<PixelSample> {
    rows.into_par_iter()
        .flat_map_iter(|y| {
            (0..settings.width).map(move |x| trace_pixel(field, settings, (x, y, sample_offset(x, y, k)), coverage))
        })
        .collect()
}

/// Traces the ray through point `at` of pixel (`x`, `y`), its march
/// starting where `coverage` says (which holds for any point of the pixel).
fn trace_pixel<F: Field + ?Sized>(
    field: &F,
    s: &RenderSettings,
    (x, y, at): (u32, u32, Vec2),
    coverage: Option<&Coverage>,
) -> PixelSample {
    let near = coverage.map_or(0.0, |c| c.near(x, y));
    if near == f32::INFINITY {
        return PixelSample::miss(s.background, [0, 0]);
    }
    let ray = s.camera.ray_at(x as f32 + at.x, y as f32 + at.y, s.width, s.height);
    let r = match coverage.and_then(Coverage::kernel) {
        Some(kernel) => kernel.trace(field, &ray, (x, y), &s.trace),
        None => trace_ray_from(field, &ray, &s.trace, near),
    };
    match r.hit {
        Some(t) => shade_hit(field, s, &ray, t, [r.steps, r.evals]),
        None => PixelSample::miss(s.background, [r.steps, r.evals]),
    }
}

/// The pixel showing the hit at distance `t` along `ray`, after `work` (steps,
/// evaluations) spent finding it.
fn shade_hit<F: Field + ?Sized>(field: &F, s: &RenderSettings, ray: &Ray, t: f32, work: [u32; 2]) -> PixelSample {
    let p = ray.at(t);
    let (gradient, albedo) = field.gradient_and_color(p);
    let normal = outward_normal(gradient, ray.dir);
    PixelSample {
        color: s.lighting.shade(&s.camera, ray.dir, normal, albedo),
        depth: t,
        normal: normal.into(),
        alpha: 1.0,
        counts: [work[0], work[1] + 2],
    }
}

/// The unit outward normal `-∇f / |∇f|`; where the gradient vanishes (a flat
/// spot of the field), the normal faces the viewer.
#[must_use]
pub fn outward_normal(gradient: Vec3A, dir: Vec3A) -> Vec3A {
    (-gradient).try_normalize().unwrap_or(-dir)
}

/// A frame of `settings`' size showing the background, with the field
/// tracer's counter channels at zero: the start of a progressive render
/// (see [`refine`]).
#[must_use]
pub fn blank_field_frame(settings: &RenderSettings) -> Frame {
    blank_frame(settings, FIELD_COUNTERS)
}

/// A frame of `settings`' size showing the background, with the extra
/// channels named `counters` at zero.
#[must_use]
pub fn blank_frame(settings: &RenderSettings, counters: [&str; 2]) -> Frame {
    let mut frame = Frame::new(settings.width, settings.height, settings.background);
    let pixels = frame.len();
    frame.extra = counters.into_iter().map(|name| (name.into(), crate::frame::filled(pixels, 0.0))).collect();
    frame
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    #[test]
    fn pixels_are_written_in_place_with_their_counters_and_totals() {
        let scene = Scene::parse(
            "Scene(camera: Camera(eye: (0.0, 0.0, 5.0), target: (0.0, 0.0, 0.0), up: (0.0, 1.0, 0.0), fov_y: 40.0), \
             size: (7, 3), threshold: 0.5, model: Point(center: (0.0, 0.0, 0.0), radius: 1.0))",
            "inline",
        )
        .unwrap();
        let s = scene.render_settings(Size(7, 3));
        let sample = |x: u32, y: u32| PixelSample {
            color: Vec3::splat(x as f32),
            depth: y as f32,
            normal: Vec3::Z,
            alpha: f32::from(u8::from(x.is_multiple_of(2))),
            counts: [x, 10 * y],
        };
        let (frame, totals) = render_pixels(blank_frame(&s, ["a.Y", "b.Y"]), &s, &|_| {}, |x, y, _| sample(x, y));
        for (i, (x, y)) in (0..3).flat_map(|y| (0..7).map(move |x| (x, y))).enumerate() {
            assert_eq!(
                (frame.color[i], frame.depth[i], frame.alpha[i]),
                (Vec3::splat(x as f32), y as f32, sample(x, y).alpha)
            );
            assert_eq!((frame.extra[0].1[i], frame.extra[1].1[i]), (x as f32, (10 * y) as f32));
        }
        assert_eq!(totals, PixelTotals { rays: 21, hits: 12, counts: [63, 210] });
        // A frame of no pixels has no rows to fill.
        let empty = RenderSettings { width: 0, ..s };
        let (frame, totals) =
            render_pixels(blank_frame(&empty, ["a.Y", "b.Y"]), &empty, &|_| {}, |_, _, _| unreachable!());
        assert_eq!((frame.len(), totals), (0, PixelTotals::default()));
    }
}
