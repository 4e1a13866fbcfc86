//! Comparing two image files the way idiff does: load both (PNG or EXR),
//! check they match in size and hold the channels the metric needs, judge
//! the differences against thresholds, and draw a heat map. The `abs` metric
//! compares every channel as idiff does; `depth` and `normal` compare the
//! surfaces two renders found, pixel by pixel.

use std::path::{Path, PathBuf};

use super::error::PipelineError;
use crate::compare::{
    ChannelImage, Decoding, DiffReport, Metric, Scale, SpecialLabels, Thresholds, Verdict, compare_channels,
    default_pixels_per_degree, differences, edge_mask, flip_errors, flip_stats, heat_map_labelled, histogram_plot,
    judge, load_channels, load_image,
};
use crate::output::FileSet;

/// How to compare two images.
#[derive(Clone, Debug)]
pub struct ImageDiffSettings {
    /// What to compare per pixel.
    pub metric: Metric,
    /// When a difference warns or fails.
    pub thresholds: Thresholds,
    /// The channels the `abs` metric compares, by name (default: every channel).
    pub channels: Option<Vec<String>>,
    /// How PNG codes become values (default: as stored, as idiff reads them).
    pub decoding: Decoding,
    /// Set aside pixels within this many pixels of a silhouette edge.
    pub mask_edges: Option<u32>,
    /// Write a heat map of the differences here.
    pub heat_map: Option<PathBuf>,
    /// Write a histogram plot of the ꟻLIP errors here (the `flip` metric).
    pub histogram: Option<PathBuf>,
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
        non_negative("hardwarn", f64::from(t.hardwarn))?;
        non_negative("failrelative", f64::from(t.failrelative))?;
        non_negative("warnrelative", f64::from(t.warnrelative))?;
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
            // ꟻLIP errors lie in [0, 1]: its map is always drawn on the whole range.
            None if self.metric == Metric::Flip => Scale::Magnitude { max: 1.0 },
            None => Scale::from_data(values, signed, if self.metric == Metric::Normal { 10.0 } else { 0.1 }),
        }
    }
}

/// Compares the images at `a` and `b`; a comparison of no pixel at all (every
/// one masked, or missed by both for depth and normals) fails.
pub fn diff_images(a: &Path, b: &Path, settings: &ImageDiffSettings) -> Result<DiffReport, ImageDiffError> {
    settings.check().map_err(ImageDiffError::Setting)?;
    let (mut report, values, (width, height)) = match settings.metric {
        Metric::Abs => diff_channels(a, b, settings)?,
        Metric::Depth | Metric::Normal => diff_surfaces(a, b, settings)?,
        Metric::Flip => diff_flip(a, b, settings)?,
    };
    // Nothing compared proves nothing: such a diff fails rather than passes.
    if report.compared == 0 {
        report.verdict = Verdict::Fail;
    }
    let mut files = FileSet::new();
    if let Some(out) = &settings.heat_map {
        let what = if settings.metric == Metric::Flip { "error" } else { "difference" };
        let title = format!("{:?} {what}: {} vs {}", settings.metric, file_name(a), file_name(b)).to_lowercase();
        let labels = match settings.metric {
            Metric::Depth | Metric::Normal | Metric::Flip => SpecialLabels::default(),
            Metric::Abs => SpecialLabels { no_value: "not a number", infinite: "finite in one image only" },
        };
        let text = (title.as_str(), settings.metric.unit());
        let img = heat_map_labelled(&values, (width, height), settings.heat_scale(&values), text, &labels);
        files.add(out, img.png_bytes_for(out).map_err(|e| ImageDiffError::File(e.to_string()))?);
    }
    if let (Some(out), Some(flip)) = (&settings.histogram, &report.flip) {
        let title = format!("FLIP histogram: {} vs {}", file_name(a), file_name(b));
        let marks = [("mean", f64::from(flip.mean)), ("weighted median", f64::from(flip.weighted_median))];
        let img = histogram_plot(&title, "FLIP error", &flip.histogram, &marks, 640, 360);
        files.add(out, img.png_bytes_for(out).map_err(|e| ImageDiffError::File(e.to_string()))?);
    }
    files.commit().map_err(|e| ImageDiffError::File(e.to_string()))?;
    Ok(report)
}

/// LDR-ꟻLIP of the second image against the first, the reference. Both are
/// read as 8-bit sRGB colour, alpha dropped as NVIDIA's tool drops it; an
/// EXR's (premultiplied, linear) colour is encoded to 8-bit sRGB first.
fn diff_flip(a: &Path, b: &Path, settings: &ImageDiffSettings) -> Result<Judged, ImageDiffError> {
    let (first, second) = (load_frame(a)?.frame, load_frame(b)?.frame);
    same_size(a, b, (first.width, first.height), (second.width, second.height))?;
    let (w, h) = (first.width, first.height);
    let ppd = default_pixels_per_degree();
    let errors = flip_errors(&first.to_srgb8(), &second.to_srgb8(), w, h, ppd);
    let masked = settings.mask_edges.map_or_else(|| vec![false; errors.len()], |k| edge_mask(&first, &second, k));
    let mut report = judge(Metric::Flip, &errors, &masked, w, settings.thresholds);
    report.flip = Some(flip_stats(&errors, w, h, ppd));
    Ok((report, errors, (w, h)))
}

type Judged = (DiffReport, Vec<f32>, (u32, u32));

/// idiff's comparison over every channel (or the ones named).
fn diff_channels(a: &Path, b: &Path, settings: &ImageDiffSettings) -> Result<Judged, ImageDiffError> {
    let load = |p: &Path| load_channels(p, settings.decoding).map_err(ImageDiffError::File);
    let (first, second) = (load(a)?, load(b)?);
    same_size(a, b, (first.width, first.height), (second.width, second.height))?;
    let (first, second) = match &settings.channels {
        Some(names) => (select(a, &first, names)?, select(b, &second, names)?),
        None => (first, second),
    };
    let masked = match settings.mask_edges {
        Some(k) => edge_mask(&load_frame(a)?.frame, &load_frame(b)?.frame, k),
        None => vec![false; first.planes.first().map_or(0, Vec::len)],
    };
    let (report, values) = compare_channels(&first, &second, &masked, settings.thresholds);
    Ok((report, values, (first.width, first.height)))
}

/// The depth or normal metric over the surfaces two renders found.
fn diff_surfaces(a: &Path, b: &Path, settings: &ImageDiffSettings) -> Result<Judged, ImageDiffError> {
    let (first, second) = (load_frame(a)?, load_frame(b)?);
    let (fa, fb) = (&first.frame, &second.frame);
    same_size(a, b, (fa.width, fa.height), (fb.width, fb.height))?;
    for (path, img) in [(a, &first), (b, &second)] {
        needs_channels(path, settings.metric, img.has_depth, img.has_normal).map_err(ImageDiffError::File)?;
    }
    let values = differences(fa, fb, settings.metric);
    let masked = settings.mask_edges.map_or_else(|| vec![false; values.len()], |k| edge_mask(fa, fb, k));
    let report = judge(settings.metric, &values, &masked, fa.width, settings.thresholds);
    Ok((report, values, (fa.width, fa.height)))
}

fn load_frame(path: &Path) -> Result<crate::compare::LoadedImage, ImageDiffError> {
    load_image(path).map_err(ImageDiffError::File)
}

fn same_size(a: &Path, b: &Path, sa: (u32, u32), sb: (u32, u32)) -> Result<(), ImageDiffError> {
    if sa == sb {
        return Ok(());
    }
    let (da, db) = (a.display(), b.display());
    Err(ImageDiffError::SizeMismatch(format!("{da} is {}x{} but {db} is {}x{}", sa.0, sa.1, sb.0, sb.1)))
}

fn select(path: &Path, img: &ChannelImage, names: &[String]) -> Result<ChannelImage, ImageDiffError> {
    img.select(names).map_err(|missing| {
        let has = img.names.join(", ");
        ImageDiffError::File(format!("{}: no channel {missing} (it has {has})", path.display()))
    })
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
