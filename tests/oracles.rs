//! `blobtrace diff` against the reference implementations it claims to
//! equal, on real renders: OpenImageIO's comparison (idiff's exit codes, and
//! its Python bindings for the statistics at full precision) and NVIDIA's
//! ꟻLIP (the `flip-evaluator` package). `scripts/test` installs both and
//! names the Python that has them in `BLOBTRACE_ORACLE_PYTHON`.

mod common;

use common::{blobtrace, scratch};
use std::path::{Path, PathBuf};
use std::process::Command;

fn oracle_python() -> PathBuf {
    let path = std::env::var_os("BLOBTRACE_ORACLE_PYTHON")
        .map_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("target/oracles/bin/python"), PathBuf::from);
    assert!(path.exists(), "no oracle Python at {}: run the tests with scripts/test", path.display());
    path
}

fn run_oracle(script: &str, args: &[&str]) -> String {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/oracles").join(script);
    let out = Command::new(oracle_python()).arg(script).args(args).output().expect("the oracle runs");
    assert!(out.status.success(), "oracle failed: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

fn render(dir: &Path, scene: &str, name: &str, extra: &[&str]) -> (String, String) {
    let (png, exr) = (dir.join(format!("{name}.png")), dir.join(format!("{name}.exr")));
    let (png, exr) = (png.to_str().unwrap().to_string(), exr.to_str().unwrap().to_string());
    let out = blobtrace(&[&["render", scene, "-o", &png, "--exr", &exr], extra].concat());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    (png, exr)
}

/// The pair scene with its colours changed: the same surface, so the same
/// misses (infinite depth) and normals, in other colours.
fn recoloured_pair(dir: &Path) -> String {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/pair.ron")).unwrap();
    let path = dir.join("pair-recoloured.ron");
    std::fs::write(
        &path,
        text.replace("(0.80, 0.45, 0.30)", "(0.78, 0.47, 0.30)").replace("(0.30, 0.50, 0.80)", "(0.25, 0.5, 0.9)"),
    )
    .unwrap();
    path.to_str().unwrap().to_string()
}

/// A copy of an RGB PNG with an alpha channel varying over the image.
fn with_alpha(png: &str, out: &Path) -> String {
    let img = image::open(png).unwrap().to_rgb8();
    let (w, h) = img.dimensions();
    let rgba: Vec<u8> =
        img.enumerate_pixels().flat_map(|(x, y, p)| [p[0], p[1], p[2], ((x * 37 + y * 11) % 256) as u8]).collect();
    let mut bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut bytes, w, h);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().unwrap();
    writer.write_image_data(&rgba).unwrap();
    writer.finish().unwrap();
    std::fs::write(out, bytes).unwrap();
    out.to_str().unwrap().to_string()
}

/// A copy of an RGB PNG with deterministic noise of up to ±`amplitude` codes.
fn with_noise(png: &str, amplitude: i32, out: &Path) -> String {
    let mut img = image::open(png).unwrap().to_rgb8();
    for (i, v) in img.iter_mut().enumerate() {
        let hash = (i as u32).wrapping_mul(2_654_435_761).rotate_left(13);
        let noise = (hash % (2 * amplitude as u32 + 1)) as i32 - amplitude;
        *v = (i32::from(*v) + noise).clamp(0, 255) as u8;
    }
    img.save(out).unwrap();
    out.to_str().unwrap().to_string()
}

const FAIL: &str = "0.05";
const WARN: &str = "0.01";

/// Checks every statistic both print, and the exit code, against OpenImageIO.
fn assert_equals_idiff(a: &str, b: &str, channels: Option<&str>) {
    let mut args = vec!["diff", a, b, "--fail", FAIL, "--warn", WARN, "--failpercent", "5", "--json"];
    let mut oracle_args = vec![a, b, FAIL, WARN];
    if let Some(c) = channels {
        args.extend(["--channels", c]);
        oracle_args.push(c);
    }
    let ours = blobtrace(&args);
    let v: serde_json::Value = serde_json::from_slice(&ours.stdout).expect("JSON");
    let theirs: serde_json::Value = serde_json::from_str(&run_oracle("oiio_compare.py", &oracle_args)).unwrap();
    let pair = format!("{a} vs {b} ({channels:?})");
    for (key, their_key) in [("mean", "mean"), ("rms", "rms"), ("psnr", "psnr"), ("max", "max")] {
        let (x, y) = (v[key].as_f64().unwrap(), theirs[their_key].as_f64().unwrap());
        assert!((x - y).abs() <= 1e-6, "{pair}: {key} {x} against OpenImageIO's {y}");
    }
    let at = &v["max_at"];
    assert_eq!((&at["x"], &at["y"], &at["channel"]), (&theirs["x"], &theirs["y"], &theirs["channel"]), "{pair}");
    assert_eq!((&v["over_warn_px"], &v["over_fail_px"]), (&theirs["nwarn"], &theirs["nfail"]), "{pair}");
    assert_eq!(v["channels"], theirs["channels"], "{pair}");
    if channels.is_none() {
        let idiff = Command::new("idiff")
            .args(["-fail", FAIL, "-warn", WARN, "-failpercent", "5", a, b])
            .output()
            .expect("idiff runs (scripts/test installs openimageio-tools)");
        assert_eq!(ours.status.code(), idiff.status.code(), "{pair}: exit codes");
    }
}

#[test]
fn diff_statistics_equal_openimageio_on_png_and_exr_pairs() {
    let dir = scratch("idiff");
    let pair = "scenes/pair.ron";
    let size = ["--size", "96x72"];
    let (field_png, field_exr) = render(&dir, pair, "field", &size);
    let (mesh_png, _) = render(&dir, pair, "mesh", &[&size[..], &["--mesh", "--res", "16"]].concat());
    let (recoloured_png, recoloured_exr) = render(&dir, &recoloured_pair(&dir), "recoloured", &size);
    // Opaque sRGB PNGs, compared as stored.
    assert_equals_idiff(&field_png, &mesh_png, None);
    assert_equals_idiff(&field_png, &recoloured_png, None);
    // Alpha against none: four channels against three, colour associated with alpha as OpenImageIO reads it.
    let alpha = with_alpha(&field_png, &dir.join("alpha.png"));
    assert_equals_idiff(&field_png, &alpha, None);
    assert_equals_idiff(&alpha, &mesh_png, None);
    // Every EXR channel, misses (infinite Z and depth.Z) agreeing; then a subset by name.
    assert_equals_idiff(&field_exr, &recoloured_exr, None);
    assert_equals_idiff(&field_exr, &recoloured_exr, Some("R,G,B,Z"));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn flip_means_equal_nvidias_on_three_pairs() {
    let dir = scratch("flip");
    let size = ["--size", "160x120"];
    let mesh = |res: &'static str| [&size[..], &["--mesh", "--res", res]].concat();
    let (pair_field, _) = render(&dir, "scenes/pair.ron", "pair-field", &size);
    let (pair_mesh, _) = render(&dir, "scenes/pair.ron", "pair-mesh", &mesh("16"));
    let (medusa_field, _) = render(&dir, "scenes/medusa.ron", "medusa-field", &size);
    let (medusa_mesh, _) = render(&dir, "scenes/medusa.ron", "medusa-mesh", &mesh("64"));
    let noisy = with_noise(&medusa_field, 12, &dir.join("medusa-noisy.png"));
    for (reference, test) in [(&pair_field, &pair_mesh), (&medusa_field, &medusa_mesh), (&medusa_field, &noisy)] {
        let out = blobtrace(&["diff", reference, test, "--metric", "flip", "--json"]);
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON");
        let ours = v["flip"]["mean"].as_f64().unwrap();
        let theirs: f64 = run_oracle("flip_mean.py", &[reference, test]).trim().parse().unwrap();
        assert!(ours > 1e-4, "{test}: a real difference, {ours}");
        assert!((ours - theirs).abs() <= 1e-4, "{reference} vs {test}: FLIP mean {ours} against NVIDIA's {theirs}");
        assert!((v["mean"].as_f64().unwrap() - ours).abs() < 1e-6, "the report's mean is FLIP's");
    }
    std::fs::remove_dir_all(dir).unwrap();
}
