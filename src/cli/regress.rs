//! `blobtrace regress`: render every entry of a reference manifest, compare
//! each with its stored reference under the entry's tolerances (the `diff`
//! rules), report failures with images and one HTML page, and exit non-zero
//! on any failure; `--bless` rewrites the references.

use std::path::PathBuf;

use clap::Args;

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
    /// Rewrite every reference from the current renders instead of comparing.
    #[arg(long)]
    pub bless: bool,
    /// Directory for actual images, heat maps of failures and index.html.
    #[arg(long, default_value = "regress-report")]
    pub report: PathBuf,
}

/// Runs `blobtrace regress`.
pub fn run(a: &RegressArgs) -> anyhow::Result<()> {
    let settings =
        RegressSettings { scenes: a.scenes.clone(), refs: a.refs.clone(), bless: a.bless, report: a.report.clone() };
    let bars = Bars::new();
    let log = |line: &str| bars.suspend(|| eprintln!("{line}"));
    let summary = regress(&settings, &bars, &log)?;
    bars.finish();
    if a.bless {
        return Ok(());
    }
    let (failed, n) = (summary.failed(), summary.rows.len());
    eprintln!("{} of {n} references pass; report in {}", n - failed, a.report.display());
    anyhow::ensure!(failed == 0, "{failed} of {n} references failed");
    Ok(())
}
