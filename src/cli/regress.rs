//! `blobtrace regress`: render every entry of a reference manifest, compare
//! each with its stored reference under the entry's tolerances (the `diff`
//! rules), report failures with images and one HTML page, and exit non-zero
//! on any failure (and when `--filter` or `--shard` selects no entry, unless
//! `--allow-empty`); `--bless` rewrites the references.

use std::path::PathBuf;

use clap::Args;

use super::args::{check_output_name, with_threads};
use super::progress::Bars;
use crate::pipeline::{RegressSettings, regress};

/// Options of `blobtrace regress`.
#[derive(Debug, Args)]
pub struct RegressArgs {
    /// Directory holding the scenes the manifest names.
    #[arg(long, default_value = "scenes")]
    pub scenes: PathBuf,
    /// Directory holding `manifest.ron` and the reference PNGs.
    #[arg(long, default_value = "images/ref")]
    pub refs: PathBuf,
    /// Rewrite the selected references (every one, or those `--entry`,
    /// `--filter` or `--shard` select) from the current renders instead of comparing.
    #[arg(long)]
    pub bless: bool,
    /// Directory for the report: index.html (open it in a browser),
    /// summary.json and the images of entries that differ (created if
    /// missing; what an earlier run left there is replaced).
    #[arg(long, default_value = "regress-report")]
    pub report: PathBuf,
    /// Only the entries whose reference name contains PATTERN (none matching fails).
    #[arg(long, value_name = "PATTERN")]
    pub filter: Option<String>,
    /// Only the entry named NAME exactly (its reference file's name, with or
    /// without .png, e.g. pair-field-96x72); repeatable; a name no entry has fails.
    #[arg(long = "entry", value_name = "NAME")]
    pub entries: Vec<String>,
    /// Only shard I of N (e.g. 2/3): N shards, one per CI job, run every entry once.
    #[arg(long, value_name = "I/N", value_parser = parse_shard)]
    pub shard: Option<(usize, usize)>,
    /// Pass when --filter or --shard selects no entry (a shard of a short
    /// manifest, say); without it such a run fails, so a typo cannot pass CI.
    #[arg(long)]
    pub allow_empty: bool,
    /// Also write JUnit XML of the results (one test case per entry) here;
    /// missing folders are created.
    #[arg(long, value_name = "FILE")]
    pub junit: Option<PathBuf>,
    /// Worker threads (default: all cores). The renders are identical for any count.
    #[arg(long)]
    pub threads: Option<usize>,
}

/// Parses `I/N`.
fn parse_shard(s: &str) -> Result<(usize, usize), String> {
    let parse = |v: &str| v.trim().parse::<usize>().ok();
    match s.split_once('/').and_then(|(i, n)| Some((parse(i)?, parse(n)?))) {
        Some((i, n)) if (1..=n).contains(&i) => Ok((i, n)),
        _ => Err(format!("expected I/N with 1 <= I <= N, such as 2/3, got {s:?}")),
    }
}

/// Runs `blobtrace regress`.
pub fn run(a: &RegressArgs) -> anyhow::Result<()> {
    if let Some(junit) = &a.junit {
        check_output_name(junit, "xml")?;
    }
    let settings = RegressSettings {
        scenes: a.scenes.clone(),
        refs: a.refs.clone(),
        bless: a.bless,
        report: a.report.clone(),
        filter: a.filter.clone(),
        entries: a.entries.clone(),
        shard: a.shard,
        junit: a.junit.clone(),
        allow_empty: a.allow_empty,
        command: std::env::args().collect(),
    };
    let bars = Bars::new();
    let log = |line: &str| bars.suspend(|| eprintln!("{line}"));
    let summary = with_threads(a.threads, || regress(&settings, &bars, &log))??;
    bars.finish();
    if a.bless {
        return Ok(());
    }
    let (failed, n) = (summary.failed(), summary.entries.len());
    let warned =
        if summary.counts.warned > 0 { format!(" ({} with warnings)", summary.counts.warned) } else { String::new() };
    eprintln!("{} of {n} references pass{warned}; report: {}", n - failed, a.report.join("index.html").display());
    anyhow::ensure!(failed == 0, "{failed} of {n} references failed");
    Ok(())
}
