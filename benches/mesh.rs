//! Polygonization: Medusa from scratch with cold caches against exact naive
//! evaluation (the caching paper's Table 1, at the sizes a benchmark run can
//! afford), local re-polygonization after moving the point/hair test's
//! probe, cached against naive (its Table 2), and the quality report at
//! each level against the meshing it checks. `cargo bench --bench mesh`;
//! `blobtrace bench mesh` and `blobtrace bench edit` print the first two's
//! ratios in one process.

/// The allocator the `blobtrace` command uses.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

use std::time::{Duration, Instant};

use blobtrace::field::{Edit, EvalMode, ModelField};
use blobtrace::mesh::quality::{MeshQuality, QualityLevel};
use blobtrace::mesh::{Lattice, PolygonizeOptions, Polygonizer, skeleton_seeds};
use blobtrace::pipeline::{PolygonizeSettings, Silent, polygonize, polygonizer_on};
use blobtrace::scene::Scene;
use criterion::{BatchSize, BenchmarkId, Criterion, criterion_group, criterion_main};
use glam::Vec3;

fn load(name: &str) -> Scene {
    Scene::load(format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR"))).expect("the bundled scene loads")
}

/// A polygonizer over `scene` at `res`, run once.
fn polygonized(scene: &Scene, mode: EvalMode, res: u32) -> Polygonizer {
    polygonizer_on(&scene.model, mode, Lattice::across(&scene.model.bounds(), res), PolygonizeOptions::default())
}

fn table_1(c: &mut Criterion) {
    let mut group = c.benchmark_group("medusa_polygonize");
    group.sample_size(10);
    for res in [64, 128] {
        for (name, mode) in [("cached_cold", EvalMode::Cached), ("naive", EvalMode::Naive)] {
            // A freshly loaded scene per iteration, so that the caches start empty.
            group.bench_with_input(BenchmarkId::new(name, res), &res, |b, &res| {
                b.iter_batched(|| load("medusa.ron"), |scene| polygonized(&scene, mode, res), BatchSize::PerIteration)
            });
        }
    }
    group.finish();
}

/// Moves the probe by `by` and re-polygonizes; returns the re-polygonization's time.
fn move_probe(scene: &mut Scene, p: &mut Polygonizer, mode: EvalMode, by: Vec3) -> Duration {
    let change = scene.model.apply(&Edit::Translate { node: "probe".into(), by }).expect("the probe moves");
    let region = scene.model.change_region(&change, mode == EvalMode::Cached);
    let field = ModelField::new(&scene.model, mode);
    let seeds = skeleton_seeds(&scene.model, scene.model.root());
    let clock = Instant::now();
    p.repolygonize(&field, &region, &seeds);
    clock.elapsed()
}

fn table_2(c: &mut Criterion) {
    let mut group = c.benchmark_group("hair_probe_local_update_res60");
    group.sample_size(10);
    for (name, mode) in [("cached", EvalMode::Cached), ("naive", EvalMode::Naive)] {
        let mut scene = load("hair_point.ron");
        let mut p = polygonized(&scene, mode, 60);
        // One step into the hair and one back per iteration, as the script does.
        let step = Vec3::new(-0.09, 0.0, 0.02);
        group.bench_function(name, |b| {
            b.iter_custom(|iterations| {
                (0..iterations)
                    .map(|_| move_probe(&mut scene, &mut p, mode, step) + move_probe(&mut scene, &mut p, mode, -step))
                    .sum()
            })
        });
    }
    group.finish();
}

/// The particles at res 256 (350 k triangles) meshed, and their mesh
/// checked at each level of the quality report.
fn quality_report(c: &mut Criterion) {
    let scene = load("particles.ron");
    let settings = PolygonizeSettings { res: 256, quality: QualityLevel::Off, ..Default::default() };
    let mesh_it = || polygonize(&scene.model, EvalMode::Indexed, &settings, &Silent).expect("the particles mesh");
    let mut group = c.benchmark_group("particles_res256_quality");
    group.sample_size(10);
    group.bench_function("meshing", |b| b.iter(mesh_it));
    let (mesh, report) = mesh_it();
    let lattice = Lattice { cell: report.cell_size };
    for (name, level) in [("summary", QualityLevel::Summary), ("full", QualityLevel::Full)] {
        group.bench_function(name, |b| b.iter(|| MeshQuality::at_level(&mesh, level, Some(&lattice))));
    }
    group.finish();
}

criterion_group!(benches, table_1, table_2, quality_report);
criterion_main!(benches);
