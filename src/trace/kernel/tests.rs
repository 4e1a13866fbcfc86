//! The kernel tracer against the segment tracer and brute force, ray by ray.

use glam::{Vec3, Vec3A};

use super::*;
use crate::field::ModelField;
use crate::frame::Size;
use crate::scene::Scene;
use crate::trace::trace_ray;

fn bundled(name: &str) -> Scene {
    Scene::load(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)).unwrap()
}

/// The first lattice point `k·q` of `ray` inside the surface, by trying
/// every one from where the ray enters the field's bounds, and the field
/// there less `T`: the hit both tracers snap to, found the slow way.
fn brute_force<F: Field>(field: &F, ray: &Ray, q: f32) -> Option<(f32, f32)> {
    let (t0, t1) = field.bounds().clip_ray(ray.origin, ray.dir.recip(), 0.0, f32::INFINITY)?;
    let iso = field.threshold();
    if field.value(ray.at(t0)) > iso {
        return Some((t0, field.value(ray.at(t0)) - iso));
    }
    ((t0 / q).floor() as i64..=(t1 / q).ceil() as i64)
        .map(|k| k as f32 * q)
        .map(|t| (t, field.value(ray.at(t)) - iso))
        .find(|&(_, v)| v > 0.0)
}

/// Traces every pixel of `scene` at `size` by kernels and by segments;
/// returns the rays that hit either way, and a line for each ray where the
/// two disagree beyond what the bounds allow: where both hit, depths more
/// than 1e-5 of the bounds' diagonal apart; where only one hits, a kernel
/// answer other than the first lattice point inside found by brute force,
/// unless that point is within rounding of `T` (a touch).
fn agreement(scene: &Scene, size: (u32, u32)) -> (u32, Vec<String>) {
    let s = scene.render_settings(Size(size.0, size.1));
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let kernel = KernelTracer::new(&scene.model, EvalMode::Indexed, &s.camera, size).unwrap();
    let diag = field.bounds().diagonal();
    let q = s.trace.quantum.unwrap();
    let (mut hits, mut bad) = (0, vec![]);
    for y in 0..size.1 {
        for x in 0..size.0 {
            let ray = s.camera.ray(x, y, size.0, size.1);
            let k = kernel.trace(&field, &ray, (x, y), &s.trace);
            let seg = trace_ray(&field, &ray, &s.trace);
            hits += u32::from(k.hit.is_some() || seg.hit.is_some());
            match (k.hit, seg.hit) {
                (Some(a), Some(b)) if (a - b).abs() <= 1e-5 * diag => {}
                (None, None) => {}
                (a, b) => {
                    let truth = brute_force(&field, &ray, q);
                    let touch = truth.is_some_and(|(_, v)| v <= outside_margin(field.threshold()));
                    if a != truth.map(|(t, _)| t) && !touch {
                        bad.push(format!("pixel {x},{y}: kernel {a:?}, segment {b:?}, brute force {truth:?}"));
                    }
                }
            }
        }
    }
    (hits, bad)
}

fn assert_agrees(scene: &Scene, size: (u32, u32), min_hits: u32) {
    let (hits, bad) = agreement(scene, size);
    assert!(hits >= min_hits, "{hits} hits");
    assert!(bad.is_empty(), "{} of {hits} disagree: {:?}", bad.len(), &bad[..bad.len().min(10)]);
}

#[test]
fn bundled_sums_of_kernels_are_hit_where_the_segment_tracer_hits_them() {
    assert_agrees(&bundled("particles.ron"), (200, 200), 4000);
    assert_agrees(&bundled("pair.ron"), (96, 72), 1500);
    assert_agrees(&bundled("sphere.ron"), (64, 48), 300);
}

/// The pixels of `scene` at `size` whose hits differ between the kernel and
/// segment tracers, to the bit.
fn differing(scene: &Scene, size: (u32, u32)) -> Vec<(u32, u32)> {
    let s = scene.render_settings(Size(size.0, size.1));
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let kernel = KernelTracer::new(&scene.model, EvalMode::Indexed, &s.camera, size).unwrap();
    (0..size.1)
        .flat_map(|y| (0..size.0).map(move |x| (x, y)))
        .filter(|&(x, y)| {
            let ray = s.camera.ray(x, y, size.0, size.1);
            kernel.trace(&field, &ray, (x, y), &s.trace).hit != trace_ray(&field, &ray, &s.trace).hit
        })
        .collect()
}

#[test]
fn bundled_sums_of_kernels_give_the_segment_tracers_hits_to_the_bit() {
    // Both snap to the first lattice point inside; with no rise passed over,
    // they agree everywhere on these scenes, not only within the bounds.
    for (name, size) in [("particles.ron", (500, 500)), ("pair.ron", (120, 90)), ("hair_point.ron", (160, 120))] {
        let differ = differing(&bundled(name), size);
        assert!(
            differ.is_empty(),
            "{name}: {} pixels differ, the first {:?}",
            differ.len(),
            &differ[..differ.len().min(5)]
        );
    }
}

/// A tiny generator of reproducible numbers (64-bit LCG).
struct Numbers(u64);

impl Numbers {
    fn unit(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }
    fn vec(&mut self, lo: f32, hi: f32) -> String {
        format!("({}, {}, {})", self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
}

/// A scene of a random blend of points and segments, some under random
/// transforms (non-uniform scales among them), some with negative weights.
fn random_blend(n: &mut Numbers) -> Scene {
    random_blend_from(n, 1.0, 6.0, 40.0)
}

/// [`random_blend`] `size` times as large, seen from `distance` through a
/// field of view of `fov_y` degrees.
fn random_blend_from(n: &mut Numbers, size: f32, distance: f32, fov_y: f32) -> Scene {
    let mut parts = vec![];
    for _ in 0..(2 + (n.unit() * 6.0) as usize) {
        let radius = size * n.range(0.4, 1.2);
        let weight = if n.unit() < 0.15 { -n.range(0.1, 0.5) } else { n.range(0.6, 1.5) };
        let primitive = if n.unit() < 0.5 {
            format!("Point(center: {}, radius: {radius}, weight: {weight})", n.vec(-size, size))
        } else {
            format!("Segment(a: {}, b: {}, radius: {radius}, weight: {weight})", n.vec(-size, size), n.vec(-size, size))
        };
        parts.push(if n.unit() < 0.5 {
            format!(
                "Transform(translate: {}, rotate: {}, scale: {}, child: {primitive})",
                n.vec(-0.5 * size, 0.5 * size),
                n.vec(-90.0, 90.0),
                n.vec(0.5, 1.6)
            )
        } else {
            primitive
        });
    }
    let eye = Vec3::new(n.range(-1.0, 1.0), n.range(-1.0, 1.0), n.range(-1.0, 1.0)).normalize() * distance;
    let text = format!(
        "Scene(camera: Camera(eye: ({}, {}, {}), target: (0.0, 0.0, 0.0), up: (0.0, 1.0, 0.0), fov_y: {fov_y}), \
         size: (24, 18), threshold: 0.5, model: Blend([{}]))",
        eye.x,
        eye.y,
        eye.z,
        parts.join(", ")
    );
    Scene::parse(&text, "random blend").unwrap()
}

#[test]
fn random_blends_of_points_and_segments_under_transforms_agree_with_the_segment_tracer() {
    let mut numbers = Numbers(7);
    let mut hits = 0;
    for case in 0..200 {
        let scene = random_blend(&mut numbers);
        let (h, bad) = agreement(&scene, (24, 18));
        hits += h;
        assert!(bad.is_empty(), "case {case}: {} disagree: {:?}", bad.len(), &bad[..bad.len().min(5)]);
    }
    assert!(hits > 200 * 24 * 18 / 10, "{hits} hits over 200 cases");
}

#[test]
fn random_blends_seen_from_afar_agree_with_the_segment_tracer() {
    // Ten times as large and seen from 300 away, as a cloud of points is:
    // the rounding allowance grows with how far rays reach, and stretches
    // start within it of `T` more often (a tracer handing the snap such a
    // stretch whole missed a surface in case 147).
    let mut numbers = Numbers(19);
    let mut hits = 0;
    for case in 0..200 {
        let scene = random_blend_from(&mut numbers, 10.0, 300.0, 6.0);
        let (h, bad) = agreement(&scene, (24, 18));
        hits += h;
        assert!(bad.is_empty(), "case {case}: {} disagree: {:?}", bad.len(), &bad[..bad.len().min(5)]);
    }
    assert!(hits > 200 * 24 * 18 / 10, "{hits} hits over 200 cases");
}

#[test]
fn a_blend_seen_from_thirty_thousand_away_is_traced_alike_by_both_tracers() {
    // Lattice steps far finer than the floats resolve that far out: both
    // tracers must still end, and agree.
    let text = "Scene(camera: Camera(eye: (0.0, 0.0, 30000.0), target: (0.0, 0.0, 0.0), up: (0.0, 1.0, 0.0), \
                fov_y: 0.01), size: (32, 24), threshold: 0.5, model: Blend([\
                Point(center: (0.0, 0.0, 0.0), radius: 1.0), Point(center: (0.8, 0.3, 0.0), radius: 1.0), \
                Segment(a: (-1.0, -1.0, 0.5), b: (1.0, 0.5, -0.5), radius: 0.6)]))";
    assert_agrees(&Scene::parse(text, "far blend").unwrap(), (32, 24), 40);
}

/// A lone point of support radius 1 and weight `weight` at the origin, and its kernel tracer for `camera`.
fn lone_point(weight: f32) -> Scene {
    let text = format!(
        "Scene(camera: Camera(eye: (0.0, 0.0, 4.0), target: (0.0, 0.0, 0.0), up: (0.0, 1.0, 0.0), fov_y: 30.0), \
         size: (32, 24), threshold: 0.5, model: Point(center: (0.0, 0.0, 0.0), radius: 1.0, weight: {weight}))"
    );
    Scene::parse(&text, "lone point").unwrap()
}

/// Traces one ray from `eye` through `through` with the kernel tracer.
fn trace_one(scene: &Scene, eye: Vec3A, through: Vec3A) -> TraceResult {
    let s = scene.render_settings(Size(1, 1));
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let camera = crate::camera::Camera::look_at(eye.into(), through.into(), Vec3::Y, 1.0);
    let kernel = KernelTracer::new(&scene.model, EvalMode::Indexed, &camera, (1, 1)).unwrap();
    kernel.trace(&field, &Ray::new(eye, through - eye), (0, 0), &s.trace)
}

#[test]
fn a_peak_barely_above_the_threshold_is_hit_from_every_direction() {
    // Peak T·(1 + 1e-4): inside within r = sqrt(1 - (1 + 1e-4)^(-1/3)) ≈ 0.00577 of the centre.
    let scene = lone_point(0.5 * (1.0 + 1e-4));
    let inside = (1.0 - (1.0f32 + 1e-4).powf(-1.0 / 3.0)).sqrt();
    let q = scene.render_settings(Size(1, 1)).trace.quantum.unwrap();
    let mut numbers = Numbers(11);
    for _ in 0..64 {
        let dir = Vec3A::new(numbers.range(-1.0, 1.0), numbers.range(-1.0, 1.0), numbers.range(-1.0, 1.0)).normalize();
        let eye = dir * 3.0;
        // Through the centre, and half the inside radius off it (chords 0.0115 and 0.0100, ≫ q).
        let off = dir.any_orthonormal_vector() * (0.5 * inside);
        for through in [Vec3A::ZERO, off] {
            let chord = 2.0 * (inside * inside - through.length_squared()).sqrt();
            assert!(chord > 10.0 * q);
            let r = trace_one(&scene, eye, through);
            let t = r.hit.unwrap_or_else(|| panic!("from {eye}: missed the peak through {through}"));
            let depth = (eye - through).length();
            assert!((t - depth).abs() <= 0.5 * chord + q, "from {eye}: hit at {t}, the peak at {depth}");
        }
    }
}

#[test]
fn a_ray_grazing_a_sphere_is_hit_and_depths_match_the_analytic_sphere() {
    let scene = lone_point(1.0);
    // Wyvill's surface of a lone point: (1 - r²)³ = T.
    let radius = (1.0 - 0.5f32.powf(1.0 / 3.0)).sqrt();
    let eye = Vec3A::new(0.0, 0.0, 4.0);
    for offset in [0.0, 0.3, 0.6, 0.9, 0.99, 0.999] {
        let h = offset * radius;
        let r = trace_one(&scene, eye, Vec3A::new(h, 0.0, 0.0));
        let t = r.hit.unwrap_or_else(|| panic!("a ray {offset} of the radius off the centre missed"));
        // The ray towards (h, 0, 0): its closest approach and the entry chord.
        let ray = Ray::new(eye, Vec3A::new(h, 0.0, 0.0) - eye);
        let b = eye.dot(ray.dir);
        let analytic = -b - (b * b - eye.length_squared() + radius * radius).sqrt();
        assert!((t - analytic).abs() <= 1e-4 * 1.0, "offset {offset}: {t} against {analytic}");
        assert!(r.evals <= 2, "offset {offset}: {} evaluations; the crossed supports' sum settles most snaps", r.evals);
    }
}

#[test]
fn a_placed_point_set_is_traced_as_the_same_points_listed_one_by_one() {
    // The same points under the same non-uniform placement, once as a point
    // set read from a file (traced from the set's arrays) and once as a
    // blend of points (copied one by one): the supports, and so every hit,
    // must be the same.
    let dir = std::env::temp_dir().join(format!("blobtrace-kernel-set-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let points: Vec<Vec3> =
        (0..40).map(|i| Vec3::new((i % 5) as f32 * 0.7, (i / 5 % 4) as f32 * 0.8, (i / 20) as f32 * 0.9)).collect();
    let text: String = points.iter().map(|p| format!("{} {} {}\n", p.x, p.y, p.z)).collect();
    std::fs::write(dir.join("pts.xyz"), text).unwrap();
    let blend: Vec<String> =
        points.iter().map(|p| format!("Point(center: ({}, {}, {}), radius: 1.1)", p.x, p.y, p.z)).collect();
    let scene = |child: &str| {
        let text = format!(
            "Scene(camera: Camera(eye: (1.5, 1.0, 9.0), target: (1.5, 1.0, 0.5), up: (0.0, 1.0, 0.0), fov_y: 50.0), \
             size: (48, 40), threshold: 0.5, model: Blend([Point(center: (-1.0, 0.0, 0.0), radius: 1.2), \
             Transform(translate: (0.3, -0.2, 0.1), rotate: (10.0, 20.0, 5.0), scale: (1.3, 0.8, 1.1), child: {child})]))"
        );
        let path = dir.join(format!("{}.ron", child.len()));
        std::fs::write(&path, text).unwrap();
        Scene::load(&path).unwrap()
    };
    // Sets before and after a listed point: runs of every kind, in order.
    let set = "Points(file: \"pts.xyz\", radius: 1.1)";
    let extra = "Point(center: (1.0, 3.5, 0.5), radius: 0.9)";
    let from_set = scene(&format!("Blend([{set}, {extra}, {set}])"));
    let listed = scene(&format!("Blend([{0}, {extra}, {0}])", blend.join(", ")));
    let (a, b) = [&from_set, &listed].map(|s| KernelSupports::of(&s.model, EvalMode::Indexed).unwrap()).into();
    assert_eq!(a.len(), 82);
    assert_eq!(a.len(), b.len());
    let probe = Vec3A::new(1.2, 1.0, 0.7);
    for i in 0..a.len() {
        assert_eq!(a.world_box(i), b.world_box(i), "support {i}");
        assert_eq!(a.world_sphere(i), b.world_sphere(i), "support {i}");
        assert_eq!(a.value(i, probe), b.value(i, probe), "support {i}");
    }
    assert!((0..a.len()).filter(|&i| a.value(i, probe) > 0.0).count() > 3, "the probe lies in some supports");
    let s = from_set.render_settings(Size(48, 40));
    let tracers = [&from_set, &listed].map(|sc| KernelTracer::new(&sc.model, EvalMode::Indexed, &s.camera, (48, 40)));
    let fields = [&from_set, &listed].map(|sc| ModelField::new(&sc.model, EvalMode::Indexed));
    let mut hits = 0;
    for y in 0..40 {
        for x in 0..48 {
            let ray = s.camera.ray(x, y, 48, 40);
            let [ka, kb] = [0, 1].map(|k| tracers[k].as_ref().unwrap().trace(&fields[k], &ray, (x, y), &s.trace));
            assert_eq!((ka.hit, ka.steps), (kb.hit, kb.steps), "pixel {x},{y}");
            hits += u32::from(ka.hit.is_some());
        }
    }
    assert!(hits > 300, "{hits} hits");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_overlap_estimate_does_not_depend_on_where_the_model_lies() {
    // A lattice of points 0.3 apart with radius 0.25 and a point 1000 units
    // away, then the same 900,000 units off the origin (map coordinates,
    // say): 3.6 million cells of the estimate from it.
    let blend = |offset: f32| {
        let points: Vec<String> = (0..216)
            .map(|i| {
                let (x, y, z) = ((i % 6) as f32 * 0.3, (i / 6 % 6) as f32 * 0.3 + offset, (i / 36) as f32 * 0.3);
                format!("Point(center: ({x}, {y}, {z}), radius: 0.25)")
            })
            .collect();
        let text = format!(
            "Scene(camera: Camera(eye: (0.0, {offset}, 20.0), target: (0.0, {offset}, 0.0), up: (0.0, 1.0, 0.0), \
             fov_y: 40.0), size: (8, 8), threshold: 0.5, model: Blend([{}, Point(center: (0.0, {}, 0.0), radius: 0.25)]))",
            points.join(", "),
            offset + 1000.0
        );
        let scene = Scene::parse(&text, "inline").unwrap();
        KernelSupports::of(&scene.model, EvalMode::Indexed).unwrap().overlap()
    };
    let (near, far) = (blend(0.0), blend(9.0e5));
    assert!(near > 1.0, "{near}");
    assert!((far / near - 1.0).abs() < 0.1, "{near} at the origin, {far} 900,000 units off");
}

#[test]
fn a_stretch_starting_within_the_margin_of_t_is_searched_from_its_start() {
    // Three points of a million-point cloud (`gen2.py 1000000`) and the ray
    // of its pixel (388, 125), with two more as far out as the cloud reaches
    // (the margin grows with the distances rays reach): the field rises above
    // `T` 0.02 after the third support's entry, where the sum starts within
    // the margin of `T`, and stays above it for 1.2 (0.65 at its peak). The
    // tracer once handed the snap the whole stretch, which tried its far end
    // alone, found it outside and marched on past the chord.
    let text = "Scene(camera: Camera(eye: (0.0, -448.0, 0.0), target: (0.0, 0.0, 0.0), up: (0.0, 0.0, 1.0), \
                fov_y: 60.0), size: (500, 500), threshold: 0.5, model: Blend([\
                Point(center: (96.64091, -144.36513, 89.07211), radius: 2.25), \
                Point(center: (97.99042, -144.22478, 87.88926), radius: 2.25), \
                Point(center: (99.05194, -143.66639, 88.15077), radius: 2.25), \
                Point(center: (-200.0, 200.0, -200.0), radius: 2.25), \
                Point(center: (200.0, -200.0, 200.0), radius: 2.25)]))";
    let scene = Scene::parse(text, "five points").unwrap();
    let s = scene.render_settings(Size(500, 500));
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let kernel = KernelTracer::new(&scene.model, EvalMode::Indexed, &s.camera, (500, 500)).unwrap();
    let ray = s.camera.ray(388, 125, 500, 500);
    let (first, _) = brute_force(&field, &ray, s.trace.quantum.unwrap()).expect("the ray crosses the surface");
    assert!((first - 330.51).abs() < 0.01 && field.value(ray.at(first + 0.6)) > 0.6, "the chord: from {first}");
    assert_eq!(kernel.trace(&field, &ray, (388, 125), &s.trace).hit, Some(first));
}

/// A cloud of `n` points at the particles scene's density: chains of fifty
/// random-walk points 1.8 apart of radius 2.25, started in a cube whose side
/// grows as `n`'s cube root, seen from in front; `place` wraps its blend.
fn cloud(n: usize, place: impl Fn(String) -> String) -> Scene {
    let mut numbers = Numbers(7);
    let side = 14.0 * (n as f32 / 1000.0).cbrt();
    let mut points = Vec::with_capacity(n);
    while points.len() < n {
        let mut p = Vec3::new(numbers.range(-side, side), numbers.range(-side, side), numbers.range(-side, side));
        for _ in 0..50.min(n - points.len()) {
            points.push(format!("Point(center: ({}, {}, {}), radius: 2.25)", p.x, p.y, p.z));
            let (angle, z) = (numbers.range(0.0, std::f32::consts::TAU), numbers.range(-1.0, 1.0));
            let r = (1.0 - z * z).sqrt();
            p += 1.8 * Vec3::new(r * angle.cos(), r * angle.sin(), z);
        }
    }
    let text = format!(
        "Scene(camera: Camera(eye: (0.0, {}, 0.0), target: (0.0, 0.0, 0.0), up: (0.0, 0.0, 1.0), fov_y: 60.0), \
         size: (64, 64), threshold: 0.5, model: {})",
        -3.2 * side,
        place(format!("Blend([{}])", points.join(", ")))
    );
    Scene::parse(&text, "cloud").unwrap()
}

/// Traces every pixel of `scene` at 64×64 walking its index's cells, from
/// tiles' lists and by segments: the hits must be the same to the bit.
fn assert_walks_alike(scene: &Scene) {
    let size = (64, 64);
    let s = scene.render_settings(Size(size.0, size.1));
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let supports = Arc::new(KernelSupports::of(&scene.model, EvalMode::Indexed).unwrap());
    let walking = KernelTracer::of_supports(Arc::clone(&supports), &s.camera, size);
    let listing = KernelTracer::gathering(supports, &s.camera, size, false);
    assert!(walking.walks_cells() && !listing.walks_cells());
    let mut hits = 0;
    for y in 0..size.1 {
        for x in 0..size.0 {
            let ray = s.camera.ray(x, y, size.0, size.1);
            let walked = walking.trace(&field, &ray, (x, y), &s.trace);
            assert_eq!(walked.hit, listing.trace(&field, &ray, (x, y), &s.trace).hit, "pixel {x},{y}");
            assert_eq!(walked.hit, trace_ray(&field, &ray, &s.trace).hit, "pixel {x},{y}");
            hits += u32::from(walked.hit.is_some());
        }
    }
    assert!(hits > 1500, "{hits} hits");
}

#[test]
fn a_cloud_walked_cell_by_cell_is_hit_where_tiles_lists_and_the_segment_tracer_hit_it() {
    // Twenty thousand points at 64×64: more than two supports a pixel, so
    // rays walk the index's cells.
    assert_walks_alike(&cloud(20_000, |blend| blend));
}

#[test]
fn a_placed_cloud_is_walked_in_its_own_frame() {
    // The same cloud turned, stretched unevenly and moved: its index lies in
    // its own frame, and rays walk it seen there.
    let place = |blend| {
        format!(
            "Transform(translate: (3.0, -5.0, 2.0), rotate: (20.0, 10.0, 35.0), scale: (1.3, 0.7, 1.1), child: {blend})"
        )
    };
    assert_walks_alike(&cloud(20_000, place));
}
