//! Choosing how a pipeline evaluates the field: exactly (through the index,
//! or the naive traversal the papers time against) or through the scene's
//! caches, and how much memory the caches may hold.

use super::error::{PipelineError, Result};
use crate::cache::SLOT_BYTES;
use crate::cache::pool::MIN_BUDGET_SLOTS;
use crate::field::{EvalMode, Model, TracerChoice};
use crate::trace::kernel::KernelSupports;

/// Which field to show: the true one, or the one the scene's caches reconstruct.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FieldChoice {
    /// Each cache answers from its lattice where the cost model says it
    /// pays, and passes through elsewhere (see [`crate::field::CacheDecision`]).
    Auto,
    /// Exact evaluation of every node (caches pass through).
    Exact,
    /// Cache nodes answer from their lattices (lazily filled with exact samples).
    Cached,
}

/// How exact evaluation finds the primitives near a point.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ExactLookup {
    /// Through the spatial index over wide blends.
    #[default]
    Indexed,
    /// Plain tree traversal with per-node box rejection (the paper's baseline).
    Naive,
}

/// How to evaluate a scene's field.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EvalSettings {
    /// Auto, exact or cached; `None`: auto, or exact when the lookup is naive.
    pub field: Option<FieldChoice>,
    /// How exact evaluation finds nearby primitives (naive only with exact evaluation).
    pub lookup: ExactLookup,
    /// Cap on the caches' sample storage, in megabytes (least-recently-used
    /// blocks are evicted and re-evaluated on demand; images do not change).
    pub cache_budget_mb: Option<f64>,
    /// Which ray tracer renders the model.
    pub tracer: TracerChoice,
}

/// Bytes per megabyte, as the cache budget counts them.
pub const MB: f64 = 1024.0 * 1024.0;

impl EvalSettings {
    /// The evaluation mode for `model`; applies the cache budget to it.
    pub fn apply(&self, model: &mut Model) -> Result<EvalMode> {
        let mode = self.apply_field(model)?;
        model.set_tracer(self.tracer);
        if self.tracer == TracerChoice::Kernel {
            KernelSupports::of(model, mode).map_err(|why| {
                PipelineError::setting(
                    "tracer",
                    format!("kernel applies to sums of points and segments only: {why} (try --tracer auto)"),
                )
            })?;
        }
        Ok(mode)
    }

    /// The evaluation mode for `model`, its caches' lattices put in use or not.
    fn apply_field(&self, model: &mut Model) -> Result<EvalMode> {
        // Asking for the naive baseline asks for exact evaluation.
        let default = if self.lookup == ExactLookup::Naive { FieldChoice::Exact } else { FieldChoice::Auto };
        if let Some(mb) = self.cache_budget_mb {
            let min_mb = (MIN_BUDGET_SLOTS * SLOT_BYTES) as f64 / MB;
            if !(mb.is_finite() && mb >= min_mb) {
                return Err(PipelineError::setting("cache_budget", format!("must be at least {min_mb} MB, got {mb}")));
            }
            model.set_cache_budget(Some((mb * MB) as usize));
        }
        match (self.field.unwrap_or(default), self.lookup) {
            // With no cache in use, auto is exact evaluation, to the bit.
            (FieldChoice::Auto, ExactLookup::Indexed) => {
                Ok(if model.use_lattices(true) > 0 { EvalMode::Cached } else { EvalMode::Indexed })
            }
            (FieldChoice::Auto, ExactLookup::Naive) => {
                Err(PipelineError::setting("eval", "naive applies to exact evaluation; add --mode exact"))
            }
            (FieldChoice::Exact, ExactLookup::Indexed) => Ok(EvalMode::Indexed),
            (FieldChoice::Exact, ExactLookup::Naive) => Ok(EvalMode::Naive),
            (FieldChoice::Cached, ExactLookup::Indexed) => {
                model.use_lattices(false);
                Ok(EvalMode::Cached)
            }
            (FieldChoice::Cached, ExactLookup::Naive) => {
                Err(PipelineError::setting("eval", "naive applies to exact evaluation; add --mode exact"))
            }
        }
    }
}
