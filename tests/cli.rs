//! The command line: outputs, JSON keys, and clear errors for bad input.

mod common;

use blobtrace::frame::read_exr_channels;
use blobtrace::pipeline::{COMPARE_OPTIONAL_OUTPUTS, COMPARE_OUTPUTS};
use common::{blobtrace, scenes_with_a_grown_radius, scratch};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn json(out: &Output) -> serde_json::Value {
    assert!(out.status.success(), "failed: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("stdout is one JSON object")
}

/// Runs blobtrace with `args`, checks it succeeded, and reads the JSON object it printed.
fn run_json(args: &[&str]) -> serde_json::Value {
    json(&blobtrace(args))
}

/// Runs blobtrace with `args` and checks it succeeded, showing its errors if not.
fn run_ok(args: &[&str]) -> Output {
    let out = blobtrace(args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    out
}

/// Checks that `v` has every one of `keys`.
fn assert_keys(v: &serde_json::Value, keys: &[&str]) {
    for key in keys {
        assert!(v.get(key).is_some(), "missing key {key} in {v}");
    }
}

#[test]
fn render_writes_png_and_exr_and_reports_json() {
    let dir = scratch("render");
    let png = dir.join("pair.png");
    let exr = dir.join("pair.exr");
    let v = run_json(&[
        "render",
        "scenes/pair.ron",
        "-o",
        png.to_str().unwrap(),
        "--exr",
        exr.to_str().unwrap(),
        "--size",
        "64x48",
        "--json",
    ]);
    assert_keys(&v, &["seconds", "rays", "hits", "field_evals", "width", "height"]);
    assert_eq!(v["rays"], 64 * 48);
    assert_eq!((v["width"].as_u64(), v["height"].as_u64()), (Some(64), Some(48)));
    let img = image::open(&png).expect("a PNG was written").to_rgb8();
    assert_eq!(img.dimensions(), (64, 48));
    assert!(exr.exists());
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn render_draws_where_the_time_went_and_refuses_it_for_a_mesh() {
    let dir = scratch("cost");
    let (png, cost) = (dir.join("sharp.png"), dir.join("cost.png"));
    let args = ["render", "scenes/sharp.ron", "--size", "80x60", "-o", png.to_str().unwrap()];
    let out = blobtrace(&[&args[..], &["--cost-png", cost.to_str().unwrap()]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let picture = image::open(&cost).expect("the cost picture was written").to_rgb8();
    assert!(picture.width() >= 2 * 80 && picture.height() > 60, "two heat maps: {:?}", picture.dimensions());
    // Some pixel of each half is drawn in magma's reds (not white, not black text).
    let magma = |p: &image::Rgb<u8>| p.0[0] > 100 && p.0[1] < 100;
    let coloured =
        |x0: u32| (x0..x0 + picture.width() / 2).any(|x| (0..picture.height()).any(|y| magma(picture.get_pixel(x, y))));
    assert!(coloured(0) && coloured(picture.width() / 2));
    std::fs::remove_file(&cost).unwrap();
    let out = blobtrace(&[&args[..], &["--mesh", "--res", "16", "--cost-png", cost.to_str().unwrap()]].concat());
    assert_eq!(out.status.code(), Some(64), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--cost-png"));
    assert!(!cost.exists(), "nothing written");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn render_spp_smooths_edges_the_same_for_any_thread_count() {
    let dir = scratch("spp");
    let render = |spp: &str, threads: &str, name: &str| {
        let (png, exr) = (dir.join(format!("{name}.png")), dir.join(format!("{name}.exr")));
        let args = ["render", "scenes/medusa.ron", "--size", "64x48", "--spp", spp, "--threads", threads];
        let out = blobtrace(&[&args[..], &["-o", png.to_str().unwrap(), "--exr", exr.to_str().unwrap()]].concat());
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        (std::fs::read(png).unwrap(), read_exr_channels(&exr).unwrap().channels["A"].clone())
    };
    let (plain, plain_exr) = render("1", "2", "plain");
    let (one, _) = render("1", "1", "one");
    assert_eq!(plain, one, "--spp 1 is the plain render");
    let (four, four_exr) = render("4", "2", "four");
    let (four_alone, _) = render("4", "1", "four-alone");
    assert_eq!(four, four_alone, "the same samples on any thread count");
    assert_ne!(four, plain);
    // Edges are part covered; inside and outside stay whole.
    let partial = |alpha: &[f32]| alpha.iter().filter(|&&a| a > 0.0 && a < 1.0).count();
    assert_eq!(partial(&plain_exr), 0);
    assert!(partial(&four_exr) > 20, "{} edge pixels", partial(&four_exr));
    assert!(plain_exr.iter().zip(&four_exr).filter(|(a, b)| a != b).count() < 64 * 48 / 4);
    for bad in ["0", "1025", "x"] {
        let out =
            blobtrace(&["render", "scenes/medusa.ron", "--spp", bad, "-o", dir.join("bad.png").to_str().unwrap()]);
        assert_eq!(out.status.code(), Some(64), "--spp {bad}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("--spp"));
    }
    assert!(!dir.join("bad.png").exists());
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn bench_view_times_each_kind_of_event() {
    let v = run_json(&["bench", "view", "scenes/example.ron", "--size", "64x48", "--events", "3", "--json"]);
    let kinds: Vec<&str> = v["events"].as_array().unwrap().iter().map(|e| e["kind"].as_str().unwrap()).collect();
    assert_eq!(kinds, ["orbit", "zoom", "move arm"]);
    for e in v["events"].as_array().unwrap() {
        assert_eq!(e["events"], 3);
        let seconds = |what: &str| (e[what]["median"].as_f64().unwrap(), e[what]["max"].as_f64().unwrap());
        for what in ["first_pass", "field_refined", "refined"] {
            let (median, max) = seconds(what);
            assert!(median > 0.0 && median <= max, "{what}: {e}");
        }
        // Each stage ends after the one before it, event by event, so their slowest do too.
        let (first, field, all) = (seconds("first_pass").1, seconds("field_refined").1, seconds("refined").1);
        assert!(first <= field && field <= all, "{e}");
        assert!((e["frame_rate"].as_f64().unwrap() * seconds("first_pass").0 - 1.0).abs() < 1e-6);
    }
    assert!(v["launch_seconds"].as_f64().unwrap() > 0.0);
    let out = blobtrace(&["bench", "view", "scenes/example.ron", "--events", "0"]);
    assert_eq!(out.status.code(), Some(64), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn threads_option_does_not_change_the_image() {
    let dir = scratch("threads");
    let render = |threads: &str, name: &str| {
        let p = dir.join(name);
        run_ok(&[
            "render",
            "scenes/sharp.ron",
            "--size",
            "80x60",
            "--threads",
            threads,
            "--exr",
            p.to_str().unwrap(),
            "-o",
            dir.join(format!("{name}.png")).to_str().unwrap(),
        ]);
        std::fs::read(p).unwrap()
    };
    assert_eq!(render("1", "one.exr"), render("2", "two.exr"));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn info_reports_counts() {
    let v = run_json(&["info", "scenes/medusa.ron", "--json"]);
    assert_eq!(v["primitives"], 9490);
    assert_eq!(v["caches"], 7);
    assert!(v["nodes"].as_u64().unwrap() > 9490);
    let names: Vec<&str> = v["names"].as_array().unwrap().iter().map(|n| n.as_str().unwrap()).collect();
    assert_eq!(names, ["body", "chest", "hair", "head", "left_hand", "neck", "tail"]);
}

const GOOD: &str = "Scene(
    camera: Camera(eye: (0.0, 0.0, 3.0), target: (0.0, 0.0, 0.0), fov_y: 30.0),
    size: (16, 16),
    model: Blend([
        Point(center: (0.0, 0.0, 0.0), radius: 1.0),
    ]),
)
";

/// Renders a scene text that must fail; checks the message and that an
/// existing output file is left as it was.
fn assert_rejected(name: &str, text: &str, expect_position: Option<(usize, usize)>, expect_words: &str) {
    let dir = scratch(name);
    let scene = dir.join(format!("{name}.ron"));
    std::fs::write(&scene, text).unwrap();
    let png = dir.join("existing.png");
    std::fs::write(&png, b"keep me").unwrap();
    let out = blobtrace(&["render", scene.to_str().unwrap(), "-o", png.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{name}: should fail");
    assert!(!err.contains("panicked"), "{name}: panicked: {err}");
    if let Some((line, col)) = expect_position {
        let at = format!("{}:{line}:{col}:", scene.display());
        assert!(err.contains(&at), "{name}: expected position {at} in {err}");
    }
    assert!(err.to_lowercase().contains(expect_words), "{name}: expected {expect_words:?} in {err}");
    assert_eq!(std::fs::read(&png).unwrap(), b"keep me", "{name}: output was touched");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn good_scene_text_renders() {
    let dir = scratch("good");
    let scene = dir.join("good.ron");
    std::fs::write(&scene, GOOD).unwrap();
    run_ok(&["render", scene.to_str().unwrap(), "-o", dir.join("g.png").to_str().unwrap()]);
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn bad_scenes_give_positions_and_no_panic() {
    assert_rejected("syntax", &GOOD.replace("radius: 1.0),", "radius: 1.0"), Some((6, 5)), "expected");
    assert_rejected("unknown-node", &GOOD.replace("Point(", "Pointy("), Some((5, 9)), "pointy");
    assert_rejected("negative-radius", &GOOD.replace("radius: 1.0", "radius: -1.0"), Some((5, 48)), "positive");
    assert_rejected(
        "nan",
        &GOOD.replace("center: (0.0, 0.0, 0.0)", "center: (0.0, NaN, 0.0)"),
        Some((5, 37)),
        "finite",
    );
    assert_rejected(
        "empty-blend",
        &GOOD.replace("Point(center: (0.0, 0.0, 0.0), radius: 1.0),", ""),
        Some((6, 5)),
        "at least one child",
    );
    assert_rejected("unknown-field", &GOOD.replace("radius: 1.0", "radius: 1.0, wieght: 2.0"), Some((5, 53)), "wieght");
    assert_rejected("huge-radius", &GOOD.replace("radius: 1.0", "radius: 1e20"), Some((5, 48)), "magnitude");
    let point = "Point(center: (0.0, 0.0, 0.0), radius: 1.0)";
    let ricci = format!("Ricci(n: 0.5, children: [{point}])");
    assert_rejected("ricci-below-one", &GOOD.replace(point, &ricci), Some((5, 18)), "at least 1");
    let flat = "Circle(center: (0.0, 0.0, 0.0), normal: (0.0, 0.0, 0.0), ring: 0.5, radius: 0.3)";
    assert_rejected("circle-without-normal", &GOOD.replace(point, flat), Some((5, 63)), "no length");
    let nested = (0..600).fold(point.to_string(), |inner, _| format!("Blend([{inner}])"));
    assert_rejected("too-deep", &GOOD.replace(point, &nested), None, "nests deeper than");
    let many = |node: &str, n: usize| GOOD.replace(point, &vec![node; n].join(", "));
    let spline = "SplinePoints(control: [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)], count: 1000000, radius: 0.01)";
    assert_rejected("too-many-primitives", &many(spline, 11), None, "11000000 primitives");
    let cache = format!("Cache(res: 1024, child: {point})");
    assert_rejected("too-many-caches", &many(&cache, 30), None, "block tables");
    assert_rejected("empty-name", &GOOD.replace(point, &format!("Named(\"\", {point})")), Some((5, 16)), "empty");
    assert_rejected(
        "far-model",
        &GOOD.replace("center: (0.0, 0.0, 0.0), radius: 1.0", "center: (9e5, 0.0, 0.0), radius: 0.1"),
        Some((4, 5)),
        "farther than",
    );
    assert_rejected(
        "zero-scale",
        &GOOD.replace(
            "Point(center: (0.0, 0.0, 0.0), radius: 1.0)",
            "Transform(scale: (1.0, 0.0, 1.0), child: Point(center: (0.0, 0.0, 0.0), radius: 1.0))",
        ),
        Some((5, 40)),
        "scale",
    );
    let cached = |opts: &str| {
        GOOD.replace(
            "Point(center: (0.0, 0.0, 0.0), radius: 1.0)",
            &format!("Cache(res: 32, {opts}child: Point(center: (0.0, 0.0, 0.0), radius: 1.0))"),
        )
    };
    assert_rejected("bad-filter", &cached("value: Cubic, "), Some((5, 31)), "cubic");
    assert_rejected("bad-res", &cached("").replace("res: 32", "res: 5000"), Some((5, 20)), "resolution");
    assert_rejected("eye-on-target", &GOOD.replace("eye: (0.0, 0.0, 3.0)", "eye: (0.0, 0.0, 0.0)"), None, "coincide");
    assert_rejected("duplicate-name", &GOOD.replace("Point(center: (0.0, 0.0, 0.0), radius: 1.0),", "Named(\"a\", Point(center: (0.0, 0.0, 0.0), radius: 1.0)), Named(\"a\", Point(center: (1.0, 0.0, 0.0), radius: 1.0)),"), Some((5, 66)), "used twice");
}

#[test]
fn missing_scene_and_bad_options_fail_cleanly() {
    for args in [
        &["render", "scenes/no-such-scene.ron"][..],
        &["render", "scenes/pair.ron", "--size", "0x10"],
        &["render", "scenes/pair.ron", "--size", "big"],
        &["render", "scenes/pair.ron", "--threads", "0", "-o", "/tmp/blobtrace-never.png"],
        &["render", "scenes/pair.ron", "--eval", "fast"],
        &["render", "scenes/pair.ron", "-o", "/no/such/dir/out.png"],
    ] {
        let out = blobtrace(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} should fail");
        assert!(!err.contains("panicked") && !err.is_empty(), "{args:?}: {err}");
    }
    assert!(!Path::new("/tmp/blobtrace-never.png").exists());
}

#[test]
fn usage_errors_exit_64_in_every_command_and_other_errors_1() {
    let usage: [&[&str]; 13] = [
        &["render", "scenes/pair.ron", "--size", "0x10"],
        &["render", "scenes/pair.ron", "--mesh", "--res", "0", "-o", "/tmp/blobtrace-never.png"],
        &["mesh", "scenes/pair.ron", "--res", "0", "-o", "/tmp/blobtrace-never.ply"],
        &["compare", "scenes/pair.ron", "--res", "0", "--out-dir", "/tmp/blobtrace-never"],
        &["edit", "scenes/hair_point.ron", "--script", "scenes/scripts/hair-probe.ron", "--refine", "1"],
        &["slice", "scenes/pair.ron", "--plane", "z=0", "--scale", "-1"],
        &["render", "scenes/pair.ron", "--cache-budget", "0.001"],
        &["render", "scenes/pair.ron", "--eye", "1,2"],
        &["diff", "a.png"],
        &["slice", "scenes/pair.ron", "--plane", "w=1"],
        &["view", "scenes/pair.ron", "--headless", "--keys", "f13"],
        &["render", "scenes/pair.ron", "-o", "/tmp/blobtrace-never.jpg"],
        &["mesh", "scenes/pair.ron", "-o", "/tmp/blobtrace-never.gltf"],
    ];
    for args in usage {
        let out = blobtrace(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(64), "{args:?}: {err}");
        assert!(!err.contains("panicked") && !err.is_empty(), "{args:?}: {err}");
    }
    let out = blobtrace(&["render", "scenes/no-such-scene.ron"]);
    assert_eq!(out.status.code(), Some(1), "a missing scene is an error, not a usage error");
    let help = String::from_utf8_lossy(&blobtrace(&["--help"]).stdout).to_string();
    assert!(help.contains("64 usage error") && help.contains("Exit codes"), "{help}");
}

#[test]
fn camera_overrides_change_the_view_and_bad_ones_are_refused() {
    let dir = scratch("camera");
    let render = |name: &str, extra: &[&str]| {
        let png = dir.join(name);
        let mut args = vec!["render", "scenes/pair.ron", "--size", "40x30", "-o", png.to_str().unwrap(), "--json"];
        args.extend_from_slice(extra);
        let v = run_json(&args);
        (std::fs::read(&png).unwrap(), v["hits"].as_u64().unwrap())
    };
    let (plain, plain_hits) = render("plain.png", &[]);
    let (same, _) = render("same.png", &["--fov", "35"]);
    let (_, far_hits) = render("far.png", &["--eye", "0,0.5,40"]);
    let (wide, wide_hits) = render("wide.png", &["--fov", "90"]);
    assert_eq!(plain, same, "an override equal to the scene's changes nothing");
    assert!(far_hits < plain_hits / 4, "a far eye sees the model small: {far_hits} of {plain_hits}");
    assert!(wide_hits < plain_hits && wide != plain, "a wider view sees it smaller");
    for (args, words) in [(&["--eye", "0,0,0", "--target", "0,0,0"][..], "coincide"), (&["--fov", "200"], "fov")] {
        let mut all = vec!["render", "scenes/pair.ron", "-o", "/tmp/blobtrace-never.png"];
        all.extend_from_slice(args);
        let out = blobtrace(&all);
        assert_eq!(out.status.code(), Some(64));
        assert!(String::from_utf8_lossy(&out.stderr).contains(words));
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn cached_render_reports_cache_statistics_and_exact_mode_omits_them() {
    let dir = scratch("cached");
    let png = dir.join("medusa.png");
    let run = |extra: &[&str]| {
        let mut args = vec!["render", "scenes/medusa.ron", "-o", png.to_str().unwrap(), "--size", "64x48", "--json"];
        args.extend_from_slice(extra);
        json(&blobtrace(&args))
    };
    // The default, auto, finds that none of Medusa's caches pays: exact evaluation, with the decisions reported.
    let auto = run(&[]);
    assert_eq!(auto["eval"], "indexed");
    let decisions = auto["cache_decisions"].as_array().expect("decisions are reported");
    assert_eq!(decisions.len(), 7);
    for d in decisions {
        assert!(
            d["exact_cost"].as_f64() > Some(0.0) && d["uses_lattice"] == false && d["reason"] == "estimated",
            "{d}"
        );
    }
    assert!(auto.get("caches").is_none());
    let cached = run(&["--mode", "cached"]);
    assert_eq!(cached["eval"], "cached");
    let caches = &cached["caches"];
    for key in ["samples_evaluated", "blocks", "bytes", "touched_fraction", "lookups", "per_cache"] {
        assert!(caches.get(key).is_some(), "missing cache key {key} in {caches}");
    }
    assert_eq!(caches["per_cache"].as_array().map(Vec::len), Some(7));
    assert!(caches["samples_evaluated"].as_u64() > Some(0));
    // Every lookup is counted, on however many threads.
    let one_thread = run(&["--mode", "cached", "--threads", "1"]);
    assert!(caches["lookups"].as_u64() > Some(0));
    assert_eq!(one_thread["caches"]["lookups"], caches["lookups"]);
    let budgeted = run(&["--mode", "cached", "--cache-budget", "0.5"]);
    assert!(budgeted["caches"]["bytes"].as_u64() <= Some(512 * 1024), "{}", budgeted["caches"]);
    assert_eq!(budgeted["hits"], cached["hits"]);
    let exact = run(&["--mode", "exact"]);
    assert_eq!(exact["eval"], "indexed");
    assert!(exact.get("caches").is_none());
    assert_eq!(run(&["--eval", "naive"])["eval"], "naive", "--eval naive alone means exact evaluation");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn conflicting_or_bad_cache_options_are_refused() {
    for args in [
        &["render", "scenes/medusa.ron", "--mode", "cached", "--eval", "naive"][..],
        &["render", "scenes/medusa.ron", "--cache-budget", "0.01"],
        &["render", "scenes/medusa.ron", "--cache-budget", "NaN"],
        &["render", "scenes/medusa.ron", "--mode", "fuzzy"],
    ] {
        let out = blobtrace(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
        assert!(err.contains("--") || err.contains("mode"), "{args:?}: unclear message {err}");
    }
}

#[test]
fn bench_cache_reports_its_keys() {
    let v = run_json(&["bench", "cache", "--size", "32x24", "--repeat", "2", "--json"]);
    assert_keys(
        &v,
        &[
            "exact_naive_s",
            "exact_s",
            "cached_cold_s",
            "cached_warm_s",
            "mismatch_px",
            "mean_depth_err",
            "p99_normal_err_deg",
            "cache_bytes",
        ],
    );
    assert!(v["mismatch_px"].as_u64() < Some(32 * 24 / 20), "{}", v["mismatch_px"]);
    assert_eq!(v["lookups"].as_array().map(Vec::len), Some(7));
    // The ratio's parts: both renders' statistics, the exact one the fastest round's.
    assert_eq!(v["exact"]["seconds"].as_f64(), v["exact_s"].as_f64());
    assert_eq!(v["exact"]["eval"], "indexed");
    assert_eq!(v["cached"]["eval"], "cached");
    for kind in ["exact", "cached"] {
        assert!(v[kind]["field_evals"].as_u64() > Some(0), "{kind}: {}", v[kind]);
    }
    // Two rounds of each render, and the fastest counts.
    for (key, best) in
        [("exact_naive", "exact_naive_s"), ("cached_cold", "cached_cold_s"), ("cached_warm", "cached_warm_s")]
    {
        let runs: Vec<f64> = v["runs_s"][key].as_array().unwrap().iter().map(|s| s.as_f64().unwrap()).collect();
        assert_eq!(runs.len(), 2, "{key}: {runs:?}");
        assert_eq!(Some(runs.iter().copied().fold(f64::MAX, f64::min)), v[best].as_f64(), "{key}");
    }
}

#[test]
fn the_tracer_is_chosen_reported_and_refused_where_it_cannot_apply() {
    let dir = scratch("tracer");
    let png = dir.join("pair.png");
    let args = ["render", "scenes/pair.ron", "--size", "64x48", "--json", "-o", png.to_str().unwrap()];
    let auto = run_json(&args);
    assert_eq!(auto["tracer"], "kernel");
    assert!(auto["supports_per_ray"].as_f64().unwrap() > 0.5 && auto["evals_per_hit"].as_f64().unwrap() >= 2.0);
    let segment = run_json(&[&args[..], &["--tracer", "segment"]].concat());
    assert_eq!(segment["tracer"], "segment");
    assert!(segment.get("supports_per_ray").is_none() && segment["empty_fraction"].as_f64().is_some());
    assert_eq!(auto["hits"], segment["hits"], "the same pixels hit either way");
    let refused = blobtrace(&["render", "scenes/sharp.ron", "--tracer", "kernel", "-o", png.to_str().unwrap()]);
    assert_eq!(refused.status.code(), Some(64));
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(err.contains("--tracer kernel applies to sums of points and segments only: a union"), "{err}");
    let info = run_json(&["info", "scenes/medusa.ron", "--json"]);
    assert_eq!(info["tracer"]["tracer"], "segment", "Medusa's supports overlap too deeply: {info}");
    assert!(info["tracer"]["overlap"].as_f64().unwrap() > 24.0);
}

#[test]
fn bench_eval_counts_the_fastest_of_its_rounds() {
    let v = run_json(&["bench", "eval", "scenes/pair.ron", "--size", "24x16", "--repeat", "3", "--json"]);
    for kind in ["kernel", "segment", "naive"] {
        let runs: Vec<f64> = v["runs_s"][kind].as_array().unwrap().iter().map(|s| s.as_f64().unwrap()).collect();
        assert_eq!(runs.len(), 3, "{kind}");
        assert_eq!(Some(runs.iter().copied().fold(f64::MAX, f64::min)), v[kind]["seconds"].as_f64(), "{kind}");
    }
    assert_eq!(v["kernel"]["tracer"], "kernel");
    assert_eq!(v["segment"]["tracer"], "segment");
    assert_eq!(v["kernel_mismatch_px"], 0, "the two tracers hit the same pixels of the pair");
    let out = blobtrace(&["bench", "eval", "scenes/pair.ron", "--repeat", "0"]);
    assert!(!out.status.success());
    // A model the kernel tracer does not apply to has no kernel row.
    let v = run_json(&["bench", "eval", "scenes/sharp.ron", "--size", "24x16", "--repeat", "1", "--json"]);
    assert!(v.get("kernel").is_none() && v["runs_s"]["kernel"].as_array().unwrap().is_empty());
}

#[test]
fn mesh_writes_every_format_and_reports_json() {
    let dir = scratch("mesh");
    for ext in ["ply", "obj", "stl"] {
        let path = dir.join(format!("pair.{ext}"));
        let v = run_json(&["mesh", "scenes/pair.ron", "--res", "24", "-o", path.to_str().unwrap(), "--json"]);
        assert_keys(&v, &["triangles", "vertices", "field_evals", "seconds", "evals_per_triangle", "quality"]);
        assert_eq!(v["closed_manifold"], true);
        if cfg!(target_os = "linux") {
            // The meshing's own memory: at least its triangles' indices, and a peak above the start.
            let memory = &v["memory"];
            let (before, peak) = (memory["before_mb"].as_f64().unwrap(), memory["peak_mb"].as_f64().unwrap());
            assert!(before > 0.0 && peak >= before, "{memory}");
            assert!(memory["bytes_per_triangle"].as_f64().unwrap() >= 0.0, "{memory}");
        }
        let bytes = std::fs::read(&path).expect("the mesh was written");
        let triangles = v["triangles"].as_u64().unwrap();
        match ext {
            "ply" => assert!(String::from_utf8_lossy(&bytes[..300]).contains(&format!("element face {triangles}"))),
            "obj" => assert_eq!(
                String::from_utf8_lossy(&bytes).lines().filter(|l| l.starts_with("f ")).count() as u64,
                triangles
            ),
            _ => assert_eq!(bytes.len() as u64, 84 + 50 * triangles),
        }
    }
    let bcc = blobtrace(&[
        "mesh",
        "scenes/pair.ron",
        "--res",
        "24",
        "--cells",
        "bcc",
        "-o",
        dir.join("b.ply").to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(json(&bcc)["cells"], "bcc");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn bad_mesh_options_fail_before_any_work_and_keep_existing_outputs() {
    let dir = scratch("mesh-bad");
    let existing = dir.join("keep.ply");
    std::fs::write(&existing, b"old").unwrap();
    let keep = existing.to_str().unwrap();
    let cases: [(&[&str], &str); 4] = [
        (&["-o", keep, "--res", "0"], "--res"),
        (&["-o", keep, "--res", "8000"], "GiB"),
        (&["-o", keep, "--res", "100000"], "--res"),
        (&["-o", "out.gltf"], "unknown mesh format"),
    ];
    for (extra, words) in cases {
        let mut args = vec!["mesh", "scenes/medusa.ron"];
        args.extend_from_slice(extra);
        let out = blobtrace(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(words), "{extra:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    assert_eq!(std::fs::read(&existing).unwrap(), b"old");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn render_mesh_draws_the_polygonized_surface() {
    let dir = scratch("render-mesh");
    let png = dir.join("m.png");
    let v = run_json(&[
        "render",
        "scenes/pair.ron",
        "--mesh",
        "--res",
        "32",
        "--size",
        "64x48",
        "-o",
        png.to_str().unwrap(),
        "--json",
    ]);
    assert!(v["hits"].as_u64().unwrap() > 300, "{v}");
    assert!(v["mesh"]["triangles"].as_u64().unwrap() > 100, "{v}");
    assert_eq!(image::open(&png).unwrap().to_rgb8().dimensions(), (64, 48));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn diff_follows_idiff_exit_codes_and_writes_a_heat_map() {
    let dir = scratch("diff");
    let path = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let render = |extra: &[&str], name: &str| {
        let (png, exr) = (path(&format!("{name}.png")), path(&format!("{name}.exr")));
        let mut args = vec!["render", "scenes/pair.ron", "-o", &png, "--exr", &exr];
        args.extend_from_slice(extra);
        assert!(blobtrace(&args).status.success());
    };
    render(&["--size", "48x36"], "ray");
    render(&["--size", "48x36", "--mesh", "--res", "16"], "mesh");
    render(&["--size", "40x30"], "small");
    let code = |args: &[&str]| blobtrace(args).status.code();
    let (ray, mesh) = (path("ray.exr"), path("mesh.exr"));
    assert_eq!(code(&["diff", &ray, &ray]), Some(0));
    assert_eq!(code(&["diff", &ray, &mesh]), Some(2));
    // Every channel is compared: depth hit by one render only fails whatever the thresholds.
    assert_eq!(code(&["diff", &ray, &mesh, "--fail", "1", "--warn", "1"]), Some(2));
    let colour = ["--channels", "R,G,B,A"];
    let with_colour = |args: &[&str]| code(&[&["diff", &ray, &mesh], &colour[..], args].concat());
    // As in idiff, a warning needs failures (tolerated by --failpercent) and warnings above theirs.
    assert_eq!(with_colour(&["--fail", "1", "--warn", "0.01"]), Some(0));
    assert_eq!(with_colour(&["--fail", "0.01", "--failpercent", "50", "--warn", "0.01"]), Some(1));
    assert_eq!(with_colour(&["--fail", "1", "--warn", "1"]), Some(0));
    assert_eq!(with_colour(&["--fail", "0.01", "--failpercent", "50", "--hardfail", "0.05"]), Some(2));
    assert_eq!(with_colour(&["--allowfailures", "100000"]), Some(0));
    assert_eq!(code(&["diff", &ray, &mesh, "--channels", "R,Q"]), Some(4));
    // As idiff does, the abs metric compares images of different sizes (over the larger one); the
    // surface metrics cannot.
    assert_eq!(code(&["diff", &path("ray.png"), &path("small.png")]), Some(2));
    assert_eq!(code(&["diff", &ray, &path("small.exr"), "--metric", "depth"]), Some(3));
    assert_eq!(code(&["diff", &ray, &path("missing.exr")]), Some(4));
    assert_eq!(code(&["diff", &path("ray.png"), &path("mesh.png"), "--metric", "depth"]), Some(4));
    // Bad options are usage errors, with the code every command gives them.
    assert_eq!(code(&["diff", &ray, &mesh, "--fail", "-1"]), Some(64));
    assert_eq!(code(&["diff", &ray, &mesh, "--no-such-option"]), Some(64));
    let heat = path("heat.png");
    let out = blobtrace(&["diff", &ray, &mesh, "--metric", "depth", "--mask-edges", "1", "-o", &heat, "--json"]);
    assert_eq!(out.status.code(), Some(2));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    for key in ["mean", "median", "p95", "p99", "max", "over_fail_px", "mismatch_px", "masked_px", "verdict"] {
        assert!(v.get(key).is_some(), "missing {key} in {v}");
    }
    assert!(v["masked_px"].as_u64().unwrap() > 0);
    let img = image::open(&heat).expect("a heat map was written").to_rgb8();
    assert!(img.width() >= 48 && img.height() > 36, "{:?}", img.dimensions());
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn diff_takes_idiffs_options_and_refuses_outputs_it_cannot_write() {
    let dir = scratch("diff-outputs");
    let path = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let (ray, mesh) = (path("ray.png"), path("mesh.png"));
    assert!(blobtrace(&["render", "scenes/pair.ron", "--size", "48x36", "-o", &ray]).status.success());
    let mesh_args = ["render", "scenes/pair.ron", "--size", "48x36", "--mesh", "--res", "16", "-o", &mesh];
    assert!(blobtrace(&mesh_args).status.success());
    let code = |args: &[&str]| blobtrace(&[&["diff"], args].concat()).status.code();
    // idiff's single-dash options mean ours.
    assert_eq!(code(&["-fail", "0.5", "-warn", "0.01", &ray, &mesh]), Some(2));
    assert_eq!(
        code(&["-fail", "0.5", "-warn", "0.01", &ray, &mesh]),
        code(&["--fail", "0.5", "--warn", "0.01", &ray, &mesh])
    );
    assert_eq!(code(&["-fail", "1", "-warn", "1", &ray, &mesh]), Some(0));
    assert_eq!(code(&["-allowfailures", "100000", &ray, &mesh]), Some(0));
    assert_eq!(code(&["-fail", "0.01", "-failpercent", "50", "-warn", "0.01", &ray, &mesh]), Some(1));
    // -p is FLIP: its report says so.
    let out = blobtrace(&["diff", "-p", &ray, &mesh]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("FLIP at 67.0 pixels per degree"), "{out:?}");
    // -q prints nothing but FAILURE, on stderr.
    let out = blobtrace(&["diff", "-q", &ray, &mesh]);
    assert_eq!((out.stdout.is_empty(), String::from_utf8_lossy(&out.stderr).trim()), (true, "FAILURE"));
    // An output name we cannot write is a usage error, and nothing is written.
    for name in ["heat.jpg", "heat", "heat.tiff"] {
        let out = blobtrace(&["diff", &ray, &mesh, "-o", &path(name)]);
        assert_eq!(out.status.code(), Some(64), "-o {name}: {}", String::from_utf8_lossy(&out.stderr));
        assert!(String::from_utf8_lossy(&out.stderr).contains(".png"), "{out:?}");
        assert!(!dir.join(name).exists());
    }
    assert_eq!(code(&[&ray, &mesh, "-o", &path("no-such-folder/heat.png")]), Some(4));
    assert_eq!(code(&["-a", &ray, &mesh]), Some(64));
    assert_eq!(code(&[&ray, &mesh, "-p", "--metric", "abs"]), Some(64));
    // -o FILE.png is a heat map; with -abs, idiff's absolute difference image of the same size.
    assert_eq!(code(&[&ray, &mesh, "-o", &path("heat.png")]), Some(2));
    assert!(image::open(path("heat.png")).unwrap().height() > 36, "a heat map with its colour bar");
    assert_eq!(code(&["-abs", "-o", &path("abs.png"), &ray, &mesh]), Some(2));
    assert_eq!(image::open(path("abs.png")).unwrap().to_rgb8().dimensions(), (48, 36));
    std::fs::remove_dir_all(dir).unwrap();
}

/// The bytes of a PNG that declares a `width × height` grey image and holds
/// no pixel data (an empty data chunk): enough for a reader that checks the
/// size first.
fn png_header_only(width: u32, height: u32) -> Vec<u8> {
    fn crc32(bytes: &[u8]) -> u32 {
        let mut crc = !0u32;
        for &b in bytes {
            crc ^= u32::from(b);
            for _ in 0..8 {
                crc = if crc & 1 == 1 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
            }
        }
        !crc
    }
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend_from_slice(&width.to_be_bytes());
    ihdr.extend_from_slice(&height.to_be_bytes());
    ihdr.extend_from_slice(&[1, 0, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    for chunk in [&ihdr[..], b"IDAT", b"IEND"] {
        png.extend_from_slice(&(chunk.len() as u32 - 4).to_be_bytes());
        png.extend_from_slice(chunk);
        png.extend_from_slice(&crc32(chunk).to_be_bytes());
    }
    png
}

#[test]
fn diff_refuses_an_image_declaring_more_pixels_than_it_may_hold_before_decoding_it() {
    let dir = scratch("diff-huge");
    let huge = dir.join("huge.png");
    std::fs::write(&huge, png_header_only(20_000, 20_000)).unwrap();
    let small = dir.join("small.png");
    image::RgbImage::new(4, 4).save(&small).unwrap();
    let out = blobtrace(&["diff", small.to_str().unwrap(), huge.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("20000x20000 is out of range"), "{err}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn compare_writes_renders_heat_maps_panel_and_stats() {
    let dir = scratch("compare");
    let v = run_json(&[
        "compare",
        "scenes/pair.ron",
        "--size",
        "64x48",
        "--res",
        "24",
        "--out-dir",
        dir.to_str().unwrap(),
        "--json",
    ]);
    for name in COMPARE_OUTPUTS {
        assert!(dir.join(name).exists(), "{name} missing");
    }
    for name in COMPARE_OPTIONAL_OUTPUTS {
        assert!(!dir.join(name).exists(), "{name} written without --error");
    }
    for key in ["depth_error_cells", "normal_error_deg", "color_error"] {
        for stat in ["mean", "median", "p95", "p99", "max", "fraction_above_tolerance"] {
            assert!(v[key].get(stat).is_some(), "{key}.{stat} missing in {v}");
        }
    }
    // A coarse mesh of two smooth blobs: depth within a cell, some silhouette pixels differ.
    assert!(v["depth_error_cells"]["p99"].as_f64().unwrap() < 1.0, "{v}");
    assert!(v["mesh"]["mesh"]["triangles"].as_u64().unwrap() > 100);
    assert_eq!(v["ray"]["rays"], 64 * 48);
    let panel = image::open(dir.join("panel.png")).unwrap();
    assert!(panel.width() > 3 * 64 && panel.height() > 2 * 48);
    // Scales chosen from the data are round numbers; the signed depth bias is reported.
    let chosen = v["scales"]["normal_deg"].as_f64().unwrap();
    assert!([1.0, 2.0, 5.0].iter().any(|m| (chosen / m).log10().fract().abs() < 1e-4), "{chosen}");
    assert!(v["depth_bias_cells"].as_f64().unwrap().abs() <= v["depth_error_cells"]["mean"].as_f64().unwrap());
    // Scales and tolerances given are the ones used; a tight normal scale marks pixels beyond it.
    let fixed = dir.join("fixed");
    let args = ["--scale-normal", "0.5", "--tol-depth", "0.5", "--tol-color", "0"];
    let mut all = vec!["compare", "scenes/pair.ron", "--size", "64x48", "--res", "24", "--json", "--out-dir"];
    all.push(fixed.to_str().unwrap());
    all.extend(args);
    let v = run_json(&all);
    assert_eq!((v["scales"]["normal_deg"].as_f64(), v["tolerances"]["depth_cells"].as_f64()), (Some(0.5), Some(0.5)));
    let heat = image::open(fixed.join("normal_error.png")).unwrap().to_rgb8();
    assert!(heat.pixels().filter(|p| p.0 == [80, 255, 40]).count() > 10, "values beyond the scale are marked");
    let bad = blobtrace(&["compare", "scenes/pair.ron", "--scale-depth", "-1", "--out-dir", fixed.to_str().unwrap()]);
    assert_eq!(bad.status.code(), Some(64), "{}", String::from_utf8_lossy(&bad.stderr));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn mesh_error_colours_vertices_by_the_cache_error() {
    let dir = scratch("mesh-error");
    let ply = dir.join("m.ply");
    let out =
        blobtrace(&["mesh", "scenes/medusa.ron", "--res", "32", "--error", "-o", ply.to_str().unwrap(), "--json"]);
    let v = json(&out);
    let e = &v["error_c"];
    let (mean, max) = (e["mean"].as_f64().unwrap(), e["max"].as_f64().unwrap());
    assert!(mean > 0.0 && mean < max && max < 0.5, "{e}");
    assert_eq!(e["points"], v["vertices"]);
    let bytes = std::fs::read(&ply).unwrap();
    let header = String::from_utf8_lossy(&bytes[..400]);
    assert!(header.contains("property float error") && header.contains("property uchar red"), "{header}");
    let no_caches = blobtrace(&["mesh", "scenes/pair.ron", "--error", "-o", ply.to_str().unwrap()]);
    assert!(!no_caches.status.success());
    assert!(String::from_utf8_lossy(&no_caches.stderr).contains("no Cache nodes"));
    let cmp = dir.join("cmp");
    run_ok(&[
        "compare",
        "scenes/hair_point.ron",
        "--size",
        "48x36",
        "--res",
        "32",
        "--error",
        "--out-dir",
        cmp.to_str().unwrap(),
    ]);
    for name in COMPARE_OUTPUTS.iter().chain(&COMPARE_OPTIONAL_OUTPUTS) {
        assert!(cmp.join(name).exists(), "{name} missing");
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn slices_show_the_field_and_the_caches_errors() {
    let dir = scratch("slice");
    let png = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let run = |args: &[&str]| blobtrace(args);
    let field = run(&["slice", "scenes/pair.ron", "--plane", "z=0", "--size", "80x60", "-o", &png("f.png")]);
    assert!(field.status.success(), "{}", String::from_utf8_lossy(&field.stderr));
    let img = image::open(png("f.png")).unwrap().to_rgb8();
    // The iso-contour is drawn in white inside the slice.
    assert!(img.pixels().any(|p| p.0 == [255, 255, 255]));
    for show in ["sharp", "error", "gradient"] {
        let out = run(&[
            "slice",
            "scenes/hair_point.ron",
            "--plane",
            "0.5,2,0+0,0,1",
            "--size",
            "60x60",
            "--show",
            show,
            "--res-sweep",
            "16,32",
            "-o",
            &png(&format!("{show}.png")),
        ]);
        assert!(out.status.success(), "{show}: {}", String::from_utf8_lossy(&out.stderr));
        let img = image::open(png(&format!("{show}.png"))).unwrap();
        // Sharp: exact and two filters; error and gradient: two filters by two resolutions.
        assert!(
            img.width() > if show == "sharp" { 3 * 50 } else { 2 * 200 },
            "{show}: {:?}",
            (img.width(), img.height())
        );
    }
    for (args, words) in [
        (vec!["--plane", "w=1"], "expected x=V"),
        (vec!["--plane", "z=0", "--show", "error"], "has none"),
        (vec!["--plane", "z=0", "--res-sweep", "1"], "2..=1024"),
    ] {
        let mut all = vec!["slice", "scenes/pair.ron"];
        all.extend(args);
        let out = run(&all);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(words), "{all:?}: {err}");
    }
    // Slices that show less than was asked say so, and still succeed.
    let plain = String::from_utf8_lossy(&field.stderr).to_string();
    assert!(!plain.contains("warning"), "{plain}");
    let warned = png("w.png");
    for (args, words) in [
        (vec!["--plane", "z=100"], "misses the model"),
        (vec!["--plane", "z=0", "--res-sweep", "16"], "sweep is ignored"),
    ] {
        let mut all = vec!["slice", "scenes/pair.ron", "--size", "40x30", "-o", &warned];
        all.extend(args);
        let out = run(&all);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success() && err.contains("warning") && err.contains(words), "{all:?}: {err}");
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn an_empty_render_warns_and_a_diff_of_no_pixels_fails() {
    let dir = scratch("empty");
    let png = dir.join("away.png");
    let exr = dir.join("away.exr");
    let (p, e) = (png.to_str().unwrap(), exr.to_str().unwrap());
    // Looking away from the model: every ray misses.
    let out = blobtrace(&["render", "scenes/pair.ron", "--size", "32x24", "--target", "0,0,10", "-o", p, "--exr", e]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && err.contains("warning: no ray hit"), "{err}");
    let hit = blobtrace(&["render", "scenes/pair.ron", "--size", "32x24", "-o", p]);
    assert!(!String::from_utf8_lossy(&hit.stderr).contains("warning"));
    // Depth where both images miss everywhere: nothing is compared, and that fails.
    let out = blobtrace(&["diff", e, e, "--metric", "depth"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("no pixel was compared"), "{err}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn regression_passes_on_the_bundled_references_and_fails_on_a_perturbed_model() {
    let dir = scratch("regress");
    let report = dir.join("report");
    run_ok(&["regress", "--report", report.to_str().unwrap()]);
    assert!(std::fs::read_to_string(report.join("index.html")).unwrap().contains("Pass"));
    let scenes = scenes_with_a_grown_radius(&dir);
    let bad_report = dir.join("bad");
    let out = blobtrace(&["regress", "--scenes", scenes.to_str().unwrap(), "--report", bad_report.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("failed"));
    let page = std::fs::read_to_string(bad_report.join("index.html")).unwrap();
    for kind in ["ref", "actual", "diff", "heat", "flip"] {
        let image = format!("002-pair-field-96x72-{kind}.png");
        assert!(bad_report.join(&image).exists() && page.contains(&image), "{image}");
    }
    assert!(!bad_report.join("000-sphere-field-64x48-actual.png").exists());
    // Blessing into a fresh directory reproduces the bundled references, which then pass.
    let refs = dir.join("refs");
    std::fs::create_dir_all(&refs).unwrap();
    let bare = blobtrace(&["regress", "--refs", refs.to_str().unwrap(), "--bless"]);
    assert!(String::from_utf8_lossy(&bare.stderr).contains("copy images/ref/manifest.ron"), "a hint, not a bare error");
    std::fs::copy("images/ref/manifest.ron", refs.join("manifest.ron")).unwrap();
    assert!(blobtrace(&["regress", "--refs", refs.to_str().unwrap(), "--bless"]).status.success());
    assert_eq!(
        std::fs::read(refs.join("pair-mesh32-96x72.png")).unwrap(),
        std::fs::read("images/ref/pair-mesh32-96x72.png").unwrap()
    );
    let again =
        blobtrace(&["regress", "--refs", refs.to_str().unwrap(), "--report", dir.join("again").to_str().unwrap()]);
    assert!(again.status.success());
    // A misspelt tolerance or an unusable one is refused where it is written.
    for (entry, words) in
        [("failpercnt: 5.0", "failpercnt"), ("fail: NaN", "finite"), ("failpercent: 150.0", "percentage")]
    {
        let text = format!("Manifest(entries: [Entry(scene: \"sphere.ron\", size: (8, 8), kind: Field, {entry})])");
        std::fs::write(refs.join("manifest.ron"), text).unwrap();
        let out = blobtrace(&["regress", "--refs", refs.to_str().unwrap(), "--bless"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains("manifest.ron:1:") && err.contains(words), "{entry}: {err}");
    }
    // A scene missing from the second entry is found before anything renders,
    // at its entry, and no report folder is made.
    let text = "Manifest(entries: [\n  Entry(scene: \"sphere.ron\", size: (8, 8), kind: Field),\n  Entry(scene: \"gone.ron\", size: (8, 8), kind: Field),\n])";
    std::fs::write(refs.join("manifest.ron"), text).unwrap();
    let unmade = dir.join("unmade");
    let out = blobtrace(&["regress", "--refs", refs.to_str().unwrap(), "--report", unmade.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("manifest.ron:3:3") && err.contains("gone.ron"), "{err}");
    assert!(!unmade.exists());
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn regress_shards_cover_every_entry_once_and_report_junit() {
    let dir = scratch("shards");
    let manifest = std::fs::read_to_string("images/ref/manifest.ron").unwrap();
    let entries = manifest.lines().filter(|l| l.trim_start().starts_with("Entry(")).count();
    let mut seen: Vec<String> = vec![];
    for shard in ["1/3", "2/3", "3/3"] {
        let junit = dir.join(format!("junit-{}.xml", &shard[..1]));
        let report = dir.join(format!("report-{}", &shard[..1]));
        let args = ["regress", "--shard", shard, "--threads", "1", "--junit", junit.to_str().unwrap(), "--report"];
        let out = blobtrace(&[&args[..], &[report.to_str().unwrap()]].concat());
        assert!(out.status.success(), "{shard}: {}", String::from_utf8_lossy(&out.stderr));
        let xml = std::fs::read_to_string(&junit).unwrap();
        let doc = roxmltree::Document::parse(&xml).expect("JUnit XML parses");
        let cases: Vec<String> = doc
            .descendants()
            .filter(|n| n.has_tag_name("testcase"))
            .map(|n| n.attribute("name").unwrap().to_string())
            .collect();
        assert!(!cases.is_empty() && doc.descendants().all(|n| !n.has_tag_name("failure")), "{xml}");
        seen.extend(cases);
    }
    let mut unique = seen.clone();
    unique.sort();
    unique.dedup();
    assert_eq!((seen.len(), unique.len()), (entries, entries), "every entry once: {seen:?}");
    // A filter runs only the entries it names.
    let junit = dir.join("pair.xml");
    let out = blobtrace(&[
        "regress",
        "--filter",
        "pair-",
        "--junit",
        junit.to_str().unwrap(),
        "--report",
        dir.join("p").to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert_eq!(xml.matches("<testcase").count(), 2, "{xml}");
    // --entry names entries exactly (`pair-field` would also match a `repair-field` as a filter).
    let junit = dir.join("entry.xml");
    let named = ["--entry", "pair-field-96x72", "--entry", "sphere-mesh24-64x48.png"];
    let report = dir.join("e");
    let tail = ["--junit", junit.to_str().unwrap(), "--report", report.to_str().unwrap()];
    assert!(blobtrace(&[&["regress"][..], &named, &tail].concat()).status.success());
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert_eq!(xml.matches("<testcase").count(), 2, "{xml}");
    assert!(xml.contains("pair-field-96x72") && xml.contains("sphere-mesh24-64x48") && !xml.contains("pair-mesh"));
    let unknown = blobtrace(&["regress", "--entry", "pair-field", "--report", report.to_str().unwrap()]);
    assert_eq!(unknown.status.code(), Some(64));
    assert!(String::from_utf8_lossy(&unknown.stderr).contains("--entry pair-field: no entry is named so"));
    for bad in ["0/3", "4/3", "x"] {
        assert_eq!(blobtrace(&["regress", "--shard", bad]).status.code(), Some(64), "{bad}");
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn edit_replays_a_script_incrementally_and_verifies_every_frame() {
    let dir = scratch("edit");
    let v = run_json(&[
        "edit",
        "scenes/hair_point.ron",
        "--script",
        "scenes/scripts/hair-probe.ron",
        "--size",
        "48x36",
        "--res",
        "24",
        "--verify",
        "--out-dir",
        dir.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(v["frames"], 40);
    assert_eq!(v["verified_frames"], 40);
    for key in ["full_s", "incremental_s", "dirty_fraction"] {
        assert!(v[key].as_f64().is_some(), "{key} in {v}");
    }
    let dirty = v["dirty_fraction"].as_f64().unwrap();
    assert!(dirty > 0.0 && dirty < 0.5, "{dirty}");
    let csv = std::fs::read_to_string(dir.join("frames.csv")).unwrap();
    assert_eq!(csv.lines().count(), 41);
    assert!(dir.join("timing.png").exists());
    // A point added to the cached hair, moved by its new name, then removed: every frame verified.
    let grow = dir.join("grow.ron");
    std::fs::write(
        &grow,
        "EditScript(frames: [(edits: [AddPoint(to: \"hair\", name: \"bump\", center: (0.5, 2.3, 0.0), radius: 0.3)]),
          (repeat: 2, edits: [Translate(node: \"bump\", by: (0.1, 0.0, 0.0))]), (edits: [Remove(node: \"bump\")])])",
    )
    .unwrap();
    let args = ["edit", "scenes/hair_point.ron", "--script", grow.to_str().unwrap(), "--size", "40x30", "--res", "16"];
    // Exact too: the named point turns the hair's index from packed point
    // sums to per-leaf sums, which round differently all over the hair.
    for mode in ["cached", "exact"] {
        let verify = ["--verify", "--mode", mode, "--out-dir", dir.to_str().unwrap(), "--json"];
        let out = blobtrace(&[&args[..], &verify[..]].concat());
        assert_eq!(json(&out)["verified_frames"], 4, "{mode}");
    }
    let bad = dir.join("bad.ron");
    std::fs::write(&bad, "EditScript(frames: [(edits: [Translate(node: \"nobody\", by: (1.0, 0.0, 0.0))])])").unwrap();
    let out = blobtrace(&[
        "edit",
        "scenes/hair_point.ron",
        "--script",
        bad.to_str().unwrap(),
        "--out-dir",
        dir.to_str().unwrap(),
    ]);
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("no node is named \"nobody\""));
    std::fs::write(&bad, "EditScript(frames: [\n  (edits: [Twist(node: \"probe\")])])").unwrap();
    let out = blobtrace(&[
        "edit",
        "scenes/hair_point.ron",
        "--script",
        bad.to_str().unwrap(),
        "--out-dir",
        dir.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("bad.ron:2:"), "{err}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// An intersection of parts that do not meet has an empty support: its mesh
/// lattice spans the parts themselves, so edits that make them meet polygonize.
#[test]
fn parts_that_meet_only_after_an_edit_polygonize_on_the_parts_lattice() {
    let dir = scratch("apart");
    let scene = dir.join("apart.ron");
    std::fs::write(
        &scene,
        "Scene(camera: Camera(eye: (0.0, 0.5, 6.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (32, 24), \
         model: Intersection([Point(center: (-0.6, 0.0, 0.0), radius: 1.0), \
         Named(\"b\", Point(center: (1.6, 0.0, 0.0), radius: 1.0))]))",
    )
    .unwrap();
    let mesh = dir.join("apart.ply");
    let out = blobtrace(&["mesh", scene.to_str().unwrap(), "--res", "16", "-o", mesh.to_str().unwrap(), "--json"]);
    let report = json(&out);
    let cell = report["cell_size"].as_f64().unwrap();
    // Sixteen cells across the two balls' extent, from -1.6 to 2.6.
    assert!((cell - 4.2 / 16.0).abs() < 1e-4 && report["triangles"] == 0, "{report}");
    let script = dir.join("meet.ron");
    std::fs::write(&script, "EditScript(frames: [(repeat: 2, edits: [Translate(node: \"b\", by: (-0.9, 0.0, 0.0))])])")
        .unwrap();
    let args = ["edit", scene.to_str().unwrap(), "--script", script.to_str().unwrap(), "--res", "16"];
    let out = blobtrace(&[&args[..], &["--verify", "--json", "--out-dir", dir.to_str().unwrap()]].concat());
    let report = json(&out);
    assert_eq!(report["verified_frames"], 2, "{report}");
    assert!(report["per_frame"][1]["triangles"].as_u64().unwrap() > 0, "{report}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn edit_scripts_are_checked_where_they_are_written_and_edits_that_overreach_are_refused() {
    let dir = scratch("edit-bad");
    let script = dir.join("s.ron");
    let run = |text: &str| {
        std::fs::write(&script, text).unwrap();
        let out = blobtrace(&[
            "edit",
            "scenes/hair_point.ron",
            "--script",
            script.to_str().unwrap(),
            "--size",
            "16x12",
            "--res",
            "12",
            "--out-dir",
            dir.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(!out.status.success() && !err.contains("panicked"), "{text}: {err}");
        err
    };
    // Unknown fields, numbers out of range: at their line and column, before any frame.
    let err = run("EditScript(frames: [\n  (repeats: 2, edits: [])])");
    assert!(err.contains("s.ron:2:") && err.contains("repeats"), "{err}");
    let err = run("EditScript(frames: [(edits: [\n  Translate(node: \"probe\", by: (1e10, 0.0, 0.0))])])");
    assert!(err.contains("s.ron:2:") && err.contains("magnitude"), "{err}");
    let err = run("EditScript(frames: [(edits: [\n  Operator(node: \"hair\", op: Ricci(0.5))])])");
    assert!(err.contains("s.ron:2:") && err.contains("at least 1"), "{err}");
    let err = run("EditScript(frames: [(edits: [Radius(node: \"probe\", radius: 0.1, spin: 1.0)])])");
    assert!(err.contains("spin"), "{err}");
    // Within range, but growing the model past what the mesh lattice may hold:
    // found when the frame is applied, and named where the frame is written.
    let err =
        run("EditScript(frames: [\n  (repeat: 2, edits: []),\n  (edits: [Radius(node: \"probe\", radius: 5e5)])])");
    assert!(err.contains("s.ron:3:3: frame 3") && err.contains("cells of the mesh lattice"), "{err}");
    // The wrong kind of node is named by its name.
    let err = run("EditScript(frames: [(edits: [Radius(node: \"hair\", radius: 0.5)])])");
    assert!(err.contains("s.ron:1:21: frame 1") && err.contains("the node under \"hair\" is a"), "{err}");
    // A name an earlier frame removed.
    let err = run(
        "EditScript(frames: [(edits: [Remove(node: \"probe\")]),\n (edits: [Radius(node: \"probe\", radius: 0.5)])])",
    );
    assert!(err.contains("s.ron:2:2: frame 2: no node is named \"probe\""), "{err}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn outputs_must_be_named_for_their_format_and_are_checked_before_any_work() {
    let dir = scratch("outputs");
    let keep = dir.join("keep.png");
    std::fs::write(&keep, b"old").unwrap();
    let k = keep.to_str().unwrap();
    let exr_dir = dir.join("a.exr");
    std::fs::create_dir_all(&exr_dir).unwrap();
    let cases: [(&[&str], &str); 8] = [
        (&["render", "scenes/sphere.ron", "-o", "out.exr"], "must end in .png"),
        (&["render", "scenes/sphere.ron", "-o", k, "--exr", k], "must end in .exr"),
        (&["render", "scenes/sphere.ron", "-o", k, "--exr", exr_dir.to_str().unwrap()], "is a directory"),
        (&["render", "scenes/sphere.ron", "-o", k, "--threads", "5000"], "--threads must be between"),
        (&["bench", "mesh", "--res", "0"], "--res must be between 1 and 8192"),
        (&["bench", "mesh", "--detail-res", "9000"], "--detail-res must be between 1 and 8192"),
        (&["bench", "mesh", "--threads", "0"], "--threads must be between"),
        (&["bench", "edit", "--threads", "0", "-o", "f8.png"], "--threads must be between"),
    ];
    for (args, words) in cases {
        let out = blobtrace(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(words), "{args:?}: {err}");
    }
    assert_eq!(std::fs::read(&keep).unwrap(), b"old");
    // One of compare's names taken by a directory: nothing at all is written.
    let set = dir.join("set");
    std::fs::create_dir_all(set.join("panel.png")).unwrap();
    let out = blobtrace(&[
        "compare",
        "scenes/sphere.ron",
        "--size",
        "16x12",
        "--res",
        "8",
        "--out-dir",
        set.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("panel.png: is a directory"), "{err}");
    assert!(!set.join("ray.png").exists(), "compare wrote part of its set");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn bench_mesh_reports_table_1_and_both_cells_costs() {
    let v = run_json(&[
        "bench",
        "mesh",
        "--res",
        "8,12",
        "--detail-res",
        "12",
        "--size",
        "16x12",
        "--threads",
        "1",
        "--json",
    ]);
    assert_eq!(v["threads"], 1);
    let rows = v["table1"].as_array().unwrap();
    assert_eq!(rows.iter().map(|r| r["res"].as_u64().unwrap()).collect::<Vec<_>>(), [8, 12]);
    // Cubes and the tetrahedra, whatever --cells says; linear placement
    // spends no evaluation on the edges, so it costs less per triangle.
    let costs = v["evals_per_triangle"].as_array().unwrap();
    assert_eq!(costs.iter().map(|c| c["cells"].as_str().unwrap()).collect::<Vec<_>>(), ["cubes", "bcc"]);
    for c in costs {
        let (root, linear) = (c["root"].as_f64().unwrap(), c["linear"].as_f64().unwrap());
        assert!(0.0 < linear && linear < root, "{c}");
    }
}

#[test]
fn bench_edit_reports_figure_8_and_plots_it() {
    let dir = scratch("bench-edit");
    let script = dir.join("s.ron");
    std::fs::write(
        &script,
        "EditScript(frames: [(repeat: 3, edits: [Translate(node: \"probe\", by: (-0.1, 0.0, 0.0))])])",
    )
    .unwrap();
    let plot = dir.join("f8.png");
    let v = run_json(&[
        "bench",
        "edit",
        "scenes/hair_point.ron",
        "--script",
        script.to_str().unwrap(),
        "--res",
        "16",
        "--size",
        "32x24",
        "--repeat",
        "2",
        "--threads",
        "1",
        "-o",
        plot.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(v["frames"], 3);
    assert_eq!(v["threads"], 1);
    for key in ["local_polygonize_ratio", "dirty_render_speedup"] {
        assert!(v[key].as_f64().is_some_and(|x| x > 0.0), "{key} in {v}");
    }
    // The probe changes some pixels of every frame, never all of the work.
    let share = v["changed_evaluation_share"].as_f64().unwrap();
    assert!(0.0 < share && share < 1.0, "{v}");
    assert!((v["evaluation_ceiling"].as_f64().unwrap() * share - 1.0).abs() < 1e-9, "{v}");
    assert!(v["naive"]["full_render_s"].as_f64().unwrap() > 0.0);
    // Two rounds of each mode; each measure is the fastest of its rounds.
    let rounds = v["rounds"].as_array().unwrap();
    assert_eq!(rounds.len(), 2);
    for (mode, side) in [("cached", 0), ("naive", 1)] {
        for measure in ["local_polygonize_s", "full_render_s"] {
            let fastest = rounds.iter().map(|r| r[side][measure].as_f64().unwrap()).fold(f64::MAX, f64::min);
            assert_eq!(v[mode][measure].as_f64(), Some(fastest), "{mode} {measure}");
        }
    }
    assert!(image::open(&plot).is_ok());
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn view_runs_headless_on_keys_and_explains_a_missing_display() {
    let dir = scratch("view");
    let png = dir.join("view.png");
    let keys = "right,right,up,v";
    let out = blobtrace(&[
        "view",
        "scenes/hair_point.ron",
        "--node",
        "probe",
        "--res",
        "24",
        "--size",
        "80x60",
        "--headless",
        "--keys",
        keys,
        "-o",
        png.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "failed: {stderr}");
    assert!(stderr.contains("mesh") && stderr.contains("moving probe") && stderr.contains("frame 3"), "{stderr}");
    let img = image::open(&png).expect("a PNG was written").to_rgb8();
    assert_eq!(img.dimensions(), (80, 60));
    // Bad input: an unknown key, an unknown node, no window to open.
    let bad_key =
        blobtrace(&["view", "scenes/sphere.ron", "--headless", "--keys", "left,f13", "-o", png.to_str().unwrap()]);
    assert!(!bad_key.status.success() && String::from_utf8_lossy(&bad_key.stderr).contains("unknown key \"f13\""));
    let scripted = blobtrace(&[
        "view",
        "scenes/hair_point.ron",
        "--script",
        "scenes/scripts/hair-probe.ron",
        "--res",
        "24",
        "--size",
        "40x30",
        "--headless",
        "--keys",
        "space,space",
        "-o",
        png.to_str().unwrap(),
    ]);
    let scripted_err = String::from_utf8_lossy(&scripted.stderr);
    assert!(scripted.status.success() && scripted_err.contains("frame 2"), "{scripted_err}");
    let bad_node =
        blobtrace(&["view", "scenes/hair_point.ron", "--node", "tail", "--headless", "-o", png.to_str().unwrap()]);
    let bad_node_err = String::from_utf8_lossy(&bad_node.stderr);
    assert!(!bad_node.status.success() && bad_node_err.contains("no node is named \"tail\""), "{bad_node_err}");
    // Local updates run on the --res lattice alone: --refine is no option of
    // theirs (refused as any unknown option, not ignored), and their help omits it.
    let out_dir = dir.join("edit");
    let commands: [&[&str]; 2] = [
        &["view", "scenes/hair_point.ron", "--refine", "1", "--headless", "-o", png.to_str().unwrap()],
        &[
            "edit",
            "scenes/hair_point.ron",
            "--script",
            "scenes/scripts/hair-probe.ron",
            "--refine",
            "1",
            "--out-dir",
            out_dir.to_str().unwrap(),
        ],
    ];
    for args in commands {
        let refined = blobtrace(args);
        let refined_err = String::from_utf8_lossy(&refined.stderr);
        assert_eq!(refined.status.code(), Some(64), "{refined_err}");
        assert!(refined_err.contains("unexpected argument '--refine'"), "{refined_err}");
        let help = blobtrace(&[args[0], "--help"]);
        let help = String::from_utf8_lossy(&help.stdout);
        assert!(help.contains("--res") && !help.contains("--refine"), "{} --help offers --refine: {help}", args[0]);
    }
    let help = blobtrace(&["mesh", "--help"]);
    assert!(String::from_utf8_lossy(&help.stdout).contains("--refine"), "mesh still refines");
    let no_display = Command::new(env!("CARGO_BIN_EXE_blobtrace"))
        .args(["view", "scenes/sphere.ron", "--res", "16", "--size", "32x24"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&no_display.stderr);
    assert!(!no_display.status.success() && err.contains("--headless") && !err.contains("panicked"), "{err}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn regress_tolerates_four_wide_sums_against_eight_wide_references_and_back_but_not_a_one_percent_radius() {
    let dir = scratch("sums");
    let with_sums = |lanes: &str, args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_blobtrace"))
            .args(args)
            .env("BLOBTRACE_SUMS", lanes)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .expect("the binary runs")
    };
    // The switch takes effect: the two paths sum in different orders.
    let (z8, z4) = (dir.join("8.exr"), dir.join("4.exr"));
    let png = dir.join("medusa.png");
    let render =
        ["render", "scenes/medusa.ron", "--size", "96x72", "--mode", "exact", "--json", "-o", png.to_str().unwrap()];
    let (exr8, exr4) = (["--exr", z8.to_str().unwrap()], ["--exr", z4.to_str().unwrap()]);
    assert_eq!(json(&with_sums("8", &[&render[..], &exr8].concat()))["point_sum_lanes"], 8);
    assert_eq!(json(&with_sums("4", &[&render[..], &exr4].concat()))["point_sum_lanes"], 4);
    let out = blobtrace(&[
        "diff",
        z8.to_str().unwrap(),
        z4.to_str().unwrap(),
        "--channels",
        "R,G,B,N.X,N.Y,N.Z",
        "--fail",
        "0",
    ]);
    assert_eq!(
        out.status.code(),
        Some(2),
        "shading differs in its last bits: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    // References blessed with eight-wide sums pass with four-wide ones ...
    let four = with_sums("4", &["regress", "--report", dir.join("four").to_str().unwrap()]);
    assert!(four.status.success(), "{}", String::from_utf8_lossy(&four.stderr));
    // ... and references blessed with four-wide sums pass with eight-wide ones.
    let refs = dir.join("refs");
    std::fs::create_dir_all(&refs).unwrap();
    std::fs::copy("images/ref/manifest.ron", refs.join("manifest.ron")).unwrap();
    let refs = refs.to_str().unwrap();
    assert!(with_sums("4", &["regress", "--refs", refs, "--bless"]).status.success());
    let eight = with_sums("8", &["regress", "--refs", refs, "--report", dir.join("eight").to_str().unwrap()]);
    assert!(eight.status.success(), "{}", String::from_utf8_lossy(&eight.stderr));
    // Either way, one blob's radius grown by 1% fails.
    let scenes = scenes_with_a_grown_radius(&dir);
    let only_pair = ["--scenes", scenes.to_str().unwrap(), "--filter", "pair"];
    for (lanes, refs) in [("4", "images/ref"), ("8", refs)] {
        let report = dir.join(format!("bad-{lanes}"));
        let args = [&["regress", "--refs", refs, "--report", report.to_str().unwrap()], &only_pair[..]].concat();
        let out = with_sums(lanes, &args);
        assert!(!out.status.success(), "{lanes}-wide sums against {refs}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("failed"), "{}", String::from_utf8_lossy(&out.stderr));
    }
    std::fs::remove_dir_all(dir).unwrap();
}

/// Runs blobtrace with files limited to `kib` KiB, as on a disk that fills up
/// mid-job: writes past the limit fail with "File too large".
fn blobtrace_on_a_small_disk(kib: u32, args: &[&str]) -> Output {
    Command::new("bash")
        .args(["-c", &format!("trap '' XFSZ; ulimit -f {kib}; exec \"$@\""), "_", env!("CARGO_BIN_EXE_blobtrace")])
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("bash runs")
}

#[test]
fn a_full_disk_leaves_every_old_output_as_it_was_and_no_temporaries() {
    let dir = scratch("full-disk");
    let listing = |d: &Path| {
        let mut names: Vec<String> =
            std::fs::read_dir(d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        names.sort();
        names
    };
    // render: the small PNG fits, the EXR (about 100 KiB) does not.
    let (png, exr) = (dir.join("out.png"), dir.join("out.exr"));
    for f in [&png, &exr] {
        std::fs::write(f, "old").unwrap();
    }
    let args =
        ["render", "scenes/pair.ron", "--size", "96x72", "-o", png.to_str().unwrap(), "--exr", exr.to_str().unwrap()];
    let out = blobtrace_on_a_small_disk(40, &args);
    assert_eq!(out.status.code(), Some(1), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("out.exr"), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!((std::fs::read(&png).unwrap(), std::fs::read(&exr).unwrap()), (b"old".to_vec(), b"old".to_vec()));
    assert_eq!(listing(&dir), ["out.exr", "out.png"]);
    // compare: an old set of outputs stays whole.
    let outputs = dir.join("compare");
    std::fs::create_dir_all(&outputs).unwrap();
    for name in ["panel.png", "ray.png", "stats.json"] {
        std::fs::write(outputs.join(name), "old").unwrap();
    }
    let args = ["compare", "scenes/pair.ron", "--size", "96x72", "--res", "16", "--out-dir", outputs.to_str().unwrap()];
    let out = blobtrace_on_a_small_disk(40, &args);
    assert!(!out.status.success());
    assert_eq!(listing(&outputs), ["panel.png", "ray.png", "stats.json"]);
    for name in ["panel.png", "ray.png", "stats.json"] {
        assert_eq!(std::fs::read(outputs.join(name)).unwrap(), b"old", "{name}");
    }
    // With room, the same command writes them all.
    assert!(blobtrace(&args).status.success());
    assert!(std::fs::read(outputs.join("ray.png")).unwrap().starts_with(b"\x89PNG"));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn warp_edit_scripts_verify_and_bad_warp_edits_name_their_line() {
    let dir = scratch("warp-scripts");
    run_ok(&[
        "edit",
        "scenes/warps.ron",
        "--script",
        "scenes/scripts/warps.ron",
        "--size",
        "64x48",
        "--res",
        "32",
        "--verify",
        "--save-frames",
        "--out-dir",
        dir.to_str().unwrap(),
    ]);
    let rows = std::fs::read_to_string(dir.join("frames.csv")).unwrap().lines().count() - 1;
    let saved = std::fs::read_dir(&dir)
        .unwrap()
        .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().starts_with("frame-"))
        .count();
    assert!(rows > 1 && saved == rows, "{saved} frames saved for {rows} rows");
    let cases = [
        (
            "(edits: [Warp(node: \"tail\", rate: 0.5)]),\n  (edits: [Warp(node: \"tail\", rate: 5.0)]),",
            "bad.ron:3:3",
            "needs its child within",
        ),
        ("(edits: [Warp(node: \"horn\", scale_to: -0.5)]),", "bad.ron:2:", "positive"),
        ("(edits: [Warp(node: \"braid\", from: 0.0)]),", "bad.ron:2:", "a taper's"),
    ];
    for (frames, place, words) in cases {
        let script = dir.join("bad.ron");
        std::fs::write(&script, format!("EditScript(frames: [\n  {frames}\n])\n")).unwrap();
        let never = dir.join("never");
        // The first case fails on its second frame, after the first was made.
        let args = ["--size", "32x24", "--save-frames", "--out-dir", never.to_str().unwrap()];
        let out = blobtrace(&[&["edit", "scenes/warps.ron", "--script", script.to_str().unwrap()][..], &args].concat());
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert!(err.contains(place) && err.contains(words), "{frames}: {err}");
        assert!(!never.exists(), "a script that fails writes nothing, not even its folder");
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn auto_mode_follows_pins_and_renders_the_same_bits_on_any_thread_count() {
    let dir = scratch("auto");
    let scene = |usage: &str| {
        let path = dir.join(format!("{usage}.ron"));
        let text = format!(
            "Scene(\n  camera: Camera(eye: (0.0, 0.5, 5.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),\n  size: (64, 48),\n  model: Blend([\n    Cache(res: 24, use: {usage}, child: Blend([Point(center: (-0.4, 0.0, 0.0), radius: 1.2), Point(center: (0.4, 0.1, 0.0), radius: 1.1)])),\n    Point(center: (0.0, -0.9, 0.3), radius: 0.8),\n  ]),\n)\n"
        );
        std::fs::write(&path, text).unwrap();
        path.to_str().unwrap().to_string()
    };
    let render = |scene: &str, extra: &[&str], name: &str| {
        let (png, exr) = (dir.join(format!("{name}.png")), dir.join(format!("{name}.exr")));
        let args =
            [&["render", scene, "-o", png.to_str().unwrap(), "--exr", exr.to_str().unwrap(), "--json"], extra].concat();
        let report = json(&blobtrace(&args));
        (report, [std::fs::read(png).unwrap(), std::fs::read(exr).unwrap()])
    };
    let (always, never) = (scene("Always"), scene("Never"));
    let (report, pinned_on) = render(&always, &[], "always-auto");
    assert_eq!(
        (report["eval"].as_str(), report["cache_decisions"][0]["reason"].as_str()),
        (Some("cached"), Some("pinned"))
    );
    assert_eq!(pinned_on, render(&always, &["--mode", "cached"], "always-cached").1, "Always answers from the lattice");
    // The same bits on one thread and two, run after run, cold or warm.
    assert_eq!(pinned_on, render(&always, &["--threads", "1"], "always-1").1);
    assert_eq!(pinned_on, render(&always, &["--threads", "2"], "always-2").1);
    let (report, pinned_off) = render(&never, &[], "never-auto");
    assert_eq!(report["eval"], "indexed");
    assert_eq!(pinned_off, render(&never, &["--mode", "exact"], "never-exact").1, "Never is exact evaluation");
    let bad = dir.join("bad.ron");
    std::fs::write(&bad, std::fs::read_to_string(&always).unwrap().replace("use: Always", "use: Sometimes")).unwrap();
    let out = blobtrace(&["info", bad.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.code() == Some(1) && err.contains("bad.ron:5:"), "{err}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn the_crown_cache_pays_so_auto_answers_from_its_lattice_on_any_thread_count() {
    let dir = scratch("crown");
    let render = |extra: &[&str], name: &str| {
        let png = dir.join(format!("{name}.png"));
        let args = [&["render", "scenes/crown.ron", "--size", "96x72", "-o", png.to_str().unwrap(), "--json"], extra];
        (json(&blobtrace(&args.concat())), std::fs::read(png).unwrap())
    };
    let (report, auto) = render(&[], "auto");
    let decision = &report["cache_decisions"][0];
    assert_eq!((report["eval"].as_str(), decision["uses_lattice"].as_bool()), (Some("cached"), Some(true)), "{report}");
    // Warps, a Ricci blend and a carved torus: loose exact bounds, counted as more steps.
    assert!(
        decision["steps"].as_f64().unwrap() > 1.0
            && decision["exact_cost"].as_f64() > decision["lattice_cost"].as_f64()
    );
    assert_eq!(auto, render(&["--mode", "cached"], "cached").1);
    assert_eq!(auto, render(&["--threads", "1"], "one").1);
    assert_ne!(auto, render(&["--mode", "exact"], "exact").1, "the lattice's image is not the exact one");
    std::fs::remove_dir_all(dir).unwrap();
}

/// A scene text whose model is `model`, with a small image.
fn scene_with(model: &str) -> String {
    format!(
        "Scene(\n    camera: Camera(eye: (0.0, 0.0, 4.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),\n    size: (8, 8),\n    model: {model},\n)\n"
    )
}

/// The 1-based line and column where `marker` first occurs in `text`; a `|`
/// in the marker points past the text before it (`")|),"`: the second `)`).
fn position_of(text: &str, marker: &str) -> (usize, usize) {
    let (lead, _) = marker.split_once('|').unwrap_or(("", marker));
    let at = text.find(&marker.replace('|', "")).unwrap_or_else(|| panic!("{marker} not in {text}")) + lead.len();
    let before = &text[..at];
    (before.matches('\n').count() + 1, before.rsplit('\n').next().unwrap().chars().count() + 1)
}

/// Runs `args` with `file` (a scene, script or manifest) written from `text`;
/// the error message, checked to be in the file's own words at `marker`.
fn error_in_own_words(args: &[&str], file: &Path, text: &str, marker: &str, words: &[&str]) -> String {
    std::fs::write(file, text).unwrap();
    let out = blobtrace(args);
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{text}: {err}");
    let (line, column) = position_of(text, marker);
    let at = format!("{}:{line}:{column}: ", file.display());
    assert!(err.contains(&at), "expected {at} in {err}");
    for word in words {
        assert!(err.to_lowercase().contains(&word.to_lowercase()), "expected {word:?} in {err}");
    }
    // Neither the grammar's Rust types nor the RON library's advice.
    for internal in ["enum", "Desc", "raw identifier", "r#", "recursion_limit", "serde", "tuple", "u32", "Unexpected"] {
        assert!(!err.contains(internal), "{internal:?} in {err}");
    }
    err
}

#[test]
fn scene_script_and_manifest_errors_say_what_the_file_may_write_there() {
    let dir = scratch("own-words");
    let scene = dir.join("s.ron");
    let png = dir.join("s.png");
    let render = ["render", scene.to_str().unwrap(), "-o", png.to_str().unwrap()];
    let point = "Point(center: (0.0, 0.0, 0.0), radius: 1.0)";
    let cached = |opts: &str| scene_with(&format!("Cache(res: 32, {opts}, child: {point})"));
    let cases: [(String, &str, &[&str]); 14] = [
        (
            scene_with(&point.replace("Point", "Pointy")),
            "Pointy",
            &["expected a node", "Point, Segment, Circle", "Named or Cache"],
        ),
        (scene_with(&format!("Twist(axis: W, rate: 1.0, child: {point})")), "W,", &["expected an axis", "X, Y or Z"]),
        (scene_with(&format!("Twist(axis: \"Y\", rate: 1.0, child: {point})")), "\"Y\"", &["write Y, not \"Y\""]),
        (scene_with(&point.replace("1.0)", "1.0, kernel: Gauss)")), "Gauss", &["expected a kernel", "Wyvill"]),
        (cached("value: Cubic"), "Cubic", &["reconstruction filter", "Trilinear or Triquadratic"]),
        (cached("storage: F64"), "F64", &["sample storage", "F32 or F16"]),
        (cached("use: Sometimes"), "Sometimes", &["`use`", "Auto, Always or Never"]),
        (cached("res: 2.5").replacen("res: 32, ", "", 1), ".5", &["whole number"]),
        (scene_with(&format!("Ricci(4, [{point}], 3)")), "3)", &["closing `)`"]),
        (scene_with("Point((0.0, 0.0, 0.0), 1.0)"), "Point(|(0.0", &["field name"]),
        (
            scene_with(&point.replace("(0.0, 0.0, 0.0)", "(0.0, 0.0)")),
            "), radius",
            &["3 values in parentheses", "found 2"],
        ),
        (scene_with(&point.replace(", radius: 1.0", "")), ")|),", &["Point needs its `radius`"]),
        (scene_with(&format!("Named(probe, {point})")), "probe", &["in double quotes"]),
        (scene_with(&format!("Difference({point})")), "),\n)", &["Difference( … ) with 2 values", "found 1"]),
    ];
    for (text, marker, words) in &cases {
        error_in_own_words(&render, &scene, text, marker, words);
    }
    // Edit scripts: an edit and an operator that do not exist.
    let script = dir.join("e.ron");
    let edit =
        ["edit", "scenes/hair_point.ron", "--script", script.to_str().unwrap(), "--out-dir", dir.to_str().unwrap()];
    let spin = "EditScript(frames: [\n  (edits: [Spin(node: \"probe\")]),\n])";
    error_in_own_words(&edit, &script, spin, "Spin", &["expected an edit", "Translate, Rotate", "Remove or Operator"]);
    let smooth = "EditScript(frames: [(edits: [Operator(node: \"hair\", op: Smooth)])])";
    error_in_own_words(&edit, &script, smooth, "Smooth", &["expected an operator", "Intersection or Ricci"]);
    // A manifest entry of a kind that does not exist.
    let refs = dir.join("refs");
    std::fs::create_dir_all(&refs).unwrap();
    let manifest = refs.join("manifest.ron");
    let report = dir.join("r");
    let regress = ["regress", "--refs", refs.to_str().unwrap(), "--report", report.to_str().unwrap()];
    let feld = "Manifest(entries: [Entry(scene: \"sphere.ron\", size: (8, 8), kind: Feld)])";
    error_in_own_words(&regress, &manifest, feld, "Feld", &["entry's kind", "Field or Mesh"]);
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn models_nest_512_nodes_deep_and_a_deeper_one_is_refused_where_it_goes_too_deep() {
    let dir = scratch("nesting");
    let scene = dir.join("deep.ron");
    let point = "Point(center: (0.0, 0.0, 0.0), radius: 1.0)";
    let chain = |n: usize, node: &str| (1..n).fold(point.to_string(), |inner, _| node.replace('@', &inner));
    let render = |text: &str| {
        std::fs::write(&scene, text).unwrap();
        let out = blobtrace(&["render", scene.to_str().unwrap(), "-o", dir.join("deep.png").to_str().unwrap()]);
        (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    // 169 transforms were refused as "deeper than 512 levels"; every kind of
    // node nests to the documented depth and renders.
    for node in ["Transform(child: @)", "Blend([@])", "Difference(@, Point(center: (5.0, 0.0, 0.0), radius: 0.1))"] {
        for n in [169, 512] {
            let (code, err) = render(&scene_with(&chain(n, node)));
            assert_eq!(code, Some(0), "{n} levels of {node}: {err}");
        }
    }
    // One more is refused in nodes, at the node that goes too deep.
    let text = scene_with(&chain(513, "Transform(child: @)"));
    let (code, err) = render(&text);
    let (line, column) = (4, position_of(&text, point).1);
    let at = format!("{}:{line}:{column}: the model nests deeper than 512 nodes", scene.display());
    assert!(code == Some(1) && err.contains(&at), "expected {at} in {err}");
    // Far deeper still: the same clear error, no overflowing stack.
    let (code, err) = render(&scene_with(&chain(100_000, "Blend([@])")));
    assert!(code == Some(1) && err.contains("nests deeper than 512 nodes") && !err.contains("overflow"), "{err}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn the_readme_scene_table_lists_every_node_and_each_reads_as_it_is_written() {
    let dir = scratch("readme-nodes");
    let readme = std::fs::read_to_string("README.md").unwrap();
    let scene = dir.join("s.ron");
    let info = |text: &str| {
        std::fs::write(&scene, text).unwrap();
        let out = blobtrace(&["info", scene.to_str().unwrap()]);
        (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    // The table's nodes are the parser's: those its error for an unknown node lists.
    let table = &readme[readme.find("| node | fields").unwrap()..];
    let rows = table.lines().skip(2).take_while(|l| l.starts_with('|'));
    let mut listed: Vec<String> = rows
        .flat_map(|row| {
            row.split('|').nth(1).unwrap().split('`').skip(1).step_by(2).map(str::to_string).collect::<Vec<_>>()
        })
        .map(|form| form.chars().take_while(char::is_ascii_alphanumeric).collect())
        .collect();
    let (_, err) = info(&scene_with("Nothing(radius: 1.0)"));
    let known = err.split("a node is ").nth(1).expect("the parser lists its nodes").trim();
    let mut known: Vec<String> = known.replace(" or ", ", ").split(", ").map(str::to_string).collect();
    listed.sort();
    known.sort();
    assert_eq!(listed, known, "the README's table against the parser");
    // Each row's form, every field the table names, read as the table writes it.
    let p = "Point(center: (0.0, 0.0, 0.0), radius: 1.0)";
    let forms = [
        "Point(center: (0.0, 0.0, 0.0), radius: 1.0, weight: 1.0, kernel: Wyvill, color: (0.5, 0.5, 0.5))".to_string(),
        "Segment(a: (0.0, 0.0, 0.0), b: (1.0, 0.0, 0.0), radius: 0.5, weight: 1.0, kernel: Wyvill, color: (0.5, 0.5, 0.5))".into(),
        "Circle(center: (0.0, 0.0, 0.0), normal: (0.0, 2.0, 0.0), ring: 1.0, radius: 0.3, weight: 1.0, kernel: Wyvill, color: (0.5, 0.5, 0.5))".into(),
        "SplinePoints(control: [(0.0, 0.0, 0.0), (1.0, 1.0, 0.0)], count: 10, radius: 0.3, radius_end: 0.1, weight: 1.0, color: (0.5, 0.5, 0.5))".into(),
        "Points(file: \"p.xyz\", radius: 0.5, weight: 1.0, kernel: Wyvill, color: (0.5, 0.5, 0.5))".into(),
        format!("Blend([{p}])"),
        format!("Union([{p}, {p}])"),
        format!("Intersection([{p}, {p}])"),
        format!("Difference({p}, {p})"),
        format!("Ricci(4, [{p}, {p}])"),
        format!("Ricci(n: 4, children: [{p}])"),
        format!("Transform(translate: (1.0, 0.0, 0.0), rotate: (0.0, 0.0, 30.0), scale: (1.0, 2.0, 1.0), child: {p}, color: (0.5, 0.5, 0.5))"),
        format!("Twist(axis: X, rate: 0.2, child: {p})"),
        format!("Taper(axis: Z, from: -1.0, to: 1.0, scale_from: 1.0, scale_to: 0.5, child: {p})"),
        format!("Bend(rate: 0.1, child: {p})"),
        format!("Named(\"name\", {p})"),
        format!("Cache(res: 16, value: Trilinear, gradient: Triquadratic, storage: F16, use: Always, child: {p})"),
    ];
    std::fs::write(dir.join("p.xyz"), "0 0 0\n0.5 0 0 # two points\n").unwrap();
    for form in &forms {
        let (ok, err) = info(&scene_with(form));
        assert!(ok, "{form}: {err}");
    }
    // And the example scene the README writes out.
    let example = readme.split("```ron\n").nth(1).unwrap().split("```").next().unwrap();
    let (ok, err) = info(example);
    assert!(ok, "the README's example: {err}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn view_refuses_an_unknown_node_and_space_without_a_script_as_usage_errors() {
    let dir = scratch("view-usage");
    let png = dir.join("v.png");
    let view = |args: &[&str]| {
        let out = blobtrace(&[&["view"], args, &["--headless", "-o", png.to_str().unwrap()]].concat());
        (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (code, err) = view(&["scenes/hair_point.ron", "--node", "nope"]);
    assert_eq!(code, Some(64), "{err}");
    assert!(err.contains("no node is named \"nope\"") && err.contains("probe"), "names the nodes there are: {err}");
    let (code, err) = view(&["scenes/hair_point.ron", "--keys", "right,space"]);
    assert_eq!(code, Some(64), "{err}");
    assert!(err.contains("space") && err.contains("no --script"), "{err}");
    // An unknown key: the message lists the mouse gestures with the keys.
    let (code, err) = view(&["scenes/sphere.ron", "--keys", "f13"]);
    assert_eq!(code, Some(64), "{err}");
    for gesture in ["drag:DX:DY", "pan:DX:DY", "wheel:N", "click:X:Y", "pageup"] {
        assert!(err.contains(gesture), "{gesture} in {err}");
    }
    assert!(!png.exists(), "nothing written");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn mesh_of_a_scene_without_a_surface_warns_and_claims_no_closed_surface() {
    let dir = scratch("mesh-empty");
    let scene = dir.join("empty.ron");
    let sphere = std::fs::read_to_string("scenes/sphere.ron").unwrap();
    std::fs::write(&scene, sphere.replace("threshold: 0.5", "threshold: 5.0")).unwrap();
    let ply = dir.join("e.ply");
    let args = ["mesh", scene.to_str().unwrap(), "--res", "16", "-o", ply.to_str().unwrap()];
    let out = blobtrace(&args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && err.contains("0 triangles") && err.contains("warning: no surface"), "{err}");
    for nonsense in ["per triangle", "closed", "watertight"] {
        assert!(!err.contains(nonsense), "{nonsense:?} of no triangles: {err}");
    }
    let out = blobtrace(&[&args[..], &["--json"]].concat());
    assert!(String::from_utf8_lossy(&out.stderr).contains("warning: no surface"));
    let v = json(&out);
    assert!(v["warning"].as_str().unwrap().contains("no surface"), "{v}");
    assert!(v["evals_per_triangle"].is_null(), "{v}");
    assert_eq!((&v["closed_manifold"], &v["quality"]["watertight"]), (&false.into(), &false.into()), "{v}");
    // A mesh with a surface has neither warning nor gaps.
    let v = run_json(&["mesh", "scenes/sphere.ron", "--res", "16", "-o", args[5], "--json"]);
    assert!(v.get("warning").is_none() && v["evals_per_triangle"].as_f64().unwrap() > 0.0, "{v}");
    std::fs::remove_dir_all(dir).unwrap();
}

/// A reference folder of one blessed entry, `size` pixels of the pair.
fn blessed_pair_refs(dir: &Path, size: &str) -> PathBuf {
    let refs = dir.join("refs");
    std::fs::create_dir_all(&refs).unwrap();
    let entry = format!("Manifest(entries: [Entry(scene: \"pair.ron\", size: ({size}), kind: Field)])");
    std::fs::write(refs.join("manifest.ron"), entry).unwrap();
    run_ok(&["regress", "--refs", refs.to_str().unwrap(), "--bless"]);
    refs
}

#[test]
fn regress_fails_when_a_filter_or_shard_selects_no_entry_unless_empty_runs_are_allowed() {
    let dir = scratch("regress-empty");
    let refs = blessed_pair_refs(&dir, "16, 12");
    let (junit, report) = (dir.join("junit.xml"), dir.join("r"));
    let args = ["regress", "--refs", refs.to_str().unwrap(), "--report", report.to_str().unwrap(), "--junit"];
    let run = |extra: &[&str]| {
        let out = blobtrace(&[&args[..], &[junit.to_str().unwrap()], extra].concat());
        (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (code, err) = run(&["--filter", "piar"]);
    assert!(code == Some(1) && err.contains("no entry matches piar"), "{err}");
    assert!(!junit.exists(), "no JUnit file to pass CI");
    let (code, err) = run(&["--shard", "2/2"]);
    assert!(code == Some(1) && err.contains("shard 2/2 holds no entry"), "{err}");
    assert!(!junit.exists());
    // Allowed, an empty shard passes, and says it ran nothing.
    let (code, err) = run(&["--shard", "2/2", "--allow-empty"]);
    assert_eq!(code, Some(0), "{err}");
    assert!(std::fs::read_to_string(&junit).unwrap().contains("tests=\"0\""));
    let (code, err) = run(&["--filter", "pair"]);
    assert_eq!(code, Some(0), "{err}");
    assert_eq!(std::fs::read_to_string(&junit).unwrap().matches("<testcase").count(), 1);
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn regress_junit_goes_into_folders_it_creates() {
    let dir = scratch("regress-junit");
    let refs = blessed_pair_refs(&dir, "16, 12");
    let (junit, report) = (dir.join("ci").join("reports").join("regress.xml"), dir.join("r"));
    let args = ["regress", "--refs", refs.to_str().unwrap(), "--report", report.to_str().unwrap()];
    let out = blobtrace(&[&args[..], &["--junit", junit.to_str().unwrap()]].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(std::fs::read_to_string(&junit).unwrap().contains("<testcase"));
    // Still no directory in the file's place, nor a misnamed file.
    for bad in [dir.join("ci"), dir.join("ci").join("regress.txt")] {
        let out = blobtrace(&[&args[..], &["--junit", bad.to_str().unwrap()]].concat());
        assert!(!out.status.success(), "{}", bad.display());
    }
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn the_regress_report_describes_the_last_run_alone() {
    let dir = scratch("regress-stale");
    let refs = blessed_pair_refs(&dir, "96, 72");
    let report = dir.join("report");
    let run = |scenes: &Path| {
        let (refs, report) = (refs.to_str().unwrap(), report.to_str().unwrap());
        blobtrace(&["regress", "--refs", refs, "--report", report, "--scenes", scenes.to_str().unwrap()])
    };
    let failure =
        ["ref", "actual", "diff", "heat", "flip"].map(|kind| report.join(format!("000-pair-field-96x72-{kind}.png")));
    assert!(!run(&scenes_with_a_grown_radius(&dir)).status.success());
    assert!(failure.iter().all(|f| f.exists()), "the failure's images");
    std::fs::write(report.join("notes.txt"), "mine").unwrap();
    let out = run(Path::new("scenes"));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for stale in &failure {
        assert!(!stale.exists(), "{} is left from the run before", stale.display());
    }
    assert!(std::fs::read_to_string(report.join("index.html")).unwrap().contains("Pass"));
    assert_eq!(std::fs::read_to_string(report.join("notes.txt")).unwrap(), "mine", "what is not the report's stays");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn bench_scale_measures_each_point_set_in_its_own_process_and_plots_every_figure_against_the_count() {
    let dir = scratch("bench-scale");
    let plot = dir.join("scale.png");
    let args = ["bench", "scale", "--points", "1000,3000", "--mesh-up-to", "1000", "--size", "64x64"];
    let v = run_json(&[&args[..], &["--threads", "1", "-o", plot.to_str().unwrap(), "--json"]].concat());
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 6, "three models at two counts: {v}");
    for row in rows {
        assert_keys(row, &["model", "points", "load_seconds", "resident_mb", "peak_mb", "render_seconds", "tracer"]);
        assert!(row["load_seconds"].as_f64().unwrap() > 0.0 && row["render_seconds"].as_f64().unwrap() > 0.0);
        // Measured in a fresh process each: the peak is this set's, not the largest before it.
        assert!(row["peak_mb"].as_f64().unwrap() < 400.0, "{row}");
        let meshed = row["points"] == 1000;
        assert_eq!(row["mesh"].is_array(), meshed, "{row}");
        assert_eq!(row["mesh_skipped"].is_string(), !meshed, "{row}");
    }
    for model in ["sparse", "dense", "spline"] {
        assert!(rows.iter().any(|r| r["model"] == model), "{model}: {v}");
    }
    let beside: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(plot.with_extension("json")).unwrap()).unwrap();
    assert_eq!(beside["rows"], v["rows"], "the JSON beside the plot holds the same figures");
    let img = image::open(&plot).unwrap();
    assert_eq!((img.width(), img.height()), (960, 2 * 320 + 24));
    for bad in ["12", "2e7", "1500.5"] {
        assert_eq!(blobtrace(&["bench", "scale", "--points", bad]).status.code(), Some(64), "{bad}");
    }
    std::fs::remove_dir_all(dir).unwrap();
}
