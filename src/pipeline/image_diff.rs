//! Comparing two image files the way idiff does: load both (PNG or EXR),
//! check they match in size and hold the channels the metric needs, judge
//! the per-pixel differences against thresholds, and draw a heat map.

use std::path::{Path, PathBuf};

use super::error::PipelineError;
use crate::compare::{
    DiffReport, Metric, Scale, SpecialLabels, Thresholds, Verdict, differences, edge_mask, heat_map_labelled, judge,
    load_image,
};

/// How to compare two images.
#[derive(Clone, Debug)]
pub struct ImageDiffSettings {
    /// What to compare per pixel.
    pub metric: Metric,
    /// When a difference warns or fails.
    pub thresholds: Thresholds,
    /// Set aside pixels within this many pixels of a silhouette edge.
    pub mask_edges: Option<u32>,
    /// Write a heat map of the differences here.
    pub heat_map: Option<PathBuf>,
    /// The heat map's full-scale value (default: chosen from the data, the p99 rounded up).
    pub scale: Option<f32>,
}

/// Why two images could not be compared.
#[derive(Debug, thiserror::Error)]
pub enum ImageDiffError {
    /// A threshold or scale out of range.
    #[error(transparent)]
    Setting(PipelineError),
    /// The images differ in size.
    #[error("{0}")]
    SizeMismatch(String),
    /// An image could not be read, lacks a channel, or the heat map could not be written.
    #[error("{0}")]
    File(String),
}

impl ImageDiffSettings {
    /// Checks the thresholds and the scale.
    pub fn check(&self) -> Result<(), PipelineError> {
        let t = &self.thresholds;
        let non_negative = |setting: &'static str, v: f64| match v.is_nan() || v < 0.0 {
            true => Err(PipelineError::setting(setting, format!("must be a non-negative number, got {v}"))),
            false => Ok(()),
        };
        non_negative("fail", f64::from(t.fail))?;
        non_negative("hardfail", f64::from(t.hardfail))?;
        non_negative("warn", f64::from(t.warn))?;
        non_negative("failpercent", t.failpercent)?;
        non_negative("warnpercent", t.warnpercent)?;
        match self.scale {
            Some(s) if !(s.is_finite() && s > 0.0) => {
                Err(PipelineError::setting("scale", format!("must be a positive number, got {s}")))
            }
            _ => Ok(()),
        }
    }

    /// The heat map's scale: the one given, or one chosen from `values`.
    fn heat_scale(&self, values: &[f32]) -> Scale {
        let signed = self.metric == Metric::Depth;
        match self.scale {
            Some(max) if signed => Scale::Signed { max },
            Some(max) => Scale::Magnitude { max },
            None => Scale::from_data(values, signed, if self.metric == Metric::Normal { 10.0 } else { 0.1 }),
        }
    }
}

/// Compares the images at `a` and `b`; a comparison of no pixel at all (every
/// one masked, or missed by both for depth and normals) fails.
pub fn diff_images(a: &Path, b: &Path, settings: &ImageDiffSettings) -> Result<DiffReport, ImageDiffError> {
    settings.check().map_err(ImageDiffError::Setting)?;
    let (first, second) = (load_image(a).map_err(ImageDiffError::File)?, load_image(b).map_err(ImageDiffError::File)?);
    let (fa, fb) = (&first.frame, &second.frame);
    if (fa.width, fa.height) != (fb.width, fb.height) {
        let (da, db) = (a.display(), b.display());
        let message = format!("{da} is {}x{} but {db} is {}x{}", fa.width, fa.height, fb.width, fb.height);
        return Err(ImageDiffError::SizeMismatch(message));
    }
    for (path, img) in [(a, &first), (b, &second)] {
        needs_channels(path, settings.metric, img.has_depth, img.has_normal).map_err(ImageDiffError::File)?;
    }
    let values = differences(fa, fb, settings.metric);
    let masked = settings.mask_edges.map_or_else(|| vec![false; values.len()], |k| edge_mask(fa, fb, k));
    let mut report = judge(settings.metric, &values, &masked, settings.thresholds);
    // Nothing compared proves nothing: such a diff fails rather than passes.
    if report.compared == 0 {
        report.verdict = Verdict::Fail;
    }
    if let Some(out) = &settings.heat_map {
        let title = format!("{:?} difference: {} vs {}", settings.metric, file_name(a), file_name(b)).to_lowercase();
        let labels = match settings.metric {
            Metric::Depth | Metric::Normal => SpecialLabels::default(),
            Metric::Abs | Metric::Rel => SpecialLabels { no_value: "not a number", infinite: "infinite" },
        };
        let (size, text) = ((fa.width, fa.height), (title.as_str(), settings.metric.unit()));
        let img = heat_map_labelled(&values, size, settings.heat_scale(&values), text, &labels);
        img.save_png(out).map_err(|e| ImageDiffError::File(format!("{e:#}")))?;
    }
    Ok(report)
}

fn needs_channels(path: &Path, metric: Metric, has_depth: bool, has_normal: bool) -> Result<(), String> {
    match metric {
        Metric::Depth if !has_depth => {
            Err(format!("{}: no depth (Z) channel; the depth metric needs EXR", path.display()))
        }
        Metric::Normal if !has_normal => {
            Err(format!("{}: no normal (N.X, N.Y, N.Z) channels; the normal metric needs EXR", path.display()))
        }
        _ => Ok(()),
    }
}

fn file_name(p: &Path) -> String {
    p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
}
