//! Warping nodes end to end: the tracer against a brute-force march on random
//! warped trees and cameras, and bad warps in scene files refused at their
//! place. (Values, gradients and bounds through warps are in the conformance
//! suite; warped edits in tests/edit.rs.)

mod common;

use blobtrace::camera::Camera;
use blobtrace::field::{EvalMode, Field, ModelField};
use blobtrace::geom::Ray;
use blobtrace::scene::Scene;
use blobtrace::trace::{TraceOptions, trace_ray};
use common::Rng;
use glam::Vec3;

/// The first `t` where a march with `step` finds the field above the
/// threshold: the crossing lies within one step before it.
fn brute_force_t(field: &impl Field, ray: &Ray, step: f32) -> Option<f32> {
    let (t0, t1) = field.bounds().clip_ray(ray.origin, ray.dir.recip(), 0.0, f32::INFINITY)?;
    let mut t = t0;
    while t <= t1 {
        if field.value(ray.at(t)) > field.threshold() {
            return Some(t);
        }
        t += step;
    }
    None
}

/// A random warped primitive: a segment or point under a twist, a taper or a
/// bend (kept inside the bend's domain), placed at `at`.
fn random_warped(rng: &mut Rng, at: Vec3) -> String {
    let mut r = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
    let child = if r(0.0, 1.0) < 0.7 {
        format!(
            "Segment(a: ({:.3}, {:.3}, {:.3}), b: ({:.3}, {:.3}, {:.3}), radius: {:.3})",
            r(-0.9, -0.3),
            r(-0.9, 0.9),
            r(-0.3, 0.3),
            r(0.3, 0.9),
            r(-0.9, 0.9),
            r(-0.3, 0.3),
            r(0.35, 0.6)
        )
    } else {
        format!("Point(center: ({:.3}, {:.3}, 0.0), radius: {:.3})", r(-0.3, 0.3), r(-0.3, 0.3), r(0.6, 0.9))
    };
    let axis = ["X", "Y", "Z"][(r(0.0, 2.999)) as usize];
    let warp = match (r(0.0, 2.999)) as u32 {
        0 => format!("Twist(axis: {axis}, rate: {:.3}, child: {child})", r(-2.5, 2.5)),
        1 => format!(
            "Taper(axis: {axis}, from: {:.3}, to: {:.3}, scale_from: {:.3}, scale_to: {:.3}, child: {child})",
            r(-1.0, -0.2),
            r(0.2, 1.0),
            r(0.5, 1.5),
            r(0.3, 1.2)
        ),
        _ => format!("Bend(rate: {:.3}, child: {child})", r(-0.6, 0.6)),
    };
    format!("Transform(translate: ({:.3}, {:.3}, {:.3}), child: {warp})", at.x, at.y, at.z)
}

fn random_scene(seed: u64) -> Scene {
    let mut rng = Rng(seed);
    let parts: Vec<String> = (0..3)
        .map(|k| random_warped(&mut rng, Vec3::new(1.3 * (k as f32 - 1.0), 0.4 * (k as f32 - 1.0), 0.0)))
        .collect();
    // Nested: a twist of a taper of a bend.
    let nested = "Twist(axis: Y, rate: 1.1, child: Taper(axis: Y, from: -1.0, to: 1.5, scale_to: 0.5, \
                  child: Bend(rate: 0.4, child: Segment(a: (-0.8, -0.5, 0.0), b: (0.8, 0.6, 0.0), radius: 0.5))))";
    let text = format!(
        "Scene(camera: Camera(eye: (0.0, 0.0, 6.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (8, 8), \
         model: Blend([{}, Transform(translate: (0.0, -1.4, 0.3), child: {nested})]))",
        parts.join(", ")
    );
    Scene::parse(&text, "random-warps").unwrap_or_else(|e| panic!("{e}\n{text}"))
}

#[test]
fn tracing_warped_trees_finds_the_hits_and_depths_of_a_fine_march() {
    let step = 2e-3;
    let (mut compared, mut hits) = (0, 0);
    for seed in 0..4 {
        let scene = random_scene(seed);
        let mut rng = Rng(100 + seed);
        let angle = rng.next_f32() * std::f32::consts::TAU;
        let eye = Vec3::new(4.0 * angle.sin(), 1.5 * (rng.next_f32() - 0.5), 4.0 * angle.cos());
        let camera = Camera::look_at(eye, Vec3::ZERO, Vec3::Y, 45.0);
        for mode in [EvalMode::Indexed, EvalMode::Naive] {
            let field = ModelField::new(&scene.model, mode);
            let (w, h) = (24, 18);
            for y in 0..h {
                for x in 0..w {
                    let at = |dx: f32, dy: f32| camera.ray_at(x as f32 + 0.5 + dx, y as f32 + 0.5 + dy, w, h);
                    let brute = brute_force_t(&field, &at(0.0, 0.0), step);
                    // Pixels on a silhouette: a quarter pixel away the march disagrees.
                    let near = [(-0.25, 0.0), (0.25, 0.0), (0.0, -0.25), (0.0, 0.25)];
                    if near
                        .iter()
                        .any(|&(dx, dy)| brute_force_t(&field, &at(dx, dy), step).is_some() != brute.is_some())
                    {
                        continue;
                    }
                    let traced = trace_ray(&field, &at(0.0, 0.0), &TraceOptions::default()).hit;
                    assert_eq!(traced.is_some(), brute.is_some(), "seed {seed} {mode:?} pixel {x},{y}");
                    if let (Some(t), Some(b)) = (traced, brute) {
                        // No crossing skipped: the traced hit lies at the march's first crossing.
                        assert!(
                            t >= b - step - 1e-3 && t <= b + 1e-3,
                            "seed {seed} {mode:?} pixel {x},{y}: depth {t} against {b}"
                        );
                        hits += 1;
                    }
                    compared += 1;
                }
            }
        }
    }
    assert!(compared > 2500 && hits > 300, "{compared} pixels compared, {hits} hits");
}

#[test]
fn the_bundled_warp_scene_traces_like_a_fine_march() {
    let scene = common::bundled("warps.ron");
    let field = ModelField::new(&scene.model, EvalMode::Cached);
    let (compared, hits) = common::assert_traces_like_brute_force(&field, &scene.camera, (48, 36), 2e-3);
    assert!(compared > 1500 && hits > 150, "{compared} compared, {hits} hits");
}

#[test]
fn bad_warps_are_refused_at_their_line_and_column() {
    let scene = |model: &str| {
        format!(
            "Scene(\n    camera: Camera(eye: (0.0, 0.0, 6.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),\n    size: (8, 8),\n    model: Blend([\n        Point(center: (0.0, 0.0, 0.0), radius: 1.0),\n        {model},\n    ]),\n)"
        )
    };
    let point = "Point(center: (0.0, 0.0, 0.0), radius: 1.0)";
    let cases = [
        (format!("Twist(axis: W, rate: 1.0, child: {point})"), "6:", "W"),
        (format!("Twist(rate: 1e30, child: {point})"), "6:", "1e30"),
        (format!("Taper(from: 1.0, to: 1.0, scale_to: 0.5, child: {point})"), "6:9", "from < to"),
        (format!("Taper(from: 0.0, to: 1.0, scale_to: -0.5, child: {point})"), "6:", "positive"),
        (
            format!(
                "Bend(rate: 0.2, child: {point}), Bend(rate: 2.0, child: Segment(a: (0.0, 0.0, 0.0), b: (3.0, 0.0, 0.0), radius: 0.5))"
            ),
            "6:78",
            "rate·x",
        ),
    ];
    for (model, place, words) in cases {
        let text = scene(&model);
        let err = Scene::parse(&text, "bad.ron").expect_err("refused").to_string();
        assert!(err.contains(&format!("bad.ron:{place}")) && err.contains(words), "{model}: {err}");
    }
}
