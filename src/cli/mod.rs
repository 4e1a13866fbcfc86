//! The command line: argument parsing (clap) and one function per subcommand.
//! The binary only calls [`main_with_args`].

mod bench;
mod info;
mod progress;
mod render;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand, ValueEnum};

use crate::field::EvalMode;
use crate::scene::Size;

/// blobtrace: ray-trace skeletal implicit models (BlobTrees) on the CPU.
#[derive(Debug, Parser)]
#[command(name = "blobtrace", version, about, long_about = None)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a scene by tracing rays through its field; write a PNG (and an EXR of all AOVs).
    Render(render::RenderArgs),
    /// Print what a scene holds: node, primitive and cache counts, names, bounds.
    Info(info::InfoArgs),
    /// Measure performance figures in one process, as ratios against a baseline.
    #[command(subcommand)]
    Bench(bench::BenchCommand),
}

/// How exact evaluation finds the primitives near a point.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum EvalArg {
    /// Spatial index over wide blends: touch only supports containing the point.
    #[default]
    Indexed,
    /// Plain tree traversal with per-node box rejection (the paper's baseline).
    Naive,
}

impl From<EvalArg> for EvalMode {
    fn from(a: EvalArg) -> Self {
        match a {
            EvalArg::Indexed => EvalMode::Indexed,
            EvalArg::Naive => EvalMode::Naive,
        }
    }
}

fn parse_size(s: &str) -> Result<Size, String> {
    Size::parse(s)
}

/// Parses `args` and runs the command; returns the process exit code.
pub fn main_with_args(args: impl IntoIterator<Item = std::ffi::OsString>) -> ExitCode {
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() { ExitCode::from(2) } else { ExitCode::SUCCESS };
        }
    };
    let result = match cli.command {
        Command::Render(a) => render::run(&a),
        Command::Info(a) => info::run(&a),
        Command::Bench(b) => bench::run(&b),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Runs `f` on a rayon pool of `threads` threads (all cores when `None`).
fn with_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> anyhow::Result<T> {
    match threads {
        None => Ok(f()),
        Some(0) => anyhow::bail!("--threads must be at least 1"),
        Some(n) => {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(n).build()?;
            Ok(pool.install(f))
        }
    }
}

/// The file stem of a scene path, for default output names.
fn scene_stem(path: &std::path::Path) -> String {
    path.file_stem().map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned())
}

/// Checks before any work that an output file's directory exists.
fn check_output_dir(path: &std::path::Path) -> anyhow::Result<()> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).map_or_else(|| PathBuf::from("."), PathBuf::from);
    anyhow::ensure!(dir.is_dir(), "{}: the output directory {} does not exist", path.display(), dir.display());
    Ok(())
}
