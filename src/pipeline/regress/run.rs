//! Running the regression: select the manifest's entries, render each, judge
//! it against its reference, and write the report folder (page, failures'
//! images, JUnit file) all or none; or bless the references.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::junit::junit_xml;
use super::manifest::{Entry, Kind, load_manifest};
use super::summary::{RegressRow, RegressSummary};
use crate::compare::{Metric, Thresholds, Verdict, differences, judge, load_image};
use crate::draw::{Scale, heat_map};
use crate::field::EvalMode;
use crate::frame::Frame;
use crate::output::FileSet;
use crate::pipeline::error::{PipelineError, Result};
use crate::pipeline::polygonize::{PolygonizeSettings, polygonize};
use crate::pipeline::render::{render_field, render_mesh};
use crate::progress::{Progress, Silent};
use crate::scene::Scene;

/// Where a regression run reads and writes.
#[derive(Clone, Debug)]
pub struct RegressSettings {
    /// Directory holding the scenes the manifest names.
    pub scenes: PathBuf,
    /// Directory holding `manifest.ron` and the reference PNGs.
    pub refs: PathBuf,
    /// Rewrite every reference from the current renders instead of comparing.
    pub bless: bool,
    /// Directory for actual images, heat maps of failures and index.html.
    pub report: PathBuf,
    /// Only the entries whose reference name contains this.
    pub filter: Option<String>,
    /// Only the entries named exactly so (the reference's file name, with or
    /// without `.png`); each must name an entry.
    pub entries: Vec<String>,
    /// Only shard `i` of `n` (from 1): the entries whose place in the manifest
    /// is `i − 1` modulo `n`, so `n` shards together run every entry once.
    pub shard: Option<(usize, usize)>,
    /// Also write JUnit XML of the results here (its folder is created).
    pub junit: Option<PathBuf>,
    /// Accept a filter or shard that selects no entry (an empty run passes).
    pub allow_empty: bool,
}

impl RegressSettings {
    /// Whether the entry at `place` in the manifest, named `name`, runs.
    fn selects(&self, place: usize, name: &str) -> bool {
        let in_shard = self.shard.is_none_or(|(i, n)| place % n == i - 1);
        let named = self.entries.is_empty() || self.entries.iter().any(|e| names(e, name));
        in_shard && named && self.filter.as_deref().is_none_or(|f| name.contains(f))
    }

    /// Refuses an `--entry` that names no entry of the manifest, listing the names.
    fn check_entries(&self, manifest: &[Entry]) -> Result<()> {
        let all: Vec<String> = manifest.iter().map(Entry::file_name).collect();
        match self.entries.iter().find(|e| !all.iter().any(|name| names(e, name))) {
            Some(e) => {
                let known = all.iter().map(|n| n.trim_end_matches(".png")).collect::<Vec<_>>().join(", ");
                Err(PipelineError::setting("entry", format!("{e}: no entry is named so (entries: {known})")))
            }
            None => Ok(()),
        }
    }

    /// Why selecting no entry of a manifest of `total` fails the run.
    fn nothing_selected(&self, total: usize) -> PipelineError {
        let what = match (&self.filter, self.shard) {
            (Some(f), Some((i, n))) => format!("no entry of shard {i}/{n} matches {f}"),
            (Some(f), None) => format!("no entry matches {f}"),
            (None, Some((i, n))) => format!("shard {i}/{n} holds no entry (the manifest has {total})"),
            (None, None) => "the manifest has no entries".to_string(),
        };
        PipelineError::Unsuitable(format!("{what}; nothing was run (--allow-empty accepts an empty run)"))
    }

    /// Checks the shard before any work.
    fn check(&self) -> Result<()> {
        match self.shard {
            Some((i, n)) if !(1..=n).contains(&i) => {
                Err(PipelineError::setting("shard", format!("must be I/N with 1 <= I <= N, got {i}/{n}")))
            }
            _ => Ok(()),
        }
    }
}

/// Whether `asked` names the entry whose reference is `file`: the file name
/// with or without its `.png`.
fn names(asked: &str, file: &str) -> bool {
    asked == file || file.strip_suffix(".png") == Some(asked)
}

/// Renders every entry of the manifest and compares it with its reference,
/// or blesses them all; `log` hears one line per entry.
pub fn regress(settings: &RegressSettings, progress: &dyn Progress, log: &dyn Fn(&str)) -> Result<RegressSummary> {
    settings.check()?;
    let manifest = load_manifest(&settings.refs, &settings.scenes)?;
    settings.check_entries(&manifest.entries)?;
    let entries: Vec<&Entry> = manifest
        .entries
        .iter()
        .enumerate()
        .filter(|(k, e)| settings.selects(*k, &e.file_name()))
        .map(|(_, e)| e)
        .collect();
    if entries.is_empty() && !settings.allow_empty {
        return Err(settings.nothing_selected(manifest.entries.len()));
    }
    let folders = settings.junit.iter().filter_map(|j| j.parent()).filter(|d| !d.as_os_str().is_empty());
    let report = (!settings.bless).then_some(settings.report.as_path());
    for dir in report.into_iter().chain(folders) {
        std::fs::create_dir_all(dir).map_err(|e| PipelineError::File { path: dir.into(), message: e.to_string() })?;
    }
    let mut summary = RegressSummary { rows: vec![], blessed: vec![] };
    let mut files = FileSet::new();
    let n = entries.len() as u64;
    for (i, entry) in entries.into_iter().enumerate() {
        progress.update("regression entries", i as u64, n);
        let actual = render_entry(&settings.scenes, entry).map_err(|e| e.at(entry.file_name()))?;
        let reference = settings.refs.join(entry.file_name());
        if settings.bless {
            actual.save_png(&reference)?;
            log(&format!("blessed {}", reference.display()));
            summary.blessed.push(reference);
            continue;
        }
        summary.rows.push(check_entry(entry, &actual, &reference, &settings.report, &mut files, log)?);
    }
    progress.update("regression entries", n, n);
    if let Some(path) = &settings.junit {
        files.add(path, junit_xml("blobtrace regress", &summary.rows).into_bytes());
    }
    if settings.bless {
        files.commit()?;
    } else {
        files.add(settings.report.join("index.html"), html(&summary.rows).into_bytes());
        files.commit_replacing(&settings.report, is_failure_image)?;
    }
    Ok(summary)
}

/// Whether a file of the report folder is a failure's image, as
/// [`save_failure`] names them.
fn is_failure_image(name: &str) -> bool {
    let failure = ["ref-", "actual-", "diff-", "heat-"].iter().any(|p| name.starts_with(p));
    failure && name.ends_with(".png")
}

/// The render an entry guards.
pub fn render_entry(scenes: &Path, entry: &Entry) -> Result<Frame> {
    let mut scene = Scene::load(scenes.join(&entry.scene))?;
    scene.model.set_cache_budget(None);
    let mode = if entry.cached { EvalMode::Cached } else { EvalMode::Indexed };
    Ok(match entry.kind {
        Kind::Field => render_field(&scene, (entry.size, 1), mode, &Silent).0,
        Kind::Mesh(res) => {
            let settings = PolygonizeSettings { res, ..Default::default() };
            let (mesh, report) = polygonize(&scene.model, mode, &settings, &Silent)?;
            render_mesh(&scene, &mesh, report, (entry.size, 1), &Silent).0
        }
    })
}

fn check_entry(
    entry: &Entry,
    actual: &Frame,
    reference: &Path,
    report: &Path,
    files: &mut FileSet,
    log: &dyn Fn(&str),
) -> Result<RegressRow> {
    let name = entry.file_name();
    let Ok(expected) = load_image(reference) else {
        let path = report.join(format!("actual-{name}"));
        files.add(&path, actual.png_bytes_for(&path)?);
        log(&format!("FAIL {name}: no readable reference at {} (bless to create it)", reference.display()));
        return Ok((name, None));
    };
    let frame = &expected.frame;
    if (frame.width, frame.height) != (actual.width, actual.height) {
        return Err(PipelineError::File {
            path: reference.to_path_buf(),
            message: format!(
                "reference is {}x{}, the render {}x{}",
                frame.width, frame.height, actual.width, actual.height
            ),
        });
    }
    // Compare what the files hold: the render quantized to 8 bits like its reference.
    let quantized = quantize(actual);
    let values = differences(&quantized, frame, Metric::Abs);
    let thresholds = Thresholds {
        fail: entry.fail,
        failpercent: entry.failpercent,
        hardfail: entry.hardfail,
        warn: entry.fail,
        warnpercent: entry.failpercent,
        ..Thresholds::default()
    };
    let diff = judge(Metric::Abs, &values, &vec![false; values.len()], frame.width, thresholds);
    if diff.verdict == Verdict::Fail {
        save_failure(&name, reference, (actual, &quantized), &values, report, files)?;
    }
    log(&format!("{:?} {name}: max {:.4}, {} pixels above {}", diff.verdict, diff.max, diff.over_fail_px, entry.fail));
    Ok((name, Some(diff)))
}

/// The images of a failed entry, added to the report's files: its reference,
/// the render, the brightened difference and a heat map (titled by metric
/// alone: the page names the entry).
fn save_failure(
    name: &str,
    reference: &Path,
    (actual, quantized): (&Frame, &Frame),
    values: &[f32],
    report: &Path,
    files: &mut FileSet,
) -> Result<()> {
    let unreadable = |message: String| PipelineError::File { path: reference.to_path_buf(), message };
    let expected = load_image(reference).map_err(unreadable)?.frame;
    files.add(report.join(format!("ref-{name}")), std::fs::read(reference).map_err(|e| unreadable(e.to_string()))?);
    let path = report.join(format!("actual-{name}"));
    files.add(&path, actual.png_bytes_for(&path)?);
    let path = report.join(format!("diff-{name}"));
    files.add(&path, difference_image(quantized, &expected).png_bytes_for(&path)?);
    let path = report.join(format!("heat-{name}"));
    let scale = Scale::Magnitude { max: 0.1 };
    let heat = heat_map(values, expected.width, expected.height, scale, "abs difference", "");
    files.add(&path, heat.png_bytes_for(&path)?);
    Ok(())
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

/// The report's page: one row per entry, with a failure's images.
fn html(rows: &[RegressRow]) -> String {
    let mut html = String::from(
        "<!doctype html><meta charset=utf-8><title>blobtrace regression</title>\
         <style>body{font-family:sans-serif}td,th{padding:4px 8px}.Fail{color:#b00}.Pass{color:#070}</style>\
         <h1>blobtrace regression</h1><table><tr><th>reference<th>verdict<th>max<th>pixels above<th>reference | actual | difference ×8 | heat map</tr>",
    );
    for (name, diff) in rows {
        let (verdict, max, over) = match diff {
            Some(d) => (format!("{:?}", d.verdict), format!("{:.4}", d.max), d.over_fail_px.to_string()),
            None => ("Fail".into(), "no reference".into(), "-".into()),
        };
        let images = if diff.is_none() {
            format!("<img src=\"actual-{name}\" title=\"actual\">")
        } else if verdict == "Fail" {
            ["ref", "actual", "diff", "heat"]
                .map(|kind| format!("<img src=\"{kind}-{name}\" title=\"{kind}\">"))
                .join(" ")
        } else {
            String::new()
        };
        let _ = write!(html, "<tr><td>{name}<td class={verdict}>{verdict}<td>{max}<td>{over}<td>{images}</tr>");
    }
    html.push_str("</table>\n");
    html
}
