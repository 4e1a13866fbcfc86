//! Edits: incremental re-rendering of the dirty rectangles equals a full
//! render bit for bit, the rectangles hold every changed pixel, local
//! re-polygonization equals a full one, and bad edits change nothing.

mod common;

use blobtrace::field::{Edit, EvalMode, Field, ModelField, TracerChoice};
use blobtrace::frame::Frame;

use blobtrace::mesh::{PolygonizeOptions, Polygonizer, skeleton_seeds};
use blobtrace::pipeline::{EditSession, PolygonizeSettings};
use blobtrace::scene::{Scene, Size};
use blobtrace::trace::{PixelRect, changed_space, render, render_model, rerender};
use common::{EVERY_NODE, Rng, assert_same_mesh, bundled, polygonize, random_edit};
use glam::Vec3;

fn changed_pixels(a: &Frame, b: &Frame) -> Vec<(u32, u32)> {
    (0..a.len())
        .filter(|&i| a.color[i] != b.color[i] || a.depth[i] != b.depth[i] || a.normal[i] != b.normal[i])
        .map(|i| (i as u32 % a.width, i as u32 / a.width))
        .collect()
}

#[test]
fn incremental_renders_after_random_edits_equal_full_renders() {
    // Each scene with the names to edit, and whether the name holds a primitive.
    type Names = &'static [(&'static str, bool)];
    let cases: [(&str, Scene, Names); 3] = [
        ("every", Scene::parse(EVERY_NODE, "every").unwrap(), &[("arm", false)]),
        ("hair_point", bundled("hair_point.ron"), &[("probe", true), ("hair", false)]),
        ("medusa", bundled("medusa.ron"), &[("head", false), ("left_hand", false)]),
    ];
    let mut rng = Rng(2026);
    let mut some_small = false;
    for (label, mut scene, names) in cases {
        for mode in [EvalMode::Indexed, EvalMode::Cached] {
            // The session re-renders as `blobtrace edit` does: the empty space
            // over the changed boxes forgotten, the rays through them re-traced.
            let polygonize = PolygonizeSettings { res: 16, ..Default::default() };
            let mut session = EditSession::new(scene.clone(), mode, Size(64, 48), &polygonize).unwrap();
            for step in 0..4 {
                let (name, primitive) = names[step % names.len()];
                let edit = random_edit(&mut rng, name, primitive);
                let before = session.field_frame().clone();
                let rects = session.apply(std::slice::from_ref(&edit)).unwrap().dirty;
                let (frame, model, settings) = (session.field_frame(), &session.scene().model, session.settings());
                // The reference skips nothing.
                let full = render(&ModelField::new(model, mode), settings, &|_| {}).0;
                if !frame.same_image(&full) {
                    let outside: Vec<(u32, u32)> = changed_pixels(frame, &full);
                    let extras = frame.extra != full.extra;
                    panic!(
                        "{label} {mode:?} step {step} {edit:?}: {} pixels differ (first {:?}), extras differ: {extras}, rects {rects:?}",
                        outside.len(),
                        outside.first()
                    );
                }
                for (x, y) in changed_pixels(&before, &full) {
                    assert!(
                        rects.iter().any(|r| r.contains(x, y)),
                        "{label} {mode:?} {edit:?}: pixel {x},{y} changed outside"
                    );
                }
                let area: u64 = rects.iter().map(PixelRect::area).sum();
                some_small |= area < 64 * 48 / 2;
            }
            scene = session.scene().clone();
        }
    }
    assert!(some_small, "a small edit re-traces less than half the screen");
}

#[test]
fn moving_a_cached_component_costs_no_samples_and_repolygonizes_locally() {
    let mut scene = bundled("medusa.ron");
    let (mut local, _) = polygonize(&scene.model, EvalMode::Cached, 40, PolygonizeOptions::default());
    let change = scene.model.apply(&Edit::Translate { node: "head".into(), by: Vec3::new(0.0, -0.3, 0.1) }).unwrap();
    assert_eq!(change.samples_cleared, 0);
    let field = ModelField::new(&scene.model, EvalMode::Cached);
    let seeds = skeleton_seeds(&scene.model, scene.model.root());
    local.repolygonize(&field, &scene.model.change_region(&change, true), &seeds);
    let mut full = Polygonizer::new(local.lattice(), PolygonizeOptions::default());
    full.polygonize(&field, &seeds);
    assert_same_mesh(&local.mesh(), &full.mesh(), "the hair probe's update");
}

#[test]
fn bad_edits_are_refused_and_change_nothing() {
    let mut scene = bundled("hair_point.ron");
    let settings = scene.render_settings(Size(48, 36));
    let before = render(&ModelField::new(&scene.model, EvalMode::Cached), &settings, &|_| {}).0;
    let bad = [
        (Edit::Translate { node: "nobody".into(), by: Vec3::X }, "no node is named"),
        (Edit::Translate { node: "probe".into(), by: Vec3::new(f32::NAN, 0.0, 0.0) }, "not finite"),
        (Edit::Scale { node: "hair".into(), by: Vec3::new(1.0, 0.0, 1.0) }, "non-zero"),
        (Edit::Radius { node: "probe".into(), radius: -1.0 }, "positive"),
        (Edit::Radius { node: "hair".into(), radius: 1.0 }, "not a Primitive"),
    ];
    for (edit, words) in bad {
        let err = scene.model.apply(&edit).expect_err("refused").to_string();
        assert!(err.contains(words), "{edit:?}: {err}");
    }
    let after = render(&ModelField::new(&scene.model, EvalMode::Cached), &settings, &|_| {}).0;
    assert!(before.same_image(&after));
    // A move puts a transform over the probe: a refusal names what lies under it.
    scene.model.apply(&Edit::Translate { node: "probe".into(), by: Vec3::X * 0.1 }).unwrap();
    let add = Edit::AddPoint { to: "probe".into(), name: "q".into(), center: Vec3::ZERO, radius: 0.2, weight: 1.0 };
    let err = scene.model.apply(&add).expect_err("refused").to_string();
    assert!(err.contains("is a Point, not a Blend"), "{err}");
}

#[test]
fn after_edits_the_model_equals_one_refreshed_from_scratch() {
    let mut scene = Scene::parse(EVERY_NODE, "every").unwrap();
    let mut rng = Rng(99);
    for _ in 0..6 {
        let edit = random_edit(&mut rng, "arm", false);
        scene.model.apply(&edit).unwrap();
    }
    let mut fresh = scene.model.clone();
    fresh.refresh();
    for (a, b) in scene.model.nodes().iter().zip(fresh.nodes()) {
        assert_eq!(a.bounds, b.bounds);
    }
    let bounds = scene.model.bounds();
    for mode in [EvalMode::Indexed, EvalMode::Naive] {
        let (edited, refreshed) = (ModelField::new(&scene.model, mode), ModelField::new(&fresh, mode));
        for _ in 0..500 {
            let p = rng.point_in(bounds.min, bounds.max);
            assert_eq!(edited.value(p).to_bits(), refreshed.value(p).to_bits(), "{mode:?} at {p}");
            let r = blobtrace::field::Region::Segment(p, p + glam::Vec3A::splat(0.3));
            assert_eq!(edited.lipschitz(&r).to_bits(), refreshed.lipschitz(&r).to_bits(), "{mode:?} at {p}");
        }
    }
}

const OPERATORS: &str = r#"Scene(
    camera: Camera(eye: (0.0, 0.0, 6.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
    size: (64, 48),
    model: Blend([
        Named("group", Blend([Point(center: (-0.6, 0.0, 0.0), radius: 1.0), Named("b", Point(center: (0.6, 0.0, 0.0), radius: 1.0))])),
        Named("cut", Intersection([Point(center: (0.0, 1.2, 0.0), radius: 1.1), Point(center: (0.3, 1.2, 0.0), radius: 1.1)])),
        Named("cached", Cache(res: 24, child: Blend([Point(center: (0.0, -1.3, 0.0), radius: 0.9), Point(center: (0.5, -1.3, 0.2), radius: 0.8)]))),
        Named("either", Union([Point(center: (1.3, 0.1, 0.0), radius: 0.9, weight: -1.0)])),
    ]),
)"#;

#[test]
fn adding_removing_and_changing_operators_update_incrementally() {
    use blobtrace::field::Operator;
    let add = |to: &str, name: &str, x: f32, y: f32| Edit::AddPoint {
        to: to.into(),
        name: name.into(),
        center: Vec3::new(x, y, 0.3),
        radius: 0.6,
        weight: 1.0,
    };
    let edits = [
        add("group", "g1", 0.0, 0.5),
        add("cached", "c1", -0.4, -1.0),
        // The union's only child dents the group: with a second, the union is
        // zero where the dent was, far from the new point.
        add("either", "e1", 2.4, -0.8),
        // Past the resize rule: the cache is laid anew on a coarser lattice.
        Edit::AddPoint {
            to: "cached".into(),
            name: "c2".into(),
            center: Vec3::new(3.0, -1.6, 0.0),
            radius: 1.4,
            weight: 1.0,
        },
        add("cut", "i1", 0.1, 1.3),
        Edit::Remove { node: "b".into() },
        Edit::Operator { node: "group".into(), op: Operator::Union },
        Edit::Operator { node: "cut".into(), op: Operator::Ricci(2.0) },
        Edit::Remove { node: "c1".into() },
    ];
    for mode in [EvalMode::Indexed, EvalMode::Cached] {
        let scene = Scene::parse(OPERATORS, "operators").unwrap();
        let polygonize = PolygonizeSettings { res: 24, ..Default::default() };
        let mut session = EditSession::new(scene, mode, Size(64, 48), &polygonize).unwrap();
        for edit in &edits {
            let before = session.field_frame().clone();
            let rects = session.apply(std::slice::from_ref(edit)).unwrap().dirty;
            let full = render(&ModelField::new(&session.scene().model, mode), session.settings(), &|_| {}).0;
            assert!(session.field_frame().same_image(&full), "{mode:?} {edit:?}");
            let check = session.verify().mismatch;
            assert!(check.is_none(), "{mode:?} {edit:?}: the local mesh differs from a fresh one: {check:?}");
            assert!(!changed_pixels(&before, &full).is_empty(), "{mode:?} {edit:?} changes the image");
            for (x, y) in changed_pixels(&before, &full) {
                assert!(rects.iter().any(|r| r.contains(x, y)), "{mode:?} {edit:?}: pixel {x},{y}");
            }
        }
        let mut scene = session.scene().clone();
        assert!(scene.model.find("b").is_none() && scene.model.find("g1").is_some());
        let refused = [
            (add("group", "g1", 0.0, 0.0), "used twice"),
            (add("b", "x", 0.0, 0.0), "no node is named"),
            (Edit::Operator { node: "cut".into(), op: Operator::Ricci(0.5) }, "at least 1"),
        ];
        for (edit, words) in refused {
            let err = scene.model.apply(&edit).expect_err("refused").to_string();
            assert!(err.contains(words), "{edit:?}: {err}");
        }
    }
}

#[test]
fn a_model_that_starts_empty_updates_like_any_other() {
    // The intersection's bounds are empty until the edit grows the point
    // into the circle's: no ray may meet the empty model's (inverted) bounds,
    // and the empty space marked over them must not stall a march afterwards.
    let text = r#"Scene(camera: Camera(eye: (0.0, 1.0, 6.0), target: (0.0, 0.0, 0.0), fov_y: 45.0), size: (32, 24),
        model: Cache(res: 23, child: Intersection([Named("n", Point(center: (-0.447, -0.924, -0.641), radius: 0.988, weight: 0.824)),
            Circle(center: (0.259, 1.076, -0.805), normal: (0.185, 0.894, -0.479), ring: 0.645, radius: 0.352, weight: 1.331)])))"#;
    for mode in [EvalMode::Indexed, EvalMode::Cached] {
        let scene = Scene::parse(text, "empty").unwrap();
        let settings = scene.render_settings(Size(32, 24));
        let (_, stats, _) = render_model(&scene.model, mode, &settings, &|_| {});
        assert_eq!(stats.hits, 0, "{mode:?}: the empty model shows");
        assert!(scene.model.bounds().is_empty());
        let mut session =
            EditSession::new(scene, mode, Size(32, 24), &PolygonizeSettings { res: 8, ..Default::default() }).unwrap();
        session.apply(&[Edit::Radius { node: "n".into(), radius: 3.0 }]).unwrap();
        let model = &session.scene().model;
        assert!(!model.bounds().is_empty(), "{mode:?}: the model's bounds stay empty");
        let full = render_model(model, mode, &settings, &|_| {}).0;
        assert!(session.field_frame().same_image(&full), "{mode:?}");
    }
}

#[test]
fn an_intersection_with_a_negative_child_updates_like_any_other() {
    // The circle's negative weight makes the intersection negative wherever
    // the circle reaches, past the point's support. Were the intersection cut
    // to the common box, its field would jump there, the tracer would hit or
    // miss a sliver depending on where its march started, and the full render
    // would miss (17, 19), which the incremental one shows.
    let text = r#"Scene(camera: Camera(eye: (0.0, 1.0, 6.0), target: (0.0, 0.0, 0.0), fov_y: 45.0), size: (32, 24),
        model: Blend([Intersection([Cache(res: 24, child: Point(center: (-0.105, -0.461, 0.979), radius: 1.025, weight: 0.756)),
            Circle(center: (-0.330, -0.967, -0.283), normal: (-0.965, -0.553, 0.150), ring: 0.557, radius: 0.725, weight: -0.819)]),
            Named("n3", Point(center: (0.506, -1.130, -0.319), radius: 1.038, weight: 1.036))]))"#;
    for mode in [EvalMode::Indexed, EvalMode::Cached] {
        let scene = Scene::parse(text, "negative").unwrap();
        let settings = scene.render_settings(Size(32, 24));
        let mut session =
            EditSession::new(scene, mode, Size(32, 24), &PolygonizeSettings { res: 16, ..Default::default() }).unwrap();
        session.apply(&[Edit::Translate { node: "n3".into(), by: Vec3::new(-0.281, -0.799, 0.722) }]).unwrap();
        let full = render_model(&session.scene().model, mode, &settings, &|_| {}).0;
        assert!(session.field_frame().same_image(&full), "{mode:?}");
    }
}

/// Rays that meet a change in front of their hit are traced again over the
/// changed stretch even where nothing they show changes: they count as
/// re-traced (the work `edit` reports), and their pixels stand.
#[test]
fn rays_traced_again_count_whether_or_not_their_pixels_change() {
    // A ball, and in front of it a point too weak to reach the threshold alone.
    let mut scene = Scene::parse(
        r#"Scene(
    camera: Camera(eye: (0.0, 0.0, 6.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
    size: (64, 48),
    model: Blend([
        Point(center: (0.0, 0.0, 0.0), radius: 1.5),
        Named("faint", Point(center: (0.0, 0.0, 2.5), radius: 0.4, weight: 0.3)),
    ]),
)"#,
        "faint",
    )
    .unwrap();
    let settings = scene.render_settings(Size(64, 48));
    let mode = EvalMode::Indexed;
    // Rays traced again in part: the segment tracer's re-render.
    scene.model.set_tracer(TracerChoice::Segment);
    let (mut frame, _, empty) = render_model(&scene.model, mode, &settings, &|_| {});
    let mut empty = empty.expect("the segment tracer marks empty space");
    let before = frame.clone();
    let change = scene.model.apply(&Edit::Translate { node: "faint".into(), by: Vec3::new(0.1, 0.0, 0.0) }).unwrap();
    let field = ModelField::new(&scene.model, mode);
    let regions = scene.model.change_support_regions(&change, false);
    empty.update(&scene.model.change_supports(&change, false));
    let space = changed_space(&field, &settings, &regions);
    let stats = rerender(&field.skipping(&empty), &settings, &mut frame, &space);
    assert!(frame.same_image(&before), "the faint point shows nowhere, before or after");
    assert!(stats.rays > 20, "{} rays traced again through the faint point's support", stats.rays);
    // Those through the middle still hit the ball behind; the others still miss it.
    assert!(stats.hits > 0 && stats.hits < stats.rays, "{} hits of {}", stats.hits, stats.rays);
    assert!(stats.field_evals >= stats.rays, "each spent evaluations");
}

/// Rotating or scaling a part whose support is empty (an intersection of
/// parts that do not meet) turns it about its parts' centre. Its support has
/// no centre, and such edits were refused as making a scale factor zero.
#[test]
fn a_part_without_support_turns_and_scales_about_its_parts() {
    let mut scene = Scene::parse(
        r#"Scene(
    camera: Camera(eye: (0.0, 0.0, 6.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
    size: (8, 8),
    model: Blend([
        Point(center: (0.0, 3.0, 0.0), radius: 1.0),
        Named("apart", Intersection([
            Point(center: (-1.0, 0.0, 0.0), radius: 0.5),
            Point(center: (1.0, 0.0, 0.0), radius: 0.5),
        ])),
    ]),
)"#,
        "apart",
    )
    .unwrap();
    let apart = scene.model.find("apart").unwrap();
    assert!(scene.model.node(apart).bounds.is_empty(), "the parts do not meet");
    scene.model.apply(&Edit::Rotate { node: "apart".into(), degrees: Vec3::new(0.0, 0.0, 90.0) }).unwrap();
    let b = scene.model.sizing_bounds_of(apart);
    assert!(b.center().length() < 1e-5, "turned about the parts' centre: {b:?}");
    assert!((b.size().y - 3.0).abs() < 1e-4 && (b.size().x - 1.0).abs() < 1e-4, "now along y: {b:?}");
    scene.model.apply(&Edit::Scale { node: "apart".into(), by: Vec3::new(1.0, 0.5, 1.0) }).unwrap();
    let b = scene.model.sizing_bounds_of(apart);
    assert!(b.center().length() < 1e-5 && (b.size().y - 1.5).abs() < 1e-4, "halved along y: {b:?}");
}

#[test]
fn an_edit_refused_mid_frame_leaves_the_session_following_the_edits_before_it() {
    let scene = bundled("hair_point.ron");
    let polygonize = PolygonizeSettings { res: 16, ..Default::default() };
    let mut session = EditSession::new(scene, EvalMode::Cached, Size(48, 36), &polygonize).unwrap();
    let frame = [
        Edit::Translate { node: "probe".into(), by: Vec3::new(0.2, 0.0, 0.0) },
        Edit::Translate { node: "nobody".into(), by: Vec3::X },
    ];
    let err = session.apply(&frame).expect_err("the second edit is refused").to_string();
    assert!(err.contains("no node is named"), "{err}");
    assert_eq!(session.frames(), 1, "the first edit made a frame");
    let check = session.verify().mismatch;
    assert!(check.is_none(), "the images and mesh follow the first edit: {check:?}");
}

#[test]
fn warp_edits_rerender_and_repolygonize_like_work_from_scratch() {
    let warp = |node: &str, rate: Option<f32>, to: Option<f32>, scale_to: Option<f32>| Edit::Warp {
        node: node.into(),
        rate,
        from: None,
        to,
        scale_from: None,
        scale_to,
    };
    let edits = [
        warp("tail", Some(0.3), None, None),
        warp("horn", None, Some(3.0), Some(0.35)),
        // The spring is cached: its samples, of the twisted field, are cleared and refilled.
        warp("spring", Some(2.4), None, None),
        Edit::Translate { node: "braid".into(), by: Vec3::new(0.2, 0.1, 0.0) },
        warp("braid", Some(1.5), None, None),
    ];
    for mode in [EvalMode::Indexed, EvalMode::Cached] {
        let polygonize = PolygonizeSettings { res: 48, ..Default::default() };
        let mut session = EditSession::new(bundled("warps.ron"), mode, Size(80, 60), &polygonize).unwrap();
        for edit in &edits {
            let before = session.field_frame().clone();
            let rects = session.apply(std::slice::from_ref(edit)).unwrap().dirty;
            let check = session.verify();
            assert_eq!(check.mismatch, None, "{mode:?} {edit:?}");
            let full = render(&ModelField::new(&session.scene().model, mode), session.settings(), &|_| {}).0;
            let changed = changed_pixels(&before, &full);
            assert!(!changed.is_empty(), "{mode:?} {edit:?} changes the image");
            for (x, y) in changed {
                assert!(rects.iter().any(|r| r.contains(x, y)), "{mode:?} {edit:?}: pixel {x},{y} changed outside");
            }
        }
    }
}

#[test]
fn bad_warp_edits_are_refused_and_change_nothing() {
    let mut scene = bundled("warps.ron");
    let before = scene.model.clone();
    let warp = |node: &str, rate: Option<f32>, from: Option<f32>, scale_to: Option<f32>| Edit::Warp {
        node: node.into(),
        rate,
        from,
        to: None,
        scale_from: None,
        scale_to,
    };
    let bad = [
        (warp("tail", Some(2.0), None, None), "needs its child within"),
        (warp("tail", Some(f32::NAN), None, None), "finite"),
        (warp("horn", None, Some(5.0), None), "from < to"),
        (warp("horn", None, None, Some(-1.0)), "positive"),
        (warp("horn", Some(1.0), None, None), "a taper has no rate"),
        (warp("braid", None, Some(0.0), None), "a taper's"),
    ];
    for (edit, words) in bad {
        let err = scene.model.apply(&edit).expect_err("refused").to_string();
        assert!(err.contains(words), "{edit:?}: {err}");
    }
    let settings = scene.render_settings(Size(48, 36));
    let now = render(&ModelField::new(&scene.model, EvalMode::Indexed), &settings, &|_| {}).0;
    let then = render(&ModelField::new(&before, EvalMode::Indexed), &settings, &|_| {}).0;
    assert!(now.same_image(&then));
}

#[test]
fn kernel_traced_edits_equal_full_kernel_renders_for_any_thread_count() {
    let mut scene = bundled("hair_point.ron");
    scene.model.set_tracer(TracerChoice::Kernel);
    let polygonize = PolygonizeSettings { res: 16, ..Default::default() };
    let mut session = EditSession::new(scene, EvalMode::Indexed, Size(64, 48), &polygonize).unwrap();
    let mut rng = Rng(48);
    for step in 0..6 {
        let (name, primitive) = [("probe", true), ("hair", false)][step % 2];
        let edit = random_edit(&mut rng, name, primitive);
        let before = session.field_frame().clone();
        let rects = session.apply(std::slice::from_ref(&edit)).unwrap().dirty;
        let (model, settings) = (&session.scene().model, session.settings());
        let full = render_model(model, EvalMode::Indexed, settings, &|_| {});
        assert!(full.2.is_none(), "the full render is traced by kernels");
        assert!(session.field_frame().same_image(&full.0), "step {step} {edit:?}: incremental differs from full");
        for (x, y) in changed_pixels(&before, &full.0) {
            assert!(rects.iter().any(|r| r.contains(x, y)), "step {step} {edit:?}: pixel {x},{y} changed outside");
        }
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let single = one.install(|| render_model(model, EvalMode::Indexed, settings, &|_| {}).0);
        assert!(single.same_image(&full.0), "step {step}: one thread differs from many");
    }
}
