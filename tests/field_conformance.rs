//! One conformance suite for every evaluator and node type: gradients against
//! finite differences, interval and Lipschitz bounds against samples, and
//! indexed against naive evaluation.

mod common;

use blobtrace::field::{EvalMode, Field, Model, ModelField, NodeId, NodeKind, Region};
use blobtrace::geom::Aabb;
use blobtrace::scene::Scene;
use common::{EVERY_NODE, Rng, bundled};
use glam::Vec3A;
use proptest::prelude::*;
use std::sync::OnceLock;

fn every_node() -> &'static Scene {
    static SCENE: OnceLock<Scene> = OnceLock::new();
    SCENE.get_or_init(|| Scene::parse(EVERY_NODE, "every-node").expect("test scene parses"))
}

fn medusa() -> &'static Scene {
    static SCENE: OnceLock<Scene> = OnceLock::new();
    SCENE.get_or_init(|| bundled("medusa.ron"))
}

/// Negatively weighted children under every operator: an intersection and a
/// union reach as far as their negative children do, a difference and a
/// Ricci blend clamp them away.
fn signed() -> &'static Scene {
    static SCENE: OnceLock<Scene> = OnceLock::new();
    SCENE.get_or_init(|| Scene::parse(SIGNED, "signed").expect("signed scene parses"))
}

const SIGNED: &str = r#"Scene(
    camera: Camera(eye: (0.0, 1.0, 6.0), target: (0.0, 0.0, 0.0), fov_y: 45.0),
    size: (32, 24),
    model: Blend([
        Intersection([
            Cache(res: 24, child: Point(center: (-0.1, -0.46, 0.98), radius: 1.03, weight: 0.76)),
            Circle(center: (-0.33, -0.97, -0.28), normal: (-0.97, -0.55, 0.15), ring: 0.56, radius: 0.73, weight: -0.82),
        ]),
        Union([Point(center: (1.2, 0.5, 0.0), radius: 0.8, weight: -0.6), Segment(a: (1.0, 0.2, 0.0), b: (1.8, 0.9, 0.3), radius: 0.5, weight: -0.9)]),
        Difference(Point(center: (-1.2, 0.8, 0.0), radius: 1.0), Point(center: (-1.0, 1.2, 0.3), radius: 0.6, weight: -1.0)),
        Ricci(n: 2.0, children: [Point(center: (0.0, 1.5, 0.0), radius: 0.7, weight: -0.5), Point(center: (0.3, 1.5, 0.0), radius: 0.7)]),
        Point(center: (0.5, -1.1, -0.3), radius: 1.04, weight: 1.04),
    ]),
)"#;

/// Nine rotated rows of ten points: an indexed blend whose leaves are
/// transforms of indexed blends, so bounds over it nest one index in another.
fn nested() -> &'static Scene {
    static SCENE: OnceLock<Scene> = OnceLock::new();
    SCENE.get_or_init(|| {
        let rows: String = (0..9)
            .map(|k| {
                let points: String = (0..10)
                    .map(|j| format!("Point(center: ({:.2}, {:.2}, 0.0), radius: 0.5),", 0.2 * j as f32, 0.1 * k as f32))
                    .collect();
                format!(
                    "Transform(translate: ({:.1}, 0.0, {:.1}), rotate: (10.0, 20.0, 30.0), child: Blend([{points}])),",
                    0.3 * k as f32,
                    0.2 * k as f32
                )
            })
            .collect();
        let source = format!(
            "Scene(camera: Camera(eye: (0.0, 1.0, 7.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (8, 8), model: Blend([{rows}]))"
        );
        Scene::parse(&source, "nested").expect("nested scene parses")
    })
}

/// Central difference of node `id` at `p` with step `h`.
fn central_difference(m: &Model, id: NodeId, p: Vec3A, h: f32, mode: EvalMode) -> Vec3A {
    let d = |axis: Vec3A| (m.node_value(id, p + axis * h, mode) - m.node_value(id, p - axis * h, mode)) / (2.0 * h);
    Vec3A::new(d(Vec3A::X), d(Vec3A::Y), d(Vec3A::Z))
}

#[test]
fn gradients_match_central_differences_for_every_node_type() {
    let m = &every_node().model;
    let mut rng = Rng(7);
    let mut checked_types = std::collections::BTreeSet::new();
    for id in 0..m.nodes().len() as NodeId {
        let node = m.node(id);
        let b = node.bounds;
        let mut compared = 0;
        for _ in 0..400 {
            let p = rng.point_in(b.min, b.max);
            // Cached gradients come from their own filter, not the value's
            // derivative: tests/cache.rs checks them against their reconstruction.
            for mode in [EvalMode::Indexed, EvalMode::Naive] {
                let fd1 = central_difference(m, id, p, 1e-3, mode);
                let fd2 = central_difference(m, id, p, 5e-4, mode);
                // Where the two step sizes disagree the field has a kink (min/max,
                // support boundary): the derivative is not defined there.
                if (fd1 - fd2).length() > 1e-2 * (1.0 + fd1.length()) {
                    continue;
                }
                let g = m.node_gradient(id, p, mode);
                let err = (g - fd1).length();
                assert!(
                    err <= 3e-3 + 1e-2 * g.length(),
                    "{} node {id} at {p}: gradient {g} vs finite difference {fd1} ({mode:?}), error {err}",
                    node.kind.type_name()
                );
                compared += 1;
            }
        }
        assert!(compared > 200, "{} node {id}: only {compared} smooth samples", node.kind.type_name());
        checked_types.insert(node.kind.type_name());
    }
    for t in [
        "Point",
        "Segment",
        "Circle",
        "Blend",
        "Union",
        "Intersection",
        "Difference",
        "Ricci",
        "Transform",
        "Twist",
        "Taper",
        "Bend",
        "Named",
        "Cache",
    ] {
        assert!(checked_types.contains(t), "no {t} node was checked");
    }
}

/// Every operator's value is its definition over its children's values, at
/// any point of the model: the box a node rejects points outside of must hold
/// all of its support, a negative one included.
#[test]
fn operators_equal_their_definitions_everywhere() {
    for scene in [every_node(), signed()] {
        let m = &scene.model;
        let (b, t) = (m.bounds(), m.threshold());
        let mut rng = Rng(23);
        let mut negative = 0;
        for _ in 0..20_000 {
            let p = rng.point_in(b.min, b.max);
            for id in 0..m.nodes().len() as NodeId {
                let value = |c: NodeId| m.node_value(c, p, EvalMode::Naive);
                let expected = match &m.node(id).kind {
                    NodeKind::Blend { children, .. } => children.iter().map(|&c| value(c)).sum(),
                    NodeKind::Union(cs) => cs.iter().map(|&c| value(c)).fold(f32::MIN, f32::max),
                    NodeKind::Intersection(cs) => cs.iter().map(|&c| value(c)).fold(f32::MAX, f32::min),
                    NodeKind::Difference(a, c) => value(*a).min(2.0 * t - value(*c)).max(0.0),
                    _ => continue,
                };
                let got = value(id);
                negative += usize::from(got < 0.0);
                assert!((got - expected).abs() <= 1e-5, "node {id} at {p}: {got}, by definition {expected}");
            }
        }
        if std::ptr::eq(scene, signed()) {
            assert!(negative > 1000, "too few samples where an operator is negative: {negative}");
        }
    }
}

#[test]
fn indexed_and_naive_evaluation_agree() {
    for scene in [medusa(), every_node()] {
        let m = &scene.model;
        let (fast, slow) = (ModelField::new(m, EvalMode::Indexed), ModelField::new(m, EvalMode::Naive));
        let b = m.bounds();
        let mut rng = Rng(11);
        let mut inside_support = 0;
        for _ in 0..20_000 {
            let p = rng.point_in(b.min, b.max);
            let (a, n) = (fast.value(p), slow.value(p));
            assert!((a - n).abs() <= 1e-6, "value at {p}: indexed {a} vs naive {n}");
            let (ga, gn) = (fast.gradient(p), slow.gradient(p));
            assert!((ga - gn).length() <= 1e-4 * (1.0 + gn.length()), "gradient at {p}: {ga} vs {gn}");
            inside_support += usize::from(n > 0.0);
        }
        assert!(inside_support > 500, "too few samples inside the supports: {inside_support}");
    }
}

/// Calls `check` at 5 000 random points of Medusa, every node kind and
/// nested blends, in each evaluation mode; `check` says whether the point
/// was telling (inside a support, say), and at least a hundred must be.
fn at_random_points_in_every_mode(seed: u64, mut check: impl FnMut(&ModelField, EvalMode, glam::Vec3A) -> bool) {
    for scene in [medusa(), every_node(), nested()] {
        let m = &scene.model;
        let b = m.bounds();
        let mut rng = Rng(seed);
        for mode in [EvalMode::Indexed, EvalMode::Naive, EvalMode::Cached] {
            let field = ModelField::new(m, mode);
            let telling = (0..5_000).filter(|_| check(&field, mode, rng.point_in(b.min, b.max))).count();
            assert!(telling > 100, "too few telling samples ({mode:?}): {telling}");
        }
    }
}

/// The tracer takes value and gradient together after curvature steps: they
/// must be the very values it would get apart, or steps and hits would move.
#[test]
fn value_and_gradient_together_equal_them_apart_to_the_bit() {
    at_random_points_in_every_mode(17, |field, mode, p| {
        let (v, g) = field.value_and_gradient(p);
        assert_eq!(v.to_bits(), field.value(p).to_bits(), "value at {p} ({mode:?})");
        let apart = field.gradient(p);
        assert_eq!(g.to_array().map(f32::to_bits), apart.to_array().map(f32::to_bits), "gradient at {p} ({mode:?})");
        v > 0.0
    });
}

/// Shading and vertex colouring take the gradient and the colour together:
/// they must be the very values taken apart, or images would change with it.
#[test]
fn gradient_and_color_together_equal_them_apart_to_the_bit() {
    at_random_points_in_every_mode(23, |field, mode, p| {
        let (g, c) = field.gradient_and_color(p);
        let apart = field.gradient(p);
        assert_eq!(g.to_array().map(f32::to_bits), apart.to_array().map(f32::to_bits), "gradient at {p} ({mode:?})");
        assert_eq!(c.to_array().map(f32::to_bits), field.color(p).to_array().map(f32::to_bits), "colour at {p}");
        field.value(p) > 0.0 && c != blobtrace::field::DEFAULT_COLOR
    });
}

#[test]
fn wide_blends_are_indexed() {
    let c = medusa().model.counts();
    assert_eq!(c.primitives, 9490);
    assert_eq!(c.caches, 7);
    assert_eq!(c.indexed_blends, 7, "each Medusa component is one indexed cluster");
    assert_eq!(nested().model.counts().indexed_blends, 10, "the rows and the blend of them");
}

/// On boxes smaller than its cells, an index sums the leaves over the box
/// itself, as naive evaluation does, instead of taking the hull of the larger
/// cells: the empty space it marks is the naive one.
#[test]
fn indexed_intervals_over_small_boxes_are_as_tight_as_naive_ones() {
    let m = &medusa().model;
    let (fast, slow) = (ModelField::new(m, EvalMode::Indexed), ModelField::new(m, EvalMode::Naive));
    let b = m.bounds();
    let side = b.size().max_element() / 64.0;
    let mut rng = Rng(5);
    let mut near_surface = 0;
    for _ in 0..4000 {
        let bx = Aabb::around(rng.point_in(b.min, b.max), 0.5 * side);
        let (indexed, naive) = (fast.interval(&bx), slow.interval(&bx));
        assert!(indexed.hi <= naive.hi * (1.0 + 1e-5) + 1e-6, "over {bx:?}: indexed {indexed:?}, naive {naive:?}");
        near_surface += usize::from(naive.hi > 0.25);
    }
    assert!(near_surface > 100, "too few boxes near the surface: {near_surface}");
}

#[test]
fn a_node_is_zero_over_a_box_exactly_where_its_interval_is_zero() {
    let (mut zero, mut nonzero) = (0, 0);
    for (scene, seed) in [(every_node(), 1), (signed(), 2), (nested(), 3), (medusa(), 4)] {
        let m = &scene.model;
        let mut rng = Rng(seed);
        let ids: Vec<NodeId> =
            (0..m.nodes().len() as NodeId).step_by(m.nodes().len().div_ceil(60)).chain([m.root()]).collect();
        for id in ids {
            let b = m.node(id).bounds.padded(0.2);
            for k in 0..60 {
                let side = b.size().max_element() * [0.01, 0.05, 0.2][k % 3];
                let bx = Aabb::around(rng.point_in(b.min, b.max), side);
                for mode in [EvalMode::Naive, EvalMode::Indexed, EvalMode::Cached] {
                    let is_zero = m.node_interval(id, &bx, mode) == blobtrace::geom::Interval::ZERO;
                    assert_eq!(m.node_is_zero_over(id, &bx, mode), is_zero, "node {id} over {bx:?} ({mode:?})");
                    (zero, nonzero) = (zero + usize::from(is_zero), nonzero + usize::from(!is_zero));
                }
            }
        }
    }
    assert!(zero > 500 && nonzero > 500, "{zero} boxes zero, {nonzero} not");
}

/// A random box or segment inside the scene bounds, from unit-cube parameters.
fn region_from(b: &Aabb, t: [f32; 6], thin: f32) -> (Vec3A, Vec3A) {
    let a = b.min + b.size() * Vec3A::new(t[0], t[1], t[2]);
    let d = b.size() * (Vec3A::new(t[3], t[4], t[5]) - 0.5) * thin;
    (a, a + d)
}

fn check_interval(field: &ModelField, a: Vec3A, c: Vec3A, seed: u64) -> Result<(), TestCaseError> {
    let bx = Aabb::from_points(a, c);
    let range = field.interval(&bx);
    let mut rng = Rng(seed);
    for _ in 0..64 {
        let p = rng.point_in(bx.min, bx.max);
        let v = field.value(p);
        prop_assert!(range.lo - 1e-5 <= v && v <= range.hi + 1e-5, "value {v} at {p} outside {range:?} over {bx:?}");
    }
    Ok(())
}

fn check_lipschitz(field: &ModelField, a: Vec3A, c: Vec3A, seed: u64) -> Result<(), TestCaseError> {
    let l = field.lipschitz(&Region::Segment(a, c));
    let mut rng = Rng(seed);
    for _ in 0..64 {
        let (s, t) = (rng.next_f32(), rng.next_f32());
        let (p, q) = (a.lerp(c, s), a.lerp(c, t));
        let slope_times_dist = l * (p - q).length();
        let dv = (field.value(p) - field.value(q)).abs();
        prop_assert!(dv <= slope_times_dist * 1.001 + 2e-6, "|Δf| {dv} > L|Δx| {slope_times_dist} on {a}..{c}");
    }
    let lb = field.lipschitz(&Region::Box(Aabb::from_points(a, c)));
    let bx = Aabb::from_points(a, c);
    for _ in 0..32 {
        let (p, q) = (rng.point_in(bx.min, bx.max), rng.point_in(bx.min, bx.max));
        let dv = (field.value(p) - field.value(q)).abs();
        prop_assert!(dv <= lb * (p - q).length() * 1.001 + 2e-6, "box bound {lb} violated: {dv}");
    }
    Ok(())
}

/// The bound on the second derivative over a segment and over its box holds
/// for second differences along sampled lines there, and so does the Taylor
/// bound the tracer steps by. Returns whether a finite, positive bound was checked.
fn check_curvature(field: &ModelField, a: Vec3A, c: Vec3A, seed: u64) -> Result<bool, TestCaseError> {
    let mut rng = Rng(seed);
    let bx = Aabb::from_points(a, c);
    let mut checked = false;
    for on_segment in [true, false] {
        let m = field.curvature(&if on_segment { Region::Segment(a, c) } else { Region::Box(bx) });
        if !m.is_finite() {
            continue;
        }
        checked |= m > 0.0;
        for _ in 0..32 {
            let mut sample = || if on_segment { a.lerp(c, rng.next_f32()) } else { rng.point_in(bx.min, bx.max) };
            let (p, q) = (sample(), sample());
            let gp = field.gradient(p);
            let taylor = field.value(p) + gp.dot(q - p) + 0.5 * m.max(0.0) * (q - p).length_squared();
            prop_assert!(field.value(q) <= taylor + 1e-5, "f({q}) above the Taylor bound {taylor} from {p}");
            // A second difference over the chord's middle third stays in the region.
            let (mid, h) = (p.lerp(q, 0.5), (q - p) / 6.0);
            let second = field.value(mid + h) - 2.0 * field.value(mid) + field.value(mid - h);
            prop_assert!(second <= m.max(0.0) * h.length_squared() + 1e-5, "second difference {second} above M = {m}");
        }
    }
    Ok(checked)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn curvature_bounds_dominate_sampled_second_differences(t in prop::array::uniform6(0.0f32..1.0), thin in 0.01f32..0.6, seed in 0u64..1000) {
        for scene in [every_node(), medusa(), nested()] {
            let (a, c) = region_from(&scene.model.bounds(), t, thin);
            for mode in [EvalMode::Indexed, EvalMode::Naive] {
                check_curvature(&ModelField::new(&scene.model, mode), a, c, seed)?;
            }
        }
    }

    #[test]
    fn intervals_contain_sampled_values(t in prop::array::uniform6(0.0f32..1.0), thin in 0.01f32..0.6, seed in 0u64..1000) {
        for scene in [every_node(), medusa(), nested(), signed()] {
            let (a, c) = region_from(&scene.model.bounds(), t, thin);
            for mode in [EvalMode::Indexed, EvalMode::Naive, EvalMode::Cached] {
                check_interval(&ModelField::new(&scene.model, mode), a, c, seed)?;
            }
        }
    }

    #[test]
    fn lipschitz_bounds_dominate_sampled_slopes(t in prop::array::uniform6(0.0f32..1.0), thin in 0.01f32..0.6, seed in 0u64..1000) {
        for scene in [every_node(), medusa(), nested(), signed()] {
            let (a, c) = region_from(&scene.model.bounds(), t, thin);
            for mode in [EvalMode::Indexed, EvalMode::Naive, EvalMode::Cached] {
                check_lipschitz(&ModelField::new(&scene.model, mode), a, c, seed)?;
            }
        }
    }
}

/// How many of 200 short random segments of `scene`, each `step` (scaled by
/// random numbers on the axes marked `random`), have a finite, positive
/// curvature bound that the samples along them respect.
fn finite_curvature_count(scene: &Scene, seed: u64, step: Vec3A, random: [bool; 3]) -> usize {
    let m = &scene.model;
    let mut rng = Rng(seed);
    let b = m.bounds();
    (0..200)
        .filter(|_| {
            let a = rng.point_in(b.min, b.max);
            let scale = random.map(|r| if r { rng.next_f32() } else { 1.0 });
            let d = step * Vec3A::from_array(scale);
            check_curvature(&ModelField::new(m, EvalMode::Indexed), a, a + d, seed).unwrap()
        })
        .count()
}

/// Where an index holds nodes, its curvature bound sums them one by one
/// instead of giving up, as its per-cell bounds (which must hold for caches) do.
#[test]
fn an_index_of_nodes_has_finite_curvature_bounds() {
    let finite = finite_curvature_count(nested(), 8, Vec3A::new(0.1, 0.05, 0.1), [true, false, true]);
    assert!(finite > 20, "only {finite} of 200 short segments had a finite, non-zero bound");
}

#[test]
fn medusa_has_finite_curvature_bounds_where_the_tracer_needs_them() {
    let checked = finite_curvature_count(medusa(), 5, Vec3A::new(0.05, 0.05, 0.025), [true, true, false]);
    assert!(checked > 20, "only {checked} of 200 short segments had a finite, non-zero bound");
}
