//! Scene files: RON text → [`Scene`] (camera, size, iso-value, [`Model`]).
//!
//! Every bad value is reported as `file:line:column: problem`, from the
//! position the parser reached when the value failed its check.

mod build;
mod desc;
mod edit_desc;
mod locate;
mod messages;
mod point_files;
mod script;
pub mod values;
mod write;

use std::path::Path;

use glam::Vec3;

pub use crate::frame::Size;
pub use desc::{CameraDesc, Children, MAX_DEPTH, MAX_PRIMITIVES, MAX_SPLINE_POINTS, NodeDesc, Resolution, SceneDesc};
pub use edit_desc::{EditDesc, OperatorDesc};
pub use point_files::{PointCloud, read_points};
pub use script::{Script, entry_positions, load_script, parse_script};
pub use values::{Color, Finite, Positive, V3};

use crate::camera::{Camera, LookAt};
use crate::field::{Model, ModelError, NodeId};

/// Background colour where the scene names none (linear RGB).
pub const DEFAULT_BACKGROUND: Vec3 = Vec3::new(0.05, 0.055, 0.065);

/// A loaded scene, ready to render.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The viewpoint.
    pub camera: Camera,
    /// The viewpoint as the file writes it.
    pub look_at: LookAt,
    /// Default image size.
    pub size: Size,
    /// The BlobTree, with its iso-value.
    pub model: Model,
    /// Colour of pixels whose ray misses (linear RGB).
    pub background: Vec3,
}

/// Why a scene could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        cause: std::io::Error,
    },
    /// The text is not a valid scene, at a known place.
    #[error("{path}:{line}:{column}: {message}")]
    Syntax {
        /// The file.
        path: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// A `Points` node's particle file could not be read.
    #[error("{path}: {message}")]
    PointFile {
        /// The particle file.
        path: String,
        /// What is wrong, with the line or the point where there is one.
        message: String,
    },
    /// The scene parsed but describes an invalid model.
    #[error("{path}: {cause}")]
    Model {
        /// The file.
        path: String,
        /// The cause.
        cause: ModelError,
    },
}

impl Scene {
    /// Reads and builds the scene in `path`.
    pub fn load(path: impl AsRef<Path>) -> Result<Scene, SceneError> {
        let path = path.as_ref();
        let label = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|cause| SceneError::Io { path: label.clone(), cause })?;
        Scene::parse(&text, &label)
    }

    /// Builds a scene from RON text; `label` names the source in errors.
    pub fn parse(text: &str, label: &str) -> Result<Scene, SceneError> {
        on_a_deep_stack(|| {
            let desc = parse_desc_here(text, label)?;
            Scene::from_desc(&desc).map_err(|cause| match locate::locate(text, &cause) {
                Some((line, column)) => {
                    SceneError::Syntax { path: label.to_string(), line, column, message: cause.to_string() }
                }
                None => SceneError::Model { path: label.to_string(), cause },
            })
        })
    }

    /// Builds a scene from its parsed description.
    pub fn from_desc(desc: &SceneDesc) -> Result<Scene, ModelError> {
        Scene::from_desc_with_ids(desc).map(|(scene, _)| scene)
    }

    /// [`Scene::from_desc`], and the model node each description node
    /// became, in depth-first order of the description (parents first), so
    /// a tool that rewrites the description can read the model's answers
    /// about each of its nodes.
    pub fn from_desc_with_ids(desc: &SceneDesc) -> Result<(Scene, Vec<NodeId>), ModelError> {
        desc.check_size()?;
        let c = &desc.camera;
        let look_at = LookAt { eye: c.eye.0, target: c.target.0, up: c.up.0, fov_y: c.fov_y.0 };
        let camera = look_at.camera();
        let (model, ids) = build::model_with_ids(&desc.model, desc.threshold.0)?;
        model.check_reach()?;
        let background = desc.background.map_or(DEFAULT_BACKGROUND, |c| c.0);
        Ok((Scene { camera, look_at, size: desc.size, model, background }, ids))
    }
}

/// Changes to a scene's view, each part optional (from the command line, say).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ViewOverrides {
    /// New eye position.
    pub eye: Option<Vec3>,
    /// New point looked at.
    pub target: Option<Vec3>,
    /// New up direction.
    pub up: Option<Vec3>,
    /// New vertical field of view in degrees.
    pub fov_y: Option<f32>,
}

impl Scene {
    /// Looks at the scene as `overrides` say, keeping what they leave unset;
    /// refuses a view that is no camera (and leaves the scene as it was).
    pub fn override_view(&mut self, overrides: &ViewOverrides) -> Result<(), String> {
        let v = self.look_at;
        let look_at = LookAt {
            eye: overrides.eye.unwrap_or(v.eye),
            target: overrides.target.unwrap_or(v.target),
            up: overrides.up.unwrap_or(v.up),
            fov_y: overrides.fov_y.unwrap_or(v.fov_y),
        };
        look_at.check()?;
        (self.look_at, self.camera) = (look_at, look_at.camera());
        Ok(())
    }
}

/// Parses RON text into a [`SceneDesc`], with positions in errors.
pub fn parse_desc(text: &str, label: &str) -> Result<SceneDesc, SceneError> {
    on_a_deep_stack(|| parse_desc_here(text, label))
}

/// [`parse_desc`] on the calling thread's stack. The particle files of
/// `Points` nodes are read too, relative to the folder of `label` (the
/// scene file's path; for text from elsewhere, the working folder).
fn parse_desc_here(text: &str, label: &str) -> Result<SceneDesc, SceneError> {
    let text = without_bom(text);
    let mut desc = ron_options().from_str::<SceneDesc>(text).map_err(|e| syntax_error(label, text, &e))?;
    let folder = Path::new(label).parent().unwrap_or(Path::new(""));
    desc.read_point_files(folder).map_err(|(path, message)| SceneError::PointFile { path, message })?;
    Ok(desc)
}

/// Nesting levels of brackets RON may read: well above the few levels each
/// of [`MAX_DEPTH`] nodes takes, so the model's own limit, counted in nodes
/// and reported as such, is the one a file meets.
const RECURSION_LIMIT: usize = 8 * MAX_DEPTH;

/// Stack for reading and building a file: parsing and building recurse once
/// per level of the model, a few kilobytes a level (more in debug builds),
/// which [`MAX_DEPTH`] levels would take past the 2 MB of a spawned thread.
const PARSE_STACK_BYTES: usize = 256 << 20;

/// Runs `f` on a thread with [`PARSE_STACK_BYTES`] of stack (only the pages
/// touched are used), or here if no such thread can be made.
fn on_a_deep_stack<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    // The work is taken by whichever runs it: the thread, or this one when
    // the thread could not be made.
    let work = std::sync::Mutex::new(Some(f));
    let run = || work.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take().map(|f| f());
    std::thread::scope(|scope| {
        let thread = std::thread::Builder::new().name("parse".into()).stack_size(PARSE_STACK_BYTES);
        let ran = match thread.spawn_scoped(scope, run) {
            Ok(handle) => handle.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)),
            Err(_) => None,
        };
        ran.or_else(run).expect("the work runs once")
    })
}

/// How scene and script files are read. Unwrapped variant newtypes let a
/// node read its values by place or by name (`Ricci(4, […])` and
/// `Ricci(n: 4, children: […])`).
fn ron_options() -> ron::Options {
    ron::Options::default()
        .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
        .with_default_extension(ron::extensions::Extensions::UNWRAP_VARIANT_NEWTYPES)
        .with_recursion_limit(RECURSION_LIMIT)
}

/// `text` without the byte-order mark some editors put first.
fn without_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

/// A RON error of the file `label` holding `text`, at its position, said in
/// the scene format's words.
pub fn syntax_error(label: &str, text: &str, e: &ron::error::SpannedError) -> SceneError {
    let (mut line, mut column) = (e.span.start.line, e.span.start.col);
    let start = text.split_inclusive('\n').take(line.saturating_sub(1)).map(str::len).sum::<usize>();
    let mut rest = text[start.min(text.len())..].chars();
    rest.by_ref().take(column.saturating_sub(1)).for_each(drop);
    // Point at what stands there, not at the space before it.
    let mut rest = rest.as_str();
    while let Some(c) = rest.chars().next().filter(|c| c.is_whitespace()) {
        (line, column) = if c == '\n' { (line + 1, 1) } else { (line, column + 1) };
        rest = &rest[c.len_utf8()..];
    }
    let message = messages::explain(&e.code, rest);
    SceneError::Syntax { path: label.to_string(), line, column, message }
}
