//! The regression manifest: which renders are guarded and how strictly, read
//! from `manifest.ron` with every scene it names checked before any render.

use std::path::{Component, Path};

use serde::Deserialize;

use crate::compare::Thresholds;
use crate::frame::Size;
use crate::pipeline::error::{PipelineError, Result};
use crate::pipeline::polygonize::MAX_RES;
use crate::scene::{Scene, SceneError, entry_positions, syntax_error, values};

/// The manifest: which renders are guarded, and how strictly.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// The guarded renders.
    pub entries: Vec<Entry>,
}

/// One guarded render.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Entry {
    /// Scene file name in the scenes directory.
    pub scene: String,
    /// Image size.
    pub size: Size,
    /// Field trace (`Field`) or mesh ray cast (`Mesh(res)`).
    pub kind: Kind,
    /// Evaluate through the caches (default: exact, indexed).
    #[serde(default)]
    pub cached: bool,
    /// A pixel differing by more than this (largest linear RGB difference) fails…
    #[serde(default = "default_fail", deserialize_with = "values::non_negative")]
    pub fail: f32,
    /// …when more than this percentage of pixels do.
    #[serde(default, deserialize_with = "values::percentage")]
    pub failpercent: f64,
    /// Any pixel above this fails.
    #[serde(default = "default_hardfail", deserialize_with = "values::non_negative")]
    pub hardfail: f32,
    /// A pixel differing by more than this warns… (default: `fail`, so an
    /// entry warns only when it is given a tighter `warn`).
    #[serde(default, deserialize_with = "some_non_negative")]
    pub warn: Option<f32>,
    /// …when more than this percentage of pixels do (default: `failpercent`).
    #[serde(default, deserialize_with = "some_percentage")]
    pub warnpercent: Option<f64>,
}

/// What an entry renders.
#[derive(Clone, Copy, Debug, Deserialize)]
pub enum Kind {
    /// The field ray trace.
    Field,
    /// The mesh polygonized at this resolution, ray cast.
    Mesh(u32),
}

fn default_fail() -> f32 {
    // Two 8-bit steps near mid-grey: tolerant of last-bit float differences across machines.
    0.01
}

fn default_hardfail() -> f32 {
    0.25
}

fn some_non_negative<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Option<f32>, D::Error> {
    values::non_negative(d).map(Some)
}

fn some_percentage<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Option<f64>, D::Error> {
    values::percentage(d).map(Some)
}

impl Entry {
    /// The reference file name: scene stem, kind, size.
    #[must_use]
    pub fn file_name(&self) -> String {
        let stem = self.scene.trim_end_matches(".ron");
        let kind = match self.kind {
            Kind::Field => "field".to_string(),
            Kind::Mesh(res) => format!("mesh{res}"),
        };
        let mode = if self.cached { "-cached" } else { "" };
        format!("{stem}-{kind}{mode}-{}x{}.png", self.size.0, self.size.1)
    }

    /// The reference's name without `.png`: what `--entry` takes.
    #[must_use]
    pub fn name(&self) -> String {
        self.file_name().trim_end_matches(".png").to_string()
    }

    /// The `diff` thresholds the entry is judged by.
    #[must_use]
    pub fn thresholds(&self) -> Thresholds {
        Thresholds {
            fail: self.fail,
            failpercent: self.failpercent,
            hardfail: self.hardfail,
            warn: self.warn.unwrap_or(self.fail),
            warnpercent: self.warnpercent.unwrap_or(self.failpercent),
            ..Thresholds::default()
        }
    }
}

/// Why a scene path cannot name an entry: a path reaching outside the scenes
/// folder (absolute, or through `..`) would also put its reference and its
/// report images outside theirs.
fn outside(scene: &str) -> Option<&'static str> {
    let path = Path::new(scene);
    if path.is_absolute() || scene.starts_with(['/', '\\']) {
        return Some("is absolute; scenes are named relative to the scenes folder");
    }
    let climbs = path.components().any(|c| !matches!(c, Component::Normal(_) | Component::CurDir));
    climbs.then_some("climbs out of the scenes folder (`..`); name scenes inside it")
}

/// Reads `refs/manifest.ron`, and checks that every scene it names loads,
/// before anything is rendered: a scene missing is reported at its entry.
pub fn load_manifest(refs: &Path, scenes: &Path) -> Result<Manifest> {
    let path = refs.join("manifest.ron");
    let label = path.display().to_string();
    let text = std::fs::read_to_string(&path).map_err(|cause| match cause.kind() {
        std::io::ErrorKind::NotFound => PipelineError::Unsuitable(format!(
            "{label}: no manifest here; a reference folder starts from one (copy images/ref/manifest.ron, keep the entries to guard, then --bless)"
        )),
        _ => SceneError::Io { path: label.clone(), cause }.into(),
    })?;
    let syntax =
        |line, column, message| PipelineError::Scene(SceneError::Syntax { path: label.clone(), line, column, message });
    let manifest: Manifest = ron::from_str(&text).map_err(|e| PipelineError::Scene(syntax_error(&label, &text, &e)))?;
    let positions = entry_positions(&text);
    for (k, entry) in manifest.entries.iter().enumerate() {
        let scene = scenes.join(&entry.scene);
        if let Some(why) = outside(&entry.scene) {
            let (line, column) = positions.get(k).copied().unwrap_or((1, 1));
            return Err(syntax(line, column, format!("scene {:?} {why}", entry.scene)));
        }
        if !scene.is_file() {
            let (line, column) = positions.get(k).copied().unwrap_or((1, 1));
            return Err(syntax(line, column, format!("no scene {:?} in {}", entry.scene, scenes.display())));
        }
        if let Kind::Mesh(res) = entry.kind
            && !(1..=MAX_RES).contains(&res)
        {
            let (line, column) = positions.get(k).copied().unwrap_or((1, 1));
            return Err(syntax(line, column, format!("Mesh({res}): the resolution must be between 1 and {MAX_RES}")));
        }
        Scene::load(&scene)?;
    }
    Ok(manifest)
}
