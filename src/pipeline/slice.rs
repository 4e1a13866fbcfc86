//! Slices: images of the field on a plane — f with its iso-contour, the
//! sharp view per filter (the caching paper's Figure 6), error_C per filter
//! and cache resolution (Figures 5 and 7), and the cached gradient's angle
//! error (Figure 4's question).

use glam::Vec3A;

use super::error::{PipelineError, Result};
use crate::cache::Filter;
use crate::draw::{ColourKey, Rgb8Image, Scale, SpecialLabels, heat_map, heat_map_labelled, panel};
use crate::field::{EvalMode, Field, ModelField};
use crate::progress::Progress;
use crate::scene::{Scene, parse_desc};
use crate::slice::{SlicePlane, iso_contour, sample, sharp_image, with_sharp_legend};

/// What a slice shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SliceView {
    /// f itself (magma) with the iso-contour in white.
    #[default]
    Field,
    /// sin(11π f) in grey with the iso-band in red: exact, tri-linear, tri-quadratic.
    Sharp,
    /// error_C = |f_C − f| for each filter and each resolution of the sweep.
    Error,
    /// Angle between cached and exact gradients, for each filter and resolution.
    Gradient,
}

/// What to draw on a plane.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SliceSettings {
    /// What to show.
    pub view: SliceView,
    /// Only this filter (default: both) for error, gradient and sharp.
    pub filter: Option<Filter>,
    /// Cache resolutions to compare (empty: the scene's own).
    pub res_sweep: Vec<u32>,
    /// Full scale of the heat maps (default: 1 for field, 0.02 for error, 10 degrees for gradient).
    pub scale: Option<f32>,
}

impl SliceSettings {
    /// Checks the settings against `scene` before any work.
    pub fn check(&self, scene: &Scene) -> Result<()> {
        if let Some(s) = self.scale
            && !(s.is_finite() && s > 0.0)
        {
            return Err(PipelineError::setting("scale", format!("must be positive, got {s}")));
        }
        if let Some(&r) = self.res_sweep.iter().find(|r| !(2..=1024).contains(*r)) {
            return Err(PipelineError::setting("res_sweep", format!("values must lie in 2..=1024, got {r}")));
        }
        if self.view != SliceView::Field && scene.model.counts().caches == 0 {
            let view = format!("{:?}", self.view).to_lowercase();
            return Err(PipelineError::Unsuitable(format!("the {view} view compares caches, and the scene has none")));
        }
        Ok(())
    }
}

/// What a slice of `scene` on `plane` would show that the user may not expect:
/// a plane beside the model, a setting the view ignores.
#[must_use]
pub fn slice_warnings(scene: &Scene, plane: &SlicePlane, settings: &SliceSettings) -> Vec<String> {
    let mut warnings = vec![];
    if !plane.meets(&scene.model.bounds()) {
        warnings.push("the plane misses the model's bounds: the slice shows only empty space".to_string());
    }
    if settings.view == SliceView::Field && !settings.res_sweep.is_empty() {
        warnings.push("the field view shows the exact field: the resolution sweep is ignored".to_string());
    }
    if settings.view == SliceView::Field && settings.filter.is_some() {
        warnings.push("the field view shows the exact field: the filter is ignored".to_string());
    }
    warnings
}

/// Draws `settings`'s view of the scene written in `text` (named `label` in
/// errors) on `plane`; cache variants are built from the text afresh.
pub fn slice(
    text: &str,
    label: &str,
    plane: &SlicePlane,
    settings: &SliceSettings,
    progress: &dyn Progress,
) -> Result<Rgb8Image> {
    let scene = Scene::parse(text, label)?;
    settings.check(&scene)?;
    let exact = ModelField::new(&scene.model, EvalMode::Indexed);
    let variants = Variants { text, label, settings };
    match settings.view {
        SliceView::Field => Ok(field_view(plane, &exact, settings.scale.unwrap_or(1.0))),
        SliceView::Sharp => sharp_view(plane, &exact, &variants, progress),
        SliceView::Error | SliceView::Gradient => error_view(plane, &exact, &variants, progress),
    }
}

/// One view of a plane through a model as its caches stand: the image at
/// the plane's pixel size, and what its colours mean (nothing for the
/// sharp view, whose colours are not a scale).
pub struct PlaneView {
    /// The picture, `plane.width × plane.height`.
    pub image: Rgb8Image,
    /// Its colour scale, metric, unit and special colours, for a colour bar.
    pub key: Option<ColourKey>,
}

/// `view` of `model` on `plane`, the caches as the model holds them
/// (error_C and the gradient error compare its cached and exact fields),
/// each heat map scaled to the 99th percentile of its values: the
/// previewer's slice view.
#[must_use]
pub fn plane_view(model: &crate::field::Model, plane: &SlicePlane, view: SliceView) -> PlaneView {
    let exact = ModelField::new(model, EvalMode::Indexed);
    let (w, h) = (plane.width, plane.height);
    match view {
        SliceView::Field => {
            let values = sample(plane, |p| exact.value(p));
            let scale = scale_of_nonzero(&values, 1.0);
            let mut image = scale.paint(&values, w, h);
            draw_contour(&mut image, &values, (w, h), exact.threshold());
            let title = ("f, the iso-contour in white", "");
            PlaneView { image, key: Some(ColourKey::of(&values, scale, title, &SpecialLabels::default())) }
        }
        SliceView::Sharp => {
            PlaneView { image: sharp_image(&sample(plane, |p| exact.value(p)), w, h, exact.threshold()), key: None }
        }
        SliceView::Error | SliceView::Gradient => {
            let cached = ModelField::new(model, EvalMode::Cached);
            let values = measure(view, plane, &cached, &exact);
            let (errors, scale, title, unit) = match view {
                SliceView::Error => {
                    let exact_values = sample(plane, |p| exact.value(p));
                    let errors = values.iter().zip(&exact_values).map(|(c, e)| (c - e).abs()).collect();
                    (errors, 0.02, "error_C = |f_C - f|", "")
                }
                _ => (values, 10.0, "cached gradient angle error", "deg"),
            };
            let scale = scale_of_nonzero(&errors, scale);
            let key = ColourKey::of(&errors, scale, (title, unit), &ERROR_MAP_LABELS);
            PlaneView { image: scale.paint(&errors, w, h), key: Some(key) }
        }
    }
}

/// A scale for a plane's `values` from those not zero (most of a plane
/// may lie outside the model, where f and its errors vanish): their 99th
/// percentile, rounded up; `fallback` where all are zero.
fn scale_of_nonzero(values: &[f32], fallback: f32) -> Scale {
    let nonzero: Vec<f32> = values.iter().copied().filter(|&v| v != 0.0).collect();
    Scale::from_data(&nonzero, false, fallback)
}

/// Draws the iso-contour of `values` (a plane's `w × h` samples, at the top
/// left of `image`) in white.
fn draw_contour(image: &mut Rgb8Image, values: &[f32], (w, h): (u32, u32), threshold: f32) {
    for (i, on) in iso_contour(values, w, h, threshold).into_iter().enumerate() {
        if on {
            image.put(i as i64 % i64::from(w), i as i64 / i64::from(w), [255, 255, 255]);
        }
    }
}

/// The cache variants a view compares: each filter, at each resolution of the sweep.
struct Variants<'a> {
    text: &'a str,
    label: &'a str,
    settings: &'a SliceSettings,
}

impl Variants<'_> {
    fn filters(&self) -> Vec<Filter> {
        self.settings.filter.map_or(vec![Filter::Trilinear, Filter::Triquadratic], |f| vec![f])
    }

    fn resolutions(&self) -> Vec<Option<u32>> {
        let sweep = &self.settings.res_sweep;
        if sweep.is_empty() { vec![None] } else { sweep.iter().map(|&r| Some(r)).collect() }
    }

    /// The scene again with every cache using `filter` for values and gradients
    /// (and `res`, when given): fresh, empty caches.
    fn scene(&self, filter: Filter, res: Option<u32>) -> Result<Scene> {
        let mut desc = parse_desc(self.text, self.label)?;
        desc.model.for_each_cache(&mut |r, value, gradient| {
            if let Some(res) = res {
                r.0 = res;
            }
            (*value, *gradient) = (filter, filter);
        });
        Scene::from_desc(&desc).map_err(|cause| PipelineError::Unsuitable(format!("{}: {cause}", self.label)))
    }
}

fn field_view(plane: &SlicePlane, exact: &ModelField, scale: f32) -> Rgb8Image {
    let (w, h) = (plane.width, plane.height);
    let values = sample(plane, |p| exact.value(p));
    let mut img = heat_map(&values, w, h, Scale::Magnitude { max: scale }, "f", "");
    draw_contour(&mut img, &values, (w, h), exact.threshold());
    img
}

fn sharp_view(
    plane: &SlicePlane,
    exact: &ModelField,
    variants: &Variants,
    progress: &dyn Progress,
) -> Result<Rgb8Image> {
    let (w, h, t) = (plane.width, plane.height, exact.threshold());
    let mut items = vec![("exact".to_string(), sharp_image(&sample(plane, |p| exact.value(p)), w, h, t))];
    let (filters, res) = (variants.filters(), variants.resolutions()[0]);
    for (k, &filter) in filters.iter().enumerate() {
        progress.update("slicing cache variants", k as u64, filters.len() as u64);
        let variant = variants.scene(filter, res)?;
        let cached = ModelField::new(&variant.model, EvalMode::Cached);
        items.push((filter_name(filter, res), sharp_image(&sample(plane, |p| cached.value(p)), w, h, t)));
    }
    Ok(with_sharp_legend(&panel(&items, items.len()), t))
}

fn error_view(
    plane: &SlicePlane,
    exact: &ModelField,
    variants: &Variants,
    progress: &dyn Progress,
) -> Result<Rgb8Image> {
    let view = variants.settings.view;
    let exact_values = measure(view, plane, exact, exact);
    let (filters, resolutions) = (variants.filters(), variants.resolutions());
    let total = (filters.len() * resolutions.len()) as u64;
    let mut items = vec![];
    for &filter in &filters {
        for &res in &resolutions {
            progress.update("slicing cache variants", items.len() as u64, total);
            let variant = variants.scene(filter, res)?;
            let cached = ModelField::new(&variant.model, EvalMode::Cached);
            let values = measure(view, plane, &cached, exact);
            let errors: Vec<f32> = match view {
                SliceView::Error => values.iter().zip(&exact_values).map(|(c, e)| (c - e).abs()).collect(),
                _ => values,
            };
            items.push((filter_name(filter, res), error_map(&errors, plane, view, variants.settings.scale)));
        }
    }
    progress.update("slicing cache variants", total, total);
    Ok(panel(&items, resolutions.len()))
}

/// The heat map of one variant's errors, titled with their mean.
fn error_map(errors: &[f32], plane: &SlicePlane, view: SliceView, scale: Option<f32>) -> Rgb8Image {
    let (scale, title, unit) = match view {
        SliceView::Error => (scale.unwrap_or(0.02), "error_C = |f_C - f|", ""),
        _ => (scale.unwrap_or(10.0), "gradient angle error", "deg"),
    };
    let title = format!("{title}, mean {:.2e}", mean_finite(errors));
    let scale = Scale::Magnitude { max: scale };
    heat_map_labelled(errors, (plane.width, plane.height), scale, (&title, unit), &ERROR_MAP_LABELS)
}

/// The special colours of error and gradient-error maps: a pixel without a
/// value is one where a gradient vanishes.
const ERROR_MAP_LABELS: SpecialLabels<'static> =
    SpecialLabels { no_value: "a gradient vanishes", infinite: "infinite" };

/// Per pixel: the value of `field` (for error), or the angle in degrees
/// between its gradient and the exact one (for gradient; `NaN` where the exact
/// gradient vanishes).
fn measure(view: SliceView, plane: &SlicePlane, field: &ModelField, exact: &ModelField) -> Vec<f32> {
    match view {
        SliceView::Gradient => sample(plane, |p: Vec3A| {
            let (g, e) = (field.gradient(p), exact.gradient(p));
            if e.length() < 1e-6 || g.length() < 1e-6 {
                return f32::NAN;
            }
            g.normalize().dot(e.normalize()).clamp(-1.0, 1.0).acos().to_degrees()
        }),
        _ => sample(plane, |p| field.value(p)),
    }
}

fn mean_finite(values: &[f32]) -> f64 {
    let finite: Vec<f64> = values.iter().filter(|v| v.is_finite()).map(|&v| f64::from(v)).collect();
    finite.iter().sum::<f64>() / finite.len().max(1) as f64
}

fn filter_name(filter: Filter, res: Option<u32>) -> String {
    let name = format!("{filter:?}").to_lowercase();
    res.map_or(name.clone(), |r| format!("{name}, res {r}"))
}
