//! The regression report read in a real browser: headless Chromium (which
//! `scripts/test` installs) loads `index.html` from disk, and its DOM, a
//! screenshot and the page's own self-test are checked against
//! `summary.json` and the entries' images. Names that look like markup,
//! quotes, spaces and scenes in subfolders are data, never markup or paths.

mod common;

use std::path::Path;
use std::process::Command;

use common::{blobtrace, scenes_with_a_grown_radius, scratch};
use serde_json::Value;

/// The browser, as `scripts/test` installs it.
fn chromium() -> &'static str {
    for name in ["chromium", "chromium-browser"] {
        if Command::new(name).arg("--version").output().is_ok_and(|o| o.status.success()) {
            return name;
        }
    }
    panic!("chromium is needed (scripts/test installs the Debian package)");
}

/// Runs headless Chromium on `page` (with `query`), in a profile in the
/// test's own folder so tests may run it at once; `extra` picks what it does.
fn browse(dir: &Path, page: &Path, query: &str, extra: &[&str]) -> Vec<u8> {
    let profile = dir.join("chromium-profile");
    let url = format!("file://{}{query}", page.canonicalize().unwrap().display());
    let out = Command::new(chromium())
        .args(["--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--no-first-run"])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(extra)
        .arg(&url)
        .output()
        .expect("chromium runs");
    assert!(out.status.success(), "chromium: {}", String::from_utf8_lossy(&out.stderr));
    out.stdout
}

/// The page's DOM after its script ran (and, for its self-test, after the
/// images it decodes have loaded).
fn page_dom(dir: &Path, page: &Path, query: &str) -> String {
    String::from_utf8(browse(dir, page, query, &["--dump-dom", "--virtual-time-budget=10000"])).unwrap()
}

/// The attribute `name` of every element whose opening tag starts `<tag`
/// and holds `class="…{class}…"`, in document order.
fn attributes(dom: &str, tag: &str, class: &str, name: &str) -> Vec<String> {
    dom.split(&format!("<{tag} "))
        .skip(1)
        .map(|rest| format!(" {}", &rest[..rest.find('>').unwrap()]))
        .filter(|open| open.contains(&format!(" class=\"{class}")))
        .map(|open| {
            let start =
                open.find(&format!(" {name}=\"")).unwrap_or_else(|| panic!("{name} in {open}")) + name.len() + 3;
            open[start..][..open[start..].find('"').unwrap()].to_string()
        })
        .collect()
}

/// The text of the cell `data-stat="{key}"` inside the article of entry `place`.
fn stat(dom: &str, place: u64, key: &str) -> String {
    let article = dom.split(&format!("id=\"entry-{place}\"")).nth(1).unwrap();
    let article = &article[..article.find("</article>").unwrap()];
    let cell = article.split(&format!("data-stat=\"{key}\">")).nth(1).unwrap_or_else(|| panic!("{key} of {place}"));
    cell[..cell.find('<').unwrap()].to_string()
}

#[test]
fn a_failing_run_reads_in_the_browser_failures_first_with_their_figures_images_and_working_views() {
    let dir = scratch("report-page");
    let scenes = scenes_with_a_grown_radius(&dir);
    let report = dir.join("report");
    let out = blobtrace(&["regress", "--scenes", scenes.to_str().unwrap(), "--report", report.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1), "{}", String::from_utf8_lossy(&out.stderr));
    let summary: Value = serde_json::from_str(&std::fs::read_to_string(report.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["verdict"], "fail");
    assert_eq!(summary["counts"]["failed"], 2);
    assert_eq!(summary["counts"]["passed"], 8);
    assert!(summary["run"]["command"].as_str().unwrap().contains("regress --scenes"));
    assert!(summary["run"]["scenes_commit"].is_null(), "a scratch folder is in no repository");

    let page = report.join("index.html");
    let dom = page_dom(&dir, &page, "");
    for key in ["failed", "warned", "passed", "skipped"] {
        let count = summary["counts"][key].as_u64().unwrap();
        assert!(dom.contains(&format!("data-count=\"{key}\"><b>{count}</b>")), "{key}: {count}");
    }
    assert!(dom.contains("<h1>FAIL: 2 of 10 entries failed</h1>"));
    // Failures first, then the passes; the page's figures are the summary's.
    let outcomes = attributes(&dom, "article", "entry ", "class");
    assert_eq!(outcomes.len(), 10);
    assert!(outcomes[..2].iter().all(|c| c == "entry failed") && outcomes[2..].iter().all(|c| c == "entry passed"));
    let entries = summary["entries"].as_array().unwrap();
    let places = attributes(&dom, "article", "entry ", "data-place");
    let failed: Vec<&Value> = entries.iter().filter(|e| e["outcome"] == "failed").collect();
    assert_eq!(places[..2], failed.iter().map(|e| e["place"].to_string()).collect::<Vec<_>>()[..]);
    for e in &failed {
        let place = e["place"].as_u64().unwrap();
        let (judged, stored) = (&e["judgement"], &e["stored"]);
        assert!(e["name"].as_str().unwrap().starts_with("pair-"));
        let max = stat(&dom, place, "max");
        assert!(max.starts_with(&format!("{:.5}", judged["max"].as_f64().unwrap())), "{max}");
        assert!(stat(&dom, place, "overfail").starts_with(&judged["over_fail_px"].to_string()));
        assert_eq!(stat(&dom, place, "flip-mean"), format!("{:.5}", stored["flip_mean"].as_f64().unwrap()));
        assert_eq!(stat(&dom, place, "stored-overfail"), stored["over_fail_px"].to_string());
        assert!(stat(&dom, place, "stored-psnr").ends_with(" dB"));
        assert!(stored["flip_weighted_median"].as_f64().unwrap() > 0.0 && stored["rms"].as_f64().unwrap() > 0.0);
        let bless = e["bless"].as_str().unwrap();
        assert!(bless.ends_with(&format!("--bless --entry {}", e["name"].as_str().unwrap().trim_end_matches(".png"))));
        assert!(dom.contains(&format!("<code class=\"command\">{bless}</code>")));
    }

    // At 1280×800 the first failure's reference and render show scaled up, crisp.
    let shot = dir.join("shot.png");
    browse(&dir, &page, "", &["--window-size=1280,800", &format!("--screenshot={}", shot.display())]);
    let shot = image::open(&shot).unwrap().to_rgb8();
    let first = failed[0]["images"].clone();
    for kind in ["reference", "actual"] {
        let image = image::open(report.join(first[kind].as_str().unwrap())).unwrap().to_rgb8();
        assert!(shows_scaled(&shot, &image, 3), "the {kind} is on screen at ×3");
    }

    // The page's own script exercises flick, swipe, amplification, probe, zoom, filter and sort.
    let tested = page_dom(&dir, &page, "?selftest");
    assert!(tested.contains("<output id=\"selftest\">pass</output>"), "{}", selftest_result(&tested));
    // Its probe read the reference's first pixel from the page's own copy.
    let reference = image::open(report.join(first["reference"].as_str().unwrap())).unwrap().to_rgb8();
    let [r, g, b] = reference.get_pixel(0, 0).0;
    assert!(
        tested.contains(&format!("(0, 0)  reference {r} {g} {b} [")),
        "{}",
        tested.split("class=\"probe\">").nth(1).unwrap_or("")
    );
    std::fs::remove_dir_all(dir).unwrap();
}

fn selftest_result(dom: &str) -> &str {
    dom.split("id=\"selftest\">").nth(1).map_or("no #selftest in the page", |r| &r[..r.find('<').unwrap_or(r.len())])
}

/// Whether `image`, each pixel a `zoom × zoom` square, appears somewhere in `shot`.
fn shows_scaled(shot: &image::RgbImage, image: &image::RgbImage, zoom: u32) -> bool {
    let (w, h) = (image.width() * zoom, image.height() * zoom);
    let near = |a: &image::Rgb<u8>, b: &image::Rgb<u8>| a.0.iter().zip(b.0).all(|(x, y)| x.abs_diff(y) <= 3);
    (0..=shot.height().saturating_sub(h)).any(|oy| {
        (0..=shot.width().saturating_sub(w)).any(|ox| {
            image.enumerate_pixels().all(|(x, y, p)| {
                [(0, 0), (zoom - 1, zoom - 1)]
                    .iter()
                    .all(|(dx, dy)| near(shot.get_pixel(ox + x * zoom + dx, oy + y * zoom + dy), p))
            })
        })
    })
}

#[test]
fn names_are_text_in_the_page_and_scenes_in_subfolders_bless_report_and_stay_inside() {
    let dir = scratch("report-names");
    let (scenes, refs, report) = (dir.join("scenes"), dir.join("refs"), dir.join("report"));
    std::fs::create_dir_all(scenes.join("sub")).unwrap();
    std::fs::create_dir_all(&refs).unwrap();
    let sphere = std::fs::read_to_string("scenes/sphere.ron").unwrap();
    let names = ["<b>x<img src=y onerror=alert(1)>.ron", "sub/a b \"q\" & ü's.ron"];
    for name in names {
        std::fs::write(scenes.join(name), &sphere).unwrap();
    }
    let entries: String =
        names.iter().map(|n| format!("  Entry(scene: {n:?}, size: (16, 12), kind: Field),\n")).collect();
    std::fs::write(refs.join("manifest.ron"), format!("Manifest(entries: [\n{entries}])")).unwrap();
    let (s, r, p) = (scenes.to_str().unwrap(), refs.to_str().unwrap(), report.to_str().unwrap());
    let out = blobtrace(&["regress", "--scenes", s, "--refs", r, "--bless"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(refs.join("sub/a b \"q\" & ü's-field-16x12.png").is_file(), "the reference keeps the scene's folder");
    assert!(blobtrace(&["regress", "--scenes", s, "--refs", r, "--report", p]).status.success());
    for name in names {
        std::fs::write(scenes.join(name), sphere.replace("radius: 2.0", "radius: 2.1")).unwrap();
    }
    let junit = dir.join("junit.xml");
    let out = blobtrace(&["regress", "--scenes", s, "--refs", r, "--report", p, "--junit", junit.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    roxmltree::Document::parse(&std::fs::read_to_string(&junit).unwrap()).expect("the JUnit file parses");
    let raw = std::fs::read_to_string(report.join("index.html")).unwrap();
    assert!(!raw.contains("<img src=y") && !raw.contains("<b>x"), "no name is markup in the file");
    let dom = page_dom(&dir, &report.join("index.html"), "?selftest");
    assert!(dom.contains("<span class=\"name\">&lt;b&gt;x&lt;img src=y onerror=alert(1)&gt;-field-16x12.png</span>"));
    assert!(dom.contains("<span class=\"name\">sub/a b \"q\" &amp; ü's-field-16x12.png</span>"));
    assert!(!dom.contains("onerror=\"") && !dom.contains("<b>x"), "no element came from a name");
    assert!(dom.contains("<output id=\"selftest\">pass</output>"), "{}", selftest_result(&dom));
    // Every image stayed in the report folder, flat, one set per entry.
    let images: Vec<String> = std::fs::read_dir(&report)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.ends_with(".png"))
        .collect();
    assert_eq!(images.len(), 10, "{images:?}");
    // The page's command blesses the one entry, through a shell, and it then passes alone.
    let summary: Value = serde_json::from_str(&std::fs::read_to_string(report.join("summary.json")).unwrap()).unwrap();
    let second = &summary["entries"][1];
    let blessed = Command::new("sh")
        .args(["-c", second["bless"].as_str().unwrap()])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(blessed.status.success(), "{}", String::from_utf8_lossy(&blessed.stderr));
    let out = blobtrace(&["regress", "--scenes", s, "--refs", r, "--report", p]);
    assert_eq!(out.status.code(), Some(1), "the other entry still fails");
    let summary: Value = serde_json::from_str(&std::fs::read_to_string(report.join("summary.json")).unwrap()).unwrap();
    assert_eq!(
        (summary["entries"][0]["outcome"].as_str(), summary["entries"][1]["outcome"].as_str()),
        (Some("failed"), Some("passed"))
    );
    // A scene outside the scenes folder is refused where the manifest names it.
    for outside in ["../sphere.ron", "sub/../../sphere.ron", "/etc/passwd"] {
        let text = format!("Manifest(entries: [\n  Entry(scene: {outside:?}, size: (8, 8), kind: Field),\n])");
        std::fs::write(refs.join("manifest.ron"), text).unwrap();
        let out = blobtrace(&["regress", "--scenes", s, "--refs", r, "--bless"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains("manifest.ron:2:3") && err.contains("scenes folder"), "{err}");
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn a_run_where_everything_passes_says_so_at_the_top_and_lists_every_entry() {
    let dir = scratch("report-pass");
    let report = dir.join("report");
    let out = blobtrace(&["regress", "--filter", "pair-", "--report", report.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let dom = page_dom(&dir, &report.join("index.html"), "");
    assert!(dom.contains("<h1>PASS: all 2 entries pass</h1>"));
    assert!(dom.contains("data-count=\"skipped\"><b>8</b>"), "the filter's skipped entries are counted");
    assert!(dom.contains("<details id=\"passed\" class=\"group\" open=\"\">"), "the passes are shown open");
    assert_eq!(attributes(&dom, "article", "entry ", "class"), ["entry passed", "entry passed"]);
    let summary: Value = serde_json::from_str(&std::fs::read_to_string(report.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["verdict"], "pass");
    assert!(
        summary["run"]["scenes_commit"].as_str().is_none_or(|c| c.len() == 40),
        "this repository's commit when in one"
    );
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn an_entry_over_its_warning_tolerance_alone_warns_passes_the_run_and_shows_its_images() {
    let dir = scratch("report-warn");
    let (refs, report) = (dir.join("refs"), dir.join("report"));
    std::fs::create_dir_all(&refs).unwrap();
    // As idiff judges: pixels over `fail` within `failpercent` pass, unless
    // they are over `warnpercent` (of pixels over `warn`), which warns.
    let entry = "Entry(scene: \"pair.ron\", size: (24, 18), kind: Field, failpercent: 100.0, hardfail: 1.0, warn: 0.02, warnpercent: 0.0)";
    std::fs::write(refs.join("manifest.ron"), format!("Manifest(entries: [{entry}])")).unwrap();
    let r = refs.to_str().unwrap();
    assert!(blobtrace(&["regress", "--refs", r, "--bless"]).status.success());
    let scenes = scenes_with_a_grown_radius(&dir);
    let junit = dir.join("junit.xml");
    let args = ["regress", "--refs", r, "--scenes", scenes.to_str().unwrap(), "--report", report.to_str().unwrap()];
    let out = blobtrace(&[&args[..], &["--junit", junit.to_str().unwrap()]].concat());
    assert!(out.status.success(), "a warning passes: {}", String::from_utf8_lossy(&out.stderr));
    assert!(!std::fs::read_to_string(&junit).unwrap().contains("<failure"));
    let summary: Value = serde_json::from_str(&std::fs::read_to_string(report.join("summary.json")).unwrap()).unwrap();
    assert_eq!((summary["verdict"].as_str(), summary["counts"]["warned"].as_u64()), (Some("warn"), Some(1)));
    let warned = &summary["entries"][0];
    assert_eq!(warned["tolerances"]["warn"].as_f64(), Some(0.02));
    assert!(warned["judgement"]["over_warn_px"].as_u64().unwrap() > 0);
    let dom = page_dom(&dir, &report.join("index.html"), "?selftest");
    assert!(dom.contains("<h1>WARN: 1 of 1 entries warn, none fails</h1>") && dom.contains("<section id=\"warned\""));
    assert!(dom.contains("<output id=\"selftest\">pass</output>"), "{}", selftest_result(&dom));
    std::fs::remove_dir_all(dir).unwrap();
}
