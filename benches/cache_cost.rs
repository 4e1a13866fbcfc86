//! Calibrates the cost model behind `--mode auto` (`field::cache_cost`): for
//! every cache of the bundled scenes, a warm lookup and an exact evaluation
//! of its subtree are timed at the same points on one thread, beside the
//! model's estimate of the exact work in point terms. The fitted nanoseconds
//! per point term turn the lookup's time into point terms: the value
//! `LOOKUP_COST` should hold, printed with the constant now in the code.
//! Criterion then times one lookup and one exact evaluation of Medusa's
//! head. `cargo bench --bench cache_cost`.

use blobtrace::bench::lookup_costs;
use blobtrace::field::{EvalMode, LOOKUP_COST, NodeKind};
use blobtrace::scene::Scene;
use criterion::{Criterion, criterion_group, criterion_main};
use glam::Vec3A;

const SCENES: [&str; 6] = ["medusa.ron", "hair_point.ron", "warps.ron", "sharp.ron", "example.ron", "crown.ron"];

fn load(name: &str) -> Scene {
    Scene::load(format!("{}/scenes/{name}", env!("CARGO_MANIFEST_DIR"))).expect("the bundled scene loads")
}

fn calibrate() {
    let mut per_point = vec![];
    let mut lookups = vec![];
    println!("{:<14} {:<12} {:>10} {:>10} {:>12}", "scene", "cache", "exact ns", "cached ns", "exact work");
    for name in SCENES {
        for l in lookup_costs(&load(name).model) {
            println!("{name:<14} {:<12} {:>10.1} {:>10.1} {:>12.1}", l.name, l.exact_ns, l.cached_ns, l.exact_cost);
            per_point.push(l.exact_ns / f64::from(l.exact_cost.max(1.0)));
            lookups.push(l.cached_ns);
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let ns_per_point = median(&mut per_point);
    let lookup = median(&mut lookups) / ns_per_point;
    println!(
        "fitted: {ns_per_point:.2} ns per point term; a lookup is {lookup:.0} point terms (LOOKUP_COST = {LOOKUP_COST})"
    );
}

fn head_lookup(c: &mut Criterion) {
    calibrate();
    let scene = load("medusa.ron");
    let model = &scene.model;
    let (cache, child) = model
        .cache_decisions()
        .into_iter()
        .find(|d| d.name == "head")
        .and_then(|d| match model.node(d.node).kind {
            NodeKind::Cache { child, .. } => Some((d.node, child)),
            _ => None,
        })
        .expect("Medusa has a cached head");
    let b = model.node(child).bounds;
    let points: Vec<Vec3A> = (0..1000)
        .map(|i| {
            let t = i as f32;
            b.min + (b.max - b.min) * Vec3A::new((t * 0.37).fract(), (t * 0.61).fract(), (t * 0.83).fract())
        })
        .collect();
    let sum = |mode: EvalMode, node| points.iter().map(|&p| model.node_value(node, p, mode)).sum::<f32>();
    sum(EvalMode::Cached, cache);
    let mut group = c.benchmark_group("medusa_head_1000_values");
    group.bench_function("exact_indexed", |b| b.iter(|| sum(EvalMode::Indexed, child)));
    group.bench_function("cached_warm", |b| b.iter(|| sum(EvalMode::Cached, cache)));
    group.finish();
}

criterion_group!(benches, head_lookup);
criterion_main!(benches);
