//! The viewer's work off the window's thread: events in, in the order they
//! came, the images out. Each event's coarse pass shows at once; while no
//! event waits, the passes refine a slice at a time and show every so often.
//! The window's thread meanwhile goes on taking input, so no press is lost
//! however long a pass takes. Each event applied is a line of the events
//! log, when one is kept.

use std::io::Write;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use super::input::Event;
use super::{Action, Viewer};
use crate::draw::Rgb8Image;

/// How long the viewer refines before it looks for events again.
const REFINE_BUDGET: Duration = Duration::from_millis(25);

/// How often the passes show while they refine.
const SHOW_EVERY: Duration = Duration::from_millis(100);

/// An event as the window's thread took it.
pub struct Received {
    pub event: Event,
    /// When it was taken.
    pub at: Instant,
    /// Whether a refinement was under way then.
    pub while_refining: bool,
}

/// A picture for the window: its pixels as minifb takes them, and its title.
pub struct Shown {
    pub pixels: Vec<u32>,
    pub title: String,
}

/// What the two threads share.
#[derive(Default)]
pub struct Shared {
    /// The newest picture not yet shown.
    pub shown: Mutex<Option<Shown>>,
    /// Whether the images are being refined.
    pub refining: AtomicBool,
    /// Events sent and not yet applied.
    pub queued: AtomicUsize,
    /// The window loop's turns, and the longest time between two, in microseconds.
    pub turns: (AtomicU64, AtomicU64),
}

impl Shared {
    /// One more turn of the window loop, `gap` after the last.
    pub fn turned(&self, gap: Duration) {
        self.turns.0.fetch_add(1, Ordering::Relaxed);
        self.turns.1.fetch_max(gap.as_micros() as u64, Ordering::Relaxed);
    }

    /// Takes the newest picture, if one came since the last call.
    pub fn take_shown(&self) -> Option<Shown> {
        self.shown.lock().map(|mut s| s.take()).unwrap_or(None)
    }
}

/// The events log: a line per event applied.
pub struct EventsLog {
    out: Box<dyn Write + Send>,
    start: Instant,
}

impl EventsLog {
    /// A log into `out`, its times counted from `start`, headed by the columns' names.
    pub fn new(mut out: Box<dyn Write + Send>, start: Instant) -> std::io::Result<Self> {
        writeln!(out, "# ms_received\tms_applied\tinput\taction\twhen\tthen")?;
        out.flush()?;
        Ok(Self { out, start })
    }

    /// One event applied: when it came and was applied, what asked for it,
    /// the action, and what the viewer then moves and has done.
    fn line(&mut self, received: &Received, viewer: &Viewer) -> std::io::Result<()> {
        let ms = |t: Instant| 1e3 * t.saturating_duration_since(self.start).as_secs_f64();
        let when = if received.while_refining { "refining" } else { "idle" };
        let then = format!("moving {}, {} frames", viewer.selected_node().unwrap_or("-"), viewer.frames_applied());
        let (input, action) = (&received.event.source, received.event.action);
        let line = format!("{:.1}\t{:.1}\t{input}\t{action:?}\t{when}\t{then}", ms(received.at), ms(Instant::now()));
        writeln!(self.out, "{line}")?;
        // Line by line, so the log is whole at any moment the window is closed.
        self.out.flush()
    }

    /// The last line: how often the window loop turned.
    fn close(&mut self, shared: &Shared) -> std::io::Result<()> {
        let (turns, longest) = (shared.turns.0.load(Ordering::Relaxed), shared.turns.1.load(Ordering::Relaxed));
        writeln!(self.out, "# window loop: {turns} turns, at most {:.1} ms apart", longest as f64 / 1e3)?;
        self.out.flush()
    }
}

/// How much lower than the window's thread the work runs: on two cores its
/// threads would otherwise keep the window's loop waiting for a core for
/// milliseconds after each of its short sleeps.
const NICER_BY: i32 = 5;

/// A pool of a thread per core, each at a lower priority than the window's
/// thread (where the system lets a thread lower its own).
pub fn background_pool() -> anyhow::Result<rayon::ThreadPool> {
    let pool = rayon::ThreadPoolBuilder::new().start_handler(|_| lower_priority());
    pool.build().map_err(|e| anyhow::anyhow!("starting the worker threads: {e}"))
}

/// Lowers the calling thread's priority by [`NICER_BY`]; where it cannot,
/// the thread runs as before.
pub fn lower_priority() {
    #[cfg(target_os = "linux")]
    // SAFETY: `gettid` and `setpriority` take and return plain integers;
    // Linux applies a thread id's priority to that thread alone.
    unsafe {
        let tid = libc::gettid();
        let now = libc::getpriority(libc::PRIO_PROCESS, tid as libc::id_t);
        libc::setpriority(libc::PRIO_PROCESS, tid as libc::id_t, now + NICER_BY);
    }
}

/// Applies the events from `events` until the window's side hangs up,
/// refining in between and leaving pictures in `shared`.
pub fn run(
    viewer: &mut Viewer,
    pool: &rayon::ThreadPool,
    events: &Receiver<Received>,
    shared: &Shared,
    mut log: Option<EventsLog>,
) -> anyhow::Result<()> {
    lower_priority();
    let mut shown_at = Instant::now();
    loop {
        shared.refining.store(!viewer.session_refined(), Ordering::Relaxed);
        let batch = match next_batch(events, viewer.is_refining()) {
            Ok(batch) => batch,
            Err(RecvTimeoutError::Disconnected) => {
                if let Some(log) = log.as_mut() {
                    log.close(shared)?;
                }
                return Ok(());
            }
            Err(RecvTimeoutError::Timeout) => vec![],
        };
        if batch.is_empty() {
            let was_refining = viewer.is_refining();
            if was_refining {
                pool.install(|| viewer.refine(REFINE_BUDGET));
            }
            // The passes every so often, and when done.
            if was_refining && (!viewer.is_refining() || shown_at.elapsed() >= SHOW_EVERY) {
                show(viewer, pool, shared);
                shown_at = Instant::now();
            }
            continue;
        }
        for (action, received) in merged(batch) {
            pool.install(|| viewer.act(action))?;
            for r in &received {
                shared.queued.fetch_sub(1, Ordering::Relaxed);
                if let Some(log) = log.as_mut() {
                    log.line(r, viewer)?;
                }
            }
        }
        show(viewer, pool, shared);
        shown_at = Instant::now();
    }
}

/// The events waiting now, oldest first; while nothing is left to refine,
/// waits for the next one.
fn next_batch(events: &Receiver<Received>, refining: bool) -> Result<Vec<Received>, RecvTimeoutError> {
    let mut batch = vec![];
    if !refining {
        batch.push(events.recv_timeout(Duration::from_millis(100))?);
    }
    loop {
        match events.try_recv() {
            Ok(r) => batch.push(r),
            Err(std::sync::mpsc::TryRecvError::Empty) => return Ok(batch),
            Err(std::sync::mpsc::TryRecvError::Disconnected) if batch.is_empty() => {
                return Err(RecvTimeoutError::Disconnected);
            }
            Err(std::sync::mpsc::TryRecvError::Disconnected) => return Ok(batch),
        }
    }
}

/// The batch's actions, the steps of one drag or of the wheel that follow
/// each other merged into one camera move (the camera ends where the steps
/// one by one would take it, within rounding, at the cost of one coarse
/// pass); each with the events it stands for.
fn merged(batch: Vec<Received>) -> Vec<(Action, Vec<Received>)> {
    let mut out: Vec<(Action, Vec<Received>)> = vec![];
    for r in batch {
        let action = r.event.action;
        if let Some((last, received)) = out.last_mut()
            && r.event.mergeable
            && received.last().is_some_and(|l| l.event.mergeable)
            && let Some(sum) = last.merged_with(action)
        {
            *last = sum;
            received.push(r);
            continue;
        }
        out.push((action, vec![r]));
    }
    out
}

/// Leaves the current screen in `shared` for the window to show.
fn show(viewer: &Viewer, pool: &rayon::ThreadPool, shared: &Shared) {
    let (image, title) = pool.install(|| (viewer.screen(), viewer.title()));
    let shown = Shown { pixels: to_window_pixels(&image), title };
    if let Ok(mut slot) = shared.shown.lock() {
        *slot = Some(shown);
    }
}

/// `0RGB` words, as the window takes them.
pub fn to_window_pixels(image: &Rgb8Image) -> Vec<u32> {
    image.pixels.chunks_exact(3).map(|p| u32::from_be_bytes([0, p[0], p[1], p[2]])).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn received(action: Action, mergeable: bool) -> Received {
        let event = Event { action, source: "test".into(), mergeable };
        Received { event, at: Instant::now(), while_refining: false }
    }

    #[test]
    fn the_steps_of_a_drag_merge_but_key_presses_and_node_moves_do_not() {
        let batch = vec![
            received(Action::Orbit(1.0, 2.0), true),
            received(Action::Orbit(3.0, -1.0), true),
            received(Action::Move(0, 1.0), false),
            received(Action::Move(0, 1.0), false),
            received(Action::Orbit(1.0, 0.0), false),
            received(Action::Orbit(1.0, 0.0), false),
            received(Action::Zoom(0.5), true),
            received(Action::Zoom(0.5), true),
        ];
        let out = merged(batch);
        let actions: Vec<Action> = out.iter().map(|(a, _)| *a).collect();
        assert_eq!(
            actions,
            [
                Action::Orbit(4.0, 1.0),
                Action::Move(0, 1.0),
                Action::Move(0, 1.0),
                Action::Orbit(1.0, 0.0),
                Action::Orbit(1.0, 0.0),
                Action::Zoom(0.25)
            ]
        );
        assert_eq!(out.iter().map(|(_, r)| r.len()).sum::<usize>(), 8, "every event is accounted for");
    }
}
