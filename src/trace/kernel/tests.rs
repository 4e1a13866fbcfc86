//! The kernel tracer against the segment tracer, ray by ray.

use super::*;
use crate::field::ModelField;
use crate::frame::Size;
use crate::scene::Scene;
use crate::trace::trace_ray;

fn bundled(name: &str) -> Scene {
    Scene::load(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)).unwrap()
}

/// Traces every pixel of `scene` at `size` both ways; returns the rays
/// that hit either way and how many disagree past the bounds allowed.
fn agreement(scene: &Scene, size: (u32, u32)) -> (u32, Vec<String>) {
    let s = scene.render_settings(Size(size.0, size.1));
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let kernel = KernelTracer::new(&scene.model, EvalMode::Indexed, &s.camera, size).unwrap();
    let diag = field.bounds().diagonal();
    let (mut hits, mut bad) = (0, vec![]);
    for y in 0..size.1 {
        for x in 0..size.0 {
            let ray = s.camera.ray(x, y, size.0, size.1);
            let k = kernel.trace(&field, &ray, (x, y), &s.trace);
            let seg = trace_ray(&field, &ray, &s.trace);
            hits += u32::from(k.hit.is_some() || seg.hit.is_some());
            match (k.hit, seg.hit) {
                (Some(a), Some(b)) if (a - b).abs() <= 1e-5 * diag => {}
                (None, None) => {}
                (a, b) => bad.push(format!("pixel {x},{y}: kernel {a:?}, segment {b:?}")),
            }
        }
    }
    (hits, bad)
}

#[test]
fn the_particles_are_hit_where_the_segment_tracer_hits_them() {
    let (hits, bad) = agreement(&bundled("particles.ron"), (200, 200));
    assert!(hits > 4000, "{hits} hits");
    assert!(bad.is_empty(), "{} of {hits} disagree: {:?}", bad.len(), &bad[..bad.len().min(10)]);
}
