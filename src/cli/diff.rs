//! `blobtrace diff A B`: compare two images (PNG or EXR) the way idiff does,
//! with idiff's exit codes, an optional heat map and JSON statistics.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, ValueEnum};

use super::args::check_output_file;
use super::exit::describe;
use crate::compare::{DiffReport, Metric, Thresholds, Verdict};
use crate::pipeline::{ImageDiffError, ImageDiffSettings, diff_images};

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
    /// The heat map's full-scale value (default: chosen from the data, the p99 rounded up).
    #[arg(long)]
    pub scale: Option<f32>,
    /// Print one JSON object of statistics on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Exit code for images of different sizes.
const SIZE_MISMATCH: u8 = 3;
/// Exit code for unreadable images.
const FILE_ERROR: u8 = 4;

/// Runs `blobtrace diff`; returns idiff's exit code (bad options: the usage code).
pub fn run(a: &DiffArgs) -> ExitCode {
    if let Some(out) = &a.output
        && let Err(e) = check_output_file(out, "png")
    {
        eprintln!("error: {e:#}");
        return ExitCode::from(FILE_ERROR);
    }
    match diff_images(&a.a, &a.b, &a.settings()) {
        Ok(report) => {
            if report.compared == 0 {
                eprintln!(
                    "warning: no pixel was compared (all {} masked or missed by both): the diff fails",
                    report.pixels
                );
            }
            print_report(a, &report);
            ExitCode::from(match report.verdict {
                Verdict::Pass => 0,
                Verdict::Warn => 1,
                Verdict::Fail => 2,
            })
        }
        Err(e) => {
            let (message, code) = match e {
                ImageDiffError::Setting(p) => describe(&p.into()),
                ImageDiffError::SizeMismatch(m) => (m, SIZE_MISMATCH),
                ImageDiffError::File(m) => (m, FILE_ERROR),
            };
            eprintln!("error: {message}");
            ExitCode::from(code)
        }
    }
}

impl DiffArgs {
    fn settings(&self) -> ImageDiffSettings {
        let thresholds = Thresholds {
            fail: self.fail,
            failpercent: self.failpercent,
            hardfail: self.hardfail,
            warn: self.warn,
            warnpercent: self.warnpercent,
        };
        ImageDiffSettings {
            metric: self.metric.into(),
            thresholds,
            mask_edges: self.mask_edges,
            heat_map: self.output.clone(),
            scale: self.scale,
        }
    }
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
