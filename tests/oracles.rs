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

/// Runs idiff itself.
fn idiff(args: &[&str]) -> std::process::Output {
    Command::new("idiff").args(args).output().expect("idiff runs (scripts/test installs openimageio-tools)")
}

/// `args` with their idiff-style options, as blobtrace's and idiff's exit codes.
fn exit_codes(args: &[&str]) -> (Option<i32>, Option<i32>) {
    (blobtrace(&[&["diff"], args].concat()).status.code(), idiff(args).status.code())
}

#[test]
fn idiff_command_lines_run_unchanged_with_idiffs_exit_codes_and_difference_images() {
    let dir = scratch("idiff-options");
    let size = ["--size", "96x72"];
    let (field_png, field_exr) = render(&dir, "scenes/pair.ron", "field", &size);
    let (mesh_png, mesh_exr) =
        render(&dir, "scenes/pair.ron", "mesh", &[&size[..], &["--mesh", "--res", "16"]].concat());
    let (f, m) = (field_png.as_str(), mesh_png.as_str());
    let lines: [&[&str]; 9] = [
        &["-fail", "0.5", "-warn", "0.01", f, m],
        &["-fail", "0.01", "-failpercent", "20", "-warn", "0.01", f, m],
        &["-fail", "0.01", "-failpercent", "20", "-warn", "0.01", "-warnpercent", "20", f, m],
        &["-fail", "0.01", "-failpercent", "20", "-hardfail", "0.3", f, m],
        &["-fail", "0.01", "-failpercent", "20", "-warn", "0.01", "-warnpercent", "20", "-hardwarn", "0.3", f, m],
        &["-allowfailures", "100000", f, m],
        &["-fail", "0.01", "-failrelative", "0.9", f, m],
        &["-fail", "0.01", "-failpercent", "20", "-warn", "0.01", "-warnrelative", "5", f, m],
        &["-fail", "1", "-warn", "1", "-v", f, f],
    ];
    let mut seen = std::collections::BTreeSet::new();
    for line in lines {
        let (ours, theirs) = exit_codes(line);
        assert_eq!(ours, theirs, "idiff {}", line.join(" "));
        seen.insert(theirs);
    }
    assert_eq!(seen.len(), 3, "the lines reach pass, warn and fail: {seen:?}");
    // idiff's difference images, EXR in float and PNG in 8 bits, equal idiff's own.
    for (a, b, ext, flags) in [
        (field_exr.as_str(), mesh_exr.as_str(), "exr", &["-abs", "-scale", "2"][..]),
        (field_exr.as_str(), mesh_exr.as_str(), "exr", &[][..]),
        (f, m, "png", &["-abs", "-scale", "4"][..]),
    ] {
        let (ours, theirs) = (dir.join(format!("ours.{ext}")), dir.join(format!("theirs.{ext}")));
        let (ours, theirs) = (ours.to_str().unwrap(), theirs.to_str().unwrap());
        blobtrace(&[&["diff"], flags, &["-o", ours, a, b]].concat());
        idiff(&[flags, &["-o", theirs, a, b]].concat());
        let v: serde_json::Value =
            serde_json::from_str(&run_oracle("oiio_compare.py", &[ours, theirs, "0", "0"])).unwrap();
        assert_eq!((v["max"].as_f64(), v["nfail"].as_u64()), (Some(0.0), Some(0)), "{flags:?} -o .{ext}: {v}");
        assert!(v["channels"].as_array().unwrap().len() >= 3, "{v}");
    }
    // -od writes nothing for identical images.
    let same = dir.join("same.exr");
    blobtrace(&["diff", "-od", "-o", same.to_str().unwrap(), f, f]);
    assert!(!same.exists(), "-od wrote a difference image of identical images");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn images_of_different_sizes_are_compared_as_idiff_compares_them() {
    let dir = scratch("idiff-sizes");
    let (large, _) = render(&dir, "scenes/pair.ron", "large", &["--size", "96x72"]);
    let (small, _) = render(&dir, "scenes/pair.ron", "small", &["--size", "64x48"]);
    // Statistics and exit codes, the larger first and the smaller first.
    assert_equals_idiff(&large, &small, None);
    assert_equals_idiff(&small, &large, None);
    // Percentages are of the first image's pixels: 5848 failures are 190% of the small image's
    // 3072 (fail at 100%) but 85% of the larger extent's 6912 (which would only warn).
    for (a, b) in [(&small, &large), (&large, &small)] {
        let line = ["-failpercent", "100", "-warnpercent", "50", a, b];
        let (ours, theirs) = exit_codes(&line);
        assert_eq!(ours, theirs, "idiff {}", line.join(" "));
    }
    assert_eq!(exit_codes(&["-failpercent", "100", "-warnpercent", "50", &small, &large]).1, Some(2));
    let out = blobtrace(&["diff", &large, &small]);
    let warning = String::from_utf8_lossy(&out.stderr);
    assert!(warning.contains("96x72 but") && warning.contains("compared over 96x72"), "{warning}");
    // Depth, normals and FLIP still need one size.
    assert_eq!(blobtrace(&["diff", &large, &small, "--metric", "flip"]).status.code(), Some(3));
    std::fs::remove_dir_all(dir).unwrap();
}

/// An EXR of one channel `Y` holding `values` in a row.
fn exr_row(path: &Path, values: &[f32]) -> String {
    let bytes = blobtrace::frame::channels_exr_bytes(values.len() as u32, 1, vec![("Y".into(), values.to_vec())]);
    std::fs::write(path, bytes.unwrap()).unwrap();
    path.to_str().unwrap().to_string()
}

/// The figure lines of a report: from the mean to the second count over a threshold.
fn figure_lines(stdout: &[u8]) -> Vec<String> {
    let text = String::from_utf8_lossy(stdout);
    let lines: Vec<String> = text.lines().map(str::to_string).collect();
    let start = lines.iter().position(|l| l.starts_with("  Mean error")).expect("a mean line");
    lines[start..start + 6].to_vec()
}

#[test]
fn idiff_stats_print_idiffs_own_figures_on_infinities_and_nans() {
    let dir = scratch("idiff-nonfinite");
    let size = ["--size", "96x72"];
    let (_, field) = render(&dir, "scenes/pair.ron", "field", &size);
    let (_, mesh) = render(&dir, "scenes/pair.ron", "mesh", &[&size[..], &["--mesh", "--res", "16"]].concat());
    let (inf, nan) = (f32::INFINITY, f32::NAN);
    let row = |name: &str, v: &[f32]| exr_row(&dir.join(name), v);
    let pairs = [
        // Renders: misses (infinite Z) in one render only.
        (field.clone(), mesh.clone()),
        // One mismatch: idiff's mean stays finite; two: infinite; NaN against numbers.
        (row("one.exr", &[1.0, 9.0, inf, 3.0]), row("finite.exr", &[1.0, 2.0, 3.0, 3.0])),
        (row("two.exr", &[1.0, inf, inf, 9.0]), row("finite2.exr", &[1.0, 2.0, 3.0, 3.0])),
        (row("nan.exr", &[inf, nan, 1.0, 0.25]), row("finite3.exr", &[0.0, 2.0, 1.0, 0.5])),
    ];
    for (a, b) in &pairs {
        let ours = blobtrace(&["diff", "--idiff-stats", "-fail", "0.5", "-warn", "0.5", a, b]);
        let theirs = idiff(&["-v", "-fail", "0.5", "-warn", "0.5", a, b]);
        assert_eq!(figure_lines(&ours.stdout), figure_lines(&theirs.stdout), "{a} vs {b}");
    }
    // Our own figures keep the mean finite and count the coverage mismatches beside it.
    let theirs = figure_lines(&idiff(&["-v", &field, &mesh]).stdout);
    assert_eq!(theirs[0], "  Mean error = inf");
    let v: serde_json::Value = serde_json::from_slice(&blobtrace(&["diff", &field, &mesh, "--json"]).stdout).unwrap();
    assert!(v["mean"].as_f64().unwrap().is_finite() && v["mismatch_px"].as_u64().unwrap() > 0, "{v}");
    assert_eq!((v["idiff"]["mean"].as_str(), v["idiff"]["psnr"].as_str()), (Some("inf"), Some("nan")));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn hdr_flip_of_exr_renders_equals_flip_evaluators() {
    let dir = scratch("hdr-flip");
    let size = ["--size", "160x120"];
    let mesh = |res: &'static str| [&size[..], &["--mesh", "--res", res]].concat();
    let (_, pair_field) = render(&dir, "scenes/pair.ron", "pair-field", &size);
    let (_, pair_mesh) = render(&dir, "scenes/pair.ron", "pair-mesh", &mesh("16"));
    let (medusa_png, medusa_field) = render(&dir, "scenes/medusa.ron", "medusa-field", &size);
    let (medusa_mesh_png, medusa_mesh) = render(&dir, "scenes/medusa.ron", "medusa-mesh", &mesh("64"));
    let cases: [(&str, &str, &[&str]); 3] = [
        (&pair_field, &pair_mesh, &[]),
        (&medusa_field, &medusa_mesh, &[]),
        (&medusa_field, &medusa_mesh, &["-2", "3.5"]),
    ];
    for (reference, test, exposures) in cases {
        let mut args = vec!["diff", reference, test, "--metric", "flip", "--json"];
        if let [start, stop] = exposures {
            args.extend(["--start-exposure", start, "--stop-exposure", stop]);
        }
        let v: serde_json::Value = serde_json::from_slice(&blobtrace(&args).stdout).expect("JSON");
        let theirs: serde_json::Value =
            serde_json::from_str(&run_oracle("flip_mean.py", &[&[reference, test, "HDR"], exposures].concat()))
                .unwrap();
        let (ours, e) = (&v["flip"]["mean"], &v["flip"]["exposures"]);
        let close =
            |a: &serde_json::Value, b: &serde_json::Value| (a.as_f64().unwrap() - b.as_f64().unwrap()).abs() <= 1e-4;
        let what = format!("{reference} vs {test} {exposures:?}: ours {v}, flip-evaluator's {theirs}");
        assert!(ours.as_f64().unwrap() > 1e-3, "a real difference: {what}");
        assert!(close(ours, &theirs["mean"]), "mean: {what}");
        assert!(close(&e["start"], &theirs["start"]) && close(&e["stop"], &theirs["stop"]), "exposures: {what}");
        assert_eq!(e["count"], theirs["count"], "{what}");
    }
    // The EXRs are judged in HDR: not the LDR-FLIP of their PNGs.
    let ldr: f64 = run_oracle("flip_mean.py", &[&medusa_png, &medusa_mesh_png]).trim().parse().unwrap();
    let hdr =
        serde_json::from_str::<serde_json::Value>(&run_oracle("flip_mean.py", &[&medusa_field, &medusa_mesh, "HDR"]))
            .unwrap()["mean"]
            .as_f64()
            .unwrap();
    assert!((ldr - hdr).abs() > 1e-3, "LDR {ldr} and HDR {hdr} should differ");
    std::fs::remove_dir_all(dir).unwrap();
}
