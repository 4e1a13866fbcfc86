//! The slice view's plane, facing the camera: moved by steps away from the
//! point the camera orbits, never to or behind the eye, and drawn again only
//! when the plane, the camera or the model changes.

use super::Viewer;
use super::views::View;
use crate::pipeline::{PlaneView, SliceView, plane_view};
use crate::slice::SlicePlane;

/// The slice view's plane and what it shows.
pub(super) struct Slice {
    /// Steps the plane lies beyond the point the camera orbits, away from
    /// the viewer (counted, so that moves and their opposites come back to
    /// the same plane).
    pub(super) steps: i32,
    /// What it shows.
    pub(super) shows: SliceView,
    /// The picture, drawn when the plane, the camera or the model last changed.
    pub(super) drawn: Option<PlaneView>,
    /// The model with every cache answering from its lattice, as of frame
    /// number `.0`: error_C and the gradient error show what the caches
    /// would answer, whether or not auto mode uses them.
    pub(super) lattices: Option<(usize, crate::field::Model)>,
}

impl Viewer {
    /// What the slice shows after what it shows now: error_C and the
    /// gradient error only where the model has caches to compare.
    pub(super) fn next_slice_view(&self) -> SliceView {
        let caches = self.session.scene().model.counts().caches > 0;
        match self.slice.shows {
            SliceView::Field => SliceView::Sharp,
            SliceView::Sharp if caches => SliceView::Error,
            SliceView::Error => SliceView::Gradient,
            SliceView::Sharp | SliceView::Gradient => SliceView::Field,
        }
    }

    /// Moves the slice plane `steps` away from the viewer, but not to or past the eye.
    pub(super) fn move_slice(&mut self, steps: i32) {
        self.slice.steps += steps;
        if self.slice_depth() <= 0.01 * self.step_length {
            self.slice.steps -= steps;
        }
    }

    /// The slice plane's distance in front of the eye: through the point
    /// the camera orbits, moved by its steps, and never behind the eye.
    pub(super) fn slice_depth(&self) -> f32 {
        let camera = &self.session.settings().camera;
        let centre = glam::Vec3A::from(self.orbit.centre());
        let depth = (centre - camera.eye).dot(camera.forward()) + self.slice.steps as f32 * self.step_length;
        depth.max(0.01 * self.step_length)
    }

    /// Draws the slice view again, when it shows.
    pub(super) fn draw_slice(&mut self) {
        if self.view != View::Slice {
            self.slice.drawn = None;
            return;
        }
        let s = self.session.settings();
        let plane = SlicePlane::facing(&s.camera, s.width, s.height, self.slice_depth());
        let model = &self.session.scene().model;
        let model = match self.slice.shows {
            SliceView::Error | SliceView::Gradient => {
                if self.slice.lattices.as_ref().is_none_or(|(frame, _)| *frame != self.frames) {
                    let mut forced = model.clone();
                    forced.use_lattices(false);
                    self.slice.lattices = Some((self.frames, forced));
                }
                &self.slice.lattices.as_ref().expect("just made").1
            }
            SliceView::Field | SliceView::Sharp => model,
        };
        self.slice.drawn = Some(plane_view(model, &plane, self.slice.shows));
    }
}
