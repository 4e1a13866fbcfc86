//! The regression report's weight: headless Chromium loading a generated
//! report of 200 entries (40 failing, with their images, pixel data and
//! views) until its script has run (`--dump-dom`), against the same browser
//! loading an empty page from the same folder. The difference is what the
//! page costs a reader; the goal is a whole load under a second. It also
//! prints the page's own figure: navigation to load event, as it measured.
//! `cargo bench --bench report_page` (needs `chromium`, which `scripts/test`
//! installs).

use std::path::{Path, PathBuf};
use std::process::Command;

use blobtrace::pipeline::{RegressSettings, regress};
use blobtrace::progress::Silent;
use criterion::{Criterion, criterion_group, criterion_main};

const SCENES: [&str; 5] = ["sphere", "pair", "sharp", "bottle", "example"];

/// A manifest of 200 entries: five scenes, field and mesh, twenty sizes.
fn manifest() -> String {
    let mut entries = String::new();
    for scene in SCENES {
        for kind in ["Field", "Mesh(24)"] {
            for k in 0..20 {
                let size = (32 + 4 * k, 24 + 3 * k);
                entries += &format!("  Entry(scene: \"{scene}.ron\", size: {size:?}, kind: {kind}),\n");
            }
        }
    }
    format!("Manifest(entries: [\n{entries}])\n")
}

/// Blesses the manifest against the bundled scenes, then reports it against
/// a copy whose pair has a grown radius (its 40 entries fail); returns the page.
fn report(dir: &Path) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let (scenes, refs, report) = (dir.join("scenes"), dir.join("refs"), dir.join("report"));
    for d in [&scenes, &refs] {
        std::fs::create_dir_all(d).unwrap();
    }
    std::fs::write(refs.join("manifest.ron"), manifest()).unwrap();
    for scene in SCENES {
        let text = std::fs::read_to_string(root.join(format!("scenes/{scene}.ron"))).unwrap();
        std::fs::write(scenes.join(format!("{scene}.ron")), text).unwrap();
    }
    let mut settings = RegressSettings {
        scenes: scenes.clone(),
        refs,
        bless: true,
        report: report.clone(),
        filter: None,
        entries: vec![],
        shard: None,
        junit: None,
        allow_empty: false,
        command: vec![],
    };
    regress(&settings, &Silent, &|_| {}).expect("the references bless");
    let pair = std::fs::read_to_string(scenes.join("pair.ron")).unwrap();
    std::fs::write(scenes.join("pair.ron"), pair.replacen("radius: 1.6", "radius: 1.616", 1)).unwrap();
    settings.bless = false;
    let summary = regress(&settings, &Silent, &|_| {}).expect("the report is written");
    assert_eq!((summary.counts.failed, summary.counts.passed), (40, 160));
    report.join("index.html")
}

/// Loads `page` in headless Chromium until its scripts ran; returns the
/// milliseconds from navigation to the load event the page measured itself
/// (`None` for a page without the report's script).
fn load(page: &Path, profile: &Path) -> Option<u32> {
    let out = Command::new("chromium")
        .args(["--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--dump-dom"])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(format!("file://{}", page.display()))
        .output()
        .expect("chromium runs (scripts/test installs it)");
    assert!(out.status.success() && out.stdout.len() > 40);
    let dom = String::from_utf8_lossy(&out.stdout);
    let ms = dom.split("data-load-ms=\"").nth(1)?;
    ms[..ms.find('"')?].parse().ok()
}

fn report_page(c: &mut Criterion) {
    let dir = std::env::temp_dir().join(format!("blobtrace-bench-report-{}", std::process::id()));
    let page = report(&dir);
    let empty = dir.join("report/empty.html");
    std::fs::write(&empty, "<!doctype html><title>empty</title><p>empty").unwrap();
    let profile = dir.join("profile");
    let bytes = std::fs::metadata(&page).unwrap().len();
    eprintln!("report of 200 entries (40 failing): index.html {:.0} KB", bytes as f64 / 1024.0);
    let mut group = c.benchmark_group("report_page_chromium");
    group.sample_size(10);
    group.bench_function("empty_page", |b| b.iter(|| load(&empty, &profile)));
    let mut own = vec![];
    group.bench_function("report_200_entries", |b| b.iter(|| own.extend(load(&page, &profile))));
    group.finish();
    own.sort_unstable();
    let (lo, mid, hi) = (own[0], own[own.len() / 2], own[own.len() - 1]);
    eprintln!("the page's own load (navigation to load event): median {mid} ms, {lo}–{hi} ms over {} loads", own.len());
    let _ = std::fs::remove_dir_all(dir);
}

criterion_group!(benches, report_page);
criterion_main!(benches);
