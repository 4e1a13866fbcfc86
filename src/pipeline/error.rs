//! What can stop a pipeline, as one typed error: bad settings (which a
//! command line reports as usage errors), bad input, work that cannot fit,
//! and an incremental result that differs from the full one.

use std::path::PathBuf;

use crate::field::ModelError;
use crate::frame::FrameIoError;
use crate::scene::SceneError;

/// Why a pipeline stopped.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// A setting out of its range; `setting` names it as its struct field does.
    #[error("{setting} {problem}")]
    Setting {
        /// The setting, e.g. `res`.
        setting: &'static str,
        /// What is wrong with its value.
        problem: String,
    },
    /// A scene or script that could not be read.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A model or edit the field refuses.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The input cannot do what was asked of it (e.g. measure caches it lacks).
    #[error("{0}")]
    Unsuitable(String),
    /// A mesh lattice whose mesh would not fit in memory.
    #[error(
        "a mesh lattice of resolution {res} would need about {need_gib:.1} GiB, more than 80% of the {available_gib:.1} GiB available"
    )]
    MeshTooLarge {
        /// The lattice resolution asked for.
        res: u32,
        /// Estimated need.
        need_gib: f64,
        /// Memory available.
        available_gib: f64,
    },
    /// Edits grew the model past what its mesh lattice may span.
    #[error(
        "the edited model spans {cells:.0} cells of the mesh lattice, more than {max}: the edits grow it too far for the lattice's resolution"
    )]
    EditedTooLarge {
        /// Cells the model's bounds now span.
        cells: f32,
        /// Most cells allowed.
        max: u32,
    },
    /// An incremental result that differs from the one computed from scratch.
    #[error("the incremental result differs from the full one: {0}")]
    Mismatch(String),
    /// A frame that could not be written.
    #[error(transparent)]
    Frame(#[from] FrameIoError),
    /// A file that could not be written or read.
    #[error("{}: {message}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// An error of one frame of a script or one entry of a manifest, with where it is written.
    #[error("{at}: {source}")]
    At {
        /// Where: `file:line:column: frame N`, or an entry's name.
        at: String,
        /// The error.
        source: Box<PipelineError>,
    },
}

impl PipelineError {
    /// A setting out of range.
    #[must_use]
    pub fn setting(setting: &'static str, problem: impl Into<String>) -> Self {
        Self::Setting { setting, problem: problem.into() }
    }

    /// This error, located at `at`.
    #[must_use]
    pub fn at(self, at: impl Into<String>) -> Self {
        Self::At { at: at.into(), source: Box::new(self) }
    }

    /// The setting at fault, when the error is a bad setting (however located).
    #[must_use]
    pub fn bad_setting(&self) -> Option<&'static str> {
        match self {
            Self::Setting { setting, .. } => Some(setting),
            Self::At { source, .. } => source.bad_setting(),
            _ => None,
        }
    }
}

impl From<crate::output::FileSetError> for PipelineError {
    fn from(e: crate::output::FileSetError) -> Self {
        Self::File { path: e.path, message: format!("could not write: {}", e.error) }
    }
}

/// A pipeline's result.
pub type Result<T> = std::result::Result<T, PipelineError>;
