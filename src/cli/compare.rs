//! `blobtrace compare`: render a scene by tracing its field and by ray casting
//! its polygonized surface with the same camera, and show where they disagree —
//! renders, EXRs of every AOV, heat maps with printed scales, one panel, and
//! statistics.

use std::path::PathBuf;

use clap::Args;

use super::args::{
    LoadedScene, PolygonizeArgs, RepairArgs, RunArgs, SceneArgs, check_output_dir, create_dir, with_threads,
};
use super::mesh::CacheErrorArgs;
use super::progress::Bars;
use crate::pipeline::{
    COMPARE_OPTIONAL_OUTPUTS, COMPARE_OUTPUTS, CompareReport, CompareSettings, ErrorScales, PolygonizeSettings,
    Tolerances, compare,
};

/// Options of `blobtrace compare`.
#[derive(Debug, Args)]
pub struct CompareArgs {
    /// The scene, its image size, camera and field evaluation.
    #[command(flatten)]
    pub input: SceneArgs,
    /// Polygonizer options.
    #[command(flatten)]
    pub polygonize: PolygonizeArgs,
    /// Mesh remedies, applied before the mesh is rendered.
    #[command(flatten)]
    pub repair: RepairArgs,
    /// Also render the mesh coloured by error_C (needs Cache nodes).
    #[command(flatten)]
    pub error: CacheErrorArgs,
    /// Heat-map scales and tolerances.
    #[command(flatten)]
    pub judging: JudgingArgs,
    /// Directory for the images and stats.json (created if missing).
    #[arg(long, default_value = "compare")]
    pub out_dir: PathBuf,
    /// Threads and the JSON report.
    #[command(flatten)]
    pub run: RunArgs,
}

/// The heat maps' full scales and the tolerances of the statistics.
#[derive(Clone, Copy, Debug, Args)]
pub struct JudgingArgs {
    /// Full scale of the depth heat map, in lattice cells either way (default: the p99, rounded up).
    #[arg(long, value_name = "CELLS", allow_negative_numbers = true)]
    pub scale_depth: Option<f32>,
    /// Full scale of the normal heat map, in degrees (default: the p99, rounded up).
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub scale_normal: Option<f32>,
    /// Full scale of the colour heat map, largest linear RGB difference (default: the p99, rounded up).
    #[arg(long, value_name = "V", allow_negative_numbers = true)]
    pub scale_color: Option<f32>,
    /// Depth tolerance in lattice cells, behind "fraction above tolerance".
    #[arg(long, value_name = "CELLS", default_value_t = Tolerances::default().depth_cells, allow_negative_numbers = true)]
    pub tol_depth: f32,
    /// Normal tolerance in degrees.
    #[arg(long, value_name = "DEG", default_value_t = Tolerances::default().normal_deg, allow_negative_numbers = true)]
    pub tol_normal: f32,
    /// Colour tolerance, largest linear RGB difference.
    #[arg(long, value_name = "V", default_value_t = Tolerances::default().color, allow_negative_numbers = true)]
    pub tol_color: f32,
}

impl JudgingArgs {
    fn scales(&self) -> ErrorScales {
        ErrorScales { depth_cells: self.scale_depth, normal_deg: self.scale_normal, color: self.scale_color }
    }

    fn tolerances(&self) -> Tolerances {
        Tolerances { depth_cells: self.tol_depth, normal_deg: self.tol_normal, color: self.tol_color }
    }
}

/// Runs `blobtrace compare`.
pub fn run(a: &CompareArgs) -> anyhow::Result<()> {
    let LoadedScene { scene, mode, size } = a.input.load()?;
    let settings = CompareSettings {
        size,
        polygonize: PolygonizeSettings { repair: a.repair.repair(), ..a.polygonize.settings() },
        error_scale: a.error.scale(),
        scales: a.judging.scales(),
        tolerances: a.judging.tolerances(),
    };
    // A set half old and half new is worse than none: every name must be
    // writable before the work, and the folder is made only once it is done
    // (a setting refused leaves no empty folder behind).
    if a.out_dir.exists() {
        check_outputs(&a.out_dir)?;
    }
    let bars = Bars::new();
    let comparison = with_threads(a.run.threads, || compare(&scene, mode, &settings, &bars))??;
    bars.finish();
    create_dir(&a.out_dir)?;
    check_outputs(&a.out_dir)?;
    let json = comparison.save(&a.out_dir)?;
    if a.run.json {
        println!("{json}");
    } else {
        print_summary(&a.out_dir, &comparison.report);
    }
    Ok(())
}

/// Checks that every name `compare` writes in `dir` can be written.
fn check_outputs(dir: &std::path::Path) -> anyhow::Result<()> {
    COMPARE_OUTPUTS.iter().chain(&COMPARE_OPTIONAL_OUTPUTS).try_for_each(|name| check_output_dir(&dir.join(name)))
}

fn print_summary(dir: &std::path::Path, r: &CompareReport) {
    eprintln!(
        "{}: {} pixels hit by one render only; depth error bias {:+.3}, mean {:.3} cells (p99 {:.3}); normal error mean {:.2}° (p99 {:.2}°); mesh of {} triangles",
        dir.display(),
        r.mismatch_px,
        r.depth_bias_cells,
        r.depth_error_cells.mean,
        r.depth_error_cells.p99,
        r.normal_error_deg.mean,
        r.normal_error_deg.p99,
        r.mesh.mesh.triangles
    );
    if let Some(quality) = &r.mesh.mesh.quality {
        eprintln!("mesh quality: {}", quality.headline());
    }
}
