//! `blobtrace mesh`: polygonize a scene and write PLY, OBJ or STL.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;

use super::args::{
    EvalOptions, PolygonizeArgs, RepairArgs, check_output_dir, output_or_default, print_json, with_threads,
};
use super::exit::UsageError;
use super::progress::Bars;
use crate::mesh::quality::QualityLevel;
use crate::mesh::{MeshFormat, write_mesh};
use crate::pipeline::{MeshReport, PolygonizeSettings, RepairReport, color_by_cache_error, polygonize};
use crate::scene::Scene;

/// Options of `blobtrace mesh`.
#[derive(Debug, Args)]
pub struct MeshArgs {
    /// Scene file (RON), e.g. scenes/medusa.ron.
    pub scene: PathBuf,
    /// Output mesh: .ply (binary, with normals and colours), .obj or .stl.
    /// Defaults to SCENE's name with .ply in the current directory.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Polygonizer options.
    #[command(flatten)]
    pub polygonize: PolygonizeArgs,
    /// Mesh remedies.
    #[command(flatten)]
    pub repair: RepairArgs,
    /// Worker threads (default: all cores). The mesh is identical for any count.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Field evaluation: exact or cached, and the cache budget.
    #[command(flatten)]
    pub field: EvalOptions,
    /// Colour the vertices by error_C = |f_C − f| (cached against exact field) and
    /// store it in the PLY as `error`; print its mean and maximum.
    #[command(flatten)]
    pub error: CacheErrorArgs,
    /// Print one JSON object of statistics on stdout instead of a summary line.
    #[arg(long)]
    pub json: bool,
    /// The quality report: full (every figure, self-intersections included),
    /// summary (all but the self-intersections, which cost the most), or off.
    #[arg(long, value_enum, default_value_t = QualityArg::Full)]
    pub quality: QualityArg,
}

/// How much of the quality report `mesh` computes.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum QualityArg {
    /// No report (watertightness is still reported).
    Off,
    /// Pieces, watertightness, genus, triangle shape and normals.
    Summary,
    /// Every figure, self-intersections included.
    Full,
}

impl From<QualityArg> for QualityLevel {
    fn from(q: QualityArg) -> Self {
        match q {
            QualityArg::Off => QualityLevel::Off,
            QualityArg::Summary => QualityLevel::Summary,
            QualityArg::Full => QualityLevel::Full,
        }
    }
}

/// Colouring a mesh by the caches' reconstruction error.
#[derive(Clone, Copy, Debug, Args)]
pub struct CacheErrorArgs {
    /// Colour vertices by error_C = |f_C(p) − f(p)| (needs Cache nodes).
    #[arg(long)]
    pub error: bool,
    /// The error drawn brightest (default 0.05, a tenth of the usual iso-value).
    #[arg(long, default_value_t = 0.05, value_name = "E")]
    pub error_scale: f32,
}

impl CacheErrorArgs {
    /// The error scale, when the mesh is to be coloured by error_C.
    #[must_use]
    pub fn scale(&self) -> Option<f32> {
        self.error.then_some(self.error_scale)
    }
}

/// Runs `blobtrace mesh`.
pub fn run(a: &MeshArgs) -> anyhow::Result<()> {
    let mut scene = Scene::load(&a.scene)?;
    let mode = a.field.apply(&mut scene.model)?;
    let output = output_or_default(a.output.as_deref(), &a.scene, "ply");
    let format = MeshFormat::from_path(&output).map_err(UsageError)?;
    check_output_dir(&output)?;
    let bars = Bars::new();
    let (mesh, report) = with_threads(a.threads, || -> anyhow::Result<_> {
        let settings =
            PolygonizeSettings { repair: a.repair.repair(), quality: a.quality.into(), ..a.polygonize.settings() };
        let (mut mesh, mut report) = polygonize(&scene.model, mode, &settings, &bars)?;
        if let Some(scale) = a.error.scale() {
            color_by_cache_error(&mut scene.model, &mut mesh, scale, &mut report)?;
        }
        Ok((mesh, report))
    })??;
    bars.finish();
    write_mesh(&output, &mesh, format).with_context(|| format!("writing {}", output.display()))?;
    if let Some(warning) = &report.warning {
        eprintln!("warning: {warning}");
    }
    if a.json {
        return print_json(&report);
    }
    print_summary(&output, &report);
    Ok(())
}

fn print_summary(output: &std::path::Path, report: &MeshReport) {
    let per_triangle = report.evals_per_triangle.map_or(String::new(), |e| {
        let closed = if report.closed_manifold { "closed" } else { "NOT closed" };
        format!(", {e:.2} field evaluations per triangle, {closed}")
    });
    eprintln!(
        "{}: {} triangles, {} vertices in {:.3} s{per_triangle}",
        output.display(),
        report.triangles,
        report.vertices,
        report.seconds,
    );

    if let Some(quality) = &report.quality {
        eprintln!("quality: {}", quality.headline());
    }
    if let Some(repairs) = &report.repairs {
        print_repairs(repairs);
    }
    if let Some(e) = report.error_c {
        eprintln!(
            "error_C at the vertices: mean {:.2e} ({:.2}% of T), max {:.2e} ({:.1}% of T)",
            e.mean,
            100.0 * e.mean_relative,
            e.max,
            100.0 * e.max_relative
        );
    }
}

fn print_repairs(repairs: &RepairReport) {
    if let Some(s) = repairs.snap {
        eprintln!(
            "snapped {} lattice corners within {} of a cell of a crossing ({} vertices moved onto them, \
             {} triangles dropped): min angle {:.3}° -> {:.3}°, max distance to the surface {:.3} -> {:.3} cells",
            s.snap.corners,
            s.snap.fraction,
            s.snap.moved,
            s.snap.dropped_triangles,
            s.min_angle_degrees[0],
            s.min_angle_degrees[1],
            s.max_distance_cells[0],
            s.max_distance_cells[1]
        );
    }
    if let Some(n) = repairs.dropped_components {
        eprintln!("dropped {n} pieces smaller than --min-component");
    }
    if let Some(n) = repairs.normals {
        eprintln!(
            "{} normals pointed against their faces: {} re-taken from the exact gradient, {} from the faces",
            n.against_faces, n.from_gradient, n.from_faces
        );
    }
}
