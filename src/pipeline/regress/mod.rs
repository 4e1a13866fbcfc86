//! Regression against reference renders: render every entry of a manifest,
//! compare each with its stored reference under the entry's tolerances (the
//! `diff` rules), keep images of the failures and one HTML page; or bless,
//! rewriting the references from the current renders.
//!
//! The report folder describes the last run alone: its page, its failures'
//! images and the JUnit file are written together, all or none, and images
//! an earlier run left there are removed. A filter or shard that selects no
//! entry is an error (a typo must not pass CI) unless empty runs are allowed.
//!
//! `manifest` reads the guarded entries, `run` renders and judges them,
//! `summary` holds what a run found, and `junit` writes that summary as
//! JUnit XML; the arrows run one way, run → junit → summary.

mod junit;
mod manifest;
mod run;
mod summary;

pub use junit::junit_xml;
pub use manifest::{Entry, Kind, Manifest, load_manifest};
pub use run::{RegressSettings, regress, render_entry};
pub use summary::{RegressRow, RegressSummary};
