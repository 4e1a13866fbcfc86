//! How load time, memory, rendering and meshing grow with the number of
//! primitives: point sets of 10³ … 10⁷ points (sparse at the particles
//! scene's density and a dense cloud, each written as a binary PLY, and one
//! long spline), each loaded as a scene, then rendered and meshed at a fixed
//! cell; a log–log
//! plot of each figure against the count, with a line of slope one beside
//! it, and the same figures as JSON beside the plot.
//!
//! Each point set is measured by a runner the caller gives: in this process
//! ([`measure_point_set`]), or, as `blobtrace bench scale` does, in a fresh
//! process each, so that the memory one set leaves with the allocator is not
//! counted against the next.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::point_sets::{PointModel, ply_bytes, scene_text, spline_scene_text};
use crate::draw::{Panel, scaling_plot};
use crate::field::EvalMode;
use crate::frame::Size;
use crate::mesh::quality::QualityLevel;
use crate::output::FileSet;
use crate::pipeline::{
    MAX_RES, MB, PipelineError, PolygonizeSettings, Result, Silent, available_memory_bytes, peak_resident_bytes,
    polygonize, render_field, reset_peak_resident, resident_bytes, with_threads,
};
use crate::progress::Progress;
use crate::scene::{MAX_SPLINE_POINTS, Scene};

/// What the scale benchmark measures.
#[derive(Clone, Debug)]
pub struct ScaleBenchSettings {
    /// Point counts, in increasing order.
    pub counts: Vec<usize>,
    /// The point sets.
    pub models: Vec<PointModel>,
    /// Image size of the renders.
    pub size: Size,
    /// Lattice cell of the meshes (model units).
    pub mesh_cell: f32,
    /// Largest count that is meshed (meshing a large cloud takes the longest).
    pub mesh_up_to: usize,
    /// The plot (PNG); the JSON goes beside it, with the same name.
    pub plot: PathBuf,
    /// Worker threads (default: all cores).
    pub threads: Option<usize>,
}

/// One point set at one count.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ScaleRow {
    /// `sparse`, `dense` or `spline`.
    pub model: PointModel,
    /// Points.
    pub points: usize,
    /// Seconds to load the scene: read its file, build the model and its index.
    pub load_seconds: f64,
    /// Resident memory the loaded scene added, in MB (Linux; `None` elsewhere).
    pub resident_mb: Option<f64>,
    /// The process's peak resident memory while loading, in MB (Linux).
    pub peak_mb: Option<f64>,
    /// Seconds to render at the benchmark's size.
    pub render_seconds: f64,
    /// The tracer `auto` chose.
    pub tracer: String,
    /// Seconds to polygonize at the fixed cell (the quality report not counted).
    pub mesh_seconds: Option<f64>,
    /// Its lattice resolution and triangles.
    pub mesh: Option<(u32, usize)>,
    /// Why it was not meshed, when it was not.
    pub mesh_skipped: Option<String>,
}

/// The benchmark's figures.
#[derive(Clone, Debug, Serialize)]
pub struct ScaleBenchReport {
    /// Worker threads.
    pub threads: usize,
    /// Image size of the renders.
    pub size: String,
    /// Lattice cell of the meshes.
    pub mesh_cell: f32,
    /// One row per point set and count measured.
    pub rows: Vec<ScaleRow>,
    /// Counts left out, and why (memory).
    pub stopped: Vec<String>,
    /// The plot.
    pub plot: String,
}

/// Measures one point set at one count.
pub type RowRunner<'a> = &'a dyn Fn(PointModel, usize) -> Result<ScaleRow>;

/// Measures every model at every count that fits in memory, each by `run`;
/// writes the plot and the JSON.
pub fn bench_scale(settings: &ScaleBenchSettings, progress: &dyn Progress, run: RowRunner) -> Result<ScaleBenchReport> {
    let (rows, stopped) = measure_all(settings, progress, run)?;
    let report = ScaleBenchReport {
        threads: with_threads(settings.threads, rayon::current_num_threads)?,
        size: settings.size.to_string(),
        mesh_cell: settings.mesh_cell,
        rows,
        stopped,
        plot: settings.plot.display().to_string(),
    };
    let mut files = FileSet::new();
    files.add(&settings.plot, plot(&report, settings).png_bytes_for(&settings.plot)?);
    let json = serde_json::to_string_pretty(&report).expect("the report serializes");
    files.add(settings.plot.with_extension("json"), json.into_bytes());
    files.commit()?;
    Ok(report)
}

type Measured = (Vec<ScaleRow>, Vec<String>);

fn measure_all(settings: &ScaleBenchSettings, progress: &dyn Progress, run: RowRunner) -> Result<Measured> {
    let (mut rows, mut stopped) = (vec![], vec![]);
    let total = (settings.models.len() * settings.counts.len()) as u64;
    let mut done = 0;
    for &model in &settings.models {
        for &n in &settings.counts {
            progress.update("point sets", done, total);
            done += 1;
            if model == PointModel::Spline && n as u64 > MAX_SPLINE_POINTS {
                stopped.push(format!("spline {n}: a SplinePoints holds at most {MAX_SPLINE_POINTS} points"));
                continue;
            }
            if let Some(why) = too_large(&rows, model, n) {
                stopped.push(why);
                continue;
            }
            rows.push(run(model, n)?);
        }
    }
    progress.update("point sets", total, total);
    Ok((rows, stopped))
}

/// Why `n` points of `model` would not fit: the last count's peak memory per
/// point, times `n`, against the memory available.
fn too_large(rows: &[ScaleRow], model: PointModel, n: usize) -> Option<String> {
    let last = rows.iter().rev().find(|r| r.model == model)?;
    let per_point = last.peak_mb? / last.points as f64;
    let need = per_point * n as f64 * 1.5;
    let available = available_memory_bytes()? / MB;
    (need > 0.8 * available)
        .then(|| format!("{} {n}: would need about {need:.0} MB, {available:.0} MB available", model.name()))
}

/// Measures `n` points of `model` in this process: writes them to a scratch
/// folder, loads, renders and (up to `mesh_up_to` points) meshes them.
pub fn measure_point_set(settings: &ScaleBenchSettings, model: PointModel, n: usize) -> Result<ScaleRow> {
    let scratch = std::env::temp_dir().join(format!("blobtrace-bench-scale-{}", std::process::id()));
    std::fs::create_dir_all(&scratch)
        .map_err(|e| PipelineError::File { path: scratch.clone(), message: e.to_string() })?;
    let row = with_threads(settings.threads, || measure(settings, &scratch, model, n));
    let _ = std::fs::remove_dir_all(&scratch);
    row?
}

fn measure(settings: &ScaleBenchSettings, scratch: &Path, model: PointModel, n: usize) -> Result<ScaleRow> {
    let scene_path = write_point_set(scratch, model, n, settings.size)?;
    let before = resident_mb(resident_bytes);
    reset_peak_resident();
    let start = Instant::now();
    let scene = Scene::load(&scene_path)?;
    let load_seconds = start.elapsed().as_secs_f64();
    let peak_mb = resident_mb(peak_resident_bytes);
    let added_mb = resident_mb(resident_bytes).zip(before).map(|(after, before)| after - before);
    let (_, render) = render_field(&scene, (settings.size, 1), EvalMode::Indexed, &Silent);
    let mut row = ScaleRow {
        model,
        points: n,
        load_seconds,
        resident_mb: added_mb,
        peak_mb,
        render_seconds: render.seconds,
        tracer: render.tracer.to_string(),
        mesh_seconds: None,
        mesh: None,
        mesh_skipped: None,
    };
    if n > settings.mesh_up_to {
        row.mesh_skipped = Some(format!("more than {} points", settings.mesh_up_to));
        return Ok(row);
    }
    let res = (scene.model.bounds().size().max_element() / settings.mesh_cell).ceil() as u32;
    // The quality report would cost several times the meshing: not measured here.
    let quality = QualityLevel::Off;
    let mesh_settings = PolygonizeSettings { res: res.clamp(1, MAX_RES), quality, ..PolygonizeSettings::default() };
    match polygonize(&scene.model, EvalMode::Indexed, &mesh_settings, &Silent) {
        Ok((_, report)) => {
            row.mesh_seconds = Some(report.seconds);
            row.mesh = Some((report.res, report.triangles));
        }
        Err(e @ PipelineError::MeshTooLarge { .. }) => row.mesh_skipped = Some(e.to_string()),
        Err(e) => return Err(e),
    }
    Ok(row)
}

/// Writes `n` points of `model` as a PLY and a scene framing them; returns the scene's path.
fn write_point_set(scratch: &Path, model: PointModel, n: usize, size: Size) -> Result<PathBuf> {
    let points = model.points(n, 2026);
    let stem = format!("{}-{n}", model.name());
    let ply = PathBuf::from(format!("{stem}.ply"));
    let scene = scratch.join(format!("{stem}.ron"));
    let mut files = FileSet::new();
    let text = match model {
        PointModel::Spline => spline_scene_text(&points, n, (size.0, size.1)),
        PointModel::Sparse | PointModel::Dense => {
            files.add(scratch.join(&ply), ply_bytes(&points));
            scene_text(&ply, &points, (size.0, size.1))
        }
    };
    files.add(&scene, text.into_bytes());
    files.commit()?;
    Ok(scene)
}

/// A reading of the process's memory in MB.
fn resident_mb(read: fn() -> Option<f64>) -> Option<f64> {
    read().map(|bytes| bytes / MB)
}

/// Load time, memory, render and mesh time against the point count, log–log.
fn plot(report: &ScaleBenchReport, settings: &ScaleBenchSettings) -> crate::draw::Rgb8Image {
    let counts: Vec<f64> = settings.counts.iter().map(|&n| n as f64).collect();
    let series = |figure: fn(&ScaleRow) -> Option<f64>| {
        settings
            .models
            .iter()
            .map(|&m| {
                let values = settings
                    .counts
                    .iter()
                    .map(|&n| {
                        let row = report.rows.iter().find(|r| r.model == m && r.points == n);
                        row.and_then(figure).unwrap_or(f64::NAN)
                    })
                    .collect();
                (m.name(), values)
            })
            .collect()
    };
    let panels = [
        Panel { title: "load (s)", series: series(|r| Some(r.load_seconds)) },
        Panel { title: "resident memory after load (MB)", series: series(|r| r.resident_mb) },
        Panel { title: &format!("render {} (s)", report.size), series: series(|r| Some(r.render_seconds)) },
        Panel { title: &format!("mesh, cell {} (s)", report.mesh_cell), series: series(|r| r.mesh_seconds) },
    ];
    let title = format!("blobtrace bench scale: points of radius 2.25 against their count, {} threads", report.threads);
    scaling_plot(&title, &counts, &panels, (480, 320))
}
