//! Regression against reference renders: render every entry of a manifest,
//! compare each with its stored reference under the entry's tolerances (the
//! `diff` rules), keep images of the entries that differ, one HTML page and
//! its summary in JSON; or bless, rewriting the references from the current
//! renders.
//!
//! The report folder describes the last run alone: its page, summary, images
//! and the JUnit file are written together, all or none, and images an
//! earlier run left there are removed. A filter or shard that selects no
//! entry is an error (a typo must not pass CI) unless empty runs are allowed.
//!
//! `manifest` reads the guarded entries, `run` renders them, `entry_check`
//! judges each and makes its images, `summary` holds what a run found,
//! `page` and `junit` write that summary for people and for CI, and
//! `command_line` quotes the commands they give.

mod command_line;
mod entry_check;
mod junit;
mod manifest;
mod markup;
mod page;
mod run;
mod summary;

pub use command_line::shell_quote;
pub use junit::junit_xml;
pub use manifest::{Entry, Kind, Manifest, load_manifest};
pub use run::{RegressSettings, regress, render_entry};
pub use summary::{
    Counts, EntryImages, EntryPixels, EntryTolerances, Judgement, Outcome, RegressRow, RegressSummary, RunFacts,
    StoredStats,
};
