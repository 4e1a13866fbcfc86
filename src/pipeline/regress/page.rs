//! The report's page, `index.html`: one self-contained file (its style and
//! script inline, its images beside it) a person opens from a CI artefact.
//! The verdict and the run's facts first, then the failures, the warnings
//! and the passes (collapsed), each entry with its figures and the command
//! that blesses it; an entry that differs gets its images with side-by-side,
//! flick and swipe views, a zoom, an amplified difference and a pixel probe.
//!
//! Every name, path and command enters the page escaped, and a content
//! security policy lets only the page's own script run (its nonce is drawn
//! per run), so an entry named like markup shows as text and runs nothing.

use std::fmt::Write as _;
use std::hash::{BuildHasher, Hasher};

use base64::Engine as _;

use super::entry_check::view_zoom;
use super::markup::escape;
use super::summary::{Outcome, RegressRow, RegressSummary, StoredStats};
use crate::compare::Verdict;

const STYLE: &str = include_str!("page.css");
const SCRIPT: &str = include_str!("page.js");

/// The whole page of `summary`.
#[must_use]
pub fn report_page(summary: &RegressSummary) -> String {
    let nonce = nonce();
    let verdict = verdict_word(summary.verdict);
    let mut page = String::with_capacity(16_384 + 2048 * summary.entries.len());
    let _ = write!(
        page,
        "<!doctype html>\n<html lang=en>\n<head>\n<meta charset=utf-8>\n\
         <meta name=viewport content=\"width=device-width, initial-scale=1\">\n\
         <meta http-equiv=Content-Security-Policy content=\"default-src 'none'; img-src 'self' data:; \
         style-src 'unsafe-inline'; script-src 'nonce-{nonce}'\">\n\
         <title>{verdict}: blobtrace regress, {}</title>\n<style>{STYLE}</style>\n</head>\n<body data-verdict={verdict}>\n",
        escape(&headline(summary))
    );
    header(&mut page, summary);
    controls(&mut page);
    let group = |o: Outcome| summary.entries.iter().filter(move |r| r.outcome == o);
    for (outcome, id, title) in [(Outcome::Failed, "failed", "Failed"), (Outcome::Warned, "warned", "Warned")] {
        let rows: Vec<&RegressRow> = group(outcome).collect();
        if !rows.is_empty() {
            let _ = writeln!(page, "<section id={id} class=group><h2>{title} ({})</h2>", rows.len());
            rows.iter().for_each(|r| entry(&mut page, r));
            page.push_str("</section>\n");
        }
    }
    let passed: Vec<&RegressRow> = group(Outcome::Passed).collect();
    // Passes are collapsed unless they are all there is to see.
    let open = if passed.len() == summary.entries.len() { " open" } else { "" };
    let _ =
        writeln!(page, "<details id=passed class=group{open}><summary><h2>Passed ({})</h2></summary>", passed.len());
    passed.iter().for_each(|r| entry(&mut page, r));
    page.push_str("</details>\n");
    pixel_data(&mut page, summary);
    let _ = writeln!(page, "<script nonce=\"{nonce}\">{SCRIPT}</script>\n</body>\n</html>");
    page
}

/// A nonce for the page's script: random per run (std's hasher keys are), so
/// markup smuggled into a name cannot carry it.
fn nonce() -> String {
    let mut hasher = std::collections::hash_map::RandomState::new().build_hasher();
    hasher.write_u128(std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos()));
    let a = hasher.finish();
    hasher.write_u32(std::process::id());
    format!("{a:016x}{:016x}", hasher.finish())
}

fn verdict_word(verdict: Verdict) -> &'static str {
    match verdict {
        Verdict::Pass => "PASS",
        Verdict::Warn => "WARN",
        Verdict::Fail => "FAIL",
    }
}

/// The verdict in words.
fn headline(summary: &RegressSummary) -> String {
    let c = summary.counts;
    let n = c.passed + c.warned + c.failed;
    match summary.verdict {
        Verdict::Pass if n == 0 => "no entry was run".to_string(),
        Verdict::Pass => format!("all {n} entries pass"),
        Verdict::Warn => format!("{} of {n} entries warn, none fails", c.warned),
        Verdict::Fail => format!("{} of {n} entries failed", c.failed),
    }
}

/// The verdict, the counts and the run's facts.
fn header(page: &mut String, summary: &RegressSummary) {
    let (c, run) = (summary.counts, &summary.run);
    let verdict = verdict_word(summary.verdict);
    let _ = writeln!(page, "<header id=verdict class={verdict}><h1>{verdict}: {}</h1>", escape(&headline(summary)));
    page.push_str("<ul id=counts>");
    for (key, n) in [("failed", c.failed), ("warned", c.warned), ("passed", c.passed), ("skipped", c.skipped)] {
        let _ = write!(page, "<li class={key} data-count={key}><b>{n}</b> {key}</li>");
    }
    page.push_str("</ul>\n<dl id=run>");
    let mut fact = |term: &str, value: String| {
        // The command line is long: it gets a row of its own.
        let wide = if term == "command" { " class=wide" } else { "" };
        let _ = write!(page, "<div{wide}><dt>{term}</dt><dd>{value}</dd></div>");
    };
    if !run.command.is_empty() {
        fact("command", format!("<code>{}</code>", escape(&run.command)));
    }
    fact("scenes", format!("<code>{}</code>", escape(&run.scenes)));
    if let Some(commit) = &run.scenes_commit {
        fact("scenes commit", format!("<code>{}</code>", escape(commit)));
    }
    fact("references", format!("<code>{}</code>", escape(&run.refs)));
    fact("blobtrace", escape(&run.version));
    fact("date", escape(&run.date));
    fact("SIMD width", format!("{} lanes", run.simd_width));
    fact("time taken", format!("{:.2} s", run.seconds));
    page.push_str("</dl>\n</header>\n");
}

/// The filter box, the failures-only switch and the sort.
fn controls(page: &mut String) {
    page.push_str(
        "<nav id=controls><input id=filter type=search placeholder=\"filter by name\" aria-label=\"filter by name\">\
         <label><input id=failures-only type=checkbox> failures only</label>\
         <label>sort by <select id=sort><option value=place>manifest order<option value=name>name\
         <option value=max>largest difference<option value=overfail>pixels over fail<option value=mean>mean difference\
         <option value=rms>RMS (stored)<option value=psnr>PSNR (stored)<option value=flip>FLIP mean\
         <option value=seconds>render time</select></label>\
         <button id=sort-dir type=button title=\"reverse the order\">ascending</button>\
         <span id=shown></span></nav>\n",
    );
}

/// One entry: its name and verdict, what it guards, its figures, its
/// blessing command and (when it differs) its images.
fn entry(page: &mut String, row: &RegressRow) {
    let outcome = outcome_word(row.outcome);
    let j = row.judgement.as_ref();
    let s = row.stored.as_ref();
    let _ = write!(
        page,
        "<article class=\"entry {outcome}\" id=entry-{} data-place={} data-name=\"{}\" data-max=\"{}\" \
         data-overfail=\"{}\" data-mean=\"{}\" data-rms=\"{}\" data-psnr=\"{}\" data-flip=\"{}\" data-seconds=\"{}\">",
        row.place,
        row.place,
        escape(&row.name),
        j.map_or(String::new(), |j| j.max.to_string()),
        j.map_or(String::new(), |j| j.over_fail_px.to_string()),
        j.map_or(String::new(), |j| j.mean.to_string()),
        s.map_or(String::new(), |s| s.rms.to_string()),
        s.and_then(|s| s.psnr).map_or(String::new(), |p| p.to_string()),
        s.map_or(String::new(), |s| s.flip_mean.to_string()),
        row.seconds,
    );
    let badge = outcome.to_uppercase();
    let _ = writeln!(page, "<h3><span class=badge>{badge}</span> <span class=name>{}</span></h3>", escape(&row.name));
    let _ = writeln!(page, "<p class=meta>{}</p>", escape(&meta(row)));
    images(page, row);
    figures(page, row);
    let _ = writeln!(
        page,
        "<p class=bless>Accept this render as the reference: <code class=command>{}</code> \
         <button type=button class=copy>copy</button></p>",
        escape(&row.bless)
    );
    page.push_str("</article>\n");
}

fn outcome_word(outcome: Outcome) -> &'static str {
    match outcome {
        Outcome::Failed => "failed",
        Outcome::Warned => "warned",
        Outcome::Passed => "passed",
    }
}

/// Scene, size, kind and tolerances in one line.
fn meta(row: &RegressRow) -> String {
    let kind = match row.mesh_res {
        Some(res) => format!("mesh ray cast, polygonized at res {res}"),
        None => "field trace".to_string(),
    };
    let mode = if row.cached { "through the caches" } else { "exact" };
    let t = row.tolerances;
    format!(
        "scene {} · {}×{} · {kind}, {mode} · fail above {} on over {}% of pixels · warn above {} on over {}% · \
         hardfail {} · rendered in {:.3} s",
        row.scene, row.size.0, row.size.1, t.fail, t.failpercent, t.warn, t.warnpercent, t.hardfail, row.seconds
    )
}

/// The verdict's statistic, and apart from it `diff`'s on the stored images.
fn figures(page: &mut String, row: &RegressRow) {
    let Some(j) = &row.judgement else {
        page.push_str("<p class=missing>No readable reference: bless to create it.</p>\n");
        return;
    };
    let at = j.max_at.map_or(String::new(), |(x, y)| format!(" at ({x}, {y})"));
    let rows = [
        ("largest difference", format!("{:.5}{at}", j.max), "max"),
        ("pixels over fail", format!("{} ({:.3}%)", j.over_fail_px, j.over_fail_percent), "overfail"),
        ("pixels over warn", format!("{} ({:.3}%)", j.over_warn_px, j.over_warn_percent), "overwarn"),
        ("mean difference", format!("{:.3e}", j.mean), "mean"),
        ("pixels compared", j.pixels.to_string(), "pixels"),
    ];
    if row.outcome == Outcome::Passed {
        // A pass needs no table: its figures in one line.
        page.push_str("<p class=figures-line>");
        for (k, (label, value, key)) in rows.iter().enumerate() {
            let sep = if k == 0 { "" } else { " · " };
            let _ = write!(page, "{sep}{label} <span data-stat={key}>{}</span>", escape(value));
        }
        page.push_str("</p>\n");
        return;
    }
    page.push_str(
        "<div class=figures><div><p class=stat-title>verdict: largest linear RGB difference per pixel, as \
         <code>regress</code> judges</p><table class=verdict-stats>",
    );
    stat_rows(page, &rows);
    page.push_str("</table></div>");
    if let Some(s) = &row.stored {
        stored_table(page, s);
    }
    page.push_str("</div>\n");
}

fn stat_rows(page: &mut String, rows: &[(&str, String, &str)]) {
    for (label, value, key) in rows {
        let _ = write!(page, "<tr><th>{label}</th><td data-stat={key}>{}</td></tr>", escape(value));
    }
}

/// `blobtrace diff`'s figures on the two stored PNGs.
fn stored_table(page: &mut String, s: &StoredStats) {
    page.push_str(
        "<div><p class=stat-title>stored images, as <code>blobtrace diff</code> prints them \
         (8-bit codes ÷ 255; FLIP)</p><table class=stored-stats>",
    );
    let max_at = s.max_at.as_ref().map_or(String::new(), |m| {
        let values = |v: &[f32]| v.iter().map(|x| format!("{x:.3}")).collect::<Vec<_>>().join(" ");
        format!(" at ({}, {}) channel {}: {} → {}", m.x, m.y, m.channel, values(&m.a), values(&m.b))
    });
    let rows = [
        ("mean", format!("{:.3e}", s.mean), "stored-mean"),
        ("RMS", format!("{:.3e}", s.rms), "stored-rms"),
        ("PSNR", s.psnr.map_or("∞ (equal)".into(), |p| format!("{p:.2} dB")), "stored-psnr"),
        ("max", format!("{:.5}{max_at}", s.max), "stored-max"),
        ("pixels over warn", s.over_warn_px.to_string(), "stored-overwarn"),
        ("pixels over fail", s.over_fail_px.to_string(), "stored-overfail"),
        ("FLIP mean", format!("{:.5}", s.flip_mean), "flip-mean"),
        ("FLIP weighted median", format!("{:.5}", s.flip_weighted_median), "flip-median"),
    ];
    stat_rows(page, &rows);
    page.push_str("</table></div>");
}

/// The images of an entry: the views of one that differs, or the render
/// alone when there is no reference.
fn images(page: &mut String, row: &RegressRow) {
    let i = &row.images;
    let (w, h) = row.size;
    let zoom = view_zoom(w);
    let img = Img { size: format!("width={} height={}", w * zoom, h * zoom) };
    let (Some(reference), Some(actual)) = (&i.reference, &i.actual) else {
        if let Some(actual) = &i.actual {
            let _ =
                writeln!(page, "<figure>{}<figcaption>the render</figcaption></figure>", img.px(actual, "actual", ""));
        }
        return;
    };
    let amplifications =
        [1, 2, 4, 8, 16, 32, 64].map(|k| format!("<option{}>{k}", if k == 8 { " selected" } else { "" }));
    let _ = write!(
        page,
        "<div class=viewer data-place={} data-w={w} data-h={h} data-zoom={zoom}>\
         <div class=tools><span class=tabs><button type=button data-view=side class=on>side by side</button>\
         <button type=button data-view=flick>flick</button><button type=button data-view=swipe>swipe</button></span>\
         <label>zoom <input class=zoom type=range min=1 max=16 value={zoom}></label>\
         <label>difference × <select class=amp>{}</select></label></div>\
         <output class=probe>hover a pixel for its values</output>",
        row.place,
        amplifications.concat(),
    );
    let figure = |image: String, caption: &str| format!("<figure>{image}<figcaption>{caption}</figcaption></figure>");
    let map = |file: &Option<String>, caption: &str| {
        let image = |f: &String| format!("<img class=map src=\"{}\" alt=\"{caption}\" loading=lazy>", escape(f));
        file.as_ref().map_or(String::new(), |f| figure(image(f), caption))
    };
    let difference = i.difference.as_ref().map_or(String::new(), |f| img.px(f, "difference", ""));
    let _ = write!(
        page,
        "<div class=\"view side\">{}{}{}{}{}</div>",
        figure(img.px(reference, "reference", ""), "reference"),
        figure(img.px(actual, "actual", ""), "actual"),
        figure(difference, "|actual − reference| in 8-bit codes, ×<span class=amp-value>8</span>"),
        map(&i.heat, "heat map of the judged difference"),
        map(&i.flip, "FLIP error map"),
    );
    let (reference, actual) = (escape(reference), escape(actual));
    let _ = writeln!(
        page,
        "<div class=\"view flick\" hidden><figure><img class=\"px flicker\" data-role=reference src=\"{reference}\" \
         data-reference=\"{reference}\" data-actual=\"{actual}\" {} alt=\"reference and actual in turn\" tabindex=0>\
         <figcaption>showing <b class=flick-label>reference</b>: click or press F to flick</figcaption></figure></div>\
         <div class=\"view swipe\" hidden><figure><div class=swipe-box>{}{}<div class=divider></div></div>\
         <input class=swipe-position type=range min=0 max=100 value=50 aria-label=\"divide\">\
         <figcaption>reference on the left of the divider, actual on the right</figcaption></figure></div></div>",
        img.size,
        img.px_escaped(&actual, "actual", ""),
        img.px_escaped(&reference, "reference", " swipe-top"),
    );
}

/// An entry's scaled-up image elements: every one the same size, crisp.
struct Img {
    size: String,
}

impl Img {
    /// The image `file` in the role `role` (with more `classes`).
    fn px(&self, file: &str, role: &str, classes: &str) -> String {
        self.px_escaped(&escape(file), role, classes)
    }

    fn px_escaped(&self, file: &str, role: &str, classes: &str) -> String {
        format!("<img class=\"px{classes}\" data-role={role} src=\"{file}\" {} alt=\"{role}\" loading=lazy>", self.size)
    }
}

/// Both images of each entry that differs, as PNG data URLs in a JSON block
/// the page's script decodes on first use (images from data URLs can be read
/// back; the image files of a page opened from disk cannot).
fn pixel_data(page: &mut String, summary: &RegressSummary) {
    let b64 = base64::engine::general_purpose::STANDARD;
    let url = |png: &[u8]| format!("\"data:image/png;base64,{}\"", b64.encode(png));
    let entries: Vec<String> = summary
        .entries
        .iter()
        .filter_map(|r| {
            let p = r.pixels.as_ref()?;
            Some(format!("\"{}\":{{\"reference\":{},\"actual\":{}}}", r.place, url(&p.reference), url(&p.actual)))
        })
        .collect();
    let _ = writeln!(page, "<script type=application/json id=pixels>{{{}}}</script>", entries.join(","));
}
