//! `blobtrace diff A B`: compare two images (PNG or EXR) the way idiff does,
//! with idiff's exit codes, an optional heat map and JSON statistics.

use std::ffi::OsString;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, ValueEnum};

use super::args::{check_output_dir, check_output_file};
use super::exit::{USAGE, describe};
use crate::compare::{Decoding, DiffReport, DifferenceForm, IdiffStats, Metric, Thresholds, Verdict};
use crate::pipeline::{DiffOutput, ImageDiffError, ImageDiffSettings, diff_images};

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
    /// NVIDIA's FLIP of B against A, the reference: LDR-FLIP for PNG, HDR-FLIP for two EXRs.
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

/// Options of `blobtrace diff`. idiff's command lines work unchanged: its
/// single-dash options (`-fail 0.5`, `-abs`, `-scale 4`, `-od`…) are read as
/// ours (see [`idiff_style`]).
#[derive(Debug, Args)]
pub struct DiffArgs {
    /// First image (.png or .exr), the reference.
    pub a: PathBuf,
    /// Second image. For the abs metric it may differ in size: as idiff does, the two are compared over the larger
    /// width and height, pixels beyond an image reading 0, with percentages (and --failpercent, --warnpercent) of
    /// the first image's pixels; a warning says so. The other metrics need one size (exit 3).
    pub b: PathBuf,
    /// What to compare per pixel.
    #[arg(long, value_enum, default_value_t = MetricArg::Abs)]
    pub metric: MetricArg,
    /// idiff's -p (perceptual): here --metric flip, NVIDIA's FLIP, not idiff's Yee metric.
    #[arg(short = 'p', long, conflicts_with = "metric")]
    pub perceptual: bool,
    /// Compare only these channels, by name (e.g. R,G,B,A or Z); default: every channel.
    #[arg(long, value_delimiter = ',', value_name = "NAMES")]
    pub channels: Option<Vec<String>>,
    /// Decode sRGB PNG codes to linear light before comparing (default: compare them as stored, as idiff does).
    #[arg(long)]
    pub linear: bool,
    /// A pixel with a channel differing by more than this counts as failed (idiff's -fail).
    #[arg(long, default_value_t = 1e-6, allow_negative_numbers = true)]
    pub fail: f32,
    /// A failed value must also differ by more than this fraction of the mean of the two magnitudes (-failrelative).
    #[arg(long, default_value_t = 0.0)]
    pub failrelative: f32,
    /// Fail when more than this percentage of pixels fail (-failpercent).
    #[arg(long, default_value_t = 0.0)]
    pub failpercent: f64,
    /// Fail when any value differs by more than this (-hardfail).
    #[arg(long, default_value_t = f32::INFINITY)]
    pub hardfail: f32,
    /// Pass whatever the errors when at most N pixels fail (-allowfailures; as in idiff, at the default 0 an image
    /// with no failed pixel passes without warning: warnings need failures that --failpercent tolerates).
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub allowfailures: usize,
    /// A pixel with a channel differing by more than this counts as a warning (-warn).
    #[arg(long, default_value_t = 1e-6)]
    pub warn: f32,
    /// A warned value must also differ by more than this fraction of the mean of the two magnitudes (-warnrelative).
    #[arg(long, default_value_t = 0.0)]
    pub warnrelative: f32,
    /// Warn when more than this percentage of pixels warn (-warnpercent).
    #[arg(long, default_value_t = 0.0)]
    pub warnpercent: f64,
    /// Warn when any value differs by more than this (-hardwarn).
    #[arg(long, default_value_t = f32::INFINITY)]
    pub hardwarn: f32,
    /// Set aside pixels within K pixels of a silhouette edge (reported separately; images of one size only).
    #[arg(long, value_name = "K")]
    pub mask_edges: Option<u32>,
    /// Output (idiff's -o): FILE.png is a heat map of the differences with its colour bar, or with --abs idiff's
    /// absolute difference image (first four channels, 8-bit); FILE.exr is idiff's difference image, every channel
    /// in float (for depth, normal and flip: one channel of the metric's values). Other names are a usage error.
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// The difference image holds |A - B| rather than A - B (idiff's -abs).
    #[arg(long)]
    pub abs: bool,
    /// Multiply the difference image by this (idiff's -scale; --scale is the heat map's full scale).
    #[arg(long, default_value_t = 1.0, value_name = "FACTOR", allow_negative_numbers = true)]
    pub diff_scale: f32,
    /// Write -o only if the images differ (idiff's -od).
    #[arg(long)]
    pub if_different: bool,
    /// With --metric flip: write a histogram plot of the FLIP errors.
    #[arg(long, value_name = "PNG")]
    pub histogram: Option<PathBuf>,
    /// The heat map's full-scale value (default: chosen from the data, the p99 rounded up).
    #[arg(long)]
    pub scale: Option<f32>,
    /// HDR-FLIP (--metric flip on two EXRs): the first exposure in stops (default: flip-evaluator's choice, from the
    /// reference's brightest pixel).
    #[arg(long, value_name = "STOPS", allow_negative_numbers = true)]
    pub start_exposure: Option<f32>,
    /// HDR-FLIP: the last exposure in stops (default: flip-evaluator's, from the reference's median luminance);
    /// max(2, ceil(stop - start)) exposures are evaluated.
    #[arg(long, value_name = "STOPS", allow_negative_numbers = true)]
    pub stop_exposure: Option<f32>,
    /// Print idiff's own figures (mean, RMS, PSNR, maximum, counts), non-finite values included, as idiff prints
    /// them, in place of ours (which leave values finite in one image only out of the sums).
    #[arg(long)]
    pub idiff_stats: bool,
    /// Print nothing but FAILURE (on stderr) when the images fail (idiff's -q).
    #[arg(short, long)]
    pub quiet: bool,
    /// idiff's -v: the report is always printed here, so it changes nothing.
    #[arg(short, long)]
    pub verbose: bool,
    /// Print one JSON object of statistics on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Exit code for images of different sizes.
const SIZE_MISMATCH: u8 = 3;
/// Exit code for unreadable images.
const FILE_ERROR: u8 = 4;

/// idiff's single-dash long options and ours they mean.
const IDIFF_OPTIONS: [(&str, &str); 12] = [
    ("-fail", "--fail"),
    ("-failrelative", "--failrelative"),
    ("-failpercent", "--failpercent"),
    ("-hardfail", "--hardfail"),
    ("-allowfailures", "--allowfailures"),
    ("-warn", "--warn"),
    ("-warnrelative", "--warnrelative"),
    ("-warnpercent", "--warnpercent"),
    ("-hardwarn", "--hardwarn"),
    ("-abs", "--abs"),
    ("-scale", "--diff-scale"),
    ("-od", "--if-different"),
];

/// `args` (the whole command line) with idiff's single-dash long options of
/// `blobtrace diff` written as ours, so idiff's command lines work unchanged
/// (`-o`, `-p`, `-q` and `-v` are our short options already). The value
/// after an option that takes one is left as it is. idiff's `-a` (every
/// subimage) is refused with a message: only an EXR's first part is read.
pub fn idiff_style(args: Vec<OsString>) -> Result<Vec<OsString>, String> {
    if args.get(1).is_none_or(|a| a != "diff") {
        return Ok(args);
    }
    let command = DiffArgs::augment_args(clap::Command::new("diff"));
    let takes_value = |flag: &str| {
        command.get_arguments().any(|arg| {
            let named = arg.get_long().is_some_and(|l| flag.strip_prefix("--") == Some(l))
                || arg.get_short().is_some_and(|c| flag.strip_prefix('-') == Some(c.encode_utf8(&mut [0; 4])));
            named && arg.get_action().takes_values()
        })
    };
    let mut out = args[..2].to_vec();
    let mut rest = args.into_iter().skip(2);
    while let Some(arg) = rest.next() {
        let text = arg.to_string_lossy();
        if text == "--" {
            out.push(arg);
            out.extend(rest);
            break;
        }
        if text == "-a" {
            return Err("idiff's -a (compare every subimage and MIP level) is not supported: diff reads an EXR's \
                        first part only"
                .into());
        }
        let mapped =
            IDIFF_OPTIONS.iter().find(|(idiff, _)| *idiff == text).map_or(arg.clone(), |(_, ours)| ours.into());
        let value_follows = takes_value(&mapped.to_string_lossy());
        out.push(mapped);
        if value_follows {
            out.extend(rest.next());
        }
    }
    Ok(out)
}

/// Runs `blobtrace diff`; returns idiff's exit code (bad options: the usage code).
pub fn run(a: &DiffArgs) -> ExitCode {
    if let Err((message, code)) = check_outputs(a) {
        eprintln!("error: {message}");
        return ExitCode::from(code);
    }
    if a.histogram.is_some() && a.metric() != MetricArg::Flip {
        eprintln!("warning: --histogram is drawn for --metric flip only; ignored");
    }
    match diff_images(&a.a, &a.b, &a.settings()) {
        Ok(report) => {
            warn_of(a, &report);
            if a.quiet {
                if report.verdict == Verdict::Fail {
                    eprintln!("FAILURE");
                }
            } else {
                print_report(a, &report);
            }
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

/// The outputs' names and folders, before any work: a name that is neither
/// .png nor .exr is a usage error; a missing folder, a file error.
fn check_outputs(a: &DiffArgs) -> Result<(), (String, u8)> {
    let failed = |e: anyhow::Error| match describe(&e) {
        (m, USAGE) => (m, USAGE),
        (m, _) => (m, FILE_ERROR),
    };
    if let Some(out) = &a.output {
        check_output_dir(out).map_err(failed)?;
        let ext = out.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        if !matches!(ext.as_deref(), Some("png" | "exr")) {
            let problem = "-o writes a heat map or difference image as .png, or a difference image as .exr";
            return Err((format!("{}: {problem}", out.display()), USAGE));
        }
    }
    if let Some(h) = &a.histogram {
        check_output_file(h, "png").map_err(failed)?;
    }
    Ok(())
}

/// Warnings a report calls for, on stderr.
fn warn_of(a: &DiffArgs, report: &DiffReport) {
    if report.compared == 0 {
        eprintln!("warning: no pixel was compared (all {} masked or missed by both): the diff fails", report.pixels);
    }
    if let Some([(wa, ha), (wb, hb)]) = report.sizes {
        eprintln!(
            "warning: {} is {wa}x{ha} but {} is {wb}x{hb}: compared over {}x{} as idiff does, pixels beyond an image \
             reading 0, percentages of the first image's {} pixels",
            a.a.display(),
            a.b.display(),
            wa.max(wb),
            ha.max(hb),
            wa * ha
        );
    }
}

impl DiffArgs {
    fn metric(&self) -> MetricArg {
        if self.perceptual { MetricArg::Flip } else { self.metric }
    }

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
            metric: self.metric().into(),
            thresholds,
            channels: self.channels.clone(),
            decoding: if self.linear { Decoding::Linear } else { Decoding::Stored },
            mask_edges: self.mask_edges,
            output: self.output.clone().map(|path| self.output_kind(path)),
            only_if_different: self.if_different,
            exposures: (self.start_exposure, self.stop_exposure),
            histogram: self.histogram.clone(),
            scale: self.scale,
        }
    }

    /// A PNG is a heat map unless --abs asks for idiff's difference image; an EXR is always one.
    fn output_kind(&self, path: PathBuf) -> DiffOutput {
        let exr = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"));
        if exr || self.abs {
            DiffOutput::Difference(path, DifferenceForm { absolute: self.abs, scale: self.diff_scale })
        } else {
            DiffOutput::HeatMap(path)
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
    println!("Comparing {:?} and {:?}{}", a.a.display().to_string(), a.b.display().to_string(), compared_what(r));
    match (&r.idiff, a.idiff_stats) {
        (Some(idiff), true) => print_idiff_figures(idiff, &r.thresholds),
        _ => print_figures(a, r),
    }
    if r.mismatch_px > 0 {
        let what = if r.channels.is_empty() { "hit in one image only" } else { "finite in one image only" };
        println!("  {} pixels {what} (counted as failed)", r.mismatch_px);
    }
    if let Some(f) = &r.flip {
        let kind = f.exposures.map_or_else(
            || "FLIP".to_string(),
            |e| format!("HDR-FLIP over {} exposures from {} to {} stops", e.count, g(e.start.into()), g(e.stop.into())),
        );
        println!(
            "  {kind} at {:.1} pixels per degree: mean {:.6}, weighted median {:.6}, weighted quartiles {:.6} and {:.6}, min {:.6}, max {:.6}",
            f.pixels_per_degree, f.mean, f.weighted_median, f.weighted_q1, f.weighted_q3, f.min, f.max
        );
    }
    if r.masked_px > 0 {
        println!(
            "  {} edge pixels set aside, {} of them over {}",
            r.masked_px,
            r.masked_over_fail_px,
            g(f64::from(r.thresholds.fail))
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

/// Our figures: mean and RMS over finite differences, with a coverage count beside them.
fn print_figures(a: &DiffArgs, r: &DiffReport) {
    let unit = match Metric::from(a.metric()).unit() {
        "" => String::new(),
        u => format!(" {u}"),
    };
    let t = &r.thresholds;
    let base = r.idiff.as_ref().map_or(r.compared, |i| if r.sizes.is_some() { i.percent_base } else { r.compared });
    let over = |n: usize, v: f32| {
        format!("  {n} pixels ({}%) over {}{unit}", g_digits(100.0 * n as f64 / base.max(1) as f64, 3), g(f64::from(v)))
    };
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
}

/// idiff's figures, printed as idiff 2.4.7 prints them.
fn print_idiff_figures(s: &IdiffStats, t: &Thresholds) {
    let word = |v: f64| match v {
        v if v.is_nan() => "nan".to_string(),
        v if v.is_infinite() => "inf".to_string(),
        v => g(v),
    };
    println!("  Mean error = {}", word(s.mean));
    println!("  RMS error = {}", word(s.rms));
    println!("  Peak SNR = {}", word(s.psnr));
    let list = |v: &[f32]| v.iter().map(|&x| shortest(x)).collect::<Vec<_>>().join(", ");
    let at = match s.max != 0.0 {
        true => format!(" @ ({}, {}, {})  values are {} vs {}", s.max_x, s.max_y, s.channel, list(&s.a), list(&s.b)),
        false => String::new(),
    };
    println!("  Max error  = {}{at}", g(s.max));
    let percent = |n: usize| g_digits(100.0 * n as f64 / s.percent_base as f64, 3);
    println!("  {} pixels ({}%) over {}", s.nwarn, percent(s.nwarn), shortest(t.warn));
    println!("  {} pixels ({}%) over {}", s.nfail, percent(s.nfail), shortest(t.fail));
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
    if v.is_nan() {
        return "nan".into();
    }
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

/// A float as the {fmt} library's `{}` prints it (idiff's values and
/// thresholds): the shortest digits that read back to it, in exponent form
/// (two exponent digits at least) below 1e-4 and from 1e16 up.
fn shortest(v: f32) -> String {
    if !v.is_finite() {
        return if v.is_nan() { "nan".into() } else { format!("{v}") };
    }
    let scientific = format!("{v:e}");
    let (mantissa, exponent) = scientific.split_once('e').unwrap_or((&scientific, "0"));
    let exponent: i32 = exponent.parse().unwrap_or(0);
    if v != 0.0 && !(-4..16).contains(&exponent) {
        format!("{mantissa}e{}{:02}", if exponent < 0 { '-' } else { '+' }, exponent.abs())
    } else {
        format!("{v}")
    }
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
        assert_eq!(g(f64::NAN), "nan");
    }

    #[test]
    fn floats_print_as_fmt_prints_them() {
        let cases = [(0.584_313_75, "0.58431375"), (37.0, "37"), (1e-6, "1e-06"), (0.01, "0.01"), (-0.0, "-0")];
        for (v, want) in cases {
            assert_eq!(shortest(v), want);
        }
        assert_eq!(
            (shortest(3.5e20), shortest(f32::NAN), shortest(f32::INFINITY)),
            ("3.5e+20".into(), "nan".into(), "inf".into())
        );
    }

    fn args(line: &str) -> Vec<String> {
        let words = line.split_whitespace().map(OsString::from).collect();
        idiff_style(words).unwrap().iter().map(|a| a.to_string_lossy().into_owned()).collect()
    }

    #[test]
    fn idiff_options_become_ours_and_values_stay_as_they_are() {
        assert_eq!(
            args("blobtrace diff -fail 0.5 -warn 0.01 -failpercent 5 -abs -scale -2 -od -o d.exr A.png B.png"),
            "blobtrace diff --fail 0.5 --warn 0.01 --failpercent 5 --abs --diff-scale -2 --if-different -o d.exr A.png B.png"
                .split(' ')
                .collect::<Vec<_>>()
        );
        // A value that looks like an idiff option is a value; only diff's command line is read so.
        assert_eq!(args("blobtrace diff --channels -abs A B")[3], "-abs");
        assert_eq!(args("blobtrace render -fail x")[2], "-fail");
        assert_eq!(args("blobtrace diff A B -- -fail")[5], "-fail");
        assert!(idiff_style(["blobtrace", "diff", "-a", "A", "B"].map(OsString::from).to_vec()).is_err());
    }
}
