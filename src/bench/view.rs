//! The previewer's latency without a window: the edit session the viewer
//! drives replays the events a user makes — orbit steps, zoom steps, moves
//! of a named node, an edit script's frames — and each event kind reports
//! how long its first, coarse pass took to show, how long until everything
//! (field, mesh, difference) was refined, and the frame rates those allow.

use std::path::PathBuf;
use std::time::Instant;

use glam::Vec3;
use serde::Serialize;

use crate::camera::{CameraMove, Orbit};
use crate::field::{Edit, TracerChoice};
use crate::frame::Size;
use crate::pipeline::{
    EditSession, EvalSettings, FieldChoice, Pending, PipelineError, PolygonizeSettings, Result, with_threads,
};
use crate::scene::{Scene, Script, load_script};

/// What `bench view` replays.
#[derive(Clone, Debug)]
pub struct ViewBenchSettings {
    /// Scene file.
    pub scene: PathBuf,
    /// Image size.
    pub size: Size,
    /// Edit script whose frames are replayed as the last event kind.
    pub script: Option<PathBuf>,
    /// Events of each of the orbit, zoom and node-move kinds.
    pub events: u32,
    /// Worker threads (default: all cores).
    pub threads: Option<usize>,
    /// Which ray tracer renders the field.
    pub tracer: TracerChoice,
}

/// Latency of one kind of event.
#[derive(Clone, Debug, Serialize)]
pub struct EventLatency {
    /// orbit, zoom, node move or script frame.
    pub kind: String,
    /// Events replayed.
    pub events: usize,
    /// Until the first, coarse pass showed.
    pub first_pass: Seconds,
    /// Until the field image was refined whole.
    pub field_refined: Seconds,
    /// Until everything was: the field, the mesh and its image, the difference.
    pub refined: Seconds,
    /// Frames per second the median first pass allows: how often the view follows input.
    pub frame_rate: f64,
}

/// The median and the slowest of some events' seconds.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Seconds {
    /// Median.
    pub median: f64,
    /// Slowest.
    pub max: f64,
}

impl Seconds {
    fn of(mut seconds: Vec<f64>) -> Self {
        seconds.sort_by(f64::total_cmp);
        Self { median: seconds[seconds.len() / 2], max: seconds.last().copied().unwrap_or(0.0) }
    }
}

/// What `bench view` measured.
#[derive(Clone, Debug, Serialize)]
pub struct ViewBenchReport {
    /// Scene file.
    pub scene: String,
    /// Image size.
    pub size: Size,
    /// Seconds from loading to the first frame shown: the scene loaded, the
    /// mesh and its BVH built, the coarse passes of the field and mesh images.
    pub launch_seconds: f64,
    /// Seconds from loading until those images are refined whole.
    pub launch_refined_seconds: f64,
    /// Per event kind.
    pub events: Vec<EventLatency>,
    /// Threads used.
    pub threads: usize,
}

/// Replays `a`'s events on a fresh edit session and times each.
pub fn bench_view(a: &ViewBenchSettings) -> Result<ViewBenchReport> {
    if a.events == 0 {
        return Err(PipelineError::setting("events", "must be at least 1"));
    }
    let script = a.script.as_deref().map(load_script).transpose()?;
    with_threads(a.threads, || {
        let start = Instant::now();
        let mut scene = Scene::load(&a.scene)?;
        let settings = EvalSettings { field: Some(FieldChoice::Exact), tracer: a.tracer, ..EvalSettings::default() };
        let mode = settings.apply(&mut scene.model)?;
        let mut session = EditSession::begin(scene, mode, a.size, &PolygonizeSettings::default())?;
        let launch_seconds = start.elapsed().as_secs_f64();
        session.finish();
        let launch_refined_seconds = start.elapsed().as_secs_f64();
        let mut events = vec![camera_events(&mut session, "orbit", a.events, orbit_step)?];
        events.push(camera_events(&mut session, "zoom", a.events, zoom_step)?);
        if let Some(moves) = node_moves(&mut session, a.events)? {
            events.push(moves);
        }
        if let Some(script) = &script {
            events.push(script_frames(&mut session, script)?);
        }
        Ok(ViewBenchReport {
            scene: a.scene.display().to_string(),
            size: a.size,
            launch_seconds,
            launch_refined_seconds,
            events,
            threads: rayon::current_num_threads(),
        })
    })?
}

/// The latency of `kind` from the times of its events.
fn latency(kind: &str, times: &[EventTimes]) -> EventLatency {
    let first_pass = Seconds::of(times.iter().map(|t| t.first_pass).collect());
    EventLatency {
        kind: kind.into(),
        events: times.len(),
        first_pass,
        field_refined: Seconds::of(times.iter().map(|t| t.field_refined).collect()),
        refined: Seconds::of(times.iter().map(|t| t.refined).collect()),
        frame_rate: 1.0 / first_pass.median.max(1e-9),
    }
}

/// One event's times from its start, in seconds.
struct EventTimes {
    first_pass: f64,
    field_refined: f64,
    refined: f64,
}

/// Times an event `begin` starts on `session`, then its refinement as the
/// viewer runs it while idle.
fn timed<T>(session: &mut EditSession, begin: impl FnOnce(&mut EditSession) -> Result<T>) -> Result<EventTimes> {
    let start = Instant::now();
    begin(session)?;
    let first_pass = start.elapsed().as_secs_f64();
    let mut field_refined = None;
    while session.refine(REFINE_BUDGET) {
        if field_refined.is_none() && !matches!(session.pending(), Some(Pending::Field(_))) {
            field_refined = Some(start.elapsed().as_secs_f64());
        }
    }
    let refined = start.elapsed().as_secs_f64();
    Ok(EventTimes { first_pass, field_refined: field_refined.unwrap_or(refined), refined })
}

/// The window's refinement budget between looks for input.
const REFINE_BUDGET: std::time::Duration = std::time::Duration::from_millis(25);

/// `count` moves of an orbiting camera, the k-th `step(k)`, timed as the session renders again.
fn camera_events(
    session: &mut EditSession,
    kind: &str,
    count: u32,
    step: fn(u32) -> CameraMove,
) -> Result<EventLatency> {
    let centre: Vec3 = session.scene().model.bounds().center().into();
    let mut orbit = Orbit::new(&session.settings().camera, centre, session.field_frame().height);
    let times = (0..count)
        .map(|k| {
            let camera = orbit.moved(step(k));
            timed(session, |s| {
                s.begin_camera(camera);
                Ok(())
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(latency(kind, &times))
}

/// Ten degrees about the camera's up axis.
fn orbit_step(_: u32) -> CameraMove {
    CameraMove::Orbit(10.0, 0.0)
}

/// A tenth in, then out again, alternately.
fn zoom_step(k: u32) -> CameraMove {
    CameraMove::Zoom(if k.is_multiple_of(2) { 0.9 } else { 1.0 / 0.9 })
}

/// `count` moves of the first named node along the screen, back and forth
/// (none when the scene names no node).
fn node_moves(session: &mut EditSession, count: u32) -> Result<Option<EventLatency>> {
    let Some(node) = session.scene().model.names().first().map(|n| n.to_string()) else { return Ok(None) };
    let step = Vec3::from(session.settings().camera.right()) * (session.scene().model.bounds().diagonal() / 50.0);
    let mut times = vec![];
    for k in 0..count {
        let by = if k.is_multiple_of(2) { step } else { -step };
        times.push(timed(session, |s| s.begin_apply(&[Edit::Translate { node: node.clone(), by }]))?);
    }
    Ok(Some(latency(&format!("move {node}"), &times)))
}

/// Every frame of `script`.
fn script_frames(session: &mut EditSession, script: &Script) -> Result<EventLatency> {
    let mut times = vec![];
    for frame in &script.frames {
        times.push(timed(session, |s| s.begin_apply(frame))?);
    }
    if times.is_empty() {
        return Err(PipelineError::Unsuitable("the script has no frames".into()));
    }
    Ok(latency("script frame", &times))
}
