//! What a regression run found: one row per entry (what it guards, how it
//! was judged, the statistics of its stored images, its images in the
//! report), the run's own facts, and the references blessed. `summary.json`
//! is this, serialized.

use std::path::PathBuf;

use serde::Serialize;

use crate::compare::{MaxAt, Verdict};

/// How an entry came out; the order is the report's (failures first).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Outcome {
    /// Above a failure threshold, or no readable reference.
    Failed,
    /// Above the warning thresholds only.
    Warned,
    /// Within every threshold.
    Passed,
}

/// The manifest's tolerances of an entry.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct EntryTolerances {
    /// A pixel above this (largest linear RGB difference) counts against `failpercent`.
    pub fail: f32,
    /// Percentage of pixels allowed above `fail`.
    pub failpercent: f64,
    /// A pixel above this counts against `warnpercent`.
    pub warn: f32,
    /// Percentage of pixels allowed above `warn`.
    pub warnpercent: f64,
    /// Any pixel above this fails.
    pub hardfail: f32,
}

/// The verdict's own statistic: the largest linear RGB difference per pixel
/// of the render (quantized as its PNG) against the reference, as `regress`
/// judges it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Judgement {
    /// Pass, warn or fail.
    pub verdict: Verdict,
    /// Largest difference.
    pub max: f32,
    /// Its pixel (column, row).
    pub max_at: Option<(u32, u32)>,
    /// Pixels above `fail`.
    pub over_fail_px: usize,
    /// The same as a percentage of the pixels.
    pub over_fail_percent: f64,
    /// Pixels above `warn`.
    pub over_warn_px: usize,
    /// The same as a percentage.
    pub over_warn_percent: f64,
    /// Mean over every pixel.
    pub mean: f64,
    /// Pixels compared.
    pub pixels: usize,
}

/// The statistics `blobtrace diff` prints on the two stored PNGs (reference
/// first): idiff's over the stored codes, and ꟻLIP's.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StoredStats {
    /// Mean difference over every channel of every pixel.
    pub mean: f64,
    /// Root mean square of the same.
    pub rms: f64,
    /// Peak signal-to-noise ratio in dB (`None`: the images are equal).
    pub psnr: Option<f64>,
    /// Largest difference.
    pub max: f32,
    /// Where, in which channel, and both images' values there.
    pub max_at: Option<MaxAt>,
    /// Pixels above the entry's `warn`.
    pub over_warn_px: usize,
    /// Pixels above the entry's `fail`.
    pub over_fail_px: usize,
    /// ꟻLIP's mean error.
    pub flip_mean: f32,
    /// ꟻLIP's weighted median.
    pub flip_weighted_median: f32,
}

/// An entry's images in the report folder (file names in it).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct EntryImages {
    /// The stored reference.
    pub reference: Option<String>,
    /// The render, as its reference would be stored.
    pub actual: Option<String>,
    /// |actual − reference| in 8-bit codes, ×8.
    pub difference: Option<String>,
    /// Heat map of the judged difference with its colour key.
    pub heat: Option<String>,
    /// ꟻLIP error map with its colour key.
    pub flip: Option<String>,
}

/// Both images' PNG files, which the page carries as data (a page opened
/// from disk cannot read back the pixels of its image files) for its pixel
/// probe and its amplified difference.
#[derive(Clone, Debug, PartialEq)]
pub struct EntryPixels {
    /// The stored reference's PNG.
    pub reference: Vec<u8>,
    /// The render's PNG.
    pub actual: Vec<u8>,
}

/// One entry's outcome.
#[derive(Clone, Debug, Serialize)]
pub struct RegressRow {
    /// Its place in the manifest (from 0).
    pub place: usize,
    /// Its reference's file name relative to the references folder (the
    /// scene's folders kept), such as `pair-field-96x72.png`.
    pub name: String,
    /// The scene file, relative to the scenes folder.
    pub scene: String,
    /// Image size.
    pub size: (u32, u32),
    /// `field` or `mesh`.
    pub kind: &'static str,
    /// The mesh's polygonization resolution.
    pub mesh_res: Option<u32>,
    /// Evaluated through the caches.
    pub cached: bool,
    /// The manifest's tolerances.
    pub tolerances: EntryTolerances,
    /// How it came out.
    pub outcome: Outcome,
    /// The verdict's statistic (`None`: no readable reference).
    pub judgement: Option<Judgement>,
    /// `diff`'s statistics on the stored images (entries that differ).
    pub stored: Option<StoredStats>,
    /// Seconds its render took.
    pub seconds: f64,
    /// The command that blesses this entry alone.
    pub bless: String,
    /// Its images in the report.
    pub images: EntryImages,
    /// Both images' PNG files (entries that differ, up to a size).
    #[serde(skip)]
    pub pixels: Option<EntryPixels>,
}

/// Entries by outcome.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Counts {
    /// Within every threshold.
    pub passed: usize,
    /// Above the warning thresholds only.
    pub warned: usize,
    /// Failed (a missing reference counted).
    pub failed: usize,
    /// Left out by `--filter`, `--entry` or `--shard`.
    pub skipped: usize,
}

/// The run itself.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RunFacts {
    /// The command line, quoted for a POSIX shell.
    pub command: String,
    /// The scenes folder, as given.
    pub scenes: String,
    /// The references folder, as given.
    pub refs: String,
    /// `git rev-parse HEAD` of the scenes folder's repository, when it is in one.
    pub scenes_commit: Option<String>,
    /// blobtrace's version.
    pub version: String,
    /// When the run started (UTC, RFC 3339).
    pub date: String,
    /// Lanes of the field sums on this machine (8 with AVX2 and FMA, else 4).
    pub simd_width: usize,
    /// Seconds the run took.
    pub seconds: f64,
}

/// What a regression run found.
#[derive(Clone, Debug, Serialize)]
pub struct RegressSummary {
    /// `pass`, `warn` or `fail`: the worst outcome.
    pub verdict: Verdict,
    /// Entries by outcome.
    pub counts: Counts,
    /// The run itself.
    pub run: RunFacts,
    /// Each entry compared, in manifest order (none when blessing).
    pub entries: Vec<RegressRow>,
    /// References written (when blessing).
    #[serde(skip)]
    pub blessed: Vec<PathBuf>,
}

impl RegressSummary {
    /// The summary of `entries`, with `skipped` entries left out of the run.
    #[must_use]
    pub fn new(run: RunFacts, entries: Vec<RegressRow>, skipped: usize) -> Self {
        let count = |o: Outcome| entries.iter().filter(|r| r.outcome == o).count();
        let counts = Counts {
            passed: count(Outcome::Passed),
            warned: count(Outcome::Warned),
            failed: count(Outcome::Failed),
            skipped,
        };
        let verdict = match (counts.failed, counts.warned) {
            (0, 0) => Verdict::Pass,
            (0, _) => Verdict::Warn,
            _ => Verdict::Fail,
        };
        Self { verdict, counts, run, entries, blessed: vec![] }
    }

    /// Entries that failed, a missing reference counted.
    #[must_use]
    pub fn failed(&self) -> usize {
        self.counts.failed
    }

    /// `summary.json`'s text.
    #[must_use]
    pub fn json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a summary serializes")
    }
}

/// A row of an entry whose reference is missing, for tests of what reads rows.
#[cfg(test)]
pub(super) fn missing_row(name: &str) -> RegressRow {
    let tolerances = EntryTolerances { fail: 0.01, failpercent: 0.0, warn: 0.01, warnpercent: 0.0, hardfail: 0.25 };
    RegressRow {
        place: 0,
        name: name.to_string(),
        scene: "sphere.ron".into(),
        size: (8, 6),
        kind: "field",
        mesh_res: None,
        cached: false,
        tolerances,
        outcome: Outcome::Failed,
        judgement: None,
        stored: None,
        seconds: 0.0,
        bless: String::new(),
        images: EntryImages::default(),
        pixels: None,
    }
}
