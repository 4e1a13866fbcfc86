//! `blobtrace slice`: images of the field on a plane — f with its iso-contour,
//! the sharp view per filter (the paper's Figure 6), error_C per filter and
//! cache resolution (Figures 5 and 7), and the cached gradient's angle error
//! (Figure 4's question).

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, ValueEnum};
use glam::Vec3A;

use super::{check_output_file, scene_stem, with_threads};
use crate::cache::Filter;
use crate::compare::{Rgb8Image, Scale, heat_map, panel};
use crate::field::{EvalMode, Field, ModelField};
use crate::scene::{Scene, Size, parse_desc};
use crate::slice::{SlicePlane, iso_contour, sample, sharp_image};

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
    #[arg(long, value_parser = super::parse_size, default_value = "400x400")]
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
    let plane = SlicePlane::parse(&a.plane, &scene.model.bounds(), a.size.0, a.size.1)?;
    if let Some(s) = a.scale {
        anyhow::ensure!(s.is_finite() && s > 0.0, "--scale must be positive, got {s}");
    }
    for &r in &a.res_sweep {
        anyhow::ensure!((2..=1024).contains(&r), "--res-sweep values must lie in 2..=1024, got {r}");
    }
    if a.show != Show::Field {
        anyhow::ensure!(scene.model.counts().caches > 0, "--show {:?} compares caches, and the scene has none", a.show);
    }
    let output = a.output.clone().unwrap_or_else(|| {
        PathBuf::from(format!("{}-{}.png", scene_stem(&a.scene), format!("{:?}", a.show).to_lowercase()))
    });
    check_output_file(&output, "png")?;
    let image = with_threads(a.threads, || draw(a, &text, &label, &scene, &plane))??;
    image.save_png(&output)?;
    eprintln!("{}: {}x{} slice at {}", output.display(), plane.width, plane.height, a.plane);
    Ok(())
}

fn draw(a: &SliceArgs, text: &str, label: &str, scene: &Scene, plane: &SlicePlane) -> anyhow::Result<Rgb8Image> {
    let exact = ModelField::new(&scene.model, EvalMode::Indexed);
    let t = exact.threshold();
    let (w, h) = (plane.width, plane.height);
    let filters: Vec<Filter> = a.filter.map_or(vec![Filter::Trilinear, Filter::Triquadratic], |f| vec![f.into()]);
    let resolutions: Vec<Option<u32>> =
        if a.res_sweep.is_empty() { vec![None] } else { a.res_sweep.iter().map(|&r| Some(r)).collect() };
    match a.show {
        Show::Field => {
            let values = sample(plane, |p| exact.value(p));
            let mut img = heat_map(&values, w, h, Scale::Magnitude { max: a.scale.unwrap_or(1.0) }, "f", "");
            for (i, on) in iso_contour(&values, w, h, t).into_iter().enumerate() {
                if on {
                    img.put(i as i64 % i64::from(w), i as i64 / i64::from(w), [255, 255, 255]);
                }
            }
            Ok(img)
        }
        Show::Sharp => {
            let mut items = vec![("exact".to_string(), sharp_image(&sample(plane, |p| exact.value(p)), w, h, t))];
            for &filter in &filters {
                let variant = cache_variant(text, label, filter, resolutions[0])?;
                let cached = ModelField::new(&variant.model, EvalMode::Cached);
                items.push((
                    filter_name(filter, resolutions[0]),
                    sharp_image(&sample(plane, |p| cached.value(p)), w, h, t),
                ));
            }
            Ok(panel(&items, items.len()))
        }
        Show::Error | Show::Gradient => {
            let exact_values = measure(a.show, plane, &exact, &exact);
            let mut items = vec![];
            for &filter in &filters {
                for &res in &resolutions {
                    let variant = cache_variant(text, label, filter, res)?;
                    let cached = ModelField::new(&variant.model, EvalMode::Cached);
                    let values = measure(a.show, plane, &cached, &exact);
                    let errors: Vec<f32> = match a.show {
                        Show::Error => values.iter().zip(&exact_values).map(|(c, e)| (c - e).abs()).collect(),
                        _ => values,
                    };
                    let (scale, title, unit) = match a.show {
                        Show::Error => (a.scale.unwrap_or(0.02), "error_C = |f_C - f|", ""),
                        _ => (a.scale.unwrap_or(10.0), "gradient angle error", "deg"),
                    };
                    let mean = mean_finite(&errors);
                    let title = format!("{title}, mean {mean:.2e}");
                    items.push((
                        filter_name(filter, res),
                        heat_map(&errors, w, h, Scale::Magnitude { max: scale }, &title, unit),
                    ));
                }
            }
            Ok(panel(&items, resolutions.len()))
        }
    }
}

/// Per pixel: the value of `field` (for error), or the angle in degrees
/// between its gradient and the exact one (for gradient; `NaN` where the exact
/// gradient vanishes).
fn measure(show: Show, plane: &SlicePlane, field: &ModelField, exact: &ModelField) -> Vec<f32> {
    match show {
        Show::Gradient => sample(plane, |p: Vec3A| {
            let (g, e) = (field.gradient(p), exact.gradient(p));
            if e.length() < 1e-6 || g.length() < 1e-6 {
                return f32::NAN;
            }
            g.normalize().dot(e.normalize()).clamp(-1.0, 1.0).acos().to_degrees()
        }),
        _ => sample(plane, |p| field.value(p)),
    }
}

fn mean_finite(values: &[f32]) -> f64 {
    let finite: Vec<f64> = values.iter().filter(|v| v.is_finite()).map(|&v| f64::from(v)).collect();
    finite.iter().sum::<f64>() / finite.len().max(1) as f64
}

fn filter_name(filter: Filter, res: Option<u32>) -> String {
    let name = format!("{filter:?}").to_lowercase();
    res.map_or(name.clone(), |r| format!("{name}, res {r}"))
}

/// The scene again with every cache using `filter` for values and gradients
/// (and `res`, when given): fresh, empty caches.
fn cache_variant(text: &str, label: &str, filter: Filter, res: Option<u32>) -> anyhow::Result<Scene> {
    let mut desc = parse_desc(text, label)?;
    desc.model.for_each_cache(&mut |r, value, gradient| {
        if let Some(res) = res {
            r.0 = res;
        }
        (*value, *gradient) = (filter, filter);
    });
    Scene::from_desc(&desc).map_err(|cause| anyhow::anyhow!("{label}: {cause}"))
}
