//! `blobtrace tune`: caches that place and size themselves from error_C
//! sampled at mesh vertices; writes the tuned scene, a table per cache, and
//! error_C slices before and after.

use std::path::{Path, PathBuf};

use super::args::{check_output_file, with_threads};
use super::exit::UsageError;
use super::progress::Bars;
use crate::output::FileSet;
use crate::pipeline::{MB, TuneReport, TuneSettings, Tuned, error_slices, tune};
use crate::scene::{Scene, parse_desc};
use anyhow::Context;
use clap::Args;

/// Options of `blobtrace tune`.
#[derive(Debug, Args)]
pub struct TuneArgs {
    /// Scene file (RON).
    pub scene: PathBuf,
    /// Tolerance E on error_C = |f_C − f| at mesh vertices, in field units
    /// (the iso-value is T): the 99th percentile must stay within E and every
    /// vertex within 4E.
    #[arg(long, allow_hyphen_values = true)]
    pub tolerance: f32,
    /// Most megabytes of samples the caches may touch in a render and a
    /// polygonization (default: no limit).
    #[arg(long, allow_hyphen_values = true)]
    pub budget: Option<f64>,
    /// Write the tuned scene here (RON). Without it, tune only reports.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Write the tuned scene even where E or the budget could not be met.
    #[arg(long)]
    pub write_anyway: bool,
    /// Folder for error_C slices of each changed cache, before and after on
    /// one scale (4E), and report.json.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Resolution of the exact polygonization whose vertices are sampled.
    #[arg(long, default_value_t = 128)]
    pub res: u32,
    /// Most rounds of measuring and changing.
    #[arg(long, default_value_t = 6)]
    pub rounds: u32,
    /// Print the report as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// Runs `blobtrace tune`.
pub fn run(a: &TuneArgs) -> anyhow::Result<()> {
    let settings = a.settings();
    settings.check()?;
    if a.rounds == 0 {
        return Err(UsageError("--rounds must be at least 1".into()).into());
    }
    if let Some(out) = &a.output {
        check_output_file(out, "ron")?;
    }
    if let Some(dir) = &a.report {
        anyhow::ensure!(!dir.is_file(), "{}: is a file, not a folder for the report", dir.display());
    }
    let label = a.scene.display().to_string();
    let text = std::fs::read_to_string(&a.scene).with_context(|| format!("reading {label}"))?;
    Scene::parse(&text, &label)?;
    let desc = parse_desc(&text, &label)?;
    let bars = Bars::new();
    let tuned = with_threads(a.threads, || tune(&desc, &settings, &bars))??;
    bars.finish();
    if a.json {
        println!("{}", serde_json::to_string_pretty(&tuned.report)?);
    } else {
        print_table(&tuned.report);
    }
    let write_scene = tuned.report.met || a.write_anyway;
    let mut files = FileSet::new();
    if let Some(out) = a.output.as_ref().filter(|_| write_scene) {
        files.add(out, tuned.desc.to_ron(&header(&label, &tuned.report))?.into_bytes());
    }
    if let Some(dir) = &a.report {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        add_report(&mut files, dir, &desc, &tuned)?;
    }
    files.commit()?;
    if !tuned.report.met {
        let kept = if a.output.is_some() && !write_scene {
            " (the scene was not written: --write-anyway writes it)"
        } else {
            ""
        };
        anyhow::bail!("the tolerance could not be met: {}{kept}", tuned.report.unmet.join("; "));
    }
    Ok(())
}

impl TuneArgs {
    fn settings(&self) -> TuneSettings {
        TuneSettings { tolerance: self.tolerance, budget_mb: self.budget, mesh_res: self.res, max_rounds: self.rounds }
    }
}

/// The comment lines the tuned scene opens with.
fn header(label: &str, r: &TuneReport) -> Vec<String> {
    let budget = r.budget_mb.map_or("no budget".to_string(), |b| format!("a budget of {b} MB"));
    let mut lines = vec![format!("Tuned by `blobtrace tune` from {label}, E = {:e}, {budget}:", r.tolerance)];
    for row in &r.rows {
        let res = |v: Option<u32>| v.map_or("-".to_string(), |r| r.to_string());
        lines.push(format!("  {}: res {} -> {}, {}", row.cache, res(row.res_before), res(row.res_after), row.decision));
    }
    lines
}

fn add_report(
    files: &mut FileSet,
    dir: &Path,
    original: &crate::scene::SceneDesc,
    tuned: &Tuned,
) -> anyhow::Result<()> {
    let slices = error_slices((original, &tuned.original_labels), (&tuned.desc, &tuned.labels), &tuned.report, 400)?;
    for (stem, image) in slices {
        files.add(dir.join(format!("{stem}.png")), image.png_bytes()?);
    }
    files.add(dir.join("report.json"), serde_json::to_string_pretty(&tuned.report)?.into_bytes());
    Ok(())
}

fn print_table(r: &TuneReport) {
    let budget = r.budget_mb.map_or(String::new(), |b| format!(", budget {b} MB"));
    println!("tune: E = {:e}{budget}, {} rounds", r.tolerance, r.rounds);
    println!(
        "  {:<14} {:>5} {:>5} {:>9} {:>9} {:>9} {:>9} {:>7} {:>8} {:>8} {:>6}  decision: reason",
        "cache", "res", "→res", "p99 was", "p99", "mean", "max", "angle°", "MB was", "MB", "cost"
    );
    let res = |v: Option<u32>| v.map_or("-".to_string(), |r| r.to_string());
    let num = |v: Option<f32>| v.map_or("-".to_string(), |e| format!("{e:.2e}"));
    for row in &r.rows {
        let after = row.after.as_ref();
        println!(
            "  {:<14} {:>5} {:>5} {:>9} {:>9} {:>9} {:>9} {:>7} {:>8.2} {:>8.2} {:>5.1}×  {}: {}",
            row.cache,
            res(row.res_before),
            res(row.res_after),
            num(row.before.map(|e| e.p99)),
            num(after.map(|e| e.p99)),
            num(after.map(|e| e.mean as f32)),
            num(after.map(|e| e.max)),
            after.map_or("-".to_string(), |e| format!("{:.1}", e.angle_p99_deg)),
            row.bytes_before as f64 / MB,
            row.bytes_after as f64 / MB,
            row.cost_ratio,
            row.decision,
            row.reason
        );
    }
    println!(
        "  samples touched: {:.2} MB before, {:.2} MB after",
        r.bytes_before as f64 / MB,
        r.bytes_after as f64 / MB
    );
    for u in &r.unmet {
        println!("  not met: {u}");
    }
}
