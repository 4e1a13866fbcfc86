//! `Points` nodes: particle files in PLY, text and NumPy form build the same
//! model as the points written out in a scene, render the same image, move
//! as one node, and bad files are refused with the file and the place.

mod common;

use std::path::Path;

use blobtrace::field::{EvalMode, NodeKind, Skeleton};
use blobtrace::pipeline::Silent;
use blobtrace::pipeline::render_field;
use blobtrace::scene::{Scene, SceneError, Size};
use common::{blobtrace, bundled, scratch};
use glam::Vec3;

/// The centres of `scenes/particles.ron`'s points, in scene order.
fn particle_centres() -> Vec<Vec3> {
    let scene = bundled("particles.ron");
    let m = &scene.model;
    let NodeKind::Blend { children, .. } = &m.node(m.root()).kind else { panic!("a blend") };
    children
        .iter()
        .map(|&c| match &m.node(c).kind {
            NodeKind::Primitive(p) => match p.skeleton {
                Skeleton::Point { center } => Vec3::from(center),
                _ => panic!("points only"),
            },
            _ => panic!("primitives only"),
        })
        .collect()
}

/// Writes the particles in each format into `dir`; returns the file names.
fn write_files(dir: &Path, points: &[Vec3]) -> Vec<&'static str> {
    let header = |format: &str| {
        format!(
            "ply\nformat {format} 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
            points.len()
        )
    };
    let mut le = header("binary_little_endian").into_bytes();
    let mut be = header("binary_big_endian").into_bytes();
    for p in points {
        for v in p.to_array() {
            le.extend_from_slice(&v.to_le_bytes());
            be.extend_from_slice(&v.to_be_bytes());
        }
    }
    let text: String = points.iter().map(|p| format!("{} {} {}\n", p.x, p.y, p.z)).collect();
    let csv: String = points.iter().map(|p| format!("{},{},{}\n", p.x, p.y, p.z)).collect();
    let npy_header = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': ({}, 3), }}", points.len());
    let mut npy = b"\x93NUMPY\x01\x00".to_vec();
    npy.extend_from_slice(&(npy_header.len() as u16).to_le_bytes());
    npy.extend_from_slice(npy_header.as_bytes());
    for p in points {
        for v in p.to_array() {
            npy.extend_from_slice(&f64::from(v).to_le_bytes());
        }
    }
    let files: [(&str, Vec<u8>); 6] = [
        ("le.ply", le),
        ("be.ply", be),
        ("ascii.ply", format!("{}{text}", header("ascii")).into_bytes()),
        ("points.xyz", format!("# the particles\n{text}").into_bytes()),
        ("points.csv", csv.into_bytes()),
        ("points.npy", npy),
    ];
    for (name, bytes) in &files {
        std::fs::write(dir.join(name), bytes).unwrap();
    }
    files.map(|(name, _)| name).to_vec()
}

/// The particles scene with its model read from `file` (relative to the scene).
fn points_scene(file: &str, model: impl Fn(String) -> String) -> String {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/particles.ron")).unwrap();
    let head = &text[..text.find("model:").unwrap()];
    format!("{head}model: {},\n)\n", model(format!("Points(file: \"{file}\", radius: 2.25)")))
}

#[test]
fn a_points_file_renders_the_particles_scene_bit_for_bit_in_every_format() {
    let dir = scratch("points-formats");
    let names = write_files(&dir, &particle_centres());
    let reference = bundled("particles.ron");
    let size = Size(100, 100);
    let (expected, _) = render_field(&reference, (size, 1), EvalMode::Indexed, &Silent);
    for name in names {
        let path = dir.join(format!("{name}.ron"));
        std::fs::write(&path, points_scene(name, |m| m)).unwrap();
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(scene.model.counts().primitives, 1001, "{name}");
        let (frame, report) = render_field(&scene, (size, 1), EvalMode::Indexed, &Silent);
        assert!(frame.same_image(&expected), "{name}: the image differs from the scene's own points");
        assert_eq!(report.tracer, "kernel", "{name}");
    }
}

#[test]
fn a_moved_points_node_updates_incrementally_like_work_from_scratch() {
    let dir = scratch("points-edit");
    write_files(&dir, &particle_centres());
    let scene = dir.join("cloud.ron");
    std::fs::write(&scene, points_scene("le.ply", |m| format!("Named(\"cloud\", {m})"))).unwrap();
    let script = dir.join("move.ron");
    std::fs::write(
        &script,
        "EditScript(frames: [(repeat: 2, edits: [Translate(node: \"cloud\", by: (0.7, 0.0, 0.3))])])",
    )
    .unwrap();
    let out = dir.join("edit");
    let run = blobtrace(&[
        "edit",
        scene.to_str().unwrap(),
        "--script",
        script.to_str().unwrap(),
        "--size",
        "80x80",
        "--res",
        "24",
        "--verify",
        "--out-dir",
        out.to_str().unwrap(),
    ]);
    let said = format!("{}{}", String::from_utf8_lossy(&run.stdout), String::from_utf8_lossy(&run.stderr));
    assert!(run.status.success(), "{said}");
    assert!(said.contains("2 verified"), "{said}");
}

#[test]
fn bad_points_files_are_refused_with_the_file_and_the_place() {
    let dir = scratch("points-errors");
    let cases: [(&str, &[u8], &str); 5] = [
        ("missing.ply", b"", "No such file"),
        ("short.ply", b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0", "vertex 0: the body ends after 0 of the header's 3 vertices"),
        ("nan.xyz", b"1 2 3\nnan 0 0\n", "point 1: position"),
        ("radius.xyz", b"1 2 3 0.5\n4 5 6 0\n", "point 1: radius"),
        ("words.csv", b"1,2,3\n4,five,6\n", "line 2:3: \"five\" is not a number"),
    ];
    for (name, bytes, expected) in cases {
        if name != "missing.ply" {
            std::fs::write(dir.join(name), bytes).unwrap();
        }
        let path = dir.join(format!("{name}.ron"));
        std::fs::write(&path, points_scene(name, |m| m)).unwrap();
        let err = Scene::load(&path).unwrap_err();
        assert!(matches!(err, SceneError::PointFile { .. }), "{name}: {err}");
        let message = err.to_string();
        assert!(message.contains(name) && message.contains(expected), "{name}: {message}");
        let run = blobtrace(&["render", path.to_str().unwrap(), "-o", dir.join("x.png").to_str().unwrap()]);
        assert_eq!(run.status.code(), Some(1), "{name}");
        assert!(!dir.join("x.png").exists());
    }
}
