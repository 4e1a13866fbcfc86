//! `blobtrace diff A B`: compare two images (PNG or EXR) the way idiff does,
//! with idiff's exit codes, an optional heat map and JSON statistics.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, ValueEnum};

use crate::compare::{
    DiffReport, Metric, Scale, Thresholds, Verdict, differences, edge_mask, heat_map, judge, load_image,
};

/// The metric, as the command line names it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum MetricArg {
    /// Largest absolute difference of linear R, G, B.
    #[default]
    Abs,
    /// Largest relative difference of R, G, B.
    Rel,
    /// Angle between normals in degrees (EXR with N.X, N.Y, N.Z).
    Normal,
    /// Signed depth difference (EXR with Z).
    Depth,
}

impl From<MetricArg> for Metric {
    fn from(m: MetricArg) -> Self {
        match m {
            MetricArg::Abs => Metric::Abs,
            MetricArg::Rel => Metric::Rel,
            MetricArg::Normal => Metric::Normal,
            MetricArg::Depth => Metric::Depth,
        }
    }
}

/// Options of `blobtrace diff`.
#[derive(Debug, Args)]
pub struct DiffArgs {
    /// First image (.png or .exr).
    pub a: PathBuf,
    /// Second image, the same size.
    pub b: PathBuf,
    /// What to compare per pixel.
    #[arg(long, value_enum, default_value_t = MetricArg::Abs)]
    pub metric: MetricArg,
    /// A pixel differing by more than this counts as failed.
    #[arg(long, default_value_t = 1e-6, allow_negative_numbers = true)]
    pub fail: f32,
    /// Fail when more than this percentage of pixels fail.
    #[arg(long, default_value_t = 0.0)]
    pub failpercent: f64,
    /// Fail when any pixel differs by more than this.
    #[arg(long, default_value_t = f32::INFINITY)]
    pub hardfail: f32,
    /// A pixel differing by more than this counts as a warning.
    #[arg(long, default_value_t = 1e-6)]
    pub warn: f32,
    /// Warn when more than this percentage of pixels warn.
    #[arg(long, default_value_t = 0.0)]
    pub warnpercent: f64,
    /// Set aside pixels within K pixels of a silhouette edge (reported separately).
    #[arg(long, value_name = "K")]
    pub mask_edges: Option<u32>,
    /// Write a heat map of the differences with its colour bar.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// The heat map's full-scale value (default: 0.1 for abs and rel, 10 degrees, 0.05 units of depth).
    #[arg(long)]
    pub scale: Option<f32>,
    /// Print one JSON object of statistics on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Exit code for images of different sizes.
const SIZE_MISMATCH: u8 = 3;
/// Exit code for unreadable images or bad options.
pub const FILE_ERROR: u8 = 4;

/// Runs `blobtrace diff`; returns idiff's exit code.
pub fn run(a: &DiffArgs) -> ExitCode {
    match compare(a) {
        Ok(report) => ExitCode::from(match report.verdict {
            Verdict::Pass => 0,
            Verdict::Warn => 1,
            Verdict::Fail => 2,
        }),
        Err((code, message)) => {
            eprintln!("error: {message}");
            ExitCode::from(code)
        }
    }
}

fn compare(a: &DiffArgs) -> Result<DiffReport, (u8, String)> {
    let file_error = |m: String| (FILE_ERROR, m);
    let thresholds = Thresholds {
        fail: a.fail,
        failpercent: a.failpercent,
        hardfail: a.hardfail,
        warn: a.warn,
        warnpercent: a.warnpercent,
    };
    check_thresholds(&thresholds, a.scale).map_err(file_error)?;
    if let Some(out) = &a.output {
        super::check_output_file(out, "png").map_err(|e| file_error(format!("{e:#}")))?;
    }
    let metric = Metric::from(a.metric);
    let (first, second) = (load_image(&a.a).map_err(file_error)?, load_image(&a.b).map_err(file_error)?);
    let (fa, fb) = (&first.frame, &second.frame);
    if (fa.width, fa.height) != (fb.width, fb.height) {
        let msg = format!(
            "{} is {}x{} but {} is {}x{}",
            a.a.display(),
            fa.width,
            fa.height,
            a.b.display(),
            fb.width,
            fb.height
        );
        return Err((SIZE_MISMATCH, msg));
    }
    for (path, img) in [(&a.a, &first), (&a.b, &second)] {
        needs_channels(path, metric, img.has_depth, img.has_normal).map_err(file_error)?;
    }
    let values = differences(fa, fb, metric);
    let masked = a.mask_edges.map_or_else(|| vec![false; values.len()], |k| edge_mask(fa, fb, k));
    let report = judge(metric, &values, &masked, thresholds);
    if let Some(out) = &a.output {
        let scale = heat_scale(metric, a.scale);
        let title = format!("{:?} difference: {} vs {}", metric, file_name(&a.a), file_name(&a.b)).to_lowercase();
        let img = heat_map(&values, fa.width, fa.height, scale, &title, metric.unit());
        img.save_png(out).map_err(|e| file_error(format!("{e:#}")))?;
    }
    print_report(a, &report);
    Ok(report)
}

fn check_thresholds(t: &Thresholds, scale: Option<f32>) -> Result<(), String> {
    let non_negative = |name: &str, v: f64| {
        if v.is_nan() || v < 0.0 { Err(format!("--{name} must be a non-negative number, got {v}")) } else { Ok(()) }
    };
    non_negative("fail", f64::from(t.fail))?;
    non_negative("hardfail", f64::from(t.hardfail))?;
    non_negative("warn", f64::from(t.warn))?;
    non_negative("failpercent", t.failpercent)?;
    non_negative("warnpercent", t.warnpercent)?;
    match scale {
        Some(s) if !(s.is_finite() && s > 0.0) => Err(format!("--scale must be a positive number, got {s}")),
        _ => Ok(()),
    }
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

/// The fixed heat-map scale of a metric, unless overridden.
fn heat_scale(metric: Metric, scale: Option<f32>) -> Scale {
    match metric {
        Metric::Abs | Metric::Rel => Scale::Magnitude { max: scale.unwrap_or(0.1) },
        Metric::Normal => Scale::Magnitude { max: scale.unwrap_or(10.0) },
        Metric::Depth => Scale::Signed { max: scale.unwrap_or(0.05) },
    }
}

fn file_name(p: &Path) -> String {
    p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
}

fn print_report(a: &DiffArgs, r: &DiffReport) {
    if a.json {
        match serde_json::to_string_pretty(r) {
            Ok(s) => println!("{s}"),
            Err(e) => eprintln!("error: encoding the report: {e}"),
        }
        return;
    }
    println!(
        "{:?}: {} of {} pixels compared, mean {:.3e}, max {:.3e}, {} above {} ({:.3}%){}",
        r.verdict,
        r.compared,
        r.pixels,
        r.mean,
        r.max,
        r.over_fail_px,
        r.thresholds.fail,
        r.over_fail_percent,
        if r.masked_px > 0 {
            format!("; {} edge pixels set aside, {} of them above", r.masked_px, r.masked_over_fail_px)
        } else {
            String::new()
        }
    );
}
