//! What a regression run found: one row per entry, and the references blessed.

use std::path::PathBuf;

use crate::compare::{DiffReport, Verdict};

/// One entry's outcome: its reference name and its judgement (`None`: no readable reference).
pub type RegressRow = (String, Option<DiffReport>);

/// What a regression run found.
#[derive(Debug)]
pub struct RegressSummary {
    /// Each entry compared (none when blessing).
    pub rows: Vec<RegressRow>,
    /// References written (when blessing).
    pub blessed: Vec<PathBuf>,
}

impl RegressSummary {
    /// Entries that failed, a missing reference counted.
    #[must_use]
    pub fn failed(&self) -> usize {
        self.rows.iter().filter(|r| r.1.as_ref().is_none_or(|d| d.verdict == Verdict::Fail)).count()
    }
}
