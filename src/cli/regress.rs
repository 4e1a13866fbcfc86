//! `blobtrace regress`: render every entry of a reference manifest, compare
//! each with its stored reference image under the entry's tolerances (the
//! `diff` rules), report failures with images and one HTML page, and exit
//! non-zero on any failure; `--bless` rewrites the references.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Args;
use serde::Deserialize;

use super::mesh::{CellsArg, PolygonizeArgs, VertexArg, polygonize_scene};
use super::render::{render_polygonized, render_scene};
use crate::compare::{DiffReport, Metric, Scale, Thresholds, Verdict, differences, heat_map, judge, load_image};
use crate::field::EvalMode;
use crate::frame::Frame;
use crate::scene::{Scene, Size, values};

/// Options of `blobtrace regress`.
#[derive(Debug, Args)]
pub struct RegressArgs {
    /// Directory holding the scenes the manifest names.
    #[arg(long, default_value = "scenes")]
    pub scenes: PathBuf,
    /// Directory holding `manifest.ron` and the reference PNGs.
    #[arg(long, default_value = "images/ref")]
    pub refs: PathBuf,
    /// Rewrite every reference from the current renders instead of comparing.
    #[arg(long)]
    pub bless: bool,
    /// Directory for actual images, heat maps of failures and index.html.
    #[arg(long, default_value = "regress-report")]
    pub report: PathBuf,
}

/// The manifest: which renders are guarded, and how strictly.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// The guarded renders.
    pub entries: Vec<Entry>,
}

/// One guarded render.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Entry {
    /// Scene file name in the scenes directory.
    pub scene: String,
    /// Image size.
    pub size: Size,
    /// Field trace (`Field`) or mesh ray cast (`Mesh(res)`).
    pub kind: Kind,
    /// Evaluate through the caches (default: exact, indexed).
    #[serde(default)]
    pub cached: bool,
    /// A pixel differing by more than this (largest linear RGB difference) fails…
    #[serde(default = "default_fail", deserialize_with = "values::non_negative")]
    pub fail: f32,
    /// …when more than this percentage of pixels do.
    #[serde(default, deserialize_with = "values::percentage")]
    pub failpercent: f64,
    /// Any pixel above this fails.
    #[serde(default = "default_hardfail", deserialize_with = "values::non_negative")]
    pub hardfail: f32,
}

/// What an entry renders.
#[derive(Clone, Copy, Debug, Deserialize)]
pub enum Kind {
    /// The field ray trace.
    Field,
    /// The mesh polygonized at this resolution, ray cast.
    Mesh(u32),
}

fn default_fail() -> f32 {
    // Two 8-bit steps near mid-grey: tolerant of last-bit float differences across machines.
    0.01
}

fn default_hardfail() -> f32 {
    0.25
}

impl Entry {
    /// The reference file name: scene stem, kind, size.
    #[must_use]
    pub fn file_name(&self) -> String {
        let stem = self.scene.trim_end_matches(".ron");
        let kind = match self.kind {
            Kind::Field => "field".to_string(),
            Kind::Mesh(res) => format!("mesh{res}"),
        };
        let mode = if self.cached { "-cached" } else { "" };
        format!("{stem}-{kind}{mode}-{}x{}.png", self.size.0, self.size.1)
    }
}

/// Runs `blobtrace regress`.
pub fn run(a: &RegressArgs) -> anyhow::Result<()> {
    let manifest_path = a.refs.join("manifest.ron");
    let text =
        std::fs::read_to_string(&manifest_path).with_context(|| format!("reading {}", manifest_path.display()))?;
    let manifest: Manifest = ron::from_str(&text).map_err(|e| {
        anyhow::anyhow!("{}:{}:{}: {}", manifest_path.display(), e.span.start.line, e.span.start.col, e.code)
    })?;
    if !a.bless {
        std::fs::create_dir_all(&a.report).with_context(|| format!("creating {}", a.report.display()))?;
    }
    let mut rows = vec![];
    for entry in &manifest.entries {
        let actual = render_entry(&a.scenes, entry)?;
        let reference = a.refs.join(entry.file_name());
        if a.bless {
            actual.save_png(&reference)?;
            eprintln!("blessed {}", reference.display());
            continue;
        }
        rows.push(check_entry(entry, &actual, &reference, &a.report)?);
    }
    if a.bless {
        return Ok(());
    }
    write_html(&a.report.join("index.html"), &rows)?;
    let failed = rows.iter().filter(|r| r.1.as_ref().is_none_or(|d| d.verdict == Verdict::Fail)).count();
    eprintln!("{} of {} references pass; report in {}", rows.len() - failed, rows.len(), a.report.display());
    anyhow::ensure!(failed == 0, "{failed} of {} references failed", rows.len());
    Ok(())
}

fn render_entry(scenes: &Path, entry: &Entry) -> anyhow::Result<Frame> {
    let mut scene = Scene::load(scenes.join(&entry.scene))?;
    scene.model.set_cache_budget(None);
    let mode = if entry.cached { EvalMode::Cached } else { EvalMode::Indexed };
    let size = entry.size;
    Ok(match entry.kind {
        Kind::Field => render_scene(&scene, size, mode).0,
        Kind::Mesh(res) => {
            let args = PolygonizeArgs { res, cells: CellsArg::Cubes, vertex: VertexArg::Root, refine: 0 };
            args.check(&scene)?;
            let (mesh, report) = polygonize_scene(&scene, mode, &args);
            render_polygonized(&scene, &mesh, report, size).0
        }
    })
}

/// One report row: the entry's reference name and its judgement (`None`: no reference).
type Row = (String, Option<DiffReport>);

fn check_entry(entry: &Entry, actual: &Frame, reference: &Path, report: &Path) -> anyhow::Result<Row> {
    let name = entry.file_name();
    let Ok(expected) = load_image(reference) else {
        actual.save_png(&report.join(format!("actual-{name}")))?;
        eprintln!("FAIL {name}: no readable reference at {} (bless to create it)", reference.display());
        return Ok((name, None));
    };
    let frame = &expected.frame;
    anyhow::ensure!(
        (frame.width, frame.height) == (actual.width, actual.height),
        "{}: reference is {}x{}, the render {}x{}",
        reference.display(),
        frame.width,
        frame.height,
        actual.width,
        actual.height
    );
    // Compare what the files hold: the render quantized to 8 bits like its reference.
    let quantized = quantize(actual);
    let values = differences(&quantized, frame, Metric::Abs);
    let thresholds = Thresholds {
        fail: entry.fail,
        failpercent: entry.failpercent,
        hardfail: entry.hardfail,
        warn: entry.fail,
        warnpercent: entry.failpercent,
    };
    let diff = judge(Metric::Abs, &values, &vec![false; values.len()], thresholds);
    if diff.verdict == Verdict::Fail {
        actual.save_png(&report.join(format!("actual-{name}")))?;
        difference_image(&quantized, frame).save_png(&report.join(format!("diff-{name}")))?;
        let title = format!("abs difference, {name}");
        heat_map(&values, frame.width, frame.height, Scale::Magnitude { max: 0.1 }, &title, "")
            .save_png(&report.join(format!("heat-{name}")))?;
    }
    eprintln!("{:?} {name}: max {:.4}, {} pixels above {}", diff.verdict, diff.max, diff.over_fail_px, entry.fail);
    Ok((name, Some(diff)))
}

/// |actual − expected| per channel, brightened eightfold so small differences show.
fn difference_image(actual: &Frame, expected: &Frame) -> Frame {
    let mut d = actual.clone();
    for (c, e) in d.color.iter_mut().zip(&expected.color) {
        *c = ((*c - *e).abs() * 8.0).min(glam::Vec3::ONE);
    }
    d
}

/// The frame as a PNG of it would read back.
fn quantize(frame: &Frame) -> Frame {
    let mut q = frame.clone();
    for c in &mut q.color {
        *c = glam::Vec3::from(c.to_array().map(|v| crate::frame::srgb8_to_linear(crate::frame::linear_to_srgb8(v))));
    }
    q
}

fn write_html(path: &Path, rows: &[Row]) -> anyhow::Result<()> {
    let mut html = String::from(
        "<!doctype html><meta charset=utf-8><title>blobtrace regression</title>\
         <style>body{font-family:sans-serif}td,th{padding:4px 8px}.Fail{color:#b00}.Pass{color:#070}</style>\
         <h1>blobtrace regression</h1><table><tr><th>reference<th>verdict<th>max<th>pixels above<th>images</tr>",
    );
    for (name, diff) in rows {
        let (verdict, max, over) = match diff {
            Some(d) => (format!("{:?}", d.verdict), format!("{:.4}", d.max), d.over_fail_px.to_string()),
            None => ("Fail".into(), "no reference".into(), "-".into()),
        };
        let images = if verdict == "Fail" {
            format!("<img src=\"actual-{name}\"> <img src=\"diff-{name}\"> <img src=\"heat-{name}\">")
        } else {
            String::new()
        };
        let _ = write!(html, "<tr><td>{name}<td class={verdict}>{verdict}<td>{max}<td>{over}<td>{images}</tr>");
    }
    html.push_str("</table>\n");
    crate::output::write_atomic(path, html.as_bytes()).with_context(|| format!("writing {}", path.display()))
}
