//! Keeping a long session as cheap as a fresh one. Between an edit and the
//! rays that reach what it changed, the empty space's marks there are stale,
//! counted as space the surface may be in; the rays traced meanwhile (the
//! edit's dirty rectangles, a camera move's whole image) start earlier and
//! take more evaluations than they would from exact marks, and the cost
//! view would keep showing it. Once idle, the session marks every stale
//! block again (or lays a new grid where the model's bounds moved, as a
//! fresh session's would be laid), and traces those pixels again whole:
//! the image stays bit for bit what it was, and its evaluations become a
//! fresh session's.

use std::time::{Duration, Instant};

use super::EditSession;
use crate::field::{EmptySpace, ModelField};
use crate::trace::{Coverage, PixelRect, PixelState, retrace_whole};

/// Pixels traced at least per batch of tidying.
const MIN_BATCH: usize = 1024;

/// The field pixels whose counts may exceed a fresh session's, and the pass
/// that traces them again.
#[derive(Default)]
pub(super) struct Tidy {
    /// Rectangles traced since the empty space was last exact.
    rects: Vec<PixelRect>,
    pass: Option<TidyPass>,
}

/// A tidying pass under way.
struct TidyPass {
    pixels: Vec<(u32, u32, PixelState)>,
    next: usize,
    coverage: Coverage,
}

impl Tidy {
    /// The pixels of `rects` are being traced while the empty space may not be exact.
    pub(super) fn traced(&mut self, rects: &[PixelRect]) {
        self.rects.extend_from_slice(rects);
        // A pass under way traced against marks an event has since made stale.
        self.pass = None;
    }

    /// A camera move is tracing the whole `width × height` image, from marks exact or not.
    pub(super) fn camera_moved(&mut self, exact: bool, width: u32, height: u32) {
        self.rects = if exact { vec![] } else { vec![PixelRect::full(width, height)] };
        self.pass = None;
    }
}

impl EditSession {
    /// Whether the field image's counts are those of a fresh session (see the module docs).
    #[must_use]
    pub fn is_tidy(&self) -> bool {
        self.tidy.rects.is_empty()
    }

    /// Whether the empty space is what a fresh session's would be: no stale
    /// marks, on the grid of the model's bounds now.
    pub(super) fn empty_space_exact(&self) -> bool {
        !self.empty.has_stale() && self.empty.built_over() == self.scene.model.bounds()
    }

    /// Once the refinement is done, tidies for about `budget` (at least a
    /// batch of pixels): brings the empty space up to date, then traces the
    /// pixels traced before that again. Returns whether tidying remains.
    pub fn tidy(&mut self, budget: Duration) -> bool {
        if self.pending().is_some() || self.is_tidy() {
            return !self.is_tidy();
        }
        let start = Instant::now();
        if self.tidy.pass.is_none() {
            self.tidy.pass = Some(self.begin_tidying());
        }
        let field = ModelField::new(&self.scene.model, self.mode);
        let field = field.skipping(&self.empty);
        let pass = self.tidy.pass.as_mut().expect("just begun");
        while pass.next < pass.pixels.len() {
            let rays = (self.work.rays_per_second * budget.saturating_sub(start.elapsed()).as_secs_f64()) as usize;
            let end = (pass.next + rays.max(MIN_BATCH)).min(pass.pixels.len());
            retrace_whole(&field, &self.settings, &mut self.field_frame, &pass.pixels[pass.next..end], &pass.coverage);
            pass.next = end;
            if start.elapsed() >= budget {
                break;
            }
        }
        if pass.next == pass.pixels.len() {
            self.tidy = Tidy::default();
        }
        !self.is_tidy()
    }

    /// Tidies to the end.
    pub fn tidy_all(&mut self) {
        while self.tidy(Duration::from_secs(1)) {}
    }

    /// The empty space made exact, and the pass over the pixels traced before it was.
    fn begin_tidying(&mut self) -> TidyPass {
        let (w, h) = (self.settings.width, self.settings.height);
        let field = ModelField::new(&self.scene.model, self.mode);
        if self.empty.built_over() == self.scene.model.bounds() {
            self.empty.refresh(&field);
        } else {
            // Every ray's walk crosses the new grid: each pixel's count changes.
            self.empty = EmptySpace::build(&field);
            self.tidy.rects = vec![PixelRect::full(w, h)];
        }
        let mut seen = vec![false; (w as usize) * (h as usize)];
        let mut pixels = vec![];
        for r in &self.tidy.rects {
            for y in r.y0..r.y1 {
                for x in r.x0..r.x1 {
                    if !std::mem::replace(&mut seen[(y * w + x) as usize], true) {
                        pixels.push((x, y, PixelState::Trace));
                    }
                }
            }
        }
        TidyPass { pixels, next: 0, coverage: self.coverage() }
    }
}
