//! The previewer's window (minifb). Its thread does nothing but take input
//! and show pictures, turning every few milliseconds (at most
//! [`LOOP_PERIOD`] apart while the system lets it run), so no key or click
//! is lost while the frames' work runs on a thread of its own (`worker`)
//! over the worker pool. A left drag orbits, a right or shift drag pans,
//! the wheel zooms, and a click (a press and release without moving)
//! selects the named node under the pointer.

use std::path::Path;
use std::sync::atomic::Ordering;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::Context;

use super::Viewer;
use super::input::{Gestures, Inbox};
use super::worker::{self, EventsLog, Received, Shared, to_window_pixels};

/// How long the window's loop waits between its turns at most.
pub const LOOP_PERIOD: Duration = Duration::from_millis(4);

/// The window loop: input in, the current view out, until the window closes
/// or Escape. With `events_log`, a line per event applied goes there.
pub fn show(viewer: &mut Viewer, pool: &rayon::ThreadPool, events_log: Option<&Path>) -> anyhow::Result<()> {
    use minifb::{MouseMode, Window, WindowOptions};
    let start = Instant::now();
    let log = match events_log {
        Some(path) => {
            let file = std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
            Some(EventsLog::new(Box::new(file), start)?)
        }
        None => None,
    };
    let image = viewer.screen();
    let (w, h) = (image.width as usize, image.height as usize);
    let mut window = Window::new(&viewer.title(), w, h, WindowOptions::default()).map_err(|e| {
        anyhow::anyhow!("could not open a window ({e}); where there is no display, run with --headless --keys …")
    })?;
    window.set_target_fps((1.0 / LOOP_PERIOD.as_secs_f64()) as usize);
    let inbox = Inbox::default();
    window.set_input_callback(Box::new(inbox.clone()));
    window.update_with_buffer(&to_window_pixels(&image), w, h).context("drawing the window")?;
    let shared = &Shared::default();
    let (send, receive) = mpsc::channel::<Received>();
    std::thread::scope(|scope| {
        let work = scope.spawn(move || worker::run(viewer, pool, &receive, shared, log));
        let mut gestures = Gestures::default();
        let mut turned = Instant::now();
        while window.is_open() && !gestures.quit && !work.is_finished() {
            shared.turned(std::mem::replace(&mut turned, Instant::now()).elapsed());
            match shared.take_shown() {
                Some(shown) => {
                    window.set_title(&shown.title);
                    window.update_with_buffer(&shown.pixels, w, h).context("drawing the window")?;
                }
                None => window.update(),
            }
            let wheel = window.get_scroll_wheel().map_or(0.0, |(_, notches)| notches);
            let pointer = window.get_mouse_pos(MouseMode::Pass);
            let caught_up = shared.queued.load(Ordering::Relaxed) == 0;
            let events = gestures.events(&inbox.take(), pointer, wheel, Instant::now(), caught_up);
            let while_refining = shared.refining.load(Ordering::Relaxed);
            for event in events {
                shared.queued.fetch_add(1, Ordering::Relaxed);
                // The worker gone (its error is reported below), nothing more is sent.
                if send.send(Received { event, at: Instant::now(), while_refining }).is_err() {
                    break;
                }
            }
        }
        drop(send);
        work.join().map_err(|_| anyhow::anyhow!("the viewer's worker panicked"))?
    })
}
