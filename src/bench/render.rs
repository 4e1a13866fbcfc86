//! Field rendering benchmarks: exact indexed evaluation against the naive
//! traversal, and cached rendering (cold and warm) against exact, with the
//! cached image's accuracy and the cost of one lookup per cache. Renders are
//! repeated in interleaved rounds and the fastest of each kind counts.

use std::path::PathBuf;
use std::time::Instant;

use glam::Vec3A;
use serde::Serialize;

use crate::field::{EvalMode, Model, NodeId, NodeKind, TracerChoice};
use crate::frame::{Frame, Size};
use crate::pipeline::{
    EvalSettings, FieldChoice, PipelineError, RenderReport, Result, Silent, render_field, with_threads,
};
use crate::progress::Progress;
use crate::scene::Scene;

/// What `bench eval` and `bench cache` render.
#[derive(Clone, Debug)]
pub struct RenderBenchSettings {
    /// Scene file.
    pub scene: PathBuf,
    /// Image size (default: the scene's).
    pub size: Option<Size>,
    /// Worker threads (default: all cores).
    pub threads: Option<usize>,
    /// Rounds of renders, each kind once per round; the fastest of each counts.
    pub repeat: u32,
}

/// The fastest of repeated renders of one kind, and every round's seconds.
pub(super) struct Fastest {
    best: Option<(Frame, RenderReport)>,
    runs_s: Vec<f64>,
}

impl Fastest {
    fn new() -> Self {
        Self { best: None, runs_s: vec![] }
    }

    /// Counts one round's render.
    fn offer(&mut self, (frame, report): (Frame, RenderReport)) {
        self.runs_s.push(report.seconds);
        if self.best.as_ref().is_none_or(|(_, b)| report.seconds < b.seconds) {
            self.best = Some((frame, report));
        }
    }

    /// The fastest render, and the seconds of every round.
    fn take(self) -> (Frame, RenderReport, Vec<f64>) {
        let (frame, report) = self.best.expect("at least one round");
        (frame, report, self.runs_s)
    }
}

/// What `bench eval --json` prints.
#[derive(Debug, Serialize)]
pub struct EvalBenchReport {
    /// The kernel tracer's render (exact, indexed), where the model is a sum of kernels.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kernel: Option<RenderReport>,
    /// The segment tracer's render, exact and indexed.
    pub segment: RenderReport,
    /// The segment tracer's render through the naive tree traversal: the baseline.
    pub naive: RenderReport,
    /// Seconds of the segment render over seconds of the kernel render.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kernel_vs_segment: Option<f64>,
    /// Seconds of the naive render over seconds of the kernel render.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kernel_vs_naive: Option<f64>,
    /// Seconds of the naive render over seconds of the segment render.
    pub segment_vs_naive: f64,
    /// Pixels whose hit/miss differs between the segment render and the naive one.
    pub mismatch_px: usize,
    /// Pixels whose hit/miss differs between the kernel render and the segment one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kernel_mismatch_px: Option<usize>,
    /// Seconds of each round's renders, by kind.
    pub runs_s: EvalBenchRuns,
}

/// Seconds of each round's renders in `bench eval`.
#[derive(Debug, Serialize)]
pub struct EvalBenchRuns {
    /// Kernel renders (none where the kernel tracer does not apply).
    pub kernel: Vec<f64>,
    /// Segment renders.
    pub segment: Vec<f64>,
    /// Naive segment renders.
    pub naive: Vec<f64>,
}

/// Renders `settings.scene` exact three ways, in interleaved rounds: by
/// the kernel tracer (where it applies) and the segment tracer with indexed
/// evaluation, and by the segment tracer through the naive tree traversal.
pub fn bench_eval(settings: &RenderBenchSettings, progress: &dyn Progress) -> Result<EvalBenchReport> {
    let scene = Scene::load(&settings.scene)?;
    let size = settings.size.unwrap_or(scene.size);
    // Each kind's scene, exact, with its tracer; none for kernels where they do not apply.
    let with = |tracer| {
        let mut s = scene.clone();
        let settings = EvalSettings { field: Some(FieldChoice::Exact), tracer, ..EvalSettings::default() };
        settings.apply(&mut s.model).ok().map(|_| s)
    };
    let kernel_scene = with(TracerChoice::Kernel);
    let segment_scene = with(TracerChoice::Segment).expect("the segment tracer traces any model");
    let (mut kernel, mut segment, mut naive) = (Fastest::new(), Fastest::new(), Fastest::new());
    let render = |s: &Scene, mode| with_threads(settings.threads, || render_field(s, (size, 1), mode, &Silent));
    for round in 0..settings.repeat {
        progress.update("benchmark rounds", u64::from(round), u64::from(settings.repeat));
        if let Some(s) = &kernel_scene {
            kernel.offer(render(s, EvalMode::Indexed)?);
        }
        segment.offer(render(&segment_scene, EvalMode::Indexed)?);
        naive.offer(render(&segment_scene, EvalMode::Naive)?);
    }
    let kernel = kernel_scene.map(|_| kernel.take());
    let ((segment_frame, segment, segment_runs), (naive_frame, naive, naive_runs)) = (segment.take(), naive.take());
    let hit_mismatch = |a: &Frame, b: &Frame| a.alpha.iter().zip(&b.alpha).filter(|(a, b)| a != b).count();
    let ratio = |slow: &RenderReport, fast: &RenderReport| slow.seconds / fast.seconds.max(1e-9);
    Ok(EvalBenchReport {
        kernel_vs_segment: kernel.as_ref().map(|(_, k, _)| ratio(&segment, k)),
        kernel_vs_naive: kernel.as_ref().map(|(_, k, _)| ratio(&naive, k)),
        segment_vs_naive: ratio(&naive, &segment),
        mismatch_px: hit_mismatch(&segment_frame, &naive_frame),
        kernel_mismatch_px: kernel.as_ref().map(|(frame, _, _)| hit_mismatch(frame, &segment_frame)),
        runs_s: EvalBenchRuns {
            kernel: kernel.as_ref().map_or_else(Vec::new, |(_, _, runs)| runs.clone()),
            segment: segment_runs,
            naive: naive_runs,
        },
        kernel: kernel.map(|(_, k, _)| k),
        segment,
        naive,
    })
}

/// What `bench cache --json` prints.
#[derive(Debug, Serialize)]
pub struct CacheBenchReport {
    /// Seconds of the exact naive render.
    pub exact_naive_s: f64,
    /// Seconds of the exact indexed render.
    pub exact_s: f64,
    /// Seconds of the cached render with empty caches.
    pub cached_cold_s: f64,
    /// Seconds of the same cached render again, caches filled.
    pub cached_warm_s: f64,
    /// Pixels hit by one of the exact and cached renders only.
    pub mismatch_px: usize,
    /// Mean depth difference over pixels both hit (scene units).
    pub mean_depth_err: f64,
    /// 99th percentile normal angle difference over pixels both hit.
    pub p99_normal_err_deg: f32,
    /// Bytes of sample storage held after the cached renders.
    pub cache_bytes: u64,
    /// Speed-ups: naive / warm, indexed / warm, indexed / cold.
    pub warm_vs_naive: f64,
    /// Exact indexed seconds over warm cached seconds.
    pub warm_vs_exact: f64,
    /// Exact indexed seconds over cold cached seconds.
    pub cold_vs_exact: f64,
    /// The cached render's statistics.
    pub cached: RenderReport,
    /// The exact indexed render's statistics: with the cached render's,
    /// where the ratio between the two comes from (evaluations asked, and
    /// the time each costs).
    pub exact: RenderReport,
    /// Per cache: the cost of one lookup against one exact evaluation of its subtree.
    pub lookups: Vec<LookupCost>,
    /// Seconds of each round's renders, by kind.
    pub runs_s: CacheBenchRuns,
}

/// Seconds of each round's renders in `bench cache`.
#[derive(Debug, Serialize)]
pub struct CacheBenchRuns {
    /// Exact naive renders.
    pub exact_naive: Vec<f64>,
    /// Exact indexed renders.
    pub exact: Vec<f64>,
    /// Cached renders from empty caches (each round loads the scene afresh).
    pub cached_cold: Vec<f64>,
    /// The same cached renders again, caches filled.
    pub cached_warm: Vec<f64>,
}

/// One cache's lookup cost against its subtree's size.
#[derive(Debug, Serialize)]
pub struct LookupCost {
    /// The cache's name.
    pub name: String,
    /// Primitives under the cache.
    pub primitives: usize,
    /// Nanoseconds per warm cached value lookup.
    pub cached_ns: f64,
    /// Nanoseconds per exact (indexed) value of the subtree at the same points.
    pub exact_ns: f64,
    /// The cost model's estimate of one exact value's work, in point terms.
    pub exact_cost: f32,
    /// Bytes of samples the warm render's cache holds.
    pub bytes: u64,
    /// Bytes a dense grid of four-byte samples would take.
    pub dense_bytes: u64,
}

/// Renders `settings.scene` exact (naive and indexed) and cached (cold and
/// warm) in interleaved rounds, and times one lookup of each cache.
pub fn bench_cache(settings: &RenderBenchSettings, progress: &dyn Progress) -> Result<CacheBenchReport> {
    let a = settings;
    let scene = Scene::load(&a.scene)?;
    if scene.model.counts().caches == 0 {
        return Err(PipelineError::Unsuitable(format!("{}: the scene has no Cache nodes", a.scene.display())));
    }
    let size = a.size.unwrap_or(scene.size);
    let (mut naive, mut exact, mut cold, mut warm) = (Fastest::new(), Fastest::new(), Fastest::new(), Fastest::new());
    for round in 0..a.repeat {
        progress.update("benchmark rounds", u64::from(round), u64::from(a.repeat));
        // Every round's cold render starts from empty caches.
        let scene = Scene::load(&a.scene)?;
        let run = |mode| with_threads(a.threads, || render_field(&scene, (size, 1), mode, &Silent));
        naive.offer(run(EvalMode::Naive)?);
        exact.offer(run(EvalMode::Indexed)?);
        cold.offer(run(EvalMode::Cached)?);
        warm.offer(run(EvalMode::Cached)?);
    }
    let ((_, naive, naive_runs), (exact_frame, exact, exact_runs)) = (naive.take(), exact.take());
    let ((cold_frame, cold, cold_runs), (warm_frame, warm, warm_runs)) = (cold.take(), warm.take());
    if cold_frame.color != warm_frame.color {
        return Err(PipelineError::Unsuitable(
            "internal error: the warm cached render differs from the cold one".into(),
        ));
    }
    let diff = warm_frame.geometry_difference(&exact_frame);
    let mut lookups = with_threads(Some(1), || lookup_costs(&scene.model))?;
    // What each cache holds is what the renders filled, not the few lookups timed.
    let held = warm.caches.iter().flat_map(|c| &c.per_cache);
    for (lookup, cache) in lookups.iter_mut().zip(held) {
        lookup.bytes = cache.stats.bytes;
    }
    let cache_bytes = warm.caches.as_ref().map_or(0, |c| c.bytes);
    Ok(CacheBenchReport {
        exact_naive_s: naive.seconds,
        exact_s: exact.seconds,
        cached_cold_s: cold.seconds,
        cached_warm_s: warm.seconds,
        mismatch_px: diff.mismatch_px,
        mean_depth_err: diff.mean_depth_err,
        p99_normal_err_deg: diff.p99_normal_err_deg,
        cache_bytes,
        warm_vs_naive: naive.seconds / warm.seconds.max(1e-9),
        warm_vs_exact: exact.seconds / warm.seconds.max(1e-9),
        cold_vs_exact: exact.seconds / cold.seconds.max(1e-9),
        cached: warm,
        exact,
        lookups,
        runs_s: CacheBenchRuns {
            exact_naive: naive_runs,
            exact: exact_runs,
            cached_cold: cold_runs,
            cached_warm: warm_runs,
        },
    })
}

/// Points where lookups are timed: inside the subtree's support, where a
/// polygonizer or tracer asks (empty space is cheap for both).
const LOOKUP_POINTS: usize = 20_000;

/// Times a warm lookup of every cache of `model` and an exact evaluation of
/// its subtree at the same points, on the calling thread, beside the cost
/// model's estimate of the exact work.
pub fn lookup_costs(model: &Model) -> Vec<LookupCost> {
    let estimates = model.cache_decisions();
    model
        .cache_stats()
        .into_iter()
        .filter_map(|(id, name, stats)| {
            let NodeKind::Cache { child, .. } = model.node(id).kind else { return None };
            let points = support_points(model, child);
            let time = |mode: EvalMode, node: NodeId| {
                let start = Instant::now();
                let sum: f32 = points.iter().map(|&p| model.node_value(node, p, mode)).sum();
                std::hint::black_box(sum);
                start.elapsed().as_secs_f64() * 1e9 / points.len().max(1) as f64
            };
            time(EvalMode::Cached, id); // fill
            Some(LookupCost {
                name,
                primitives: model.primitives_under(id),
                cached_ns: time(EvalMode::Cached, id),
                exact_ns: time(EvalMode::Indexed, child),
                exact_cost: estimates.iter().find(|d| d.node == id).map_or(0.0, |d| d.value_cost),
                // Filled in from the warm render by the caller.
                bytes: 0,
                dense_bytes: stats.grid_points * 4,
            })
        })
        .collect()
}

/// Up to [`LOOKUP_POINTS`] deterministic random points where `node`'s field is non-zero.
fn support_points(model: &Model, node: NodeId) -> Vec<Vec3A> {
    let b = model.node(node).bounds;
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut out = Vec::with_capacity(LOOKUP_POINTS);
    for _ in 0..LOOKUP_POINTS * 50 {
        let p = b.min + b.size() * Vec3A::new(next(), next(), next());
        if model.node_value(node, p, EvalMode::Indexed) > 0.0 {
            out.push(p);
            if out.len() == LOOKUP_POINTS {
                break;
            }
        }
    }
    out
}
