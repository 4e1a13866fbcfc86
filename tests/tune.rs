//! `blobtrace tune`: caches removed where they do not pay, raised, lowered,
//! split and inserted until error_C at mesh vertices meets the tolerance;
//! tuning a tuned scene changes nothing; budgets and bad values are refused
//! clearly.

mod common;

use common::{blobtrace, scratch};
use std::path::Path;
use std::process::Output;

fn report(out: &Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|_| panic!("stdout is JSON: {}", String::from_utf8_lossy(&out.stderr)))
}

fn tune(scene: &Path, extra: &[&str]) -> Output {
    blobtrace(&[&["tune", scene.to_str().unwrap(), "--json"], extra].concat())
}

fn decisions(r: &serde_json::Value) -> Vec<(String, String)> {
    let rows = r["rows"].as_array().expect("rows");
    rows.iter().map(|row| (row["cache"].as_str().unwrap().into(), row["decision"].as_str().unwrap().into())).collect()
}

/// A big smooth blob and a small one under one coarse cache, pinned on.
const PAIR: &str = r#"Scene(camera: Camera(eye: (0.0, 0.0, 9.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (64, 48),
  model: Named("pair", Cache(res: 16, use: Always, child: Blend([
    Point(center: (-0.5, 0.0, 0.0), radius: 3.0),
    Point(center: (2.4, 0.0, 0.0), radius: 0.5, weight: 2.0),
  ]))))"#;

#[test]
fn medusa_loses_every_cache_because_none_pays() {
    let dir = scratch("tune-medusa");
    let out_scene = dir.join("tuned.ron");
    let out = tune(Path::new("scenes/medusa.ron"), &["--tolerance", "1e-3", "-o", out_scene.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let r = report(&out);
    let all = decisions(&r);
    assert_eq!(all.len(), 7);
    assert!(all.iter().all(|(_, d)| d == "removed"), "{all:?}");
    assert_eq!((r["met"].as_bool(), r["bytes_after"].as_u64()), (Some(true), Some(0)));
    assert!(r["bytes_before"].as_u64().unwrap() > 1 << 20, "the hand-placed caches' samples are counted");
    // The tuned scene loads, keeps every name, and holds no cache.
    let info = blobtrace(&["info", out_scene.to_str().unwrap(), "--json"]);
    let info = report(&info);
    assert_eq!(info["caches"], 0, "{info}");
    assert_eq!(info["names"].as_array().unwrap().len(), 7);
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn a_coarse_cache_splits_off_its_small_child_and_tuning_again_changes_nothing() {
    let dir = scratch("tune-split");
    let (scene, tuned, again) = (dir.join("pair.ron"), dir.join("tuned.ron"), dir.join("again.ron"));
    std::fs::write(&scene, PAIR).unwrap();
    let args = ["--tolerance", "1e-2", "--res", "64"];
    let r = report(&tune(
        &scene,
        &[&args[..], &["-o", tuned.to_str().unwrap(), "--report", dir.to_str().unwrap()]].concat(),
    ));
    let all = decisions(&r);
    assert!(all[0].1.contains("split into 2"), "{all:?}");
    assert_eq!(all.iter().map(|d| d.0.as_str()).collect::<Vec<_>>(), ["pair", "pair/0", "pair/1"]);
    // Every cache of the tuned scene meets E: 99th percentile within E, all within 4E.
    for row in &r["rows"].as_array().unwrap()[1..] {
        let after = &row["after"];
        assert!(after["p99"].as_f64().unwrap() <= 1e-2 && after["max"].as_f64().unwrap() <= 4e-2, "{row}");
    }
    assert!(dir.join("tune-pair.png").exists() && dir.join("report.json").exists());
    // The tuned scene is a fixed point.
    let r = report(&tune(&tuned, &[&args[..], &["-o", again.to_str().unwrap()]].concat()));
    assert!(decisions(&r).iter().all(|(_, d)| d == "kept"), "{r}");
    assert_eq!(r["rounds"], 1);
    let body =
        |p: &Path| std::fs::read_to_string(p).unwrap().lines().filter(|l| !l.starts_with("//")).collect::<String>();
    assert_eq!(body(&tuned), body(&again));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn an_expensive_subtree_gets_a_cache_of_its_own() {
    let dir = scratch("tune-insert");
    let crown = std::fs::read_to_string("scenes/crown.ron").unwrap();
    let bare = crown
        .replace("Cache(res: 96, child: Difference(", "Difference(")
        .replace("weight: 1.0)))),", "weight: 1.0))),");
    assert_ne!(bare, crown);
    let (scene, tuned) = (dir.join("bare.ron"), dir.join("tuned.ron"));
    std::fs::write(&scene, bare).unwrap();
    let out = tune(&scene, &["--tolerance", "2e-2", "--res", "40", "-o", tuned.to_str().unwrap()]);
    let r = report(&out);
    let all = decisions(&r);
    assert_eq!(all.len(), 1);
    assert!(all[0].0 == "crown (new)" && all[0].1.starts_with("raised 32->"), "{all:?}");
    assert!(r["rows"][0]["cost_ratio"].as_f64().unwrap() > 1.0);
    assert!(std::fs::read_to_string(&tuned).unwrap().contains("Cache("));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn a_budget_that_cannot_meet_the_tolerance_fails_and_writes_the_scene_only_when_asked() {
    let dir = scratch("tune-budget");
    let (scene, tuned) = (dir.join("pair.ron"), dir.join("tuned.ron"));
    std::fs::write(&scene, PAIR).unwrap();
    let args = ["--tolerance", "1e-4", "--budget", "0.001", "--res", "48", "-o", tuned.to_str().unwrap()];
    let out = tune(&scene, &args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("could not be met") && err.contains("--write-anyway"), "{err}");
    let r = report(&out);
    assert_eq!(r["met"], false);
    assert!(r["rows"][0]["reason"].as_str().unwrap().contains("budget"), "{r}");
    assert!(!tuned.exists(), "an unmet tune writes no scene");
    let out = tune(&scene, &[&args[..], &["--write-anyway"]].concat());
    assert_eq!(out.status.code(), Some(1));
    assert!(tuned.exists(), "--write-anyway writes it");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn bad_tolerances_and_budgets_are_usage_errors() {
    for (args, words) in [
        (&["--tolerance", "0"][..], "--tolerance must be a positive number"),
        (&["--tolerance", "-1e-3"][..], "--tolerance must be a positive number"),
        (&["--tolerance", "nan"][..], "--tolerance must be a positive number"),
        (&["--tolerance", "1e-3", "--budget", "0"][..], "--budget must be a positive number"),
        (&["--tolerance", "1e-3", "--budget", "-5"][..], "--budget must be a positive number"),
        (&["--tolerance", "1e-3", "--rounds", "0"][..], "--rounds must be at least 1"),
        (&["--budget", "10"][..], "--tolerance"),
    ] {
        let out = tune(Path::new("scenes/sphere.ron"), args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(64), "{args:?}: {err}");
        assert!(err.contains(words), "{args:?}: {err}");
    }
}
