//! `blobtrace slice`: images of the field on a plane — f with its iso-contour,
//! the sharp view per filter (the paper's Figure 6), error_C per filter and
//! cache resolution (Figures 5 and 7), and the cached gradient's angle error
//! (Figure 4's question).

use std::path::PathBuf;

use super::args::{check_output_file, parse_size, scene_stem, with_threads};
use super::exit::UsageError;
use super::progress::Bars;
use crate::cache::Filter;
use crate::frame::Size;
use crate::pipeline::{SliceSettings, SliceView, slice, slice_warnings};
use crate::scene::Scene;
use crate::slice::SlicePlane;
use anyhow::Context;
use clap::{Args, ValueEnum};

/// What a slice shows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum Show {
    /// f itself (magma) with the iso-contour in white.
    #[default]
    Field,
    /// sin(11π f) in grey with the iso-band in red: exact, tri-linear, tri-quadratic.
    Sharp,
    /// error_C = |f_C − f| for each filter and each resolution of the sweep.
    Error,
    /// Angle between cached and exact gradients, for each filter and resolution.
    Gradient,
}

/// A reconstruction filter, as the command line names it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FilterArg {
    /// Tri-linear (8 samples).
    Trilinear,
    /// Tri-quadratic B-spline (27 samples).
    Triquadratic,
}

impl From<FilterArg> for Filter {
    fn from(f: FilterArg) -> Self {
        match f {
            FilterArg::Trilinear => Filter::Trilinear,
            FilterArg::Triquadratic => Filter::Triquadratic,
        }
    }
}

/// Options of `blobtrace slice`.
#[derive(Debug, Args)]
pub struct SliceArgs {
    /// Scene file (RON).
    pub scene: PathBuf,
    /// The plane: x=V, y=V, z=V, or PX,PY,PZ+NX,NY,NZ (a point and a normal).
    #[arg(long)]
    pub plane: String,
    /// Largest image size of one slice, WIDTHxHEIGHT (square pixels).
    #[arg(long, value_parser = parse_size, default_value = "400x400")]
    pub size: Size,
    /// What to show.
    #[arg(long, value_enum, default_value_t = Show::Field)]
    pub show: Show,
    /// Only this filter (default: both) for error, gradient and sharp.
    #[arg(long, value_enum)]
    pub filter: Option<FilterArg>,
    /// Cache resolutions to compare (default: the scene's own).
    #[arg(long, value_delimiter = ',')]
    pub res_sweep: Vec<u32>,
    /// Full scale of the heat maps (default: 1 for field, 0.02 for error, 10 degrees for gradient).
    #[arg(long)]
    pub scale: Option<f32>,
    /// Output PNG (default: SCENE-SHOW.png in the current directory).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// Runs `blobtrace slice`.
pub fn run(a: &SliceArgs) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(&a.scene).with_context(|| format!("reading {}", a.scene.display()))?;
    let label = a.scene.display().to_string();
    let scene = Scene::parse(&text, &label)?;
    let plane = SlicePlane::parse(&a.plane, &scene.model.bounds(), a.size.0, a.size.1)
        .map_err(|e| UsageError(e.to_string()))?;
    let settings = a.settings();
    settings.check(&scene)?;
    for warning in slice_warnings(&scene, &plane, &settings) {
        eprintln!("warning: {warning}");
    }
    let show = format!("{:?}", a.show).to_lowercase();
    let output = a.output.clone().unwrap_or_else(|| PathBuf::from(format!("{}-{show}.png", scene_stem(&a.scene))));
    check_output_file(&output, "png")?;
    let bars = Bars::new();
    let image = with_threads(a.threads, || slice(&text, &label, &plane, &settings, &bars))??;
    bars.finish();
    image.save_png(&output)?;
    eprintln!("{}: {}x{} slice at {}", output.display(), plane.width, plane.height, a.plane);
    Ok(())
}

impl SliceArgs {
    fn settings(&self) -> SliceSettings {
        SliceSettings {
            view: match self.show {
                Show::Field => SliceView::Field,
                Show::Sharp => SliceView::Sharp,
                Show::Error => SliceView::Error,
                Show::Gradient => SliceView::Gradient,
            },
            filter: self.filter.map(Filter::from),
            res_sweep: self.res_sweep.clone(),
            scale: self.scale,
        }
    }
}
