//! Running the regression: select the manifest's entries, render each, judge
//! it against its reference, and write the report folder (page, summary,
//! images of the entries that differ, JUnit file) all or none; or bless the
//! references.

use std::path::{Path, PathBuf};
use std::time::Instant;

use super::command_line::{repository_commit, shell_quote};
use super::entry_check::{EntryFacts, check_entry, is_entry_image};
use super::junit::junit_xml;
use super::manifest::{Entry, Kind, load_manifest};
use super::page::report_page;
use super::summary::{RegressRow, RegressSummary, RunFacts};
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
    /// Rewrite the selected references (every one, or those `--entry`,
    /// `--filter` or `--shard` select) from the current renders instead of comparing.
    pub bless: bool,
    /// Directory for the report: its page, `summary.json` and the images of
    /// the entries that differ.
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
    /// The command line that runs this (the program first), for the report
    /// and the commands it gives for blessing; empty when not run from one.
    pub command: Vec<String>,
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
    let started = Instant::now();
    let date = humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string();
    settings.check()?;
    let manifest = load_manifest(&settings.refs, &settings.scenes)?;
    settings.check_entries(&manifest.entries)?;
    let entries: Vec<(usize, &Entry)> =
        manifest.entries.iter().enumerate().filter(|(k, e)| settings.selects(*k, &e.file_name())).collect();
    if entries.is_empty() && !settings.allow_empty {
        return Err(settings.nothing_selected(manifest.entries.len()));
    }
    let folders = settings.junit.iter().filter_map(|j| j.parent()).filter(|d| !d.as_os_str().is_empty());
    let report = (!settings.bless).then_some(settings.report.as_path());
    for dir in report.into_iter().chain(folders) {
        create_folder(dir)?;
    }
    let mut rows = vec![];
    let mut blessed = vec![];
    let mut files = FileSet::new();
    let n = entries.len() as u64;
    for (i, &(place, entry)) in entries.iter().enumerate() {
        progress.update("regression entries", i as u64, n);
        let rendering = Instant::now();
        let actual = render_entry(&settings.scenes, entry).map_err(|e| e.at(entry.file_name()))?;
        let seconds = rendering.elapsed().as_secs_f64();
        let reference = settings.refs.join(entry.file_name());
        if settings.bless {
            if let Some(dir) = reference.parent() {
                create_folder(dir)?;
            }
            files.add(&reference, actual.png_bytes_for(&reference)?);
            blessed.push(reference);
            continue;
        }
        let facts = EntryFacts { place, entry, seconds, bless: bless_command(settings, entry) };
        let row = check_entry(&facts, &actual, &reference, &settings.report, &mut files)?;
        log(&row_line(&row));
        rows.push(row);
    }
    progress.update("regression entries", n, n);
    let run = run_facts(settings, date, started);
    let mut summary = RegressSummary::new(run, rows, manifest.entries.len() - entries.len());
    if let Some(path) = &settings.junit {
        files.add(path, junit_xml("blobtrace regress", &summary.entries).into_bytes());
    }
    if settings.bless {
        // Every reference at once: a render that fails blesses none.
        files.commit()?;
        blessed.iter().for_each(|r| log(&format!("blessed {}", r.display())));
        summary.blessed = blessed;
    } else {
        files.add(settings.report.join("index.html"), report_page(&summary).into_bytes());
        files.add(settings.report.join("summary.json"), summary.json().into_bytes());
        files.commit_replacing(&settings.report, is_entry_image)?;
    }
    Ok(summary)
}

/// The run's own facts, for the report: `date` when it started, `started` to time it.
fn run_facts(settings: &RegressSettings, date: String, started: Instant) -> RunFacts {
    RunFacts {
        command: settings.command.iter().map(|a| shell_quote(a)).collect::<Vec<_>>().join(" "),
        scenes: settings.scenes.display().to_string(),
        refs: settings.refs.display().to_string(),
        scenes_commit: repository_commit(&settings.scenes),
        version: env!("CARGO_PKG_VERSION").to_string(),
        date,
        simd_width: crate::field::sum_lanes(),
        seconds: started.elapsed().as_secs_f64(),
    }
}

fn create_folder(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| PipelineError::File { path: dir.into(), message: e.to_string() })
}

/// The log line of a judged entry.
fn row_line(row: &RegressRow) -> String {
    match &row.judgement {
        None => format!("FAIL {}: no readable reference (bless to create it)", row.name),
        Some(j) => {
            format!(
                "{:?} {}: max {:.4}, {} pixels above {}",
                j.verdict, row.name, j.max, j.over_fail_px, row.tolerances.fail
            )
        }
    }
}

/// The command that blesses `entry` alone, with this run's folders.
fn bless_command(settings: &RegressSettings, entry: &Entry) -> String {
    let program = settings.command.first().map_or("blobtrace", String::as_str);
    let (scenes, refs) = (settings.scenes.display().to_string(), settings.refs.display().to_string());
    let name = entry.name();
    [program, "regress", "--scenes", &scenes, "--refs", &refs, "--bless", "--entry", &name].map(shell_quote).join(" ")
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
