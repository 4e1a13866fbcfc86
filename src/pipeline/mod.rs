//! Pipelines: the stages joined into the jobs blobtrace does — polygonize a
//! model, render a scene by its field or by a mesh of it, compare the two,
//! keep an edit session up to date edit by edit, replay an edit script,
//! regress against reference renders, draw slices. Each takes plain settings
//! structs and reports through a [`Progress`] hook; the command line and the
//! viewer are thin layers over them.
//!
//! Scripting an edit session: load a scene, move a named node, get the dirty
//! rectangles and the updated frame, and check it equals a fresh render.
//!
//! ```
//! use blobtrace::field::{Edit, EvalMode};
//! use blobtrace::frame::Size;
//! use blobtrace::pipeline::{EditSession, PolygonizeSettings};
//! use blobtrace::scene::Scene;
//! use blobtrace::trace::render_model;
//!
//! let scene = Scene::parse(
//!     r#"Scene(camera: Camera(eye: (0.0, 0.0, 5.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
//!            size: (64, 48),
//!            model: Blend([
//!                Named("left", Point(center: (-0.7, 0.0, 0.0), radius: 1.0)),
//!                Named("right", Point(center: (0.7, 0.0, 0.0), radius: 1.0)),
//!            ]))"#,
//!     "inline",
//! )?;
//! let polygonize = PolygonizeSettings { res: 32, ..Default::default() };
//! let mut session = EditSession::new(scene, EvalMode::Indexed, Size(64, 48), &polygonize)?;
//!
//! let moved = session.apply(&[Edit::Translate { node: "right".into(), by: glam::Vec3::new(0.3, 0.0, 0.0) }])?;
//! // Only the rectangles around the moved point were traced again…
//! assert!(!moved.dirty.is_empty() && moved.row.dirty_fraction < 1.0);
//!
//! // …and the frame equals a render of the edited scene from scratch, through
//! // the session's settings (its tracer and mesh lattices stay the first frame's).
//! let fresh = render_model(&session.scene().model, EvalMode::Indexed, session.settings(), &|_| {}).0;
//! assert!(session.field_frame().same_image(&fresh));
//! assert!(session.verify().mismatch.is_none(), "the mesh equals a fresh polygonization too");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod cache_report;
mod compare;
mod cost_map;
mod edit_output;
mod edit_session;
mod error;
mod eval;
mod image_diff;
mod memory;
mod mesh_repair;
mod polygonize;
mod regress;
mod render;
mod replay;
mod slice;
mod threads;
mod tune;

pub use crate::progress::{Progress, Silent, rows, stage};
pub use cache_report::{CacheReport, NamedCacheStats};
pub use compare::{
    COMPARE_OPTIONAL_OUTPUTS, COMPARE_OUTPUTS, CompareReport, CompareSettings, Comparison, ErrorImages, ErrorScales,
    ErrorStats, StageSeconds, Tolerances, UsedScales, compare,
};
pub use cost_map::cost_map;
pub use edit_output::KeptFrames;
pub use edit_session::{EditSession, FrameRow, FrameUpdate, IDLE_SAMPLES, Pending, Verification, outline_dirty};
pub use error::{PipelineError, Result};
pub use eval::{EvalSettings, ExactLookup, FieldChoice, MB};
pub use image_diff::{DiffOutput, ImageDiffError, ImageDiffSettings, diff_images};
pub use memory::{available_memory_bytes, peak_resident_bytes, reset_peak_resident, resident_bytes};
pub use mesh_repair::{MAX_SNAP, MeshRepair, RepairReport, SnapEffect, repair_mesh};
pub use polygonize::{
    MAX_REFINE, MAX_RES, MeshMemory, MeshReport, PolygonizeSettings, cells_name, color_by_cache_error, polygonize,
    polygonizer_on, vertex_name,
};
pub use regress::{
    Counts, Entry, EntryImages, EntryPixels, EntryTolerances, Judgement, Kind, Manifest, Outcome, RegressRow,
    RegressSettings, RegressSummary, RunFacts, StoredStats, junit_xml, load_manifest, regress, render_entry,
    shell_quote,
};
pub use render::{MeshRenderReport, RenderFiles, RenderReport, render_field, render_mesh};
pub use replay::{EditReport, ScratchFrame, check_names, replay_from_scratch};
pub use slice::{PlaneView, SliceSettings, SliceView, plane_view, slice, slice_warnings};
pub use threads::{MAX_THREADS, with_threads, worker_pool};
pub use tune::{INSERT_RES, TuneReport, TuneRow, TuneSettings, Tuned, VertexError, error_slices, tune};
