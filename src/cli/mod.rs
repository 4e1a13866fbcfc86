//! The command line: argument parsing (clap) and one file per subcommand,
//! each turning its arguments into the pipelines' settings, calling the
//! library and printing or writing what it returns. The binary only calls
//! [`main_with_args`].

mod args;
mod bench;
mod compare;
mod diff;
mod edit;
mod exit;
mod info;
mod mesh;
mod progress;
mod regress;
mod render;
mod slice;
mod tune;
#[cfg(feature = "viewer")]
mod view;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

pub use exit::{FAILURE, SUCCESS, USAGE, UsageError};

/// blobtrace: ray-trace skeletal implicit models (BlobTrees) on the CPU.
#[derive(Debug, Parser)]
#[command(name = "blobtrace", version, about, long_about = None, after_help = EXIT_CODES)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The exit codes, as `--help` lists them.
const EXIT_CODES: &str = "Exit codes: 0 success; 1 error (bad scene or script, failed write, failed check); \
64 usage error (bad option or value). `diff` exits as idiff does: 0 pass, 1 warn, 2 fail, 3 size mismatch, 4 file error.";

/// `diff`'s exit codes and where it departs from idiff, as its `--help` lists them.
const DIFF_EXIT_CODES: &str = "idiff's command lines work unchanged (-fail, -failrelative, -failpercent, -hardfail, \
-allowfailures, -warn, -warnrelative, -warnpercent, -hardwarn, -o, -od, -abs, -scale, -p, -q, -v), and diff judges \
as idiff 2.4.7 does, except: a value finite in one image only (a miss's infinite Z) fails its pixel and stays out of \
the sums, so the mean and RMS stay finite and such pixels are counted beside them (idiff's first mismatch only sets \
the maximum to inf and is not counted; later ones make its mean inf or nan; --idiff-stats prints idiff's figures); \
-o FILE.png is a heat map unless -abs is given; -p is NVIDIA's FLIP, not idiff's Yee metric; the report is printed \
on a pass too; -a (every subimage) is not supported. Images of different sizes are compared as idiff compares \
them (over the larger extent, pixels beyond an image reading 0, percentages of the first image's pixels), with a \
warning; --metric depth, normal and flip need one size. --metric flip is LDR-FLIP for PNG and HDR-FLIP (ACES, \
flip-evaluator's exposures) for two EXRs.\n\n\
Exit codes (idiff's): 0 pass, 1 warn, 2 fail, 3 size mismatch (depth, normal, flip), 4 file error; 64 usage error \
(bad option or value, an -o name other than .png or .exr).";

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a scene by tracing rays through its field; write a PNG (and an EXR of all AOVs).
    #[command(after_help = EXIT_CODES)]
    Render(render::RenderArgs),
    /// Polygonize a scene's surface and write it as PLY, OBJ or STL.
    #[command(after_help = EXIT_CODES)]
    Mesh(mesh::MeshArgs),
    /// Render a scene by tracing its field and by ray casting its polygonized
    /// surface, and show where they disagree: renders, heat maps, a panel, stats.
    #[command(after_help = EXIT_CODES)]
    Compare(compare::CompareArgs),
    /// Images of the field on a plane: f, the sharp view, error_C and gradient
    /// error of the caches per filter and resolution.
    #[command(after_help = EXIT_CODES)]
    Slice(slice::SliceArgs),
    /// Replay an edit script, updating only what each edit changed (dirty
    /// rectangles, local mesh cells, BVH2 triangles); time it, optionally verify it.
    #[command(after_help = EXIT_CODES)]
    Edit(edit::EditArgs),
    /// Render every entry of images/ref/manifest.ron and compare it with its
    /// reference (--bless rewrites them); exits non-zero on any failure.
    #[command(after_help = EXIT_CODES)]
    Regress(regress::RegressArgs),
    /// Compare two images (PNG or EXR) like idiff, taking its options: exit 0
    /// pass, 1 warn, 2 fail, 3 size mismatch, 4 file error; optionally write a
    /// heat map or idiff's difference image.
    #[command(after_help = DIFF_EXIT_CODES)]
    Diff(diff::DiffArgs),
    /// Place and size the scene's caches from error_C sampled at mesh vertices:
    /// remove those that do not pay, refine or split those over the tolerance,
    /// insert them over expensive subtrees; write the tuned scene and a report.
    #[command(after_help = EXIT_CODES)]
    Tune(tune::TuneArgs),
    /// Print what a scene holds: node, primitive and cache counts, names, bounds.
    #[command(after_help = EXIT_CODES)]
    Info(info::InfoArgs),
    /// Preview a scene in a window: arrow keys move its named nodes along the
    /// screen (Space steps an edit script), each move updating only what it
    /// changed, a coarse pass at once and the rest refined while idle; the
    /// mouse orbits, pans, zooms and selects; V cycles the field, mesh, depth
    /// and normal differences, cost and slice views; H shows every key (in
    /// pages where the window is small). Every tap and click counts; held keys
    /// repeat after 0.3 s, 20 a second.
    /// --headless takes the keys from --keys and writes the last view.
    #[cfg(feature = "viewer")]
    #[command(after_help = EXIT_CODES)]
    View(view::ViewArgs),
    /// Measure performance figures in one process, as ratios against a baseline.
    #[command(subcommand, after_help = EXIT_CODES)]
    Bench(bench::BenchCommand),
}

/// Parses `args` and runs the command; returns the process exit code.
pub fn main_with_args(args: impl IntoIterator<Item = std::ffi::OsString>) -> ExitCode {
    let args = match diff::idiff_style(args.into_iter().collect()) {
        Ok(args) => args,
        Err(message) => {
            eprintln!("error: {message}");
            return ExitCode::from(USAGE);
        }
    };
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() { ExitCode::from(USAGE) } else { ExitCode::SUCCESS };
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
        Command::Tune(a) => tune::run(&a),
        Command::Info(a) => info::run(&a),
        #[cfg(feature = "viewer")]
        Command::View(a) => view::run(&a),
        Command::Bench(b) => bench::run(&b),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let (message, code) = exit::describe(&e);
            eprintln!("error: {message}");
            ExitCode::from(code)
        }
    }
}
