//! The previewer's views: one table of every view, in the order V cycles
//! through them, with the name the status line gives it and how it draws.
//! Adding a view is a variant, a row and its drawing.

use super::Viewer;
use crate::compare::{Metric, differences};
use crate::draw::{ColourKey, Rgb8Image, Scale, SpecialLabels};
use crate::frame::srgb8_of;

/// What the window shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum View {
    Field,
    Mesh,
    /// Mesh depth less field depth, red where the mesh lies behind.
    Difference,
    /// The angle between the mesh's and the field's normals, on magma.
    NormalError,
    /// Field evaluations per pixel, on magma.
    Cost,
    /// A plane facing the camera through the model: f, the sharp view,
    /// error_C or the cached gradient's error on it.
    Slice,
}

/// How a view draws: its image at the render's size, and the colour key
/// (scale, metric, unit, special colours) of a heat map.
type Draw = fn(&Viewer) -> (Rgb8Image, Option<ColourKey>);

/// Every view, in the order V cycles through them: the status line's name
/// for it, and how it draws.
const VIEWS: [(View, &str, Draw); 6] = [
    (View::Field, "field", Viewer::field_view),
    (View::Mesh, "mesh", Viewer::mesh_view),
    (View::Difference, "depth difference", Viewer::difference_view),
    (View::NormalError, "normal error", Viewer::normal_error_view),
    (View::Cost, "cost", Viewer::cost_view),
    (View::Slice, "slice", Viewer::slice_view),
];

/// The normal-error view's full scale: 30°, beyond which pixels are marked.
const NORMAL_ERROR_SCALE: Scale = Scale::Magnitude { max: 30.0 };

impl View {
    /// The view's place in [`VIEWS`].
    fn place(self) -> usize {
        VIEWS.iter().position(|v| v.0 == self).expect("every view has a row")
    }

    /// As the status line names it.
    pub(super) fn name(self) -> &'static str {
        VIEWS[self.place()].1
    }

    /// The view V shows after this one.
    pub(super) fn next(self) -> View {
        VIEWS[(self.place() + 1) % VIEWS.len()].0
    }
}

impl Viewer {
    /// The current view at the render's size, and the colour key of a heat-map view.
    pub(super) fn view(&self) -> (Rgb8Image, Option<ColourKey>) {
        (VIEWS[self.view.place()].2)(self)
    }

    /// `values` painted on `scale`, with their key. The special colours
    /// mean what they mean in `compare`'s maps: missed by both renders, hit
    /// by one only.
    fn heat_map(
        &self,
        values: &[f32],
        (scale, title, unit): (Scale, &'static str, &'static str),
    ) -> (Rgb8Image, Option<ColourKey>) {
        let (w, h) = (self.session.settings().width, self.session.settings().height);
        let key = ColourKey::of(values, scale, (title, unit), &SpecialLabels::default());
        (scale.paint(values, w, h), Some(key))
    }

    /// The field's colours alone: a preview of every channel would cost as much again.
    fn field_view(&self) -> (Rgb8Image, Option<ColourKey>) {
        let (w, h) = (self.session.settings().width, self.session.settings().height);
        (Rgb8Image { width: w, height: h, pixels: srgb8_of(&self.session.field_colors()) }, None)
    }

    fn mesh_view(&self) -> (Rgb8Image, Option<ColourKey>) {
        let (w, h) = (self.session.settings().width, self.session.settings().height);
        let colors = self.session.mesh_refinement().preview_values(&self.session.mesh_frame().color);
        (Rgb8Image { width: w, height: h, pixels: srgb8_of(&colors) }, None)
    }

    /// A lattice cell either way is the strongest colour.
    fn difference_view(&self) -> (Rgb8Image, Option<ColourKey>) {
        let scale = Scale::Signed { max: self.session.lattice().cell };
        let title = "mesh depth - field depth, 1 cell full scale";
        self.heat_map(&self.session.depth_diff_preview(), (scale, title, "scene units"))
    }

    fn normal_error_view(&self) -> (Rgb8Image, Option<ColourKey>) {
        let angles = differences(&self.session.mesh_preview(), &self.session.field_preview(), Metric::Normal);
        self.heat_map(&angles, (NORMAL_ERROR_SCALE, "angle between mesh and field normals", "deg"))
    }

    /// On the evaluations' 99th percentile, rounded up.
    fn cost_view(&self) -> (Rgb8Image, Option<ColourKey>) {
        let evaluations = self.session.field_frame().aov("evals.Y").unwrap_or(&[]);
        let evaluations = self.session.field_refinement().preview_values(evaluations);
        let scale = Scale::from_data(&evaluations, false, 1.0);
        self.heat_map(&evaluations, (scale, "field evaluations per pixel", "evaluations"))
    }

    fn slice_view(&self) -> (Rgb8Image, Option<ColourKey>) {
        let (w, h) = (self.session.settings().width, self.session.settings().height);
        match &self.slice.drawn {
            Some(drawn) => (drawn.image.clone(), drawn.key.clone()),
            None => (Rgb8Image::filled(w, h, [0, 0, 0]), None),
        }
    }
}
