//! The previewer's latency without a window: the edit session the viewer
//! drives replays the events a user makes — orbit steps, zoom steps, moves
//! of a named node, an edit script's frames — and each event kind reports
//! how long a frame took to show and the frame rate that allows. The viewer
//! has no progressive passes yet, so a frame shows when it is whole: the
//! first pass is the full frame.

use std::path::PathBuf;
use std::time::Instant;

use glam::Vec3;
use serde::Serialize;

use crate::camera::{CameraMove, Orbit};
use crate::field::{Edit, EvalMode};
use crate::frame::Size;
use crate::pipeline::{EditSession, PipelineError, PolygonizeSettings, Result, with_threads};
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
}

/// Latency of one kind of event.
#[derive(Clone, Debug, Serialize)]
pub struct EventLatency {
    /// orbit, zoom, node move or script frame.
    pub kind: String,
    /// Events replayed.
    pub events: usize,
    /// Median seconds until the frame showed.
    pub median_seconds: f64,
    /// Slowest event, seconds.
    pub max_seconds: f64,
    /// Frames per second the median allows.
    pub frame_rate: f64,
}

/// What `bench view` measured.
#[derive(Clone, Debug, Serialize)]
pub struct ViewBenchReport {
    /// Scene file.
    pub scene: String,
    /// Image size.
    pub size: Size,
    /// Seconds from loading to the first frame (the session's renders, mesh and BVH).
    pub launch_seconds: f64,
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
        let scene = Scene::load(&a.scene)?;
        let mut session = EditSession::new(scene, EvalMode::Indexed, a.size, &PolygonizeSettings::default())?;
        let launch_seconds = start.elapsed().as_secs_f64();
        let mut events = vec![camera_events(&mut session, "orbit", a.events, orbit_step)];
        events.push(camera_events(&mut session, "zoom", a.events, zoom_step));
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
            events,
            threads: rayon::current_num_threads(),
        })
    })?
}

/// The latency of `kind` from the seconds of its events.
fn latency(kind: &str, mut seconds: Vec<f64>) -> EventLatency {
    seconds.sort_by(f64::total_cmp);
    let median = seconds[seconds.len() / 2];
    EventLatency {
        kind: kind.into(),
        events: seconds.len(),
        median_seconds: median,
        max_seconds: seconds.last().copied().unwrap_or(0.0),
        frame_rate: 1.0 / median.max(1e-9),
    }
}

/// Seconds of `f`.
fn timed(f: impl FnOnce()) -> f64 {
    let start = Instant::now();
    f();
    start.elapsed().as_secs_f64()
}

/// `count` moves of an orbiting camera, the k-th `step(k)`, timed as the session renders again.
fn camera_events(session: &mut EditSession, kind: &str, count: u32, step: fn(u32) -> CameraMove) -> EventLatency {
    let centre: Vec3 = session.scene().model.bounds().center().into();
    let mut orbit = Orbit::new(&session.settings().camera, centre, session.field_frame().height);
    let seconds = (0..count)
        .map(|k| {
            let camera = orbit.moved(step(k));
            timed(|| session.set_camera(camera))
        })
        .collect();
    latency(kind, seconds)
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
    let mut seconds = vec![];
    for k in 0..count {
        let by = if k.is_multiple_of(2) { step } else { -step };
        let start = Instant::now();
        session.apply(&[Edit::Translate { node: node.clone(), by }])?;
        seconds.push(start.elapsed().as_secs_f64());
    }
    Ok(Some(latency(&format!("move {node}"), seconds)))
}

/// Every frame of `script`.
fn script_frames(session: &mut EditSession, script: &Script) -> Result<EventLatency> {
    let mut seconds = vec![];
    for frame in &script.frames {
        let start = Instant::now();
        session.apply(frame)?;
        seconds.push(start.elapsed().as_secs_f64());
    }
    if seconds.is_empty() {
        return Err(PipelineError::Unsuitable("the script has no frames".into()));
    }
    Ok(latency("script frame", seconds))
}
