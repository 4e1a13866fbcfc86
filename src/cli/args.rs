//! What several commands share: the options for field evaluation,
//! polygonization, the camera and threads, their conversion into the
//! pipelines' settings, checks of output paths, and printing reports.

use std::path::{Path, PathBuf};

use clap::{Args, ValueEnum};
use glam::Vec3;
use serde::Serialize;

use super::exit::UsageError;
use crate::field::{EvalMode, Model, TracerChoice};
use crate::frame::Size;
use crate::mesh::quality::QualityLevel;
use crate::mesh::{CellShape, VertexPlacement};
use crate::pipeline::{self, EvalSettings, ExactLookup, FieldChoice, MeshRepair, PolygonizeSettings};
use crate::scene::{Scene, ViewOverrides};

/// How exact evaluation finds the primitives near a point.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum EvalArg {
    /// Spatial index over wide blends: touch only supports containing the point.
    #[default]
    Indexed,
    /// Plain tree traversal with per-node box rejection (the paper's baseline).
    Naive,
}

/// Which field to show: the true one, or the one the scene's caches reconstruct.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ModeArg {
    /// Each cache answers from its lattice where the cost model says it pays (`info` shows the decisions).
    Auto,
    /// Exact evaluation of every node (caches pass through).
    Exact,
    /// Cache nodes answer from their lattices (lazily filled with exact samples).
    Cached,
}

/// How a command evaluates the field: shared by every command that traces or samples it.
#[derive(Clone, Copy, Debug, Args)]
pub struct EvalOptions {
    /// auto, exact or cached (default: auto, or exact with --eval naive).
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

impl TracerArg {
    /// The pipelines' tracer choice.
    #[must_use]
    pub fn choice(self) -> TracerChoice {
        match self {
            TracerArg::Auto => TracerChoice::Auto,
            TracerArg::Kernel => TracerChoice::Kernel,
            TracerArg::Segment => TracerChoice::Segment,
        }
    }
}

/// The `--tracer` choices.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum TracerArg {
    /// The kernel tracer where the model is a sum of polynomial kernels that
    /// overlap little, else the segment tracer.
    #[default]
    Auto,
    /// The kernel tracer (refused where the model is not a sum of polynomial kernels).
    Kernel,
    /// The segment tracer.
    Segment,
}

impl EvalOptions {
    /// The pipelines' evaluation settings.
    #[must_use]
    pub fn settings(&self) -> EvalSettings {
        EvalSettings {
            field: self.mode.map(|m| match m {
                ModeArg::Auto => FieldChoice::Auto,
                ModeArg::Exact => FieldChoice::Exact,
                ModeArg::Cached => FieldChoice::Cached,
            }),
            lookup: match self.eval {
                EvalArg::Indexed => ExactLookup::Indexed,
                EvalArg::Naive => ExactLookup::Naive,
            },
            cache_budget_mb: self.cache_budget,
            tracer: TracerChoice::Auto,
        }
    }

    /// The evaluation mode for `model`; applies the cache budget to it.
    pub fn apply(&self, model: &mut Model) -> anyhow::Result<EvalMode> {
        Ok(self.settings().apply(model)?)
    }
}

/// Cell decomposition.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum CellsArg {
    /// Cubes with the watertight marching-cubes table.
    #[default]
    Cubes,
    /// Body-centred-cubic tetrahedra.
    Bcc,
}

impl From<CellsArg> for CellShape {
    fn from(c: CellsArg) -> Self {
        match c {
            CellsArg::Cubes => CellShape::Cubes,
            CellsArg::Bcc => CellShape::Bcc,
        }
    }
}

/// Vertex placement on crossed edges.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum VertexArg {
    /// Illinois root finding to 1e-4 of the edge.
    #[default]
    Root,
    /// Linear interpolation of the corner values (no evaluation; a preview).
    Linear,
}

/// The polygonizer's lattice: shared by every command that builds a mesh,
/// the incremental ones (`edit`, `view`) included.
#[derive(Clone, Copy, Debug, Args)]
pub struct LatticeArgs {
    /// Lattice cells along the longest side of the model's bounds.
    #[arg(long, default_value_t = 128)]
    pub res: u32,
    /// Cell decomposition.
    #[arg(long, value_enum, default_value_t = CellsArg::Cubes)]
    pub cells: CellsArg,
    /// Vertex placement.
    #[arg(long, value_enum, default_value_t = VertexArg::Root)]
    pub vertex: VertexArg,
}

impl LatticeArgs {
    /// The pipelines' polygonization settings, unrefined.
    #[must_use]
    pub fn settings(&self) -> PolygonizeSettings {
        PolygonizeSettings {
            res: self.res,
            cells: self.cells.into(),
            vertex: match self.vertex {
                VertexArg::Root => VertexPlacement::default(),
                VertexArg::Linear => VertexPlacement::Linear,
            },
            refine: 0,
            repair: MeshRepair::default(),
            quality: QualityLevel::Full,
        }
    }
}

/// How to polygonize from scratch: the lattice, and refinement (which local
/// updates cannot take, so `edit` and `view` take [`LatticeArgs`] alone).
#[derive(Clone, Copy, Debug, Args)]
pub struct PolygonizeArgs {
    /// The lattice.
    #[command(flatten)]
    pub lattice: LatticeArgs,
    /// Refine K levels: polygonize at res·2^K, grown from the surface found at
    /// res instead of from the skeletons (coarse and fine meshes of one lattice family).
    #[arg(long, default_value_t = 0, value_name = "K")]
    pub refine: u32,
}

impl PolygonizeArgs {
    /// The pipelines' polygonization settings.
    #[must_use]
    pub fn settings(&self) -> PolygonizeSettings {
        PolygonizeSettings { refine: self.refine, ..self.lattice.settings() }
    }
}

/// Remedies for the polygonized mesh, each off by default.
#[derive(Clone, Copy, Debug, Args)]
pub struct RepairArgs {
    /// Snap the lattice corners within F of a cell from a crossing onto the
    /// surface (F at most 0.3; cubes only): every vertex on an edge leaving such
    /// a corner moves onto it, vertices that meet merge, collapsed triangles are
    /// dropped. Removes the needles and slivers marching cubes makes next to
    /// corners; moved vertices stay within about F cells of the surface (the
    /// smallest angle and the distance before and after are reported)
    #[arg(long, value_name = "F")]
    pub snap: Option<f32>,
    /// Drop connected pieces of fewer than N triangles. Off by default: a thin
    /// feature sampled coarsely falls apart into small pieces that are real
    #[arg(long, value_name = "N")]
    pub min_component: Option<u32>,
    /// Re-take vertex normals that point against their faces from the exact
    /// field's gradient (a cached lattice's gradient can flip next to features
    /// thinner than a cell), or from the faces where that disagrees too
    #[arg(long)]
    pub fix_normals: bool,
}

impl RepairArgs {
    /// The remedies asked for.
    #[must_use]
    pub fn repair(&self) -> MeshRepair {
        MeshRepair { snap: self.snap, min_component: self.min_component, fix_normals: self.fix_normals }
    }
}

/// Camera overrides: every rendering command takes them, so a view can be
/// changed without editing the scene.
#[derive(Clone, Copy, Debug, Default, Args)]
pub struct CameraArgs {
    /// Eye position X,Y,Z, overriding the scene's camera.
    #[arg(long, value_parser = parse_vec3, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub eye: Option<Vec3>,
    /// Point looked at X,Y,Z, overriding the scene's camera.
    #[arg(long, value_parser = parse_vec3, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub target: Option<Vec3>,
    /// Up direction X,Y,Z, overriding the scene's camera.
    #[arg(long, value_parser = parse_vec3, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub up: Option<Vec3>,
    /// Vertical field of view in degrees, overriding the scene's camera.
    #[arg(long, value_name = "DEG")]
    pub fov: Option<f32>,
}

impl CameraArgs {
    /// Applies the overrides to `scene`'s camera.
    pub fn apply(&self, scene: &mut Scene) -> anyhow::Result<()> {
        let overrides = ViewOverrides { eye: self.eye, target: self.target, up: self.up, fov_y: self.fov };
        if overrides != ViewOverrides::default() {
            scene.override_view(&overrides).map_err(|e| UsageError(format!("--eye/--target/--up/--fov: {e}")))?;
        }
        Ok(())
    }
}

/// The scene a rendering command works on and how it looks at it: shared
/// by `render`, `compare`, `edit` and `view`.
#[derive(Clone, Debug, Args)]
pub struct SceneArgs {
    /// Scene file (RON), e.g. scenes/medusa.ron.
    pub scene: PathBuf,
    /// Image size WIDTHxHEIGHT, overriding the scene's `size`.
    #[arg(long, value_parser = parse_size)]
    pub size: Option<Size>,
    /// Camera overrides.
    #[command(flatten)]
    pub camera: CameraArgs,
    /// Field evaluation: exact or cached, and the cache budget.
    #[command(flatten)]
    pub field: EvalOptions,
    /// Ray tracer: kernel (hits as roots of each ray's polynomial, for sums of
    /// points and segments), segment (marching, for any model), or auto: kernel
    /// where it applies and pays (`info` shows the decision).
    #[arg(long, value_enum, default_value_t = TracerArg::Auto)]
    pub tracer: TracerArg,
}

/// A scene loaded as [`SceneArgs`] say: the camera overridden, the
/// evaluation mode chosen (the cache budget applied), the image size.
pub struct LoadedScene {
    /// The scene.
    pub scene: Scene,
    /// How its field is evaluated.
    pub mode: EvalMode,
    /// The image size.
    pub size: Size,
}

impl SceneArgs {
    /// Loads the scene, applies the camera overrides and the evaluation options.
    pub fn load(&self) -> anyhow::Result<LoadedScene> {
        let mut scene = load_scene(&self.scene, &self.camera)?;
        let settings = EvalSettings { tracer: self.tracer.choice(), ..self.field.settings() };
        let mode = settings.apply(&mut scene.model)?;
        let size = self.size.unwrap_or(scene.size);
        Ok(LoadedScene { scene, mode, size })
    }
}

/// How a batch command runs and reports: shared by `render`, `compare` and
/// `edit` (`view` runs its work beside a window, and prints no report).
#[derive(Clone, Copy, Debug, Args)]
pub struct RunArgs {
    /// Worker threads (default: all cores). Images and meshes are identical for any count.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print the statistics as one JSON object on stdout instead of a summary line.
    #[arg(long)]
    pub json: bool,
}

/// Loads the scene at `path` and applies the camera overrides.
fn load_scene(path: &Path, camera: &CameraArgs) -> anyhow::Result<Scene> {
    let mut scene = Scene::load(path)?;
    camera.apply(&mut scene)?;
    Ok(scene)
}

/// Parses `X,Y,Z`.
fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<f32> = s
        .split(',')
        .map(|c| c.trim().parse::<f32>().ok().filter(|v| v.is_finite()))
        .collect::<Option<_>>()
        .ok_or_else(|| format!("expected three finite numbers X,Y,Z, got {s:?}"))?;
    <[f32; 3]>::try_from(parts).map(Vec3::from).map_err(|_| format!("expected three numbers X,Y,Z, got {s:?}"))
}

/// Parses `WIDTHxHEIGHT`.
pub fn parse_size(s: &str) -> Result<Size, String> {
    Size::parse(s)
}

/// Runs `f` on a rayon pool of `threads` threads (all cores when `None`).
pub fn with_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> anyhow::Result<T> {
    Ok(pipeline::with_threads(threads, f)?)
}

/// A rayon pool of `threads` threads (all cores when `None`), to run work on.
pub fn worker_pool(threads: Option<usize>) -> anyhow::Result<rayon::ThreadPool> {
    Ok(pipeline::worker_pool(threads)?)
}

/// The file stem of a scene path, for default output names.
pub fn scene_stem(path: &Path) -> String {
    path.file_stem().map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned())
}

/// `path`, or `SCENE_STEM.extension` in the current directory.
pub fn output_or_default(path: Option<&Path>, scene: &Path, extension: &str) -> PathBuf {
    path.map_or_else(|| PathBuf::from(format!("{}.{extension}", scene_stem(scene))), Path::to_path_buf)
}

/// Checks before any work that an output file's directory exists and that
/// the path is not a directory itself.
pub fn check_output_dir(path: &Path) -> anyhow::Result<()> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).map_or_else(|| PathBuf::from("."), PathBuf::from);
    anyhow::ensure!(dir.is_dir(), "{}: the output directory {} does not exist", path.display(), dir.display());
    anyhow::ensure!(!path.is_dir(), "{}: is a directory, not a file to write", path.display());
    Ok(())
}

/// [`check_output_dir`], and that the file's name ends in `.extension` (the
/// format written), so no file is given a name that misstates its contents.
pub fn check_output_file(path: &Path, extension: &str) -> anyhow::Result<()> {
    check_output_dir(path)?;
    check_output_name(path, extension)
}

/// That `path` is no directory and its name ends in `.extension`, for an
/// output whose missing folders the command creates.
pub fn check_output_name(path: &Path, extension: &str) -> anyhow::Result<()> {
    anyhow::ensure!(!path.is_dir(), "{}: is a directory, not a file to write", path.display());
    let named = path.extension().is_some_and(|e| e.eq_ignore_ascii_case(extension));
    if !named {
        let problem = format!("the output is written as {extension}, so its name must end in .{extension}");
        return Err(UsageError(format!("{}: {problem}", path.display())).into());
    }
    Ok(())
}

/// Creates `dir` (and its parents) if missing.
pub fn create_dir(dir: &Path) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| anyhow::anyhow!("creating {}: {e}", dir.display()))
}

/// Prints `report` as pretty JSON on stdout.
pub fn print_json(report: &impl Serialize) -> anyhow::Result<()> {
    println!("{}", serde_json::to_string_pretty(report).map_err(|e| anyhow::anyhow!("encoding the report: {e}"))?);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vectors_parse_as_three_finite_numbers() {
        assert_eq!(parse_vec3("1, -2,3.5").unwrap(), Vec3::new(1.0, -2.0, 3.5));
        for bad in ["1,2", "1,2,3,4", "a,b,c", "1,inf,2", ""] {
            assert!(parse_vec3(bad).is_err(), "{bad}");
        }
    }
}
