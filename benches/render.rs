//! Field rendering of Medusa: exact indexed against exact naive evaluation and
//! against the caches (warm after the first iteration), each marking its empty
//! space as the command line does, and the indexed render across thread
//! counts. `cargo bench --bench render`.

use blobtrace::field::EvalMode;
use blobtrace::scene::{Scene, Size};
use blobtrace::trace::{RenderSettings, render_model};
use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};

fn medusa() -> Scene {
    Scene::load(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/medusa.ron")).expect("medusa loads")
}

fn settings(scene: &Scene, w: u32, h: u32) -> RenderSettings {
    scene.render_settings(Size(w, h))
}

fn eval_modes(c: &mut Criterion) {
    let scene = medusa();
    let mut group = c.benchmark_group("medusa_160x120");
    group.sample_size(10);
    for (name, mode) in [("indexed", EvalMode::Indexed), ("naive", EvalMode::Naive), ("cached_warm", EvalMode::Cached)]
    {
        let s = settings(&scene, 160, 120);
        group.bench_function(name, |b| b.iter(|| render_model(&scene.model, mode, &s, &|_| {})));
    }
    group.finish();
}

fn threads(c: &mut Criterion) {
    let scene = medusa();
    let mut group = c.benchmark_group("medusa_indexed_threads");
    group.sample_size(10);
    for n in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
        let s = settings(&scene, 160, 120);
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| pool.install(|| render_model(&scene.model, EvalMode::Indexed, &s, &|_| {})))
        });
    }
    group.finish();
}

criterion_group!(benches, eval_modes, threads);
criterion_main!(benches);
