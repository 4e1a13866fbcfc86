//! `blobtrace diff A B`: compare two images (PNG or EXR) the way idiff does,
//! with idiff's exit codes, an optional heat map and JSON statistics.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, ValueEnum};

use super::args::check_output_file;
use super::exit::describe;
use crate::compare::{Decoding, DiffReport, Metric, Thresholds, Verdict};
use crate::pipeline::{ImageDiffError, ImageDiffSettings, diff_images};

/// The metric, as the command line names it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum MetricArg {
    /// Absolute difference of every channel (idiff's comparison).
    #[default]
    Abs,
    /// Angle between normals in degrees (EXR with N.X, N.Y, N.Z).
    Normal,
    /// Signed depth difference (EXR with Z).
    Depth,
    /// LDR-FLIP perceptual error of B against A, the reference (NVIDIA's FLIP).
    Flip,
}

impl From<MetricArg> for Metric {
    fn from(m: MetricArg) -> Self {
        match m {
            MetricArg::Abs => Metric::Abs,
            MetricArg::Normal => Metric::Normal,
            MetricArg::Depth => Metric::Depth,
            MetricArg::Flip => Metric::Flip,
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
    /// Compare only these channels, by name (e.g. R,G,B,A or Z); default: every channel.
    #[arg(long, value_delimiter = ',', value_name = "NAMES")]
    pub channels: Option<Vec<String>>,
    /// Decode sRGB PNG codes to linear light before comparing (default: compare them as stored, as idiff does).
    #[arg(long)]
    pub linear: bool,
    /// A pixel with a channel differing by more than this counts as failed.
    #[arg(long, default_value_t = 1e-6, allow_negative_numbers = true)]
    pub fail: f32,
    /// A failed value must also differ by more than this fraction of the mean of the two magnitudes.
    #[arg(long, default_value_t = 0.0)]
    pub failrelative: f32,
    /// Fail when more than this percentage of pixels fail.
    #[arg(long, default_value_t = 0.0)]
    pub failpercent: f64,
    /// Fail when any value differs by more than this.
    #[arg(long, default_value_t = f32::INFINITY)]
    pub hardfail: f32,
    /// Pass whatever the errors when at most N pixels fail (as in idiff, at the default 0 an image with no
    /// failed pixel passes without warning: warnings need failures that --failpercent tolerates).
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub allowfailures: usize,
    /// A pixel with a channel differing by more than this counts as a warning.
    #[arg(long, default_value_t = 1e-6)]
    pub warn: f32,
    /// A warned value must also differ by more than this fraction of the mean of the two magnitudes.
    #[arg(long, default_value_t = 0.0)]
    pub warnrelative: f32,
    /// Warn when more than this percentage of pixels warn.
    #[arg(long, default_value_t = 0.0)]
    pub warnpercent: f64,
    /// Warn when any value differs by more than this.
    #[arg(long, default_value_t = f32::INFINITY)]
    pub hardwarn: f32,
    /// Set aside pixels within K pixels of a silhouette edge (reported separately).
    #[arg(long, value_name = "K")]
    pub mask_edges: Option<u32>,
    /// Write a heat map of the differences with its colour bar.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// With --metric flip: write a histogram plot of the FLIP errors.
    #[arg(long, value_name = "PNG")]
    pub histogram: Option<PathBuf>,
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
    for out in a.output.iter().chain(&a.histogram) {
        if let Err(e) = check_output_file(out, "png") {
            eprintln!("error: {e:#}");
            return ExitCode::from(FILE_ERROR);
        }
    }
    if a.histogram.is_some() && a.metric != MetricArg::Flip {
        eprintln!("warning: --histogram is drawn for --metric flip only; ignored");
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
            failrelative: self.failrelative,
            failpercent: self.failpercent,
            hardfail: self.hardfail,
            allowfailures: self.allowfailures,
            warn: self.warn,
            warnrelative: self.warnrelative,
            warnpercent: self.warnpercent,
            hardwarn: self.hardwarn,
        };
        ImageDiffSettings {
            metric: self.metric.into(),
            thresholds,
            channels: self.channels.clone(),
            decoding: if self.linear { Decoding::Linear } else { Decoding::Stored },
            mask_edges: self.mask_edges,
            heat_map: self.output.clone(),
            histogram: self.histogram.clone(),
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
    let unit = match Metric::from(a.metric).unit() {
        "" => String::new(),
        u => format!(" {u}"),
    };
    let t = &r.thresholds;
    let over = |n: usize, v: f32| {
        format!(
            "  {n} pixels ({}%) over {}{unit}",
            g_digits(100.0 * n as f64 / r.compared.max(1) as f64, 3),
            g(f64::from(v))
        )
    };
    println!("Comparing {:?} and {:?}{}", a.a.display().to_string(), a.b.display().to_string(), compared_what(r));
    println!("  Mean error = {}{unit}", g(r.mean));
    println!("  RMS error = {}{unit}", g(r.rms));
    if r.metric == Metric::Abs {
        println!("  Peak SNR = {}", r.psnr.map_or_else(|| "inf".to_string(), |p| format!("{} dB", g(p))));
    }
    println!(
        "  Max error  = {}{unit}{}",
        g(f64::from(r.max)),
        r.max_at.as_ref().map_or_else(String::new, max_location)
    );
    println!("{}", over(r.over_warn_px, t.warn));
    println!("{}", over(r.over_fail_px, t.fail));
    if r.mismatch_px > 0 {
        let what = if r.channels.is_empty() { "hit in one image only" } else { "finite in one image only" };
        println!("  {} pixels {what} (counted as failed)", r.mismatch_px);
    }
    if let Some(f) = &r.flip {
        println!(
            "  FLIP at {:.1} pixels per degree: mean {:.6}, weighted median {:.6}, weighted quartiles {:.6} and {:.6}, min {:.6}, max {:.6}",
            f.pixels_per_degree, f.mean, f.weighted_median, f.weighted_q1, f.weighted_q3, f.min, f.max
        );
    }
    if r.masked_px > 0 {
        println!(
            "  {} edge pixels set aside, {} of them over {}",
            r.masked_px,
            r.masked_over_fail_px,
            g(f64::from(t.fail))
        );
    }
    println!(
        "{}",
        match r.verdict {
            Verdict::Pass => "PASS",
            Verdict::Warn => "WARNING",
            Verdict::Fail => "FAILURE",
        }
    );
}

fn compared_what(r: &DiffReport) -> String {
    match r.channels.as_slice() {
        [] => format!(": {:?} over {} of {} pixels", r.metric, r.compared, r.pixels).to_lowercase(),
        names => format!(", channels {}", names.join(", ")),
    }
}

fn max_location(m: &crate::compare::MaxAt) -> String {
    let list = |v: &[f32]| v.iter().map(ToString::to_string).collect::<Vec<_>>().join(", ");
    match m.a.is_empty() {
        true => format!(" @ ({}, {})", m.x, m.y),
        false => format!(" @ ({}, {}, {})  values are {} vs {}", m.x, m.y, m.channel, list(&m.a), list(&m.b)),
    }
}

/// A number as C's `%.{digits}g` prints it: that many significant digits,
/// no trailing zeros, scientific below 1e-4 and from 10^digits up.
fn g_digits(v: f64, digits: usize) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let scientific = format!("{v:.*e}", digits - 1);
    let (mantissa, exponent) = scientific.split_once('e').unwrap_or((&scientific, "0"));
    let exponent: i32 = exponent.parse().unwrap_or(0);
    let trim = |s: &str| {
        if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s.to_string() }
    };
    if exponent < -4 || exponent >= digits as i32 {
        format!("{}e{}{:02}", trim(mantissa), if exponent < 0 { '-' } else { '+' }, exponent.abs())
    } else {
        trim(&format!("{v:.*}", (digits as i32 - 1 - exponent).max(0) as usize))
    }
}

/// `%g`: six significant digits.
fn g(v: f64) -> String {
    g_digits(v, 6)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_print_as_c_prints_them() {
        let cases = [
            (1e-6, "1e-06"),
            (0.05, "0.05"),
            (35.600_412, "35.6004"),
            (0.698_039_2, "0.698039"),
            (512.729_3, "512.729"),
        ];
        for (v, want) in cases {
            assert_eq!(g(v), want);
        }
        assert_eq!(
            (g_digits(9.4987, 3), g_digits(0.996_094, 3), g_digits(65.0, 3)),
            ("9.5".into(), "0.996".into(), "65".into())
        );
        assert_eq!(g(1_234_567.0), "1.23457e+06");
    }
}
