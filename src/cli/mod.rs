//! The command line: argument parsing (clap) and one function per subcommand.
//! The binary only calls [`main_with_args`].

mod bench;
mod bench_edit;
mod bench_mesh;
mod compare;
mod diff;
mod edit;
mod info;
mod mesh;
mod progress;
mod regress;
mod render;
mod slice;
mod view;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand, ValueEnum};

use crate::cache::SLOT_BYTES;
use crate::cache::pool::MIN_BUDGET_SLOTS;
use crate::field::{EvalMode, Model};
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
    /// Polygonize a scene's surface and write it as PLY, OBJ or STL.
    Mesh(mesh::MeshArgs),
    /// Render a scene by tracing its field and by ray casting its polygonized
    /// surface, and show where they disagree: renders, heat maps, a panel, stats.
    Compare(compare::CompareArgs),
    /// Images of the field on a plane: f, the sharp view, error_C and gradient
    /// error of the caches per filter and resolution.
    Slice(slice::SliceArgs),
    /// Replay an edit script, updating only what each edit changed (dirty
    /// rectangles, local mesh cells, BVH2 triangles); time it, optionally verify it.
    Edit(edit::EditArgs),
    /// Render every entry of images/ref/manifest.ron and compare it with its
    /// reference (--bless rewrites them); exits non-zero on any failure.
    Regress(regress::RegressArgs),
    /// Compare two images (PNG or EXR) like idiff: exit 0 pass, 1 warn, 2 fail,
    /// 3 size mismatch, 4 file error; optionally write a heat map.
    Diff(diff::DiffArgs),
    /// Print what a scene holds: node, primitive and cache counts, names, bounds.
    Info(info::InfoArgs),
    /// Preview a scene in a window: arrow keys move its named nodes along the
    /// screen (Space steps an edit script), each move updating only what it
    /// changed; V switches between the field render, the mesh render and their
    /// depth difference, R outlines the dirty rectangles, P snapshots, A/D/W/S orbit, Z/X
    /// zoom. --headless takes the keys from --keys and writes the last view.
    View(view::ViewArgs),
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

/// Which field to show: the true one, or the one the scene's caches reconstruct.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ModeArg {
    /// Exact evaluation of every node (caches pass through).
    Exact,
    /// Cache nodes answer from their lattices (lazily filled with exact samples).
    Cached,
}

/// How a command evaluates the field: shared by every command that traces or samples it.
#[derive(Clone, Copy, Debug, Args)]
pub struct EvalOptions {
    /// exact or cached (default: cached when the scene has Cache nodes and --eval is not naive).
    #[arg(long, value_enum)]
    pub mode: Option<ModeArg>,
    /// How exact evaluation finds nearby primitives (naive only with --mode exact).
    #[arg(long, value_enum, default_value_t = EvalArg::Indexed)]
    pub eval: EvalArg,
    /// Cap the caches' sample storage at this many megabytes (least-recently-used
    /// blocks are evicted and re-evaluated on demand; the image does not change).
    #[arg(long, value_name = "MB")]
    pub cache_budget: Option<f64>,
}

impl EvalOptions {
    /// The evaluation mode for `model`; applies the cache budget to it.
    pub fn apply(&self, model: &mut Model) -> anyhow::Result<EvalMode> {
        // Asking for the naive baseline asks for exact evaluation.
        let cached_by_default = model.counts().caches > 0 && self.eval != EvalArg::Naive;
        let mode = self.mode.unwrap_or(if cached_by_default { ModeArg::Cached } else { ModeArg::Exact });
        if let Some(mb) = self.cache_budget {
            let min_mb = (MIN_BUDGET_SLOTS * SLOT_BYTES) as f64 / MB;
            anyhow::ensure!(mb.is_finite() && mb >= min_mb, "--cache-budget must be at least {min_mb} MB, got {mb}");
            model.set_cache_budget(Some((mb * MB) as usize));
        }
        match (mode, self.eval) {
            (ModeArg::Exact, eval) => Ok(eval.into()),
            (ModeArg::Cached, EvalArg::Indexed) => Ok(EvalMode::Cached),
            (ModeArg::Cached, EvalArg::Naive) => {
                anyhow::bail!("--eval naive applies to exact evaluation; add --mode exact")
            }
        }
    }
}

/// Bytes per megabyte, as `--cache-budget` counts them.
const MB: f64 = 1024.0 * 1024.0;

fn parse_size(s: &str) -> Result<Size, String> {
    Size::parse(s)
}

/// Parses `args` and runs the command; returns the process exit code.
pub fn main_with_args(args: impl IntoIterator<Item = std::ffi::OsString>) -> ExitCode {
    let args: Vec<std::ffi::OsString> = args.into_iter().collect();
    let cli = match Cli::try_parse_from(&args) {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            // `diff` keeps idiff's codes, where 2 means "images differ": bad options are 4 there.
            let usage_error = if args.get(1).is_some_and(|a| a == "diff") { diff::FILE_ERROR } else { 2 };
            return if e.use_stderr() { ExitCode::from(usage_error) } else { ExitCode::SUCCESS };
        }
    };
    let result = match cli.command {
        Command::Diff(a) => return diff::run(&a),
        Command::Render(a) => render::run(&a),
        Command::Compare(a) => compare::run(&a),
        Command::Slice(a) => slice::run(&a),
        Command::Regress(a) => regress::run(&a),
        Command::Edit(a) => edit::run(&a),
        Command::Mesh(a) => mesh::run(&a),
        Command::Info(a) => info::run(&a),
        Command::View(a) => view::run(&a),
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

/// Most worker threads `--threads` may ask for.
const MAX_THREADS: usize = 1024;

/// Runs `f` on a rayon pool of `threads` threads (all cores when `None`).
fn with_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> anyhow::Result<T> {
    Ok(worker_pool(threads)?.install(f))
}

/// A rayon pool of `threads` threads (all cores when `None`), to run work on.
///
/// Work installed in the pool runs on one of its threads: each parallel step
/// it takes then joins in and wakes only the others, where a step taken from
/// outside the pool puts the caller to sleep until the step is done. A local
/// update is hundreds of small parallel steps.
fn worker_pool(threads: Option<usize>) -> anyhow::Result<rayon::ThreadPool> {
    let mut pool = rayon::ThreadPoolBuilder::new();
    match threads {
        None => {}
        Some(n) if !(1..=MAX_THREADS).contains(&n) => {
            anyhow::bail!("--threads must be between 1 and {MAX_THREADS}, got {n}")
        }
        Some(n) => pool = pool.num_threads(n),
    }
    pool.build().map_err(|e| anyhow::anyhow!("starting the worker threads: {e}"))
}

/// The file stem of a scene path, for default output names.
fn scene_stem(path: &std::path::Path) -> String {
    path.file_stem().map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned())
}

/// Checks before any work that an output file's directory exists and that
/// the path is not a directory itself.
fn check_output_dir(path: &std::path::Path) -> anyhow::Result<()> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).map_or_else(|| PathBuf::from("."), PathBuf::from);
    anyhow::ensure!(dir.is_dir(), "{}: the output directory {} does not exist", path.display(), dir.display());
    anyhow::ensure!(!path.is_dir(), "{}: is a directory, not a file to write", path.display());
    Ok(())
}

/// [`check_output_dir`], and that the file's name ends in `.extension` (the
/// format written), so no file is given a name that misstates its contents.
fn check_output_file(path: &std::path::Path, extension: &str) -> anyhow::Result<()> {
    check_output_dir(path)?;
    let named = path.extension().is_some_and(|e| e.eq_ignore_ascii_case(extension));
    anyhow::ensure!(
        named,
        "{}: the output is written as {extension}, so its name must end in .{extension}",
        path.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn work_runs_on_a_pool_thread_of_the_size_asked() {
        // On the caller's thread, every parallel step would put it to sleep
        // and wake it: a local update's hundreds of steps paid for that.
        assert!(with_threads(None, || rayon::current_thread_index().is_some()).unwrap());
        assert_eq!(with_threads(Some(3), rayon::current_num_threads).unwrap(), 3);
        let refused = with_threads(Some(0), || ()).unwrap_err().to_string();
        assert!(refused.contains("--threads must be between 1 and"), "{refused}");
    }
}
