//! Judging one entry: its render against its stored reference under the
//! manifest's tolerances, and for an entry that differs, `diff`'s statistics
//! on the two stored images and the images the report shows (reference,
//! render, difference, heat map, ꟻLIP error map), named by the entry's place
//! in the manifest so no name can collide with another or leave the folder.

use std::path::Path;

use super::manifest::{Entry, Kind};
use super::summary::{EntryImages, EntryPixels, EntryTolerances, Judgement, Outcome, RegressRow, StoredStats};
use crate::compare::{
    FlipStats, Metric, Verdict, default_pixels_per_degree, differences, flip_errors, flip_stats, judge, load_image,
};
use crate::draw::{Rgb8Image, Scale, SpecialLabels, heat_map_zoomed};
use crate::frame::Frame;
use crate::output::FileSet;
use crate::pipeline::error::{PipelineError, Result};
use crate::pipeline::image_diff::{ImageDiffSettings, diff_images};

/// The largest image whose PNGs the page carries for its pixel probe.
const MAX_PROBE_PIXELS: usize = 1024 * 1024;

/// The kinds of image an entry can have in the report, as its file names end.
const IMAGE_KINDS: [&str; 5] = ["ref", "actual", "diff", "heat", "flip"];

/// What the run knows of an entry besides its images.
pub struct EntryFacts<'a> {
    /// Its place in the manifest.
    pub place: usize,
    /// The entry.
    pub entry: &'a Entry,
    /// Seconds its render took.
    pub seconds: f64,
    /// The command that blesses it alone.
    pub bless: String,
}

/// Whether a file of the report folder is an entry's image, as
/// [`image_name`] names them (or as reports before it did).
pub fn is_entry_image(name: &str) -> bool {
    let Some(stem) = name.strip_suffix(".png") else { return false };
    let numbered =
        stem.split_once('-').is_some_and(|(place, _)| !place.is_empty() && place.bytes().all(|b| b.is_ascii_digit()));
    let ours = numbered && IMAGE_KINDS.iter().any(|k| stem.ends_with(&format!("-{k}")));
    ours || ["ref-", "actual-", "diff-", "heat-"].iter().any(|p| name.starts_with(p))
}

/// The report's file name of an entry's image of `kind`: its place, then its
/// name with anything but letters, digits, `.`, `_` and `-` made `_`.
fn image_name(place: usize, name: &str, kind: &str) -> String {
    let stem = name.trim_end_matches(".png");
    let safe: String =
        stem.chars().take(80).map(|c| if c.is_ascii_alphanumeric() || "._-".contains(c) { c } else { '_' }).collect();
    format!("{place:03}-{safe}-{kind}.png")
}

/// Judges the render `actual` of an entry against the reference stored at
/// `reference`, adding the images of an entry that differs to `files`.
pub fn check_entry(
    facts: &EntryFacts,
    actual: &Frame,
    reference: &Path,
    report: &Path,
    files: &mut FileSet,
) -> Result<RegressRow> {
    let entry = facts.entry;
    let mut row = empty_row(facts);
    let mut add = |kind: &str, bytes: Vec<u8>| {
        let file = image_name(facts.place, &row.name, kind);
        files.add(report.join(&file), bytes);
        file
    };
    let actual_png = actual.png_bytes_for(reference)?;
    let Ok(expected) = load_image(reference) else {
        row.images.actual = Some(add("actual", actual_png));
        return Ok(row);
    };
    let frame = &expected.frame;
    if (frame.width, frame.height) != (actual.width, actual.height) {
        let (w, h) = (frame.width, frame.height);
        let message = format!("reference is {w}x{h}, the render {}x{}", actual.width, actual.height);
        return Err(PipelineError::File { path: reference.to_path_buf(), message });
    }
    // Compare what the files hold: the render quantized to 8 bits like its reference.
    let quantized = quantize(actual);
    let values = differences(&quantized, frame, Metric::Abs);
    let thresholds = entry.thresholds();
    let diff = judge(Metric::Abs, &values, &vec![false; values.len()], frame.width, thresholds);
    row.outcome = match diff.verdict {
        Verdict::Pass => Outcome::Passed,
        Verdict::Warn => Outcome::Warned,
        Verdict::Fail => Outcome::Failed,
    };
    row.judgement = Some(Judgement {
        verdict: diff.verdict,
        max: diff.max,
        max_at: diff.max_at.as_ref().map(|m| (m.x, m.y)),
        over_fail_px: diff.over_fail_px,
        over_fail_percent: diff.over_fail_percent,
        over_warn_px: diff.over_warn_px,
        over_warn_percent: diff.over_warn_percent,
        mean: diff.mean,
        pixels: diff.compared,
    });
    if diff.verdict == Verdict::Pass {
        return Ok(row);
    }
    let (codes_ref, codes_actual) = (frame.to_srgb8(), quantized.to_srgb8());
    let (w, h) = (frame.width, frame.height);
    let ppd = default_pixels_per_degree();
    // ꟻLIP of the stored codes, as `diff --metric flip` computes it: once, for its statistics and its map.
    let errors = flip_errors(&codes_ref, &codes_actual, w, h, ppd);
    row.stored = Some(stored_stats(reference, &actual_png, facts, flip_stats(&errors, w, h, ppd))?);
    let unreadable = |e: std::io::Error| PipelineError::File { path: reference.to_path_buf(), message: e.to_string() };
    let reference_png = std::fs::read(reference).map_err(unreadable)?;
    if (w * h) as usize <= MAX_PROBE_PIXELS {
        row.pixels = Some(EntryPixels { reference: reference_png.clone(), actual: actual_png.clone() });
    }
    row.images.reference = Some(add("ref", reference_png));
    row.images.actual = Some(add("actual", actual_png));
    let difference = difference_image(&codes_ref, &codes_actual, w, h);
    row.images.difference = Some(add("diff", difference.png_bytes_for(reference)?));
    // The maps are drawn at the page's first zoom, so their colour keys keep
    // a readable size beside the scaled-up images.
    let (k, labels) = (view_zoom(w), SpecialLabels::default());
    let title = ("largest linear RGB difference", "");
    let heat = heat_map_zoomed(&values, (w, h), k, Scale::Magnitude { max: 0.1 }, title, &labels);
    row.images.heat = Some(add("heat", heat.png_bytes_for(reference)?));
    let title = ("FLIP error", Metric::Flip.unit());
    let flip = heat_map_zoomed(&errors, (w, h), k, Scale::Magnitude { max: 1.0 }, title, &labels);
    row.images.flip = Some(add("flip", flip.png_bytes_for(reference)?));
    Ok(row)
}

/// The row of an entry before it is judged: failed, for want of a reference.
fn empty_row(facts: &EntryFacts) -> RegressRow {
    let entry = facts.entry;
    let t = entry.thresholds();
    RegressRow {
        place: facts.place,
        name: entry.file_name(),
        scene: entry.scene.clone(),
        size: (entry.size.0, entry.size.1),
        kind: match entry.kind {
            Kind::Field => "field",
            Kind::Mesh(_) => "mesh",
        },
        mesh_res: match entry.kind {
            Kind::Field => None,
            Kind::Mesh(res) => Some(res),
        },
        cached: entry.cached,
        tolerances: EntryTolerances {
            fail: t.fail,
            failpercent: t.failpercent,
            warn: t.warn,
            warnpercent: t.warnpercent,
            hardfail: t.hardfail,
        },
        outcome: Outcome::Failed,
        judgement: None,
        stored: None,
        seconds: facts.seconds,
        bless: facts.bless.clone(),
        images: EntryImages::default(),
        pixels: None,
    }
}

/// What `blobtrace diff REFERENCE ACTUAL` prints on the stored images, run
/// on them (the render's PNG goes to a temporary file for the comparison
/// and is removed after it), with `flip`, the ꟻLIP statistics of their codes.
fn stored_stats(reference: &Path, actual_png: &[u8], facts: &EntryFacts, flip: FlipStats) -> Result<StoredStats> {
    let entry = facts.entry;
    let scratch = std::env::temp_dir().join(format!("blobtrace-regress-{}-{}.png", std::process::id(), facts.place));
    let failed = |message: String| PipelineError::File { path: scratch.clone(), message };
    std::fs::write(&scratch, actual_png).map_err(|e| failed(e.to_string()))?;
    let settings = ImageDiffSettings {
        metric: Metric::Abs,
        thresholds: entry.thresholds(),
        channels: None,
        decoding: Default::default(),
        mask_edges: None,
        output: None,
        only_if_different: false,
        exposures: (None, None),
        histogram: None,
        scale: None,
    };
    let abs = diff_images(reference, &scratch, &settings);
    let _ = std::fs::remove_file(&scratch);
    let abs = abs.map_err(|e| failed(e.to_string()))?;
    Ok(StoredStats {
        mean: abs.mean,
        rms: abs.rms,
        psnr: abs.psnr,
        max: abs.max,
        max_at: abs.max_at,
        over_warn_px: abs.over_warn_px,
        over_fail_px: abs.over_fail_px,
        flip_mean: flip.mean,
        flip_weighted_median: flip.weighted_median,
    })
}

/// |actual − reference| per channel of the 8-bit codes, ×8 so small
/// differences show (the page amplifies it further).
fn difference_image(reference: &[u8], actual: &[u8], width: u32, height: u32) -> Rgb8Image {
    let pixels = reference.iter().zip(actual).map(|(r, a)| (u32::from(r.abs_diff(*a)) * 8).min(255) as u8).collect();
    Rgb8Image { width, height, pixels }
}

/// The width, in pixels, an entry's images are first scaled up towards.
const VIEW_WIDTH: u32 = 288;

/// How many times an image `width` pixels wide is first scaled up in the page.
pub fn view_zoom(width: u32) -> u32 {
    (VIEW_WIDTH / width.max(1)).clamp(1, 16)
}

/// The frame as a PNG of it would read back.
fn quantize(frame: &Frame) -> Frame {
    let mut q = frame.clone();
    for c in &mut q.color {
        *c = glam::Vec3::from(c.to_array().map(|v| crate::frame::srgb8_to_linear(crate::frame::linear_to_srgb8(v))));
    }
    q
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn images_are_first_scaled_towards_288_pixels_wide() {
        assert_eq!((view_zoom(64), view_zoom(96), view_zoom(1000), view_zoom(8)), (4, 3, 1, 16));
    }

    #[test]
    fn image_names_are_numbered_flat_and_claimed_back_by_the_stale_image_test() {
        let name = image_name(7, "sub/<b> \"x\" & ü-field-8x8.png", "heat");
        assert_eq!(name, "007-sub__b___x_____-field-8x8-heat.png");
        assert!(is_entry_image(&name) && is_entry_image("ref-pair-field-96x72.png"));
        for other in ["notes.png", "index.html", "summary.json", "007-x-heat.txt", "x-007-heat.png", "plot-heat.png"] {
            assert!(!is_entry_image(other), "{other}");
        }
    }
}
