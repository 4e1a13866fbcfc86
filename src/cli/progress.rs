//! Progress bars on stderr for the pipelines' progress hook: one bar per
//! stage, shown only once a job has run for about a second, and never when
//! stderr is not a terminal.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::pipeline::Progress;

/// Delay before the first bar appears: short jobs stay quiet.
const SHOW_AFTER: Duration = Duration::from_secs(1);

/// Draws the stage being reported as a bar (a spinner when its length is unknown).
pub struct Bars {
    shared: Arc<Shared>,
}

/// What the job's thread and the thread that reveals the bar share.
struct Shared {
    start: Instant,
    state: Mutex<State>,
}

#[derive(Default)]
struct State {
    /// The stage shown and its bar.
    current: Option<(String, ProgressBar)>,
    /// Whether the job is done: nothing more is to be drawn.
    finished: bool,
}

impl Default for Bars {
    fn default() -> Self {
        let shared = Arc::new(Shared { start: Instant::now(), state: Mutex::new(State::default()) });
        // A stage still running after the delay is revealed even if it reports
        // nothing more (a long polygonization's growth, say).
        let waiting = Arc::clone(&shared);
        std::thread::spawn(move || {
            std::thread::sleep(SHOW_AFTER);
            if let Ok(state) = waiting.state.lock()
                && !state.finished
                && let Some((_, bar)) = &state.current
            {
                bar.set_draw_target(ProgressDrawTarget::stderr());
            }
        });
        Self { shared }
    }
}

impl Bars {
    /// Bars for a job starting now.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Runs `f` (which prints) with the bar out of the way.
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        let bar = self.shared.state.lock().ok().and_then(|s| s.current.as_ref().map(|(_, b)| b.clone()));
        match bar {
            Some(bar) => bar.suspend(f),
            None => f(),
        }
    }

    /// Removes the bar; nothing is drawn after.
    pub fn finish(&self) {
        if let Ok(mut state) = self.shared.state.lock() {
            state.finished = true;
            if let Some((_, bar)) = state.current.take() {
                bar.finish_and_clear();
            }
        }
    }
}

impl Drop for Bars {
    fn drop(&mut self) {
        self.finish();
    }
}

impl Progress for Bars {
    fn update(&self, stage: &str, done: u64, total: u64) {
        let Ok(mut state) = self.shared.state.lock() else { return };
        if state.finished {
            return;
        }
        if state.current.as_ref().is_none_or(|(name, _)| name != stage) {
            if let Some((_, old)) = state.current.take() {
                old.finish_and_clear();
            }
            state.current = Some((stage.to_string(), new_bar(stage, total)));
        }
        let Some((_, bar)) = state.current.as_ref() else { return };
        if bar.is_hidden() && self.shared.start.elapsed() > SHOW_AFTER {
            // stderr() draws nothing when stderr is not a terminal.
            bar.set_draw_target(ProgressDrawTarget::stderr());
        }
        if total > 0 {
            bar.set_length(total);
            bar.set_position(done);
        } else {
            bar.tick();
        }
    }
}

/// A hidden bar (or spinner, for `total == 0`) labelled `stage`.
fn new_bar(stage: &str, total: u64) -> ProgressBar {
    let (bar, template) = if total > 0 {
        (
            ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::hidden()),
            "{msg} [{bar:40}] {pos}/{len}, {eta} left",
        )
    } else {
        (ProgressBar::with_draw_target(None, ProgressDrawTarget::hidden()), "{spinner} {msg}, {elapsed}")
    };
    if let Ok(style) = ProgressStyle::with_template(template) {
        bar.set_style(style.progress_chars("=> "));
    }
    bar.set_message(stage.to_string());
    if total == 0 {
        bar.enable_steady_tick(Duration::from_millis(120));
    }
    bar
}
