//! A progress bar on stderr that appears only for work longer than about a
//! second, and never when stderr is not a terminal.

use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Delay before the bar appears.
const SHOW_AFTER: Duration = Duration::from_secs(1);

/// A bar that shows itself once work has run for a second.
pub struct Progress {
    bar: ProgressBar,
    start: Instant,
    shown: Mutex<bool>,
}

impl Progress {
    /// A hidden bar for `len` units of work described by `label`.
    pub fn new(len: u64, label: &str) -> Self {
        let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::hidden());
        if let Ok(style) = ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} rows, {eta} left") {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_message(label.to_string());
        Self { bar, start: Instant::now(), shown: Mutex::new(false) }
    }

    /// Records `done` finished units; reveals the bar after the delay.
    pub fn set(&self, done: usize) {
        if self.start.elapsed() > SHOW_AFTER
            && let Ok(mut shown) = self.shown.lock()
            && !*shown
        {
            // stderr() draws nothing when stderr is not a terminal.
            self.bar.set_draw_target(ProgressDrawTarget::stderr());
            *shown = true;
        }
        self.bar.set_position(done as u64);
    }

    /// Removes the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
