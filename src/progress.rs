//! The progress hook: every long job — a pipeline, a polygonization —
//! reports through it what stage it is in and how far along, so a command
//! line can draw bars, a window a status line, and a test nothing at all.
//! It imports nothing, so any stage may report through it.

/// Receives progress from a pipeline, possibly from several worker threads at once.
pub trait Progress: Sync {
    /// `done` of `total` units of `stage` are finished; `total == 0` when the
    /// stage cannot say how much work it has (a bar then only shows it runs).
    fn update(&self, stage: &str, done: u64, total: u64);
}

impl<F: Fn(&str, u64, u64) + Sync> Progress for F {
    fn update(&self, stage: &str, done: u64, total: u64) {
        self(stage, done, total);
    }
}

/// A hook that ignores everything.
#[derive(Clone, Copy, Debug, Default)]
pub struct Silent;

impl Progress for Silent {
    fn update(&self, _: &str, _: u64, _: u64) {}
}

/// Runs `work` as the stage `stage` of unknown length, reported as started and finished.
pub fn stage<T>(progress: &dyn Progress, stage: &str, work: impl FnOnce() -> T) -> T {
    progress.update(stage, 0, 0);
    let out = work();
    progress.update(stage, 1, 1);
    out
}

/// A row callback for a tracer of `height` rows that reports as `stage`.
pub fn rows<'a>(progress: &'a dyn Progress, stage: &'a str, height: u32) -> impl Fn(usize) + Sync + 'a {
    move |rows| progress.update(stage, rows as u64, u64::from(height))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    #[test]
    fn a_closure_is_a_hook_and_stages_report_start_and_end() {
        let seen = Mutex::new(vec![]);
        let hook = |stage: &str, done: u64, total: u64| seen.lock().unwrap().push((stage.to_string(), done, total));
        assert_eq!(stage(&hook, "seeding", || 7), 7);
        rows(&hook, "tracing", 48)(12);
        let seen = seen.into_inner().unwrap();
        assert_eq!(seen, [("seeding".into(), 0, 0), ("seeding".into(), 1, 1), ("tracing".into(), 12, 48)]);
    }
}
