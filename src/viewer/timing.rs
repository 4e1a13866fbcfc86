//! How long each edit or camera move took to show: its first, coarse pass,
//! and once refined the rays per second and evaluations per ray, as the
//! status line says them.

use std::time::Instant;

/// How long the last edit or camera move took to show, coarse and refined.
#[derive(Clone, Debug)]
pub(super) struct EventTiming {
    /// "frame N" or "camera".
    pub(super) what: String,
    pub(super) start: Instant,
    /// Seconds until its first, coarse pass showed.
    pub(super) first_pass_s: f64,
    /// Seconds until everything was up to date, with the rays traced per
    /// second then and the field evaluations per ray of the image.
    pub(super) refined_s: Option<(f64, f64, f64)>,
    /// The fraction of the image its dirty rectangles cover, and how many
    /// there are (edits only).
    pub(super) dirty: Option<(f64, usize)>,
}

impl EventTiming {
    /// An event that started at `start` and has just shown its coarse pass.
    pub(super) fn new(what: &str, start: Instant, dirty: Option<(f64, usize)>) -> Self {
        let first_pass_s = start.elapsed().as_secs_f64();
        Self { what: what.into(), start, first_pass_s, refined_s: None, dirty }
    }

    /// As a narrow status line says it: the first pass and refined milliseconds.
    pub(super) fn brief(&self) -> String {
        match self.refined_s {
            Some((s, ..)) => format!("{}: {:.0} / {:.0} ms", self.what, 1e3 * self.first_pass_s, 1e3 * s),
            None => format!("{}: {:.0} ms", self.what, 1e3 * self.first_pass_s),
        }
    }

    /// As the status line says it.
    pub(super) fn describe(&self) -> String {
        let mut text = format!("{}: first pass {:.0} ms", self.what, 1e3 * self.first_pass_s);
        if let Some((s, rays_per_second, per_ray)) = self.refined_s {
            text += &format!(", refined {:.0} ms ({:.1} M rays/s", 1e3 * s, rays_per_second / 1e6);
            text += &format!(", {per_ray:.1} evaluations per ray)");
        }
        if let Some((dirty, rects)) = self.dirty {
            let s = if rects == 1 { "" } else { "s" };
            text += &format!(", {rects} dirty rectangle{s} ({:.1}%)", 100.0 * dirty);
        }
        text
    }
}
