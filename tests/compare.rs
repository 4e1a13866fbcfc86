//! Slices and image differences: pixel centres, error_C against resolution,
//! and the statistics of a known depth offset.

use blobtrace::compare::{Metric, Thresholds, Verdict, differences, judge};
use blobtrace::field::{EvalMode, Field, ModelField};
use blobtrace::frame::Frame;
use blobtrace::scene::Scene;
use blobtrace::slice::{SlicePlane, sample};
use glam::{Vec3, Vec3A};

fn cached(res: u32) -> Scene {
    Scene::parse(
        &format!(
            "Scene(camera: Camera(eye: (0.0, 0.0, 5.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (8, 8),
             model: Cache(res: {res}, child: Blend([
                 Point(center: (-0.5, 0.0, 0.0), radius: 1.2),
                 Segment(a: (0.2, -0.3, 0.1), b: (0.9, 0.6, -0.2), radius: 0.8),
             ])))"
        ),
        "cached",
    )
    .unwrap()
}

#[test]
fn slice_pixels_sample_the_field_at_their_centres() {
    let scene = cached(16);
    let bounds = scene.model.bounds();
    let plane = SlicePlane::parse("z=0.25", &bounds, 60, 60).unwrap();
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let values = sample(&plane, |p| field.value(p));
    let size = bounds.size();
    let pixel = (size.x / plane.width as f32).max(size.y / plane.height as f32);
    for (x, y) in [(0, 0), (17, 31), (plane.width - 1, plane.height - 1)] {
        let centre = Vec3A::new(bounds.min.x + (x as f32 + 0.5) * pixel, bounds.max.y - (y as f32 + 0.5) * pixel, 0.25);
        assert!((plane.point(x, y) - centre).length() < 1e-4, "pixel {x},{y}");
        let v = values[(y * plane.width + x) as usize];
        assert!((v - field.value(centre)).abs() < 1e-5, "pixel {x},{y}: {v}");
    }
}

#[test]
fn the_error_slice_is_zero_for_the_exact_field_and_shrinks_with_resolution() {
    let mean_error = |res: u32| {
        let scene = cached(res);
        let plane = SlicePlane::parse("0,0,0+0.2,0.3,1", &scene.model.bounds(), 80, 80).unwrap();
        let exact = ModelField::new(&scene.model, EvalMode::Indexed);
        let cached = ModelField::new(&scene.model, EvalMode::Cached);
        let e = sample(&plane, |p| (cached.value(p) - exact.value(p)).abs());
        let zero = sample(&plane, |p| (exact.value(p) - exact.value(p)).abs());
        assert!(zero.iter().all(|&v| v == 0.0));
        e.iter().map(|&v| f64::from(v)).sum::<f64>() / e.len() as f64
    };
    let errors: Vec<f64> = [8, 16, 32, 64].into_iter().map(mean_error).collect();
    for w in errors.windows(2) {
        assert!(w[1] < 0.6 * w[0], "{errors:?}");
    }
}

#[test]
fn a_known_depth_offset_gives_its_statistics() {
    let mut a = Frame::new(10, 10, Vec3::ZERO);
    for i in 0..60 {
        a.depth[i] = 2.0 + i as f32 * 0.01;
        a.alpha[i] = 1.0;
    }
    let mut b = a.clone();
    for d in &mut b.depth[..60] {
        *d += 0.1;
    }
    // One pixel hit by the second image only.
    b.depth[60] = 3.0;
    let d = differences(&a, &b, Metric::Depth);
    let t = Thresholds { fail: 0.05, failpercent: 50.0, ..Default::default() };
    let r = judge(Metric::Depth, &d, &[false; 100], 10, t);
    assert_eq!((r.compared, r.mismatch_px), (61, 1));
    assert!((r.mean - 0.1).abs() < 1e-5 && (r.median - 0.1).abs() < 1e-5, "{r:?}");
    assert_eq!(r.over_fail_px, 61);
    // The one-sided hit fails but stays out of the sums: the largest finite difference is the offset.
    assert!((r.max - 0.1).abs() < 1e-5 && (r.rms - 0.1).abs() < 1e-5, "{r:?}");
    assert_eq!(r.verdict, Verdict::Fail);
}
