//! The previewer's own tests: moves by key against work from scratch, the
//! overlay's fit, the views, the slice, the help card and the gestures.

use super::keys::{KEYS, ZOOM_FACTOR};
use super::*;
use crate::field::EvalMode;
use crate::frame::Size;
use crate::mesh::canonical_triangles;
use crate::pipeline::PolygonizeSettings;
use crate::scene::Scene;
use crate::trace::render_model;

const SCENE: &str = "Scene(
    camera: Camera(eye: (0.0, 0.5, 5.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
    size: (48, 36),
    model: Blend([
        Named(\"left\", Point(center: (-0.6, 0.0, 0.0), radius: 1.0)),
        Named(\"right\", Cache(res: 32, child: Point(center: (0.6, 0.0, 0.0), radius: 1.0))),
    ]),
)";

fn viewer(mode: EvalMode) -> (Viewer, PolygonizeSettings) {
    let scene = Scene::parse(SCENE, "inline").unwrap();
    let polygonize = PolygonizeSettings { res: 24, ..Default::default() };
    let size = scene.size;
    let session = EditSession::new(scene, mode, size, &polygonize).unwrap();
    let snapshots = std::env::temp_dir().join(format!("blobtrace-view-test-{}.png", std::process::id()));
    (Viewer::new(session, Script::default(), None, snapshots).unwrap(), polygonize)
}

#[test]
fn after_moves_by_key_the_views_equal_a_render_and_a_mesh_from_scratch() {
    for mode in [EvalMode::Indexed, EvalMode::Cached] {
        let (mut v, polygonize) = viewer(mode);
        let keys = [
            "right",
            "right",
            "a",
            "up",
            "tab",
            "w",
            "left",
            "z",
            "drag:12:-5",
            "pagedown",
            "pan:6:3",
            "tab",
            "wheel:1",
            "down",
        ];
        // Where each move should take its node: along the screen as the camera then was.
        let mut expected = [glam::Vec3A::ZERO; 2];
        for (k, key) in keys.into_iter().enumerate() {
            let action = Action::named(key).unwrap();
            if let Action::Move(axis, sign) = action {
                expected[v.selected] += v.screen_axis(axis) * sign * v.step_length;
            }
            v.act(action).unwrap();
            // Events come as the last one's passes stand: coarse only, one pass further, or all.
            match k % 3 {
                0 => {}
                1 => v.refine(std::time::Duration::ZERO),
                _ => v.settle(),
            }
        }
        v.settle();
        assert_eq!(v.frames, 6, "every move is a frame; tab is none");
        let s = &v.session;
        let full = render_model(&s.scene().model, mode, s.settings(), &|_| {}).0;
        assert!(full.same_image(s.field_frame()), "{mode:?}: the field view differs from a full render");
        // The model has grown: a lattice over its new bounds would differ, so polygonize on the session's.
        let fresh = crate::pipeline::polygonizer_on(&s.scene().model, mode, s.lattice(), polygonize.options());
        assert_eq!(fresh.mesh().triangle_set(), canonical_triangles(s.mesh().triangles()));
        // The moves went where the keys said.
        let centre = |model: &crate::field::Model, name: &str| model.node(model.find(name).unwrap()).bounds.center();
        let start = Scene::parse(SCENE, "inline").unwrap();
        for (name, expected) in ["left", "right"].iter().zip(expected) {
            let moved = centre(&v.session.scene().model, name) - centre(&start.model, name);
            assert!((moved - expected).length() < 1e-5, "{name}: {moved} against {expected}");
            assert!(expected.length() > 0.5 * v.step_length, "{name} moved");
        }
    }
}

#[test]
fn a_move_too_far_is_refused_and_leaves_the_views_consistent() {
    let (mut v, _) = viewer(EvalMode::Cached);
    let model = |v: &Viewer| v.session.scene().model.clone();
    let start = model(&v).node(model(&v).find("left").unwrap()).bounds;
    // Far past where a model may reach (a thousand times its size).
    v.step_length = 1.0e5;
    v.act(Action::Move(0, 1.0)).unwrap();
    v.settle();
    let now = model(&v).node(model(&v).find("left").unwrap()).bounds;
    assert!((now.center() - start.center()).length() < 0.02, "{start:?} -> {now:?}");
    let s = &v.session;
    let full = render_model(&s.scene().model, EvalMode::Cached, s.settings(), &|_| {}).0;
    assert!(full.same_image(s.field_frame()));
}

#[test]
fn the_overlay_fits_every_window_and_overlaps_nothing_in_every_view_and_help_page() {
    for (w, h) in [(160, 120), (320, 240), (640, 480), (1920, 1080)] {
        let scene = Scene::parse(SCENE, "inline").unwrap();
        let polygonize = PolygonizeSettings { res: 16, ..Default::default() };
        let session = EditSession::begin(scene, EvalMode::Indexed, Size(w, h), &polygonize).unwrap();
        let mut v = Viewer::new(session, Script::default(), None, PathBuf::from("unused.png")).unwrap();
        v.act(Action::Move(0, 1.0)).unwrap();
        let mut checked = 0;
        for view in 0..6 {
            let slice_views = if v.view == View::Slice { 4 } else { 1 };
            for _ in 0..slice_views {
                let (_, key) = v.view();
                let what = format!("{w}x{h} {:?} {:?}", v.view, v.slice.shows);
                hud::tests::assert_fits(&v.overlay(key.as_ref()), w, h, &what);
                assert_eq!(v.overlay(key.as_ref()).len(), 1 + usize::from(key.is_some()), "{what}: a bar when a key");
                v.act(Action::NextSliceView).unwrap();
                checked += 1;
            }
            if view == 0 {
                // Every page of the help card, then hidden again.
                let pages = v.help_card().pages();
                for page in 0..pages {
                    v.act(Action::ToggleHelp).unwrap();
                    assert_eq!(v.help, Some(page));
                    hud::tests::assert_fits(&v.overlay(None), w, h, &format!("{w}x{h} help page {page}"));
                }
                v.act(Action::ToggleHelp).unwrap();
                assert_eq!(v.help, None, "{w}x{h}: H after the last page hides the card");
                assert!(w > 320 || pages > 1, "{w}x{h}: a small window pages the card");
            }
            v.act(Action::NextView).unwrap();
        }
        assert_eq!(checked, 9);
    }
}

#[test]
fn the_help_card_names_every_key_and_the_screen_draws_over_the_view() {
    let listed: Vec<String> =
        Action::help().iter().flat_map(|(names, _)| names.split(", ").map(String::from)).collect();
    for (name, ..) in KEYS {
        assert!(listed.iter().any(|l| l == name), "{name} is on the help card");
    }
    let (mut v, _) = viewer(EvalMode::Indexed);
    let (plain, screen) = (v.image(), v.screen());
    assert_eq!((plain.width, plain.height), (screen.width, screen.height));
    let row =
        |img: &Rgb8Image, y: u32| img.pixels[(3 * y * img.width) as usize..(3 * (y + 1) * img.width) as usize].to_vec();
    assert_ne!(row(&plain, 2), row(&screen, 2), "the status line");
    assert!(v.status().iter().any(|p| p.contains("moving left")), "{:?}", v.status());
    v.act(Action::named("h").unwrap()).unwrap();
    let with_help = v.screen();
    assert_ne!(row(&with_help, screen.height / 2), row(&screen, screen.height / 2), "the card");
    // F1 turns the pages as H does, and after the last hides the card.
    for _ in 1..v.help_card().pages() {
        v.act(Action::named("f1").unwrap()).unwrap();
        assert!(v.screen().pixels != screen.pixels, "the next page");
    }
    v.act(Action::named("f1").unwrap()).unwrap();
    assert!(v.screen().pixels == screen.pixels, "f1 hides it again");
    v.act(Action::named("a").unwrap()).unwrap();
    assert!(v.status().iter().any(|p| p.starts_with("camera: first pass")), "{:?}", v.status());
    v.settle();
    assert!(v.status().iter().any(|p| p.contains("refined")), "{:?}", v.status());
}

#[test]
fn the_slice_view_moves_its_plane_and_shows_f_sharp_error_and_gradient() {
    let (mut v, _) = viewer(EvalMode::Indexed);
    for _ in 0..5 {
        v.act(Action::NextView).unwrap();
    }
    let shows = |v: &Viewer| v.status().iter().any(|p| p.contains(" at depth "));
    assert!(shows(&v), "{:?}", v.status());
    // Through the blobs' centres, f reaches its peak and the contour is drawn in white.
    let through = v.image();
    let white = |img: &Rgb8Image| img.pixels.chunks(3).filter(|p| p == &[255, 255, 255]).count();
    assert!(white(&through) > 10, "the iso-contour");
    // Far behind the model the plane shows nothing; back again, the same picture.
    for _ in 0..60 {
        v.act(Action::named("period").unwrap()).unwrap();
    }
    assert_eq!(white(&v.image()), 0, "no contour beyond the model");
    for _ in 0..60 {
        v.act(Action::named("comma").unwrap()).unwrap();
    }
    assert!(v.image().pixels == through.pixels, "the plane comes back");
    // n: the sharp view, then (the model has a cache) error_C and the gradient error, then f.
    let mut seen = vec![through.pixels.clone()];
    for expected in ["sharp:", "error_C", "gradient error", "f at"] {
        v.act(Action::named("n").unwrap()).unwrap();
        assert!(v.status().iter().any(|p| p.starts_with(expected)), "{expected}: {:?}", v.status());
        seen.push(v.image().pixels);
    }
    assert!(seen[1] != seen[0] && seen[2] != seen[1] && seen[3] != seen[2]);
    assert!(seen[4] == seen[0], "n comes back to f");
    // The heat maps carry a colour bar on screen.
    assert!(v.screen().pixels != v.image().pixels);
}

#[test]
fn mouse_gestures_orbit_zoom_pan_and_select() {
    assert_eq!(Action::named("drag:10:-5").unwrap(), Action::Orbit(-4.0, -2.0));
    assert_eq!(Action::named("wheel:1").unwrap(), Action::Zoom(ZOOM_FACTOR));
    for bad in ["drag:1", "wheel:x", "click:-1:2", "drag:nan:0", "pan:1:2:3", "spin:1"] {
        assert!(Action::named(bad).is_err(), "{bad} is refused");
    }
    // A wheel notch in is the zoom key.
    let (mut by_wheel, _) = viewer(EvalMode::Indexed);
    let (mut by_key, _) = viewer(EvalMode::Indexed);
    by_wheel.act(Action::named("wheel:1").unwrap()).unwrap();
    by_key.act(Action::named("z").unwrap()).unwrap();
    assert_eq!(by_wheel.image().pixels, by_key.image().pixels);
    // However far the wheel turns, the camera stays usable.
    let (mut far, _) = viewer(EvalMode::Indexed);
    for gesture in ["wheel:-1000", "wheel:1000", "wheel:1000"] {
        far.act(Action::named(gesture).unwrap()).unwrap();
        assert!(far.session.settings().camera.eye.is_finite(), "after {gesture}");
    }
    // A pan and its opposite bring the camera back.
    let (mut v, _) = viewer(EvalMode::Indexed);
    let before = v.session.settings().camera;
    v.act(Action::Pan(15.0, -4.0)).unwrap();
    assert!((v.session.settings().camera.eye - before.eye).length() > 1e-3, "the pan moved the camera");
    v.act(Action::Pan(-15.0, 4.0)).unwrap();
    v.settle();
    assert!((v.session.settings().camera.eye - before.eye).length() < 1e-4);
    // A click on either blob selects it; a click on the background keeps the selection.
    let frame = v.session.field_frame();
    let (w, h) = (frame.width, frame.height);
    let hit_in = |xs: std::ops::Range<u32>| xs.into_iter().find(|&x| frame.depth[(h / 2 * w + x) as usize].is_finite());
    let (left_x, right_x) = (hit_in(0..w / 2 - 4).unwrap(), hit_in(w / 2 + 4..w).map(|x| x + 2).unwrap());
    v.act(Action::SelectAt(right_x, h / 2)).unwrap();
    assert_eq!(v.names[v.selected], "right");
    v.act(Action::SelectAt(0, 0)).unwrap();
    assert_eq!(v.names[v.selected], "right", "the background selects nothing");
    v.act(Action::named(&format!("click:{left_x}:{}", h / 2)).unwrap()).unwrap();
    assert_eq!(v.names[v.selected], "left");
}

#[test]
fn the_views_cycle_and_differ_and_unknown_keys_are_refused() {
    let (mut v, _) = viewer(EvalMode::Indexed);
    let field = v.image();
    v.act(Action::NextView).unwrap();
    let mesh = v.image();
    v.act(Action::NextView).unwrap();
    let difference = v.image();
    v.act(Action::NextView).unwrap();
    let normals = v.image();
    v.act(Action::NextView).unwrap();
    let cost = v.image();
    assert!(v.status()[0] == "cost", "{:?}", v.status());
    v.act(Action::NextView).unwrap();
    let slice = v.image();
    assert!(v.status()[0] == "slice", "{:?}", v.status());
    v.act(Action::NextView).unwrap();
    assert!(v.image().pixels == field.pixels, "six presses come back to the field");
    assert!(normals.pixels != cost.pixels && slice.pixels != cost.pixels);
    for other in [&mesh, &difference, &cost, &slice] {
        assert!(other.pixels != field.pixels);
    }
    for image in [&field, &mesh, &difference, &normals, &cost, &slice] {
        assert_eq!((image.width, image.height), (48, 36));
    }
    v.act(Action::Move(0, 1.0)).unwrap();
    v.settle();
    let moved = v.image();
    v.act(Action::ToggleRectangles).unwrap();
    let outlined = v.image();
    let yellow = |img: &Rgb8Image| img.pixels.chunks(3).filter(|p| p == &[255, 220, 0]).count();
    assert!(yellow(&outlined) > yellow(&moved), "r outlines the move's dirty rectangles");
    v.act(Action::Snapshot).unwrap();
    let snapshot = numbered(&v.snapshots.0, 1);
    let written = image::open(&snapshot).expect("p writes a snapshot").to_rgb8();
    assert_eq!(written.as_raw(), &outlined.pixels, "the snapshot is the view");
    std::fs::remove_file(snapshot).unwrap();
    let err = Action::named("F13").unwrap_err().to_string();
    assert!(err.contains("unknown key") && err.contains("f13"), "{err}");
}
