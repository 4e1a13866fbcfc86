//! The field ray caster against analytic answers, brute force and itself.

mod common;

use blobtrace::field::{EmptySpace, EvalMode, Field, ModelField};
use blobtrace::geom::Ray;
use blobtrace::scene::{Scene, Size};
use blobtrace::trace::{Coverage, Crossing, RenderSettings, march, render, render_covered, trace_ray};
use common::{assert_traces_like_brute_force, bundled};
use glam::Vec3A;

fn settings(scene: &Scene, w: u32, h: u32) -> RenderSettings {
    scene.render_settings(Size(w, h))
}

/// Distance along `ray` to the sphere of radius `r` at the origin, if hit.
fn ray_sphere(ray: &Ray, r: f32) -> Option<f32> {
    let o = ray.origin;
    let b = o.dot(ray.dir);
    let c = o.length_squared() - r * r;
    let disc = b * b - c;
    (disc >= 0.0).then(|| -b - disc.sqrt())
}

#[test]
fn lone_point_depth_matches_the_analytic_sphere() {
    let scene = bundled("sphere.ron");
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let radius = 2.0f32; // the scene's support radius R
    let iso_radius = radius * (1.0 - 0.5f32.powf(1.0 / 3.0)).sqrt();
    let s = settings(&scene, 160, 120);
    let (frame, _) = render(&field, &s, &|_| {});
    let (mut hits, mut checked_misses) = (0, 0);
    for y in 0..s.height {
        for x in 0..s.width {
            let i = (y * s.width + x) as usize;
            let ray = scene.camera.ray(x, y, s.width, s.height);
            // Distance from the centre to the ray's line: how far from the silhouette.
            let miss_distance = (ray.origin - ray.dir * ray.origin.dot(ray.dir)).length();
            let near_silhouette = (miss_distance - iso_radius).abs() < 2e-3;
            match ray_sphere(&ray, iso_radius) {
                Some(t) if !near_silhouette => {
                    assert!(frame.depth[i].is_finite(), "pixel {x},{y} should hit");
                    let err = (frame.depth[i] - t).abs();
                    assert!(err <= 1e-4 * radius, "pixel {x},{y}: Z {} vs analytic {t} (error {err})", frame.depth[i]);
                    hits += 1;
                }
                None if !near_silhouette => {
                    assert!(frame.depth[i].is_infinite(), "pixel {x},{y} should miss");
                    checked_misses += 1;
                }
                _ => {}
            }
        }
    }
    assert!(hits > 5000 && checked_misses > 1000, "hits {hits}, misses {checked_misses}");
}

/// Thin features: capsules and blobs far thinner than a naive step would resolve.
const THIN: &str = r#"Scene(
    camera: Camera(eye: (0.3, 0.4, 3.0), target: (0.0, 0.0, 0.0), fov_y: 45.0),
    size: (48, 48),
    model: Blend([
        Segment(a: (-1.0, -0.8, 0.0), b: (1.0, 0.9, 0.1), radius: 0.07),
        Segment(a: (-1.0, 0.7, -0.5), b: (0.9, -0.6, 0.6), radius: 0.05),
        Circle(center: (0.0, 0.0, 0.0), normal: (0.2, 0.3, 1.0), ring: 0.8, radius: 0.05),
        SplinePoints(control: [(-0.9, 0.0, 0.5), (0.0, 0.5, 0.6), (0.9, 0.0, 0.4)], count: 9, radius: 0.06),
        Point(center: (0.4, 0.4, 0.2), radius: 1.0, weight: 0.45),
    ]),
)"#;

#[test]
fn no_tunnelling_through_thin_features() {
    let scene = Scene::parse(THIN, "thin").unwrap();
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let (compared, hits) = assert_traces_like_brute_force(&field, &scene.camera, (48, 48), 1e-3);
    assert!(compared > 1500 && hits > 100, "compared {compared}, hits {hits}");
}

#[test]
fn one_and_many_threads_give_identical_frames_and_exr_bytes() {
    let scene = bundled("medusa.ron");
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let s = settings(&scene, 96, 72);
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| render(&field, &s, &|_| {}).0)
    };
    let one = run(1);
    let many = run(4);
    assert!(one.hits() > 300, "the view should hit Medusa: {} hits", one.hits());
    assert_eq!(one, many);
    let dir = std::env::temp_dir().join(format!("blobtrace-threads-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    one.save_exr(&dir.join("one.exr")).unwrap();
    many.save_exr(&dir.join("many.exr")).unwrap();
    assert_eq!(std::fs::read(dir.join("one.exr")).unwrap(), std::fs::read(dir.join("many.exr")).unwrap());
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn exr_holds_every_aov() {
    let scene = bundled("pair.ron");
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let (frame, stats) = render(&field, &settings(&scene, 40, 30), &|_| {});
    let path = std::env::temp_dir().join(format!("blobtrace-aov-{}.exr", std::process::id()));
    frame.save_exr(&path).unwrap();
    let exr = blobtrace::frame::read_exr_channels(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert_eq!((exr.width, exr.height), (40, 30));
    for name in ["R", "G", "B", "A", "Z", "N.X", "N.Y", "N.Z", "steps.Y"] {
        assert!(exr.channels.contains_key(name), "missing channel {name}");
    }
    let z = &exr.channels["Z"];
    let a = &exr.channels["A"];
    assert_eq!(a.iter().filter(|&&v| v > 0.0).count() as u64, stats.hits);
    for (z, a) in z.iter().zip(a) {
        assert_eq!(z.is_infinite(), *a == 0.0, "Z is +inf exactly on misses");
    }
    // Normals are unit length on hits.
    let n = |i: usize| Vec3A::new(exr.channels["N.X"][i], exr.channels["N.Y"][i], exr.channels["N.Z"][i]);
    for i in (0..z.len()).filter(|&i| a[i] > 0.0) {
        assert!((n(i).length() - 1.0).abs() < 1e-4);
    }
}

#[test]
fn naive_and_indexed_renders_agree_on_coverage() {
    let scene = bundled("hair_point.ron");
    let s = settings(&scene, 64, 48);
    let (a, _) = render(&ModelField::new(&scene.model, EvalMode::Indexed), &s, &|_| {});
    let (b, _) = render(&ModelField::new(&scene.model, EvalMode::Naive), &s, &|_| {});
    let mismatch = a.alpha.iter().zip(&b.alpha).filter(|(x, y)| x != y).count();
    assert!(mismatch <= 2, "{mismatch} pixels differ in coverage");
    let worst = a
        .depth
        .iter()
        .zip(&b.depth)
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-3, "depths differ by {worst}");
}

#[test]
fn peer_particles_scene_covers_what_the_reference_tracer_covers() {
    // The Segment Tracing reference code reports 34,380 hit pixels on this
    // scene at 500 x 500 (its rays stop at the first sample inside, without
    // refinement, so a few silhouette pixels may differ).
    let scene = bundled("particles.ron");
    assert_eq!(scene.model.counts().primitives, 1001);
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let (frame, stats) = render(&field, &settings(&scene, 500, 500), &|_| {});
    let hits = frame.hits() as f64;
    assert!((hits - 34_380.0).abs() / 34_380.0 < 0.002, "{hits} hit pixels");
    assert!(stats.steps as f64 / stats.rays as f64 > 1.0);
}

#[test]
fn a_march_from_any_point_before_the_hit_finds_the_same_hit() {
    // The property incremental re-rendering stands on: the snapped hit
    // depends on the field near it, not on where the march began. Medusa's
    // hair grazes many rays with features thinner than the tolerance.
    let scene = bundled("medusa.ron");
    let field = ModelField::new(&scene.model, EvalMode::Cached);
    let s = settings(&scene, 48, 36);
    let bounds = field.bounds();
    let mut checked = 0;
    for y in 0..s.height {
        for x in 0..s.width {
            let ray = s.camera.ray(x, y, s.width, s.height);
            let Some(hit) = trace_ray(&field, &ray, &s.trace).hit else { continue };
            let (t_start, t_end) = bounds.clip_ray(ray.origin, ray.dir.recip(), 0.0, f32::INFINITY).unwrap();
            for k in 1..8 {
                let t0 = t_start + (hit - t_start) * k as f32 / 8.0;
                let (found, _) = march(&field, &ray, &s.trace, (t0, t_end));
                assert_eq!(found, Crossing::At(hit), "pixel {x},{y} from {t0}");
                checked += 1;
            }
        }
    }
    assert!(checked > 1000, "{checked} marches checked");
}

#[test]
fn a_feature_thinner_than_the_tolerance_is_found_from_any_start_when_it_holds_a_lattice_point() {
    // A ray grazing a small sphere: inside over a chord of 0.6 lattice steps
    // centred on a lattice point. Wherever the march starts, it must find it.
    let scene = Scene::parse(
        "Scene(camera: Camera(eye: (0.0, 0.0, 10.0), target: (0.0, 0.0, 0.0), up: (0.0, 1.0, 0.0), fov_y: 40.0),
               size: (8, 8), threshold: 0.5,
               model: Blend([Point(center: (0.0, 0.0, 0.0), radius: 0.01), Point(center: (5.0, 5.0, 5.0), radius: 1.0)]))",
        "thin",
    )
    .unwrap();
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let opts = settings(&scene, 8, 8).trace;
    let q = opts.quantum.unwrap();
    let iso_radius = 0.01 * (1.0 - 0.5f32.powf(1.0 / 3.0)).sqrt();
    let half_chord = 0.3 * q;
    let miss_distance = (iso_radius * iso_radius - half_chord * half_chord).sqrt();
    let k = (2.0 / q).round();
    let ray = Ray::new(Vec3A::new(-k * q, miss_distance, 0.0), Vec3A::X);
    let hit = Crossing::At(k * q);
    assert_eq!(trace_ray(&field, &ray, &opts).hit, Some(k * q));
    for i in 0..64 {
        let t0 = (k - 1000.0) * q + i as f32 * 0.37 * q;
        assert_eq!(march(&field, &ray, &opts, (t0, 4.0)).0, hit, "from {t0}");
    }
}

/// After an edit grows the model, the tolerance (a fraction of the bounds'
/// diagonal) outgrows the hit lattice, which stays fixed. A ray grazing one
/// point (under a union, so without curvature steps) walks that finer
/// lattice; it must then speed up again, not crawl one
/// lattice step at a time to a point far behind (and run out of steps).
#[test]
fn a_march_speeds_up_again_after_walking_a_lattice_finer_than_the_tolerance() {
    let scene = Scene::parse(
        "Scene(camera: Camera(eye: (0.0, 0.0, 10.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (8, 8),
               model: Union([Point(center: (0.0, 0.0, 0.0), radius: 1.0), Point(center: (6.0, 0.4, 0.0), radius: 1.0)]))",
        "graze",
    )
    .unwrap();
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let mut opts = settings(&scene, 8, 8).trace;
    let tol = opts.tolerance * scene.model.bounds().diagonal();
    opts.quantum = Some(0.25 * tol);
    // Along +x at the height where the first point's field peaks a hair below T.
    let graze = (1.0 - (0.5f32 - 2e-6).powf(1.0 / 3.0)).sqrt();
    let ray = Ray::new(Vec3A::new(-2.0, graze, 0.0), Vec3A::X);
    let result = trace_ray(&field, &ray, &opts);
    let iso_radius2 = 1.0 - 0.5f32.powf(1.0 / 3.0);
    let expected = 8.0 - (iso_radius2 - (graze - 0.4) * (graze - 0.4)).sqrt();
    let hit = result.hit.expect("the second point is hit");
    assert!((hit - expected).abs() < 1e-3, "hit at {hit}, the second point's surface at {expected}");
    // Under a thousand lattice steps past the graze; a crawl would take 10⁵.
    assert!(result.steps < 2000, "{} steps", result.steps);
}

/// Rays that touch the surface to within rounding (found by fuzzing): the
/// snapped hit is a lattice point whose computed value exceeds `T`, and
/// marches that skip empty space or step from elsewhere must meet it alike.
/// Before, one march stepped over it and the other hit it, or a march that
/// touched the surface between lattice points reported a point outside.
#[test]
fn rays_touching_the_surface_hit_alike_with_and_without_skipping() {
    let header =
        "Scene(camera: Camera(eye: (0.0, 1.0, 6.0), target: (0.0, 0.0, 0.0), fov_y: 45.0), size: (16, 12), model: ";
    let cases = [
        (
            "Blend([SplinePoints(control: [(-0.53, -0.65, -0.01), (1.47, -1.47, 1.11), (-0.09, -1.1, 1.26)], count: 18, radius: 0.5, radius_end: 0.85, weight: 0.28),
                SplinePoints(control: [(-1.12, 0.99, -0.57), (-0.9, 0.41, 0.62), (0.99, 1.25, 0.04)], count: 14, radius: 0.86, weight: 0.44),
                Circle(center: (-0.49, 1.31, 0.42), normal: (-0.42, -0.1, 0.36), ring: 0.94, radius: 0.63, weight: -0.24),
                Segment(a: (-0.74, 0.55, -0.49), b: (0.48, -0.04, -0.89), radius: 0.73, weight: 0.84)])",
            EvalMode::Naive,
            Ray::new(Vec3A::new(-1.1322665, -1.3386351, -3.7712917), Vec3A::new(0.42565364, 0.45474797, 0.7823193)),
        ),
        (
            "Blend([Blend([Cache(res: 25, value: Trilinear, gradient: Trilinear, storage: F16, child:
                    Transform(translate: (0.75, -0.36, 0.42), rotate: (147.01, -47.16, 121.72), scale: (0.57, 0.59, 1.92),
                        child: Segment(a: (-0.15, 0.31, 0.85), b: (-0.27, -0.81, 0.43), radius: 0.39, weight: 1.36))),
                SplinePoints(control: [(0.54, 0.97, -0.64), (1.39, 0.63, -0.94)], count: 27, radius: 0.74, weight: 0.19),
                Cache(res: 28, child: Union([Circle(center: (-0.82, 0.14, -0.38), normal: (0.89, -0.52, -0.67), ring: 0.29, radius: 0.82, weight: 1.1),
                    Point(center: (0.26, -0.12, 0.39), radius: 1.1, weight: 1.55),
                    Circle(center: (0.39, -1.24, -0.55), normal: (-0.93, -0.08, 0.15), ring: 0.66, radius: 0.42, weight: 0.47)])),
                Difference(Circle(center: (1.29, 0.22, 1.43), normal: (0.44, 0.96, 0.49), ring: 1.01, radius: 0.69, weight: 0.75),
                    Blend([Point(center: (-0.88, -1.16, 0.99), radius: 0.44, weight: 0.5),
                        Segment(a: (1.47, 0.88, 1.33), b: (-0.72, 0.29, -0.59), radius: 0.52, weight: 0.93),
                        Segment(a: (0.96, -1.31, 0.47), b: (-0.92, -0.9, -0.72), radius: 1.6, weight: 0.49)]))])])",
            EvalMode::Indexed,
            Ray::new(Vec3A::new(2.9707243, 0.1183545, -1.3803828), Vec3A::new(-0.8017092, 0.37928173, 0.46196067)),
        ),
    ];
    for (i, (model, mode, ray)) in cases.into_iter().enumerate() {
        let scene = Scene::parse(&format!("{header}{model})"), "touching").unwrap();
        let field = ModelField::new(&scene.model, mode);
        let empty = EmptySpace::build(&field);
        let opts = settings(&scene, 16, 12).trace;
        let plain = trace_ray(&field, &ray, &opts).hit.expect("the ray hits");
        let skipping = trace_ray(&field.skipping(&empty), &ray, &opts).hit;
        assert_eq!(skipping, Some(plain), "case {i}: skipping empty space moved the hit");
        assert!(field.value(ray.at(plain)) > field.threshold(), "case {i}: the hit at {plain} is outside");
    }
}

#[test]
fn skipping_empty_space_and_starting_rays_at_their_coverage_change_no_pixel() {
    for (name, mode, eye) in [
        ("medusa.ron", EvalMode::Cached, None),
        ("sharp.ron", EvalMode::Indexed, None),
        ("bottle.ron", EvalMode::Cached, None),
        ("hair_point.ron", EvalMode::Naive, None),
        ("particles.ron", EvalMode::Indexed, None),
        // The eye among the particles: boxes reach the eye plane and behind it.
        ("particles.ron", EvalMode::Indexed, Some(Vec3A::new(2.0, -3.0, 1.0))),
    ] {
        let mut scene = bundled(name);
        if let Some(eye) = eye {
            scene.camera.eye = eye;
        }
        let s = settings(&scene, 96, 72);
        let field = ModelField::new(&scene.model, mode);
        let empty = EmptySpace::build(&field);
        assert!(empty.empty_fraction() > 0.3, "{name}: only {} of the cells are empty", empty.empty_fraction());
        let coverage = Coverage::of(&empty, &scene.model.bounds(), &s.camera, s.width, s.height);
        let (plain, plain_stats) = render(&field, &s, &|_| {});
        let (skipping, skipping_stats) = render(&field.skipping(&empty), &s, &|_| {});
        let (covered, covered_stats) = render_covered(&field.skipping(&empty), &s, Some(&coverage), &|_| {});
        assert!(plain.depth.iter().any(|z| z.is_finite()), "{name}: nothing hit");
        let same = |a: &[f32], b: &[f32]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
        for (how, frame) in [("skipping", &skipping), ("coverage", &covered)] {
            assert!(same(&plain.depth, &frame.depth), "{name} in {mode:?}: {how} moved a hit");
            assert!(plain.color == frame.color && plain.normal == frame.normal, "{name}: {how} changed shading");
        }
        assert!(skipping_stats.steps < plain_stats.steps, "{name}: skipping saved no steps");
        // From inside, boxes at the eye cover every pixel from the eye: nothing to save.
        if eye.is_none() {
            assert!(covered_stats.field_evals < skipping_stats.field_evals, "{name}: coverage saved nothing");
            assert!(coverage.uncovered_fraction() > 0.2, "{name}: {}", coverage.uncovered_fraction());
        }
    }
}

/// Parts that do not meet leave the model's support empty; the hit lattice is
/// then sized by the parts, so that once an edit makes them meet, the render
/// after the edit (with the first frame's settings) finds what a render of the
/// edited scene finds.
#[test]
fn the_hit_lattice_of_parts_that_do_not_meet_is_sized_by_the_parts() {
    let text = |b: f32| {
        format!(
            "Scene(camera: Camera(eye: (0.0, 0.5, 6.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (48, 36), \
             model: Intersection([Point(center: (-0.6, 0.0, 0.0), radius: 1.0), \
             Named(\"b\", Point(center: ({b}, 0.0, 0.0), radius: 1.0))]))"
        )
    };
    let mut apart = Scene::parse(&text(1.6), "apart").unwrap();
    assert!(apart.model.bounds().is_empty());
    let first = settings(&apart, 48, 36);
    let quantum = first.trace.quantum.expect("snapped hits");
    // The parts span x from -1.6 to 2.6, y and z from -1 to 1.
    let diagonal = (4.2f32 * 4.2 + 2.0 * 2.0 * 2.0).sqrt();
    assert!((quantum - first.trace.tolerance * diagonal).abs() < 1e-9, "{quantum}");
    apart
        .model
        .apply(&blobtrace::field::Edit::Translate { node: "b".into(), by: glam::Vec3::new(-1.8, 0.0, 0.0) })
        .unwrap();
    let met = Scene::parse(&text(-0.2), "met").unwrap();
    let hits = |s: &Scene, settings: &RenderSettings| {
        let (frame, _) = render(&ModelField::new(&s.model, EvalMode::Indexed), settings, &|_| {});
        frame.depth.iter().filter(|d| d.is_finite()).count()
    };
    let found = hits(&apart, &first);
    assert!(found > 0 && found == hits(&met, &settings(&met, 48, 36)), "{found}");
}
