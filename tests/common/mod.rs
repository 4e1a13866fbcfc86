//! Shared helpers for the integration tests.
#![allow(dead_code)]

use blobtrace::camera::Camera;
use blobtrace::field::{Edit, EvalMode, Field, Model};
use blobtrace::geom::Ray;
use blobtrace::mesh::{Lattice, Mesh, PolygonizeOptions, Polygonizer};
use blobtrace::pipeline::polygonizer_on;
use blobtrace::scene::Scene;
use blobtrace::trace::{TraceOptions, trace_ray};
use glam::{Vec3, Vec3A};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the blobtrace binary in the project folder.
pub fn blobtrace(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_blobtrace"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("the binary runs")
}

/// A fresh scratch folder for one test, unique to this process.
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("blobtrace-test-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A copy of the bundled scenes in `dir` with one blob of the pair's radius
/// grown by 1%: the pair's two regression entries fail, the rest pass.
pub fn scenes_with_a_grown_radius(dir: &Path) -> PathBuf {
    let scenes = dir.join("scenes");
    std::fs::create_dir_all(&scenes).unwrap();
    for entry in std::fs::read_dir("scenes").unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "ron") {
            std::fs::copy(&path, scenes.join(path.file_name().unwrap())).unwrap();
        }
    }
    let pair = std::fs::read_to_string("scenes/pair.ron").unwrap();
    std::fs::write(scenes.join("pair.ron"), pair.replacen("radius: 1.6", "radius: 1.616", 1)).unwrap();
    scenes
}

/// A scene using every node type, with transforms that rotate and scale unevenly.
pub const EVERY_NODE: &str = r#"Scene(
    camera: Camera(eye: (0.0, 1.0, 7.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
    size: (64, 48),
    model: Blend([
        Point(center: (0.0, 0.0, 0.0), radius: 1.0),
        Segment(a: (1.0, 0.0, 0.0), b: (2.0, 0.5, 0.3), radius: 0.6, weight: 1.3),
        Circle(center: (-1.5, 0.0, 0.0), normal: (0.3, 1.0, 0.2), ring: 0.8, radius: 0.4),
        SplinePoints(control: [(-2.0, 1.0, 0.0), (-1.0, 1.6, 0.4), (0.0, 1.4, 0.8)], count: 30, radius: 0.35, radius_end: 0.2),
        Union([Point(center: (0.0, -1.5, 0.0), radius: 0.9), Point(center: (0.5, -1.6, 0.2), radius: 0.8)]),
        Intersection([Point(center: (2.0, -1.5, 0.0), radius: 1.4), Segment(a: (1.5, -1.5, 0.0), b: (2.5, -1.5, 0.0), radius: 0.9)]),
        Difference(Point(center: (-2.0, -1.5, 0.0), radius: 1.3), Point(center: (-1.8, -1.3, 0.4), radius: 0.7)),
        Ricci(n: 3.0, children: [Point(center: (0.0, 2.5, 0.0), radius: 0.8), Point(center: (0.4, 2.6, 0.0), radius: 0.8)]),
        Named("arm", Transform(translate: (0.5, 0.3, -1.0), rotate: (20.0, -35.0, 50.0), scale: (1.5, 0.7, 1.1),
            child: Segment(a: (0.0, 0.0, 0.0), b: (1.0, 0.0, 0.0), radius: 0.5))),
        Cache(res: 32, child: Point(center: (0.0, 0.0, 1.5), radius: 0.7)),
        Named("twisted", Twist(axis: Y, rate: 1.4, child: Segment(a: (0.3, 3.0, 0.0), b: (0.3, 4.2, 0.0), radius: 0.5))),
        Transform(translate: (2.6, 2.4, 0.0), child: Twist(axis: Z, rate: 0.9, child: Taper(axis: X, from: -0.5, to: 0.8,
            scale_to: 0.5, child: Bend(rate: 0.5, child: Segment(a: (-0.5, 0.0, 0.0), b: (1.0, 0.0, 0.0), radius: 0.6))))),
        Cache(res: 24, child: Taper(axis: Y, from: -3.6, to: -2.4, scale_from: 1.2, scale_to: 0.6,
            child: Point(center: (0.0, -3.0, 0.0), radius: 0.8))),
    ]),
)"#;

/// A random move, turn or scaling of `node`, or for a primitive a new radius.
pub fn random_edit(rng: &mut Rng, node: &str, primitive: bool) -> Edit {
    let mut v = |s: f32| Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5) * s;
    let node = node.to_string();
    let pick = (v(1.0).x + 0.5) * 5.0;
    match pick as u32 {
        0 => Edit::Rotate { node, degrees: v(60.0) },
        1 => Edit::Scale { node, by: Vec3::ONE + v(0.4) },
        2 if primitive => Edit::Radius { node, radius: 0.3 + (v(1.0).y + 0.5) * 0.5 },
        _ => Edit::Translate { node, by: v(0.6) },
    }
}

/// Loads a bundled scene by file name.
pub fn bundled(name: &str) -> Scene {
    Scene::load(format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR"))).expect("bundled scene loads")
}

/// `model` polygonized in `mode` on the lattice of `res` cells across its
/// bounds, grown from every skeleton; the polygonizer and its mesh.
pub fn polygonize(model: &Model, mode: EvalMode, res: u32, options: PolygonizeOptions) -> (Polygonizer, Mesh) {
    let p = polygonizer_on(model, mode, Lattice::across(&model.bounds(), res), options);
    let mesh = p.mesh();
    (p, mesh)
}

/// Asserts that a local update's mesh is a fresh polygonization's: the same
/// triangles and vertices (exact bits, see [`Mesh::digest`]), numbered the same way.
pub fn assert_same_mesh(local: &Mesh, fresh: &Mesh, what: &str) {
    assert_eq!(local.triangle_set(), fresh.triangle_set(), "{what}: the triangles");
    assert_eq!(
        (local.positions.len(), local.digest()),
        (fresh.positions.len(), fresh.digest()),
        "{what}: the vertices (unused ones included)"
    );
    assert!(local == fresh, "{what}: the numbering");
    let mut used = vec![false; local.positions.len()];
    local.triangles.iter().flatten().for_each(|&v| used[v as usize] = true);
    assert!(used.iter().all(|&u| u), "{what}: a vertex no triangle uses");
}

/// A small deterministic generator (SplitMix64) so tests need no seed plumbing.
pub struct Rng(pub u64);

impl Rng {
    /// Next value in `[0, 1)`.
    pub fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }

    /// A point uniformly in the box `[min, max]`.
    pub fn point_in(&mut self, min: Vec3A, max: Vec3A) -> Vec3A {
        let t = Vec3A::new(self.next_f32(), self.next_f32(), self.next_f32());
        min + (max - min) * t
    }
}

/// Asserts `|a - b| <= tol`, printing the actual difference.
#[track_caller]
pub fn assert_close(a: f32, b: f32, tol: f32, what: &str) {
    assert!((a - b).abs() <= tol, "{what}: {a} vs {b}, difference {} > {tol}", (a - b).abs());
}

/// Hit or miss by marching with a tiny fixed step.
pub fn brute_force_hit(field: &impl Field, ray: &Ray, step: f32) -> bool {
    let Some((t0, t1)) = field.bounds().clip_ray(ray.origin, ray.dir.recip(), 0.0, f32::INFINITY) else {
        return false;
    };
    let mut t = t0;
    while t <= t1 {
        if field.value(ray.at(t)) > field.threshold() {
            return true;
        }
        t += step;
    }
    false
}

/// Traces every pixel of a `w`×`h` view and asserts that hit/miss equals a
/// brute-force march with `step`, except at pixels whose quarter-pixel
/// neighbours disagree (they straddle a silhouette). Returns the pixels
/// compared and how many of them hit.
pub fn assert_traces_like_brute_force(
    field: &impl Field,
    camera: &Camera,
    (w, h): (u32, u32),
    step: f32,
) -> (usize, usize) {
    let (mut compared, mut hits) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let at = |dx: f32, dy: f32| camera.ray_at(x as f32 + 0.5 + dx, y as f32 + 0.5 + dy, w, h);
            let brute = brute_force_hit(field, &at(0.0, 0.0), step);
            let straddles = [(-0.25, 0.0), (0.25, 0.0), (0.0, -0.25), (0.0, 0.25)]
                .iter()
                .any(|&(dx, dy)| brute_force_hit(field, &at(dx, dy), step) != brute);
            if straddles {
                continue;
            }
            let traced = trace_ray(field, &at(0.0, 0.0), &TraceOptions::default()).hit.is_some();
            assert_eq!(traced, brute, "pixel {x},{y}: traced hit {traced}, brute force {brute}");
            compared += 1;
            hits += usize::from(brute);
        }
    }
    (compared, hits)
}
