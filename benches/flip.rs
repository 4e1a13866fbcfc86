//! ꟻLIP on a 1280×960 pair (Medusa, field render against mesh render):
//! NVIDIA's code over the whole image on one thread against the same code in
//! parallel strips, as `blobtrace diff --metric flip` runs it. The error maps
//! are bit-identical (a unit test holds this); only the time differs.
//! `cargo bench --bench flip`. Against NVIDIA's own tool (flip-evaluator,
//! OpenMP) the whole command is timed from outside: see docs/PERFORMANCE.md.

use blobtrace::compare::{default_pixels_per_degree, flip_errors, flip_whole};
use blobtrace::field::EvalMode;
use blobtrace::frame::Size;
use blobtrace::pipeline::{PolygonizeSettings, polygonize, render_field, render_mesh};
use blobtrace::progress::Silent;
use blobtrace::scene::Scene;
use criterion::{Criterion, criterion_group, criterion_main};

fn medusa_pair() -> (Vec<u8>, Vec<u8>, u32, u32) {
    let scene =
        Scene::load(format!("{}/scenes/medusa.ron", env!("CARGO_MANIFEST_DIR"))).expect("the bundled scene loads");
    let size = Size(1280, 960);
    let (field, _) = render_field(&scene, (size, 1), EvalMode::Indexed, &Silent);
    let settings = PolygonizeSettings { res: 128, ..PolygonizeSettings::default() };
    let (mesh, report) = polygonize(&scene.model, EvalMode::Indexed, &settings, &Silent).expect("Medusa polygonizes");
    let (mesh_frame, _) = render_mesh(&scene, &mesh, report, (size, 1), &Silent);
    (field.to_srgb8(), mesh_frame.to_srgb8(), size.0, size.1)
}

fn flip(c: &mut Criterion) {
    let (reference, test, w, h) = medusa_pair();
    let ppd = default_pixels_per_degree();
    let mut group = c.benchmark_group("flip_1280x960");
    group.sample_size(10);
    group.bench_function("whole_one_thread", |b| b.iter(|| flip_whole(&reference, &test, w, h, ppd)));
    group.bench_function("strips_all_threads", |b| b.iter(|| flip_errors(&reference, &test, w, h, ppd)));
    group.finish();
}

criterion_group!(benches, flip);
criterion_main!(benches);
