//! Cache nodes: reconstruction, convergence, invalidation, the resize rule,
//! determinism, the memory budget and conservative tracing on cached fields.

mod common;

use blobtrace::cache::{CacheGrid, CacheSpec, Filter, Refit, SamplePool, Storage};
use blobtrace::field::{EvalMode, Field, Model, ModelField, NodeId, NodeKind, Placement, Primitive, Region, Skeleton};
use blobtrace::geom::{Aabb, Interval};
use blobtrace::scene::{Scene, Size};
use blobtrace::trace::render;
use common::{Rng, assert_traces_like_brute_force, bundled, random_edit};
use glam::{Vec3, Vec3A};

/// A smooth blobby pair under one cache, with a named point inside it to edit.
fn cached_scene(res: u32, value: &str, gradient: &str, storage: &str) -> Scene {
    Scene::parse(
        &format!(
            r#"Scene(
    camera: Camera(eye: (0.0, 0.5, 5.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
    size: (64, 48),
    model: Cache(res: {res}, value: {value}, gradient: {gradient}, storage: {storage}, child: Blend([
        Point(center: (-0.5, 0.0, 0.0), radius: 1.2),
        Point(center: (0.6, 0.1, 0.0), radius: 1.0),
        Named("probe", Point(center: (0.0, 0.6, 0.3), radius: 0.5)),
    ])),
)"#
        ),
        "cached",
    )
    .expect("test scene parses")
}

fn default_scene(res: u32) -> Scene {
    cached_scene(res, "Trilinear", "Triquadratic", "F32")
}

fn cache_node(model: &Model) -> (NodeId, usize, NodeId) {
    model
        .nodes()
        .iter()
        .enumerate()
        .find_map(|(id, n)| match n.kind {
            NodeKind::Cache { grid, child, .. } => Some((id as NodeId, grid, child)),
            _ => None,
        })
        .expect("a cache node")
}

fn samples_evaluated(model: &Model) -> u64 {
    model.cache_stats().iter().map(|(_, _, s)| s.samples_evaluated).sum()
}

/// The model's cache node, and `n` random points of its bounds at which it
/// was evaluated (filling the samples around them).
fn warm_cache(model: &Model, n: usize, seed: u64) -> (NodeId, Vec<Vec3A>) {
    let (cache, _, _) = cache_node(model);
    let points = random_points(model, n, seed);
    for &p in &points {
        model.node_value(cache, p, EvalMode::Cached);
    }
    (cache, points)
}

fn random_points(model: &Model, n: usize, seed: u64) -> Vec<Vec3A> {
    let b = model.bounds();
    let mut rng = Rng(seed);
    (0..n).map(|_| rng.point_in(b.min, b.max)).collect()
}

#[test]
fn trilinear_reproduces_the_samples_at_lattice_points() {
    let scene = default_scene(24);
    let (cache, grid, child) = cache_node(&scene.model);
    let c = scene.model.cache(grid).cell();
    let mut rng = Rng(7);
    for _ in 0..300 {
        let p = rng.point_in(Vec3A::splat(-1.5), Vec3A::splat(1.5));
        let lattice = (p / c).round() * c;
        let exact = scene.model.node_value(child, lattice, EvalMode::Indexed);
        let cached = scene.model.node_value(cache, lattice, EvalMode::Cached);
        assert_eq!(cached, exact, "at lattice point {lattice}");
    }
}

/// Hits and vertices take a cache's value and gradient from one gather: the
/// very bits of the two lookups apart, whichever filter reads more samples.
#[test]
fn value_and_gradient_together_equal_them_apart_for_every_pair_of_filters() {
    for (value, gradient, storage) in [
        ("Trilinear", "Triquadratic", "F32"),
        ("Triquadratic", "Trilinear", "F32"),
        ("Trilinear", "Trilinear", "F16"),
        ("Triquadratic", "Triquadratic", "F32"),
    ] {
        let scene = cached_scene(20, value, gradient, storage);
        let field = ModelField::new(&scene.model, EvalMode::Cached);
        for p in random_points(&scene.model, 2_000, 5) {
            let (v, g) = field.value_and_gradient(p);
            assert_eq!(v.to_bits(), field.value(p).to_bits(), "{value}/{gradient} value at {p}");
            assert_eq!(g.to_array().map(f32::to_bits), field.gradient(p).to_array().map(f32::to_bits), "at {p}");
        }
    }
}

#[test]
fn gradients_match_central_differences_of_the_reconstruction() {
    for filter in ["Trilinear", "Triquadratic"] {
        let scene = cached_scene(20, filter, filter, "F32");
        let field = ModelField::new(&scene.model, EvalMode::Cached);
        let c = scene.model.cache(cache_node(&scene.model).1).cell();
        let h = c * 1e-2;
        let mut rng = Rng(11);
        let mut checked = 0;
        while checked < 200 {
            let p = rng.point_in(Vec3A::splat(-1.2), Vec3A::splat(1.2));
            // Stay clear of the trilinear's kinks at cell faces.
            let frac = (p / c).fract_gl();
            if filter == "Trilinear" && (frac.min_element() < 0.05 || frac.max_element() > 0.95) {
                continue;
            }
            let cd = Vec3A::new(
                field.value(p + Vec3A::X * h) - field.value(p - Vec3A::X * h),
                field.value(p + Vec3A::Y * h) - field.value(p - Vec3A::Y * h),
                field.value(p + Vec3A::Z * h) - field.value(p - Vec3A::Z * h),
            ) / (2.0 * h);
            let g = field.gradient(p);
            assert!((g - cd).length() <= 2e-2 * (1.0 + cd.length()), "{filter} at {p}: {g} vs {cd}");
            checked += 1;
        }
    }
}

#[test]
fn cached_error_shrinks_as_resolution_grows() {
    let mut previous = f64::INFINITY;
    for res in [16, 32, 64, 128] {
        let scene = default_scene(res);
        let (cache, _, child) = cache_node(&scene.model);
        let points = random_points(&scene.model, 4000, 3);
        let err: f64 = points
            .iter()
            .map(|&p| {
                let e = scene.model.node_value(child, p, EvalMode::Indexed);
                f64::from((scene.model.node_value(cache, p, EvalMode::Cached) - e).abs())
            })
            .sum::<f64>()
            / points.len() as f64;
        assert!(err < previous * 0.6, "res {res}: mean error {err} did not drop enough from {previous}");
        previous = err;
    }
}

fn probe(model: &Model) -> NodeId {
    match model.node(model.find("probe").expect("probe")).kind {
        NodeKind::Named { child, .. } => child,
        _ => unreachable!(),
    }
}

fn moved_probe() -> Primitive {
    Primitive::new(Skeleton::Point { center: Vec3A::new(0.2, 0.4, 0.1) }, 0.5, 1.0, Default::default())
}

/// Short segments (a couple of cells) from `points`, whose slope bounds the
/// cache takes from its samples and keeps.
fn short_segments(points: &[Vec3A]) -> Vec<Region> {
    let step = Vec3A::new(0.05, -0.03, 0.04);
    points.iter().map(|&p| Region::Segment(p, p + step)).collect()
}

/// Once the samples around a box are held, the cache bounds its value there by
/// their range (tighter than the subtree's bound over their reach), without
/// evaluating anything; both filters and both storages stay inside it.
#[test]
fn intervals_over_held_samples_are_tighter_and_still_hold() {
    for (value, storage) in [("Trilinear", "F32"), ("Triquadratic", "F16")] {
        let scene = cached_scene(32, value, "Triquadratic", storage);
        let field = ModelField::new(&scene.model, EvalMode::Cached);
        let c = field.bounds().size().max_element() / 32.0;
        let boxes: Vec<Aabb> = random_points(&scene.model, 400, 21).into_iter().map(|p| Aabb::around(p, c)).collect();
        let cold: Vec<_> = boxes.iter().map(|b| field.interval(b)).collect();
        for p in random_points(&scene.model, 40_000, 22) {
            field.value(p);
        }
        let evaluated = samples_evaluated(&scene.model);
        let warm: Vec<_> = boxes.iter().map(|b| field.interval(b)).collect();
        assert_eq!(samples_evaluated(&scene.model), evaluated, "{value} {storage}: ranges evaluated samples");
        let mut rng = Rng(23);
        let mut tighter = 0;
        for ((b, cold), warm) in boxes.iter().zip(&cold).zip(&warm) {
            assert!(
                warm.lo >= cold.lo - 1e-6 && warm.hi <= cold.hi + 1e-6,
                "{value} {storage}: {warm:?} wider than {cold:?}"
            );
            tighter += usize::from(warm.hi < cold.hi - 1e-3);
            for _ in 0..32 {
                let v = field.value(rng.point_in(b.min, b.max));
                assert!(warm.lo <= v && v <= warm.hi, "{value} {storage}: {v} outside {warm:?} over {b:?}");
            }
        }
        assert!(tighter > 40, "{value} {storage}: only {tighter} of 400 ranges got tighter");
    }
}

/// A cache bounds its value over a box by exactly the samples its value
/// filter reads there. Just outside a ball, where the lattice plane one cell
/// in is inside it but no point of the box reads that plane, the bound is
/// zero, cold (the subtree's range over the samples read) and warm (their
/// range once held); a box reaching one cell farther in reads the plane.
#[test]
fn intervals_bound_only_the_samples_the_value_filter_reads() {
    let pool = SamplePool::new(None);
    let grid = CacheGrid::new(CacheSpec::new(16), Aabb::new(Vec3A::splat(-1.0), Vec3A::splat(1.0)), &pool);
    let c = grid.cell();
    assert_eq!(c, 0.125);
    // Wyvill's kernel of a point at the origin with radius 0.95, and its
    // exact range over a box (it falls with the distance to the origin).
    let field = |p: Vec3A| (1.0 - p.length_squared() / (0.95 * 0.95)).max(0.0).powi(3);
    let range = |b: &Aabb| {
        let nearest = Vec3A::ZERO.clamp(b.min, b.max);
        let farthest = Vec3A::select(b.min.abs().cmpgt(b.max.abs()), b.min, b.max);
        Interval::new(field(farthest), field(nearest))
    };
    // The lattice plane x = 1 is outside the ball, x = 0.875 inside.
    let (outside, inside) = (8.0 * c, 7.0 * c);
    assert!(field(Vec3A::new(outside, 0.0, 0.0)) == 0.0 && field(Vec3A::new(inside, 0.0, 0.0)) > 0.0);
    let b =
        Aabb::new(Vec3A::new(outside + 0.1 * c, -0.4 * c, -0.4 * c), Vec3A::new(outside + 0.9 * c, 0.4 * c, 0.4 * c));
    assert_eq!(grid.interval(&b, &pool, &range).hi, 0.0, "cold");
    let mut rng = Rng(31);
    for _ in 0..200 {
        assert_eq!(grid.value(rng.point_in(b.min, b.max), &pool, &field), 0.0);
    }
    assert_eq!(grid.interval(&b, &pool, &range).hi, 0.0, "warm");
    let wider = Aabb::new(b.min - Vec3A::new(c, 0.0, 0.0), b.max);
    assert!(grid.interval(&wider, &pool, &range).hi > 0.0);
}

/// Along any segment, the cached value's slope never drops below the floor
/// the caches give for it (both value filters, both storages, under a
/// rotating and stretching transform); and the floor is tight enough to show
/// the field rising along many of the segments along which it rises.
#[test]
fn slope_floors_bound_the_cached_values_derivative_along_segments() {
    for (value, storage) in [("Trilinear", "F32"), ("Triquadratic", "F16")] {
        let scene = Scene::parse(
            &format!(
                r#"Scene(
    camera: Camera(eye: (0.0, 0.5, 5.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
    size: (64, 48),
    model: Blend([
        Transform(translate: (0.2, 0.0, 0.0), rotate: (20.0, 30.0, 10.0), scale: (1.0, 1.5, 0.8),
            child: Cache(res: 24, value: {value}, storage: {storage}, child: Blend([
                Point(center: (-0.5, 0.0, 0.0), radius: 1.2),
                Point(center: (0.6, 0.1, 0.0), radius: 1.0),
            ]))),
        Cache(res: 16, child: Point(center: (0.0, 0.8, 0.3), radius: 0.6)),
    ]),
)"#
            ),
            "floors",
        )
        .expect("test scene parses");
        let field = ModelField::new(&scene.model, EvalMode::Cached);
        let exact = ModelField::new(&scene.model, EvalMode::Indexed);
        let mut rng = Rng(31);
        let (mut rising, mut shown) = (0, 0);
        for p in random_points(&scene.model, 2000, 32) {
            let q = p + rng.point_in(Vec3A::splat(-0.15), Vec3A::splat(0.15));
            assert_eq!(exact.slope_floor(p, q), None, "exact fields take curvature bounds instead");
            let floor = field.slope_floor(p, q).expect("a sum of caches has a floor");
            let length = (q - p).length();
            let values: Vec<f32> = (0..=64).map(|k| field.value(p.lerp(q, k as f32 / 64.0))).collect();
            let h = length / 64.0;
            for (k, pair) in values.windows(2).enumerate() {
                let slope = (pair[1] - pair[0]) / h;
                assert!(slope >= floor - 4e-6 / h, "{value} {storage}: slope {slope} < floor {floor} at step {k}");
            }
            if values.windows(2).all(|w| w[1] > w[0] + 1e-4) {
                rising += 1;
                shown += usize::from(floor > 0.0);
            }
        }
        // The quadratic filter's floor takes the differences of a 4×4×4 block: looser.
        let share = if value == "Trilinear" { 2 } else { 5 };
        assert!(
            rising > 30 && shown * share > rising,
            "{value} {storage}: {shown} of {rising} rising segments shown rising"
        );
    }
}

#[test]
fn invalidation_after_an_edit_matches_a_fresh_cache_and_spares_the_rest() {
    let mut scene = default_scene(32);
    let (cache, points) = warm_cache(&scene.model, 5000, 5);
    let segments = short_segments(&points);
    for s in &segments {
        scene.model.node_lipschitz(cache, s, EvalMode::Cached);
    }
    let before = samples_evaluated(&scene.model);
    let id = probe(&scene.model);
    let change = scene.model.set_primitive(id, moved_probe()).unwrap();
    assert!(change.samples_cleared > 0);
    // A fresh model with the probe already moved.
    let mut fresh = default_scene(32).model;
    fresh.set_primitive(probe(&fresh), moved_probe()).unwrap();
    for &p in &points {
        let (a, b) = (scene.model.node_value(cache, p, EvalMode::Cached), fresh.node_value(cache, p, EvalMode::Cached));
        assert_eq!(a, b, "at {p}");
    }
    // The slope bounds kept before the edit were cleared where samples were.
    for s in &segments {
        let (a, b) =
            (scene.model.node_lipschitz(cache, s, EvalMode::Cached), fresh.node_lipschitz(cache, s, EvalMode::Cached));
        assert_eq!(a, b, "over {s:?}");
    }
    let refilled = samples_evaluated(&scene.model) - before;
    assert!(
        refilled <= change.samples_cleared,
        "{refilled} samples re-evaluated, only {} cleared",
        change.samples_cleared
    );
    assert!(refilled > 0);
}

/// Two small balls far apart under one cache, the second named to move.
fn far_apart_scene() -> Scene {
    Scene::parse(
        r#"Scene(
    camera: Camera(eye: (0.0, 0.5, 5.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
    size: (64, 48),
    model: Cache(res: 64, child: Blend([
        Point(center: (-2.0, 0.0, 0.0), radius: 0.4),
        Named("probe", Point(center: (2.0, 0.0, 0.0), radius: 0.4)),
    ])),
)"#,
        "far apart",
    )
    .expect("test scene parses")
}

/// Points of the slab |x| ≤ 1 between the two balls, a lattice block or
/// more from either support.
fn points_between(n: usize, seed: u64) -> Vec<Vec3A> {
    let mut rng = Rng(seed);
    (0..n).map(|_| rng.point_in(Vec3A::new(-1.0, -0.4, -0.4), Vec3A::new(1.0, 0.4, 0.4))).collect()
}

#[test]
fn a_cache_stores_and_evaluates_nothing_where_its_subtree_is_zero() {
    let mut scene = far_apart_scene();
    let (cache, _, _) = cache_node(&scene.model);
    let between = points_between(2000, 17);
    for &p in &between {
        assert_eq!(scene.model.node_value(cache, p, EvalMode::Cached), 0.0, "at {p}");
        assert_eq!(scene.model.node_gradient(cache, p, EvalMode::Cached), Vec3A::ZERO, "at {p}");
    }
    let stats = |m: &Model| m.cache_stats()[0].2;
    assert_eq!(stats(&scene.model).samples_evaluated, 0, "no sample evaluated between the balls");
    assert_eq!(stats(&scene.model).blocks, 0, "no block stored between the balls");
    // Near a ball the samples are read and evaluated as before.
    let near = Vec3A::new(-2.0, 0.1, 0.0);
    assert!(
        (scene.model.node_value(cache, near, EvalMode::Cached)
            - scene.model.node_value(cache, near, EvalMode::Indexed))
        .abs()
            < 0.05
    );
    assert!(stats(&scene.model).samples_evaluated > 0);
    // The second ball moved between them: the cache forgets that the
    // region was zero, and answers as a fresh cache of the moved model.
    let id = probe(&scene.model);
    let centre = Primitive::new(Skeleton::Point { center: Vec3A::ZERO }, 0.4, 1.0, Default::default());
    scene.model.set_primitive(id, centre).unwrap();
    let mut fresh = far_apart_scene().model;
    fresh.set_primitive(probe(&fresh), centre).unwrap();
    let mut inside = 0;
    for &p in &between {
        let value = scene.model.node_value(cache, p, EvalMode::Cached);
        assert_eq!(value, fresh.node_value(cache, p, EvalMode::Cached), "at {p}");
        inside += usize::from(value > 0.5);
    }
    assert!(inside > 0, "the moved ball shows between the others");
}

/// A cache over a cache over a named ball, beside a ball.
fn nested_caches_scene() -> Scene {
    Scene::parse(
        r#"Scene(
    camera: Camera(eye: (0.0, 0.5, 5.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
    size: (64, 48),
    model: Blend([
        Point(center: (0.0, 0.0, 0.0), radius: 0.5),
        Cache(res: 16, child: Cache(res: 32, child: Named("probe", Point(center: (-0.184, 1.629, 1.648), radius: 0.481)))),
    ]),
)"#,
        "nested caches",
    )
    .expect("test scene parses")
}

#[test]
fn an_edit_under_nested_caches_clears_the_outer_one_where_the_inner_one_changed() {
    let squash = |by: Vec3| blobtrace::field::Edit::Scale { node: "probe".into(), by };
    let edits = [squash(Vec3::new(1.2, 0.82, 0.97)), squash(Vec3::new(0.74, 0.98, 1.28))];
    let mut scene = nested_caches_scene();
    let root = scene.model.root();
    let points = random_points(&scene.model, 20_000, 23);
    let mut fresh = nested_caches_scene().model;
    let cells = |m: &Model| m.cache_stats().iter().map(|(_, _, s)| s.cell).collect::<Vec<_>>();
    for edit in &edits {
        for &p in &points {
            scene.model.node_value(root, p, EvalMode::Cached);
            scene.model.node_gradient(root, p, EvalMode::Cached);
        }
        scene.model.apply(edit).unwrap();
        fresh.apply(edit).unwrap();
    }
    assert_eq!(cells(&scene.model), cells(&fresh), "the lattices were kept, not laid anew");
    // The inner cache's reconstruction changed a filter's reach beyond the
    // ball's boxes, and the outer cache samples that reconstruction.
    for &p in &points {
        let (a, b) = (scene.model.node_value(root, p, EvalMode::Cached), fresh.node_value(root, p, EvalMode::Cached));
        assert_eq!(a, b, "at {p}");
        let (a, b) =
            (scene.model.node_gradient(root, p, EvalMode::Cached), fresh.node_gradient(root, p, EvalMode::Cached));
        assert_eq!(a, b, "gradient at {p}");
    }
}

/// Caches nested, under transforms, beside and inside carvings, with named
/// parts at every level to edit.
const CACHES_EVERYWHERE: &str = r#"Scene(
    camera: Camera(eye: (0.0, 1.0, 7.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
    size: (64, 48),
    model: Blend([
        Named("outer", Cache(res: 16, child: Blend([
            Point(center: (0.0, 0.0, 0.0), radius: 1.0),
            Named("inner", Cache(res: 32, child: Blend([
                Named("a", Point(center: (0.6, 0.4, 0.2), radius: 0.5)),
                Named("b", Segment(a: (-0.5, 0.2, 0.0), b: (0.2, 0.9, 0.3), radius: 0.4)),
            ]))),
        ]))),
        Named("carved", Difference(
            Cache(res: 24, child: Named("c", Point(center: (-1.5, -0.5, 0.0), radius: 0.9))),
            Named("d", Transform(translate: (0.2, 0.1, 0.0), rotate: (10.0, 20.0, 0.0), scale: (1.0, 0.8, 1.2),
                child: Cache(res: 16, child: Point(center: (-1.4, -0.3, 0.4), radius: 0.5)))),
        )),
        Named("ring", Cache(res: 24, child: Named("e", Circle(center: (1.5, -0.5, 0.0), normal: (0.3, 1.0, 0.2), ring: 0.6, radius: 0.3)))),
    ]),
)"#;

#[test]
fn warm_caches_after_random_edits_equal_fresh_ones() {
    let targets = [
        ("outer", false),
        ("inner", false),
        ("a", true),
        ("b", true),
        ("carved", false),
        ("c", true),
        ("d", false),
        ("ring", false),
        ("e", true),
    ];
    let cells = |m: &Model| m.cache_stats().iter().map(|(_, _, s)| s.cell).collect::<Vec<_>>();
    let mut rng = Rng(31);
    let (mut compared, mut relaid) = (0, 0);
    for _ in 0..3 {
        let mut scene = Scene::parse(CACHES_EVERYWHERE, "caches everywhere").unwrap();
        let mut edits = vec![];
        for _ in 0..6 {
            let points = random_points(&scene.model, 4000, u64::from(rng.next_f32().to_bits()));
            let root = scene.model.root();
            for &p in &points {
                scene.model.node_value(root, p, EvalMode::Cached);
                scene.model.node_gradient(root, p, EvalMode::Cached);
            }
            let (name, primitive) = targets[(rng.next_f32() * targets.len() as f32) as usize % targets.len()];
            let edit = random_edit(&mut rng, name, primitive);
            scene.model.apply(&edit).unwrap();
            edits.push(edit);
            let mut fresh = Scene::parse(CACHES_EVERYWHERE, "caches everywhere").unwrap().model;
            for e in &edits {
                fresh.apply(e).unwrap();
            }
            if cells(&scene.model) != cells(&fresh) {
                // The resize rule kept a lattice a fresh cache lays otherwise.
                relaid += 1;
                continue;
            }
            let root = scene.model.root();
            for &p in &points {
                let warm = (
                    scene.model.node_value(root, p, EvalMode::Cached),
                    scene.model.node_gradient(root, p, EvalMode::Cached),
                );
                assert_eq!(
                    warm,
                    (fresh.node_value(root, p, EvalMode::Cached), fresh.node_gradient(root, p, EvalMode::Cached)),
                    "after {edits:?}, at {p}"
                );
            }
            compared += 1;
        }
    }
    assert!(compared >= 12, "{compared} edits compared, {relaid} relaid");
}

#[test]
fn a_clone_has_cold_caches_on_the_same_lattices() {
    let mut scene = default_scene(32);
    let (cache, points) = warm_cache(&scene.model, 3000, 41);
    // The probe moved outward: the bounds grow, the cell size is kept.
    let outward = Primitive::new(Skeleton::Point { center: Vec3A::new(1.8, 0.3, 0.3) }, 0.5, 1.0, Default::default());
    scene.model.set_primitive(probe(&scene.model), outward).unwrap();
    let cell = |m: &Model| m.cache_stats()[0].2.cell;
    let mut relaid = scene.model.clone();
    relaid.set_cache_budget(None);
    assert_ne!(cell(&relaid), cell(&scene.model), "a lattice laid afresh differs from the kept one");
    let clone = scene.model.clone();
    assert_eq!(cell(&clone), cell(&scene.model));
    assert_eq!(samples_evaluated(&clone), 0, "the clone's caches are cold");
    for &p in &points {
        let (warm, cold) =
            (scene.model.node_value(cache, p, EvalMode::Cached), clone.node_value(cache, p, EvalMode::Cached));
        assert_eq!(warm.to_bits(), cold.to_bits(), "at {p}");
    }
    assert!(samples_evaluated(&clone) > 0);
}

#[test]
fn moving_a_cached_subtree_rigidly_costs_no_samples() {
    let mut scene = Scene::parse(
        r#"Scene(
    camera: Camera(eye: (0.0, 0.5, 5.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
    size: (64, 48),
    model: Blend([
        Point(center: (2.0, 0.0, 0.0), radius: 1.0),
        Named("part", Transform(translate: (0.0, 0.0, 0.0), child: Cache(res: 32, child: Blend([
            Point(center: (-0.5, 0.0, 0.0), radius: 1.2), Point(center: (0.6, 0.1, 0.0), radius: 1.0)])))),
    ]),
)"#,
        "rigid",
    )
    .unwrap();
    let named = scene.model.find("part").unwrap();
    let NodeKind::Named { child: transform, .. } = scene.model.node(named).kind else { unreachable!() };
    let local_points = random_points(&scene.model, 3000, 9);
    let field = ModelField::new(&scene.model, EvalMode::Cached);
    let before: Vec<f32> = local_points.iter().map(|&p| field.value(p)).collect();
    let filled = samples_evaluated(&scene.model);
    let placement = Placement::new(Vec3::new(0.3, -0.2, 0.5), Vec3::new(0.0, 30.0, 10.0), Vec3::ONE).unwrap();
    scene.model.set_placement(transform, placement).unwrap();
    // The same local points, seen through the new placement: all samples are already there.
    let field = ModelField::new(&scene.model, EvalMode::Cached);
    let other = Primitive::new(Skeleton::Point { center: Vec3A::new(2.0, 0.0, 0.0) }, 1.0, 1.0, Default::default());
    for (&p, &v) in local_points.iter().zip(&before) {
        let world = placement.to_world.transform_point3a(p);
        let moved = field.value(world) - other.value(world);
        let unmoved = v - other.value(p);
        assert!((moved - unmoved).abs() < 1e-5, "at {p}: {moved} vs {unmoved}");
    }
    assert_eq!(samples_evaluated(&scene.model), filled, "a rigid move evaluated new samples");
}

#[test]
fn the_resize_rule_fires_at_the_thresholds_and_not_between() {
    let pool = SamplePool::default();
    let unit = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
    let scaled = |s: f32| Aabb::new(Vec3A::ZERO, Vec3A::splat(s));
    for (factor, expected) in
        [(1.9, Refit::Kept), (2.1, Refit::Rebuilt), (0.55, Refit::Kept), (0.45, Refit::Rebuilt), (1.0, Refit::Kept)]
    {
        let mut grid = CacheGrid::new(CacheSpec::new(64), unit, &pool);
        assert_eq!(grid.fit(scaled(factor), &pool), expected, "bounds scaled by {factor}");
        let c = grid.cell();
        let wanted = if expected == Refit::Rebuilt { factor / 64.0 } else { 1.0 / 64.0 };
        assert!((c - wanted).abs() < 1e-6, "cell {c} after scaling by {factor}");
    }
}

#[test]
fn a_subtree_moved_far_within_its_cache_lays_the_cache_anew_instead_of_stretching_it() {
    let pool = SamplePool::default();
    let unit = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
    let mut grid = CacheGrid::new(CacheSpec::new(64), unit, &pool);
    let moved = |by: f32| Aabb::new(unit.min + by, unit.max + by);
    // Near: the table grows over both places and the samples stay.
    assert_eq!(grid.fit(moved(0.5), &pool), Refit::Kept);
    // Far (a million cells along each axis): a table over both would hold 10^18 blocks.
    assert_eq!(grid.fit(moved(1.6e4), &pool), Refit::Rebuilt);
    assert!(grid.stats(&pool).grid_points < 100 * 100 * 100, "{:?}", grid.stats(&pool));
}

#[test]
fn a_cache_over_an_empty_subtree_takes_edits_inside_it() {
    // An intersection of two points apart is empty: its cache holds no table.
    let mut scene = Scene::parse(
        r#"Scene(
    camera: Camera(eye: (0.0, 0.0, 6.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
    size: (16, 12),
    model: Blend([
        Point(center: (0.0, 0.0, 0.0), radius: 1.0),
        Cache(res: 16, child: Intersection([Point(center: (-3.0, 0.0, 0.0), radius: 0.5), Named("far", Point(center: (0.5, 0.5, 0.5), radius: 0.5))])),
    ]),
)"#,
        "empty-cache",
    )
    .unwrap();
    let change =
        scene.model.apply(&blobtrace::field::Edit::Translate { node: "far".into(), by: Vec3::new(0.1, 0.0, 0.0) });
    assert_eq!(change.unwrap().samples_cleared, 0);
    let frame = render_cached(&scene, 1, (16, 12));
    assert!(frame.alpha.iter().any(|&a| a > 0.0), "the point outside the cache still shows");
}

fn render_cached(scene: &Scene, threads: usize, size: (u32, u32)) -> blobtrace::frame::Frame {
    let field = ModelField::new(&scene.model, EvalMode::Cached);
    let s = scene.render_settings(Size(size.0, size.1));
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    pool.install(|| render(&field, &s, &|_| {}).0)
}

#[test]
fn cached_renders_are_identical_for_any_thread_count_cold_or_warm() {
    let medusa = bundled("medusa.ron");
    let one_cold = render_cached(&medusa, 1, (80, 60));
    let one_warm = render_cached(&medusa, 1, (80, 60));
    let fresh = bundled("medusa.ron");
    let many_cold = render_cached(&fresh, 4, (80, 60));
    let many_warm = render_cached(&fresh, 4, (80, 60));
    assert!(one_cold.hits() > 200, "{} hits", one_cold.hits());
    assert_eq!(one_cold, one_warm);
    assert_eq!(one_cold, many_cold);
    assert_eq!(one_cold, many_warm);
}

#[test]
fn a_small_budget_stays_under_it_and_changes_nothing() {
    let unbounded = render_cached(&bundled("medusa.ron"), 2, (96, 72));
    let mut tight = bundled("medusa.ron");
    let budget = 256 * blobtrace::cache::SLOT_BYTES;
    tight.model.set_cache_budget(Some(budget));
    let bounded = render_cached(&tight, 2, (96, 72));
    assert_eq!(bounded, unbounded);
    assert!(tight.model.pool().bytes() <= budget, "{} bytes held", tight.model.pool().bytes());
    assert!(tight.model.pool().evictions() > 0, "the budget never bit");
}

#[test]
fn two_byte_storage_stays_close_and_halves_the_memory() {
    let full = default_scene(48);
    let half = cached_scene(48, "Trilinear", "Triquadratic", "F16");
    let points = random_points(&full.model, 4000, 13);
    let (mut worst, mut scale) = (0.0f32, 0.0f32);
    for &p in &points {
        let a = ModelField::new(&full.model, EvalMode::Cached).value(p);
        let b = ModelField::new(&half.model, EvalMode::Cached).value(p);
        worst = worst.max((a - b).abs());
        scale = scale.max(a.abs());
    }
    assert!(worst <= scale * 1e-3 + 1e-6, "F16 error {worst} for values up to {scale}");
    let held = |m: &Model| m.cache_stats()[0].2;
    let (f32s, f16s) = (held(&full.model), held(&half.model));
    let per_sample = |s: blobtrace::cache::CacheStats| s.bytes as f64 / s.samples_held as f64;
    assert!(per_sample(f16s) < 0.75 * per_sample(f32s), "{f16s:?} vs {f32s:?}");
    assert_eq!(Storage::F16.round_trip(0.5), 0.5);
    assert_eq!(Filter::default(), Filter::Trilinear);
}

#[test]
fn cached_tracing_misses_no_crossing_of_the_cached_field() {
    let scene = Scene::parse(
        r#"Scene(
    camera: Camera(eye: (0.3, 0.4, 3.0), target: (0.0, 0.0, 0.0), fov_y: 45.0),
    size: (40, 40),
    model: Cache(res: 48, child: Blend([
        Segment(a: (-1.0, -0.8, 0.0), b: (1.0, 0.9, 0.1), radius: 0.12),
        Circle(center: (0.0, 0.0, 0.0), normal: (0.2, 0.3, 1.0), ring: 0.8, radius: 0.1),
        Point(center: (0.4, 0.4, 0.2), radius: 1.0, weight: 0.45),
    ])),
)"#,
        "thin-cached",
    )
    .unwrap();
    let field = ModelField::new(&scene.model, EvalMode::Cached);
    let (compared, hits) = assert_traces_like_brute_force(&field, &scene.camera, (40, 40), 2e-3);
    assert!(compared > 1000 && hits > 100, "compared {compared}, hits {hits}");
}
