//! Comparing two image files the way idiff does: load both (PNG or EXR),
//! check they hold the channels the metric needs, judge the differences
//! against thresholds, and draw a heat map or write idiff's difference image.
//! The `abs` metric compares every channel as idiff does, images of
//! different sizes over the larger extent (pixels beyond an image read 0, and
//! percentages are of the first image's pixels, as in idiff); `depth` and
//! `normal` compare the surfaces two renders found, pixel by pixel; `flip`
//! is LDR-ꟻLIP for PNG and HDR-ꟻLIP for a pair of EXRs.

use std::path::{Path, PathBuf};

use super::error::PipelineError;
use crate::compare::{
    ChannelImage, Decoding, DiffReport, DifferenceForm, Exposures, Metric, Thresholds, Verdict, compare_channels,
    default_pixels_per_degree, difference_planes, differences, edge_mask, flip_errors, flip_stats, hdr_flip, judge,
    load_channels, load_image, planes_png_bytes,
};
use crate::draw::{Scale, SpecialLabels, heat_map_labelled, histogram_plot};
use crate::frame::channels_exr_bytes;
use crate::output::FileSet;

/// What `-o` writes.
#[derive(Clone, Debug, PartialEq)]
pub enum DiffOutput {
    /// Our heat map of the per-pixel differences with its colour bar (PNG).
    HeatMap(PathBuf),
    /// idiff's difference image: every channel's difference (EXR, or the
    /// first four channels as 8-bit PNG); for depth, normal and ꟻLIP one
    /// channel of the metric's per-pixel values.
    Difference(PathBuf, DifferenceForm),
}

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
    /// Write a heat map or a difference image.
    pub output: Option<DiffOutput>,
    /// Write the output only when the images differ (idiff's `-od`).
    pub only_if_different: bool,
    /// HDR-ꟻLIP's first and last exposures (default: chosen from the reference).
    pub exposures: (Option<f32>, Option<f32>),
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
        for (setting, v) in [("start_exposure", self.exposures.0), ("stop_exposure", self.exposures.1)] {
            if v.is_some_and(|v| !v.is_finite()) {
                return Err(PipelineError::setting(setting, "must be a finite number"));
            }
        }
        if let Some(DiffOutput::Difference(_, form)) = &self.output
            && !form.scale.is_finite()
        {
            return Err(PipelineError::setting("diff_scale", "must be a finite number"));
        }
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
    let Judged { mut report, values, size, channels } = match settings.metric {
        Metric::Abs => diff_channels(a, b, settings)?,
        Metric::Depth | Metric::Normal => diff_surfaces(a, b, settings)?,
        Metric::Flip => diff_flip(a, b, settings)?,
    };
    // Nothing compared proves nothing: such a diff fails rather than passes.
    if report.compared == 0 {
        report.verdict = Verdict::Fail;
    }
    let mut files = FileSet::new();
    let differs = report.max != 0.0 || report.mismatch_px > 0;
    match &settings.output {
        Some(_) if settings.only_if_different && !differs => {}
        Some(DiffOutput::HeatMap(out)) => {
            let what = if settings.metric == Metric::Flip { "error" } else { "difference" };
            let title = format!("{:?} {what}: {} vs {}", settings.metric, file_name(a), file_name(b)).to_lowercase();
            let labels = match settings.metric {
                Metric::Depth | Metric::Normal | Metric::Flip => SpecialLabels::default(),
                Metric::Abs => SpecialLabels { no_value: "not a number", infinite: "finite in one image only" },
            };
            let text = (title.as_str(), settings.metric.unit());
            let img = heat_map_labelled(&values, size, settings.heat_scale(&values), text, &labels);
            files.add(out, img.png_bytes_for(out).map_err(|e| ImageDiffError::File(e.to_string()))?);
        }
        Some(DiffOutput::Difference(out, form)) => {
            let planes = match channels {
                Some((first, second)) => difference_planes(&first, &second, *form),
                None => vec![(format!("{:?}", settings.metric).to_lowercase(), metric_plane(&values, *form))],
            };
            files.add(out, difference_bytes(out, planes, size)?);
        }
        None => {}
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

/// ꟻLIP of the second image against the first, the reference: HDR-ꟻLIP of
/// the linear colour when both are EXR, else LDR-ꟻLIP of 8-bit sRGB colour
/// (an EXR's premultiplied linear colour encoded to it), alpha dropped as
/// NVIDIA's tool drops it.
fn diff_flip(a: &Path, b: &Path, settings: &ImageDiffSettings) -> Result<Judged, ImageDiffError> {
    let (first, second) = (load_frame(a)?.frame, load_frame(b)?.frame);
    same_size(a, b, (first.width, first.height), (second.width, second.height))?;
    let (w, h) = (first.width, first.height);
    let ppd = default_pixels_per_degree();
    let (errors, exposures) = if is_exr(a) && is_exr(b) {
        let (start, stop) = settings.exposures;
        let exposures = Exposures::for_reference(&first.color, start, stop)
            .map_err(|e| ImageDiffError::File(format!("{}: {e}", a.display())))?;
        (hdr_flip(&first.color, &second.color, w, h, ppd, exposures), Some(exposures))
    } else {
        (flip_errors(&first.to_srgb8(), &second.to_srgb8(), w, h, ppd), None)
    };
    let masked = settings.mask_edges.map_or_else(|| vec![false; errors.len()], |k| edge_mask(&first, &second, k));
    let mut report = judge(Metric::Flip, &errors, &masked, w, settings.thresholds);
    let mut stats = flip_stats(&errors, w, h, ppd);
    stats.exposures = exposures;
    report.flip = Some(stats);
    Ok(Judged { report, values: errors, size: (w, h), channels: None })
}

/// A judgement with what its output needs: the per-pixel values, the
/// image size, and (the `abs` metric) both images' channels as compared.
struct Judged {
    report: DiffReport,
    values: Vec<f32>,
    size: (u32, u32),
    channels: Option<(ChannelImage, ChannelImage)>,
}

/// idiff's comparison over every channel (or the ones named); images of
/// different sizes are compared over the larger extent, as idiff does.
fn diff_channels(a: &Path, b: &Path, settings: &ImageDiffSettings) -> Result<Judged, ImageDiffError> {
    let load = |p: &Path| load_channels(p, settings.decoding).map_err(ImageDiffError::File);
    let (first, second) = (load(a)?, load(b)?);
    let (sa, sb) = ((first.width, first.height), (second.width, second.height));
    let (first, second) = match &settings.channels {
        Some(names) => (select(a, &first, names)?, select(b, &second, names)?),
        None => (first, second),
    };
    let masked = match settings.mask_edges {
        Some(k) => {
            same_size(a, b, sa, sb)?;
            edge_mask(&load_frame(a)?.frame, &load_frame(b)?.frame, k)
        }
        None => vec![false; (sa.0.max(sb.0) * sa.1.max(sb.1)) as usize],
    };
    let (first, second, base) = match sa == sb {
        true => (first, second, None),
        false => {
            let (w, h) = (sa.0.max(sb.0), sa.1.max(sb.1));
            (first.padded(w, h), second.padded(w, h), Some((sa.0 * sa.1) as usize))
        }
    };
    let (mut report, values) = compare_channels(&first, &second, &masked, settings.thresholds, base);
    report.sizes = (sa != sb).then_some([sa, sb]);
    let size = (first.width, first.height);
    Ok(Judged { report, values, size, channels: Some((first, second)) })
}

/// One metric's per-pixel values as a difference plane (absolute and scaled as asked).
fn metric_plane(values: &[f32], form: DifferenceForm) -> Vec<f32> {
    values.iter().map(|&v| if form.absolute { v.abs() } else { v } * form.scale).collect()
}

/// A difference image's bytes, EXR or PNG by `out`'s extension.
fn difference_bytes(
    out: &Path,
    planes: Vec<(String, Vec<f32>)>,
    (w, h): (u32, u32),
) -> Result<Vec<u8>, ImageDiffError> {
    let failed = |e: String| ImageDiffError::File(format!("{}: could not encode: {e}", out.display()));
    match is_exr(out) {
        true => channels_exr_bytes(w, h, planes).map_err(failed),
        false => planes_png_bytes(&planes, w, h).map_err(failed),
    }
}

fn is_exr(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"))
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
    Ok(Judged { report, values, size: (fa.width, fa.height), channels: None })
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
