//! Progressive refinement: edits and camera moves taken in the middle of
//! each other's passes end in images equal to renders from scratch, and once
//! an event's coarse pass is up, no pixel shows the field from before it.

mod common;

use std::time::Duration;

use blobtrace::camera::{CameraMove, Orbit};
use blobtrace::field::{EvalMode, ModelField};
use blobtrace::frame::Frame;
use blobtrace::pipeline::{EditSession, IDLE_SAMPLES, PolygonizeSettings};
use blobtrace::scene::Size;
use blobtrace::trace::{PASS_STEPS, RenderSettings, render};
use common::{Rng, bundled, random_edit};

/// An edit session on Medusa at `size`, its mesh on the lattice of `res`.
fn medusa(mode: EvalMode, size: Size, res: u32) -> EditSession {
    EditSession::new(bundled("medusa.ron"), mode, size, &PolygonizeSettings { res, ..Default::default() }).unwrap()
}

/// The field render of the session's model and camera from scratch.
fn from_scratch(session: &EditSession) -> Frame {
    let field = ModelField::new(&session.scene().model, session.mode());
    render(&field, session.settings(), &|_| {}).0
}

/// Whether `shown` takes every pixel from `truth` at the pixel itself or at
/// a corner of one of its 2×2, 4×4 or 8×8 blocks: the field as it is now,
/// sampled nearby. The first pixel that does not, if one does not.
fn first_pixel_not_from(shown: &Frame, truth: &Frame) -> Option<(u32, u32)> {
    let same =
        |i: usize, j: usize| shown.color[i] == truth.color[j] && shown.depth[i].to_bits() == truth.depth[j].to_bits();
    (0..shown.height).flat_map(|y| (0..shown.width).map(move |x| (x, y))).find(|&(x, y)| {
        let i = (y * shown.width + x) as usize;
        !PASS_STEPS.iter().any(|&s| same(i, ((y - y % s) * shown.width + x - x % s) as usize))
    })
}

#[test]
fn events_taken_mid_refinement_end_in_images_equal_to_work_from_scratch() {
    let names: [(&str, bool); 2] = [("head", false), ("left_hand", false)];
    let mut rng = Rng(35);
    for mode in [EvalMode::Indexed, EvalMode::Cached] {
        let mut session = medusa(mode, Size(72, 56), 24);
        let centre = session.scene().model.bounds().center().into();
        let mut orbit = Orbit::new(&session.settings().camera, centre, 56);
        for event in 0..9 {
            match event % 3 {
                0 => session.begin_camera(orbit.moved(CameraMove::Orbit(17.0, 4.0))),
                1 => {
                    let (name, primitive) = names[event % 2];
                    session.begin_apply(&[random_edit(&mut rng, name, primitive)]).unwrap();
                }
                _ => session.begin_camera(orbit.moved(CameraMove::Zoom(0.85))),
            }
            assert!(session.pending().is_some(), "{mode:?} event {event} left passes to do");
            // The next event comes after none, one or a few of the passes.
            for _ in 0..event % 4 {
                session.refine(Duration::ZERO);
            }
            if event % 4 == 3 {
                session.finish();
                assert!(session.is_refined());
                assert!(session.field_frame().same_image(&from_scratch(&session)), "{mode:?} event {event}");
            }
        }
        session.finish();
        assert!(session.field_frame().same_image(&from_scratch(&session)), "{mode:?}");
        let check = session.verify();
        assert_eq!(check.mismatch, None, "{mode:?}: the images and the mesh equal work from scratch");
    }
}

#[test]
fn once_the_coarse_pass_is_up_no_pixel_shows_the_field_before_the_edit() {
    let mut rng = Rng(7);
    for mode in [EvalMode::Indexed, EvalMode::Cached] {
        let mut session = medusa(mode, Size(80, 60), 16);
        let mut stale_seen = 0;
        for event in 0..4 {
            let before = session.field_frame().clone();
            let edit = random_edit(&mut rng, "head", false);
            session.begin_apply(std::slice::from_ref(&edit)).unwrap();
            let truth = from_scratch(&session);
            stale_seen += (0..truth.len()).filter(|&i| before.color[i] != truth.color[i]).count();
            // After the coarse pass, and after each pass or batch of rows since.
            while session.pending().is_some() {
                let shown = session.field_preview();
                assert_eq!(first_pixel_not_from(&shown, &truth), None, "{mode:?} event {event} {edit:?}");
                session.refine(Duration::ZERO);
            }
            assert!(session.field_frame().same_image(&truth), "{mode:?} event {event}: refined");
        }
        assert!(stale_seen > 50, "{mode:?}: the edits changed what the screen shows ({stale_seen} pixels)");
    }
}

#[test]
fn samples_added_while_idle_converge_to_the_render_of_as_many_samples() {
    let mut session = medusa(EvalMode::Indexed, Size(40, 30), 16);
    assert_eq!(session.samples_taken(), 1);
    let plain = session.field_colors().into_owned();
    while session.supersample(Duration::ZERO) {}
    assert_eq!(session.samples_taken(), IDLE_SAMPLES);
    let settings = RenderSettings { samples: IDLE_SAMPLES, ..*session.settings() };
    let field = ModelField::new(&session.scene().model, session.mode());
    let smooth = render(&field, &settings, &|_| {}).0;
    assert!(session.field_colors().iter().zip(&smooth.color).all(|(a, b)| a == b), "the colours of render --spp 16");
    assert_ne!(plain, smooth.color);
    // A camera move starts again from one sample.
    let camera = session.settings().camera;
    session.begin_camera(camera);
    assert_eq!(session.samples_taken(), 1);
}

#[test]
fn an_edit_before_the_last_one_is_refined_leaves_no_pixel_of_either_behind() {
    let mut rng = Rng(38);
    for mode in [EvalMode::Indexed, EvalMode::Cached] {
        let mut session = medusa(mode, Size(80, 60), 16);
        for (refines, names) in [(0, ["head", "left_hand"]), (1, ["left_hand", "head"]), (2, ["head", "head"])] {
            session.begin_apply(&[random_edit(&mut rng, names[0], false)]).unwrap();
            for _ in 0..refines {
                session.refine(Duration::ZERO);
            }
            session.begin_apply(&[random_edit(&mut rng, names[1], false)]).unwrap();
            session.finish();
            assert!(session.field_frame().same_image(&from_scratch(&session)), "{mode:?}, {refines} passes between");
        }
        assert_eq!(session.verify().mismatch, None);
    }
}

#[test]
fn a_sample_part_way_through_weighs_only_the_rows_it_reached() {
    let mut session = medusa(EvalMode::Indexed, Size(200, 150), 16);
    let field = ModelField::new(&session.scene().model, session.mode());
    let two = render(&field, &RenderSettings { samples: 2, ..*session.settings() }, &|_| {}).0;
    let one = session.field_frame().color.clone();
    // Sampling stops on its budget within the second sample's rows.
    while session.samples_taken() < 2 {
        session.supersample(Duration::ZERO);
        let shown = session.field_colors();
        let from_two = shown.iter().zip(&two.color).take_while(|(a, b)| a == b).count();
        let from_one = shown.iter().zip(&one).rev().take_while(|(a, b)| a == b).count();
        assert!(from_two + from_one >= shown.len(), "each row shows one sample or both: {from_two} + {from_one}");
    }
    assert!(session.field_colors().iter().zip(&two.color).all(|(a, b)| a == b));
}

/// The evaluations per pixel of the session's field image, and their sum.
fn evaluations(session: &EditSession) -> (Vec<f32>, f64) {
    let evals = session.field_frame().aov("evals.Y").expect("an evaluations channel").to_vec();
    let sum = evals.iter().map(|&e| f64::from(e)).sum();
    (evals, sum)
}

#[test]
fn a_long_session_once_idle_costs_what_a_fresh_one_does() {
    let size = Size(160, 120);
    let polygonize = PolygonizeSettings { res: 32, ..Default::default() };
    for mode in [EvalMode::Indexed, EvalMode::Cached] {
        let mut session = EditSession::new(bundled("medusa.ron"), mode, size, &polygonize).unwrap();
        // 20 orbit steps out and back.
        let centre = session.scene().model.bounds().center().into();
        let mut orbit = Orbit::new(&session.settings().camera, centre, size.1);
        for k in 0..20 {
            let yaw = if k < 10 { 6.0 } else { -6.0 };
            session.begin_camera(orbit.moved(CameraMove::Orbit(yaw, 0.0)));
        }
        // 200 moves of the head out and back, refined after some, not others.
        let step = session.scene().model.bounds().diagonal() / 2000.0;
        for k in 0..200 {
            let sign = if k < 100 { 1.0 } else { -1.0 };
            let by = glam::Vec3::new(step, 0.3 * step, 0.0) * sign;
            session.begin_apply(&[blobtrace::field::Edit::Translate { node: "head".into(), by }]).unwrap();
            if k % 7 == 0 {
                session.finish();
            }
        }
        session.finish();
        assert!(!session.is_tidy(), "{mode:?}: edits leave pixels to tidy");
        let untidy = evaluations(&session).0;
        session.tidy_all();
        // A fresh session of the scene as it was, through the same camera.
        let mut fresh = EditSession::new(bundled("medusa.ron"), mode, size, &polygonize).unwrap();
        fresh.set_camera(session.settings().camera);
        let ((kept, kept_sum), (new, new_sum)) = (evaluations(&session), evaluations(&fresh));
        let ratio = kept_sum / new_sum;
        let differing = kept.iter().zip(&new).filter(|(a, b)| a != b).count();
        let untidy_differing = untidy.iter().zip(&new).filter(|(a, b)| a != b).count();
        eprintln!(
            "{mode:?}: {kept_sum} against {new_sum} evaluations ({ratio:.4}), {differing} pixels differ ({untidy_differing} untidy)"
        );
        if mode == EvalMode::Cached {
            // The long session's caches hold the samples of every view it
            // saw, and slope bounds from more samples are tighter: it may
            // be cheaper than a fresh session's cold caches, never dearer.
            assert!(ratio <= 1.01, "{mode:?}: {kept_sum} evaluations against {new_sum} fresh");
            continue;
        }
        assert!((ratio - 1.0).abs() <= 0.01, "{mode:?}: {kept_sum} evaluations against {new_sum} fresh");
        assert!(differing <= kept.len() / 100, "{mode:?}: the cost image differs in {differing} pixels");
    }
}
