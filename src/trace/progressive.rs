//! Progressive refinement: the pixels of a frame that a camera move or an
//! edit made stale are traced again in passes, coarse to fine — first one
//! pixel in every 8×8 block, then every 4×4, 2×2, and at last every pixel —
//! and until its own pass reaches it a stale pixel is shown as the nearest
//! pixel traced since (the corner of its block). Each stale pixel is traced
//! once, by the same per-pixel function as a whole render, so the refined
//! frame equals a render bit for bit. Passes go in batches of rows, so a
//! caller can stop between batches to take input, and a new change marks
//! more pixels stale and starts the passes again from the coarsest.

use std::borrow::Cow;

use rayon::prelude::*;

use super::PixelRect;
use crate::frame::Frame;

/// The block edges of the passes, coarsest first.
pub const PASS_STEPS: [u32; 4] = [8, 4, 2, 1];

/// What a pixel of a refining frame needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelState {
    /// Up to date.
    Done,
    /// Up to date before the last edit only: its ray is traced again from
    /// its old hit (only over the stretch the edit can have changed).
    Retrace,
    /// Stale: its ray is traced whole (after a camera move, or when it was
    /// still stale as another edit came).
    Trace,
}

/// The stale pixels of a frame and how far their passes have gone.
#[derive(Clone, Debug)]
pub struct Refinement {
    width: u32,
    height: u32,
    state: Vec<PixelState>,
    /// Pixels not [`PixelState::Done`].
    pending: usize,
    /// The pass under way, an index into [`PASS_STEPS`].
    pass: usize,
    /// The next row the pass looks at.
    row: u32,
}

impl Refinement {
    /// A `width × height` frame with every pixel up to date.
    #[must_use]
    pub fn new(width: u32, height: u32) -> Self {
        let state = vec![PixelState::Done; (width as usize) * (height as usize)];
        Self { width, height, state, pending: 0, pass: 0, row: 0 }
    }

    /// True when no pixel is stale.
    #[must_use]
    pub fn is_done(&self) -> bool {
        self.pending == 0
    }

    /// Stale pixels left.
    #[must_use]
    pub fn pending(&self) -> usize {
        self.pending
    }

    /// The block edge of the pass under way (8, 4, 2 or 1), `None` when done.
    #[must_use]
    pub fn level(&self) -> Option<u32> {
        // A pass whose rows are all traced is over, though the next batch moves on from it.
        let pass = if self.row >= self.height { (self.pass + 1).min(PASS_STEPS.len() - 1) } else { self.pass };
        (!self.is_done()).then(|| PASS_STEPS[pass])
    }

    /// The state of pixel (`x`, `y`).
    #[must_use]
    pub fn state(&self, x: u32, y: u32) -> PixelState {
        self.state[self.index(x, y)]
    }

    /// Marks the pixels inside `rects` stale as `how`. A pixel already stale,
    /// inside the rectangles or not, needs its ray traced whole from now on:
    /// it was to be retraced against the change before, which is no longer
    /// the only one since it was up to date. The passes start again from the
    /// coarsest.
    pub fn mark(&mut self, rects: &[PixelRect], how: PixelState) {
        if self.pending > 0 {
            for state in &mut self.state {
                if *state == PixelState::Retrace {
                    *state = PixelState::Trace;
                }
            }
        }
        for r in rects {
            for y in r.y0..r.y1.min(self.height) {
                for x in r.x0..r.x1.min(self.width) {
                    let i = self.index(x, y);
                    self.state[i] = match (self.state[i], how) {
                        (PixelState::Done, how) => {
                            self.pending += usize::from(how != PixelState::Done);
                            how
                        }
                        (_, PixelState::Done) => unreachable!("marking pixels done is `finish`'s"),
                        _ => PixelState::Trace,
                    };
                }
            }
        }
        (self.pass, self.row) = (0, 0);
    }

    /// Marks every pixel stale, to be traced whole.
    pub fn mark_all(&mut self) {
        self.state.fill(PixelState::Trace);
        self.pending = self.state.len();
        (self.pass, self.row) = (0, 0);
    }

    /// The next stale pixels to trace and their states: whole rows of one
    /// pass, at least `max_pixels` where the pass has that many left. Tracing
    /// them and telling [`Self::finish`] moves the passes on.
    #[must_use]
    pub fn next_batch(&mut self, max_pixels: usize) -> Vec<(u32, u32, PixelState)> {
        let mut batch = vec![];
        while !self.is_done() && batch.len() < max_pixels.max(1) {
            let step = PASS_STEPS[self.pass];
            if self.row >= self.height {
                if !batch.is_empty() {
                    // A batch ends with its pass, so a caller can show each pass whole.
                    break;
                }
                // The finest pass takes every stale pixel, so it is never left while any is
                // stale, unless a caller dropped a batch unfinished: then it looks again.
                (self.pass, self.row) = ((self.pass + 1).min(PASS_STEPS.len() - 1), 0);
                continue;
            }
            let y = self.row;
            for x in (0..self.width).step_by(step as usize) {
                let state = self.state(x, y);
                if state != PixelState::Done {
                    batch.push((x, y, state));
                }
            }
            self.row += step;
        }
        batch
    }

    /// Records that the pixels of a batch are up to date.
    pub fn finish(&mut self, batch: &[(u32, u32, PixelState)]) {
        for &(x, y, _) in batch {
            let i = self.index(x, y);
            if self.state[i] != PixelState::Done {
                self.state[i] = PixelState::Done;
                self.pending -= 1;
            }
        }
    }

    /// True once the coarsest pass has reached every stale pixel's block, so
    /// that [`Self::preview`] shows nothing stale.
    #[must_use]
    pub fn coarse_pass_done(&self) -> bool {
        self.is_done() || self.pass > 0 || self.row >= self.height
    }

    /// What to show of `frame` meanwhile: each stale pixel takes every
    /// channel of the nearest up-to-date corner of its 2×2, 4×4 or 8×8 block
    /// (a stale pixel with none keeps what it had).
    #[must_use]
    pub fn preview<'a>(&self, frame: &'a Frame) -> Cow<'a, Frame> {
        if self.is_done() {
            return Cow::Borrowed(frame);
        }
        let mut shown = Frame {
            color: self.preview_values(&frame.color).into_owned(),
            depth: self.preview_values(&frame.depth).into_owned(),
            normal: self.preview_values(&frame.normal).into_owned(),
            alpha: self.preview_values(&frame.alpha).into_owned(),
            extra: vec![],
            ..*frame
        };
        shown.extra = frame.extra.iter().map(|(n, v)| (n.clone(), self.preview_values(v).into_owned())).collect();
        Cow::Owned(shown)
    }

    /// [`Self::preview`] of one channel of a frame, `values` per pixel.
    #[must_use]
    pub fn preview_values<'a, T: Copy + Send + Sync>(&self, values: &'a [T]) -> Cow<'a, [T]> {
        if self.is_done() {
            return Cow::Borrowed(values);
        }
        // Rows in parallel: the previewer shows a preview per pass.
        let rows = values.par_chunks(self.width as usize).zip(self.state.par_chunks(self.width as usize));
        let shown = rows.enumerate().flat_map_iter(|(y, (row, states))| {
            let y = y as u32;
            row.iter().zip(states).enumerate().map(move |(x, (&v, &state))| match state {
                PixelState::Done => v,
                _ => self.nearest_done_corner(x as u32, y).map_or(v, |i| values[i]),
            })
        });
        Cow::Owned(shown.collect())
    }

    /// The index of the finest block corner of (`x`, `y`) that is up to date.
    fn nearest_done_corner(&self, x: u32, y: u32) -> Option<usize> {
        PASS_STEPS[..3]
            .iter()
            .rev()
            .map(|&s| self.index(x - x % s, y - y % s))
            .find(|&i| self.state[i] == PixelState::Done)
    }

    fn index(&self, x: u32, y: u32) -> usize {
        (y * self.width + x) as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn traced_in_passes(r: &mut Refinement, batch_size: usize) -> Vec<Vec<(u32, u32, PixelState)>> {
        let mut batches = vec![];
        while !r.is_done() {
            let batch = r.next_batch(batch_size);
            assert!(!batch.is_empty(), "a refinement with stale pixels gives some");
            r.finish(&batch);
            batches.push(batch);
        }
        batches
    }

    #[test]
    fn every_stale_pixel_is_traced_once_coarse_blocks_first() {
        let mut r = Refinement::new(21, 13);
        r.mark(&[PixelRect { x0: 3, y0: 2, x1: 17, y1: 11 }], PixelState::Retrace);
        assert_eq!(r.pending(), 14 * 9);
        assert_eq!(r.level(), Some(8));
        let traced: Vec<_> = traced_in_passes(&mut r, 5).concat();
        let mut seen = std::collections::HashSet::new();
        for &(x, y, state) in &traced {
            assert!(seen.insert((x, y)), "({x}, {y}) traced twice");
            assert_eq!(state, PixelState::Retrace);
            assert!((3..17).contains(&x) && (2..11).contains(&y), "({x}, {y}) was not stale");
        }
        assert_eq!(seen.len(), 14 * 9, "every stale pixel");
        // The stale pixels on the 8×8 corners come first, then the 4×4 ones.
        let corners8 = traced.iter().take_while(|(x, y, _)| x % 8 == 0 && y % 8 == 0).count();
        assert_eq!(corners8, 2, "(8, 8) and (16, 8): {traced:?}");
        assert!(r.is_done() && r.level().is_none());
    }

    #[test]
    fn marking_pending_pixels_again_traces_them_whole_and_restarts_the_passes() {
        let mut r = Refinement::new(16, 16);
        r.mark(&[PixelRect { x0: 0, y0: 0, x1: 8, y1: 8 }], PixelState::Retrace);
        let first = r.next_batch(1);
        r.finish(&first);
        assert_eq!(first, vec![(0, 0, PixelState::Retrace)]);
        r.mark(&[PixelRect { x0: 4, y0: 4, x1: 12, y1: 12 }], PixelState::Retrace);
        assert_eq!(r.state(5, 5), PixelState::Trace, "stale before the second edit");
        assert_eq!(r.state(1, 1), PixelState::Trace, "stale before, outside the second edit's rectangle");
        assert_eq!(r.state(0, 0), PixelState::Done);
        assert_eq!(r.state(10, 10), PixelState::Retrace);
        assert_eq!(r.level(), Some(8));
        assert_eq!(r.pending(), 64 - 1 + 64 - 16);
        r.mark_all();
        assert_eq!((r.pending(), r.state(0, 0)), (256, PixelState::Trace));
    }

    #[test]
    fn the_preview_shows_the_nearest_traced_corner_of_each_stale_pixel() {
        let mut frame = Frame::new(8, 8, glam::Vec3::ZERO);
        frame.extra.push(("evals.Y".into(), vec![0.0; 64]));
        let mut r = Refinement::new(8, 8);
        r.mark_all();
        assert!(!r.coarse_pass_done());
        let batch = r.next_batch(1);
        assert_eq!(batch, vec![(0, 0, PixelState::Trace)], "one 8×8 block: its corner");
        frame.color[0] = glam::Vec3::ONE;
        frame.extra[0].1[0] = 7.0;
        r.finish(&batch);
        assert!(r.coarse_pass_done(), "one corner is the whole coarse pass");
        assert_eq!(r.level(), Some(4), "the 4×4 pass is next");
        let shown = r.preview(&frame);
        assert!(shown.color.iter().all(|&c| c == glam::Vec3::ONE), "every pixel shows the corner");
        assert!(shown.extra[0].1.iter().all(|&e| e == 7.0));
        // Once (4, 4) is traced, its 4×4 block shows it.
        frame.color[4 * 8 + 4] = glam::Vec3::X;
        r.finish(&[(4, 4, PixelState::Trace)]);
        let shown = r.preview(&frame);
        assert_eq!(shown.color[7 * 8 + 7], glam::Vec3::X);
        assert_eq!(shown.color[3 * 8 + 3], glam::Vec3::ONE);
        assert_eq!(frame.color[7 * 8 + 7], glam::Vec3::ZERO, "the frame itself keeps what it had");
    }
}
