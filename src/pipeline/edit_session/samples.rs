//! Samples added to each pixel of a still, refined field image while the
//! previewer is idle (see [`crate::trace::samples`]), so that it converges to
//! the image of `render --spp`.

use std::borrow::Cow;
use std::time::Instant;

use glam::Vec3;

use super::{EditSession, MIN_BATCH_RAYS};
use crate::field::ModelField;
use crate::trace::{Coverage, trace_sample_rows};

/// Samples per pixel the previewer takes at most while idle.
pub const IDLE_SAMPLES: u32 = 16;

/// Samples added to each pixel of a still, refined field image while the
/// previewer is idle (see [`crate::trace::samples`]), so that it converges to
/// the image of `render --spp`.
pub(super) struct Samples {
    /// Per pixel, the sum of its samples' colours, in sample order.
    pub(super) sum: Vec<Vec3>,
    /// Samples summed in every pixel.
    pub(super) count: u32,
    /// The first row of sample `count` not yet summed.
    pub(super) row: u32,
    pub(super) coverage: Coverage,
}

impl EditSession {
    /// Adds samples to the pixels of the refined field image for about
    /// `budget` (at least a batch of rows); returns whether it takes more
    /// (up to [`IDLE_SAMPLES`] per pixel). Nothing while refinement is left.
    pub fn supersample(&mut self, budget: std::time::Duration) -> bool {
        if self.pending().is_some() {
            return true;
        }
        let start = Instant::now();
        while self.samples_taken() < IDLE_SAMPLES {
            let left = budget.saturating_sub(start.elapsed()).as_secs_f64();
            self.add_sample_rows((self.work.sample_rays_per_second * left) as usize);
            if start.elapsed() >= budget {
                break;
            }
        }
        self.samples_taken() < IDLE_SAMPLES
    }

    /// Samples per pixel summed into the field image's colours (1: its own).
    #[must_use]
    pub fn samples_taken(&self) -> u32 {
        self.samples.as_ref().map_or(1, |s| s.count)
    }

    /// Traces the next rows, about `max_rays` rays, of the next sample of every pixel.
    fn add_sample_rows(&mut self, max_rays: usize) {
        let (w, h) = (self.settings.width, self.settings.height);
        if self.samples.is_none() {
            let coverage = self.coverage();
            self.samples = Some(Samples { sum: self.field_frame.color.clone(), count: 1, row: 0, coverage });
        }
        let samples = self.samples.as_mut().expect("just made");
        let rows = (max_rays.max(MIN_BATCH_RAYS) / w.max(1) as usize).max(1) as u32;
        let (first, end) = (samples.row, (samples.row + rows).min(h));
        let field = ModelField::new(&self.scene.model, self.mode);
        let clock = Instant::now();
        let traced = trace_sample_rows(
            &field.skipping(&self.empty),
            &self.settings,
            Some(&samples.coverage),
            samples.count,
            first..end,
        );
        let seconds = clock.elapsed().as_secs_f64();
        self.work.sample_rays_per_second = traced.len() as f64 / seconds.max(1e-6);
        let offset = (first * w) as usize;
        for (sum, p) in samples.sum[offset..offset + traced.len()].iter_mut().zip(&traced) {
            *sum += p.color;
        }
        samples.row = end;
        if end == h {
            (samples.count, samples.row) = (samples.count + 1, 0);
        }
    }

    /// The field image's colours as they stand: the preview's while it
    /// refines, the mean of the samples taken since.
    #[must_use]
    pub fn field_colors(&self) -> Cow<'_, [Vec3]> {
        match &self.samples {
            // Rows before `row` hold one sample more: the one under way.
            Some(s) if s.count > 1 || s.row > 0 => {
                let done_rows = (s.row * self.settings.width) as usize;
                let mean = |(i, &c): (usize, &Vec3)| c / (s.count + u32::from(i < done_rows)) as f32;
                Cow::Owned(s.sum.iter().enumerate().map(mean).collect())
            }
            _ => self.work.field.preview_values(&self.field_frame.color),
        }
    }
}
