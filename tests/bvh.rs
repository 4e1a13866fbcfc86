//! The mesh ray caster: BVH hits against a brute-force loop, the obvhs
//! validator, and the rendered depth of the polygonized sphere.

mod common;

use blobtrace::bvh::{BvhUpdate, DynamicMesh, MeshBvh, RayTarget, StaticMesh, brute_force_intersect, render_mesh};
use blobtrace::field::{Edit, EvalMode, ModelField, NodeKind, Placement};
use blobtrace::geom::Ray;
use blobtrace::mesh::{Mesh, PolygonizeOptions, Polygonizer, canonical_triangles, skeleton_seeds};
use blobtrace::scene::{Scene, Size};
use common::{EVERY_NODE, Rng, bundled, polygonize};
use glam::{Vec3, Vec3A};

fn polygonized(scene: &Scene, res: u32) -> (Polygonizer, Mesh) {
    polygonize(&scene.model, EvalMode::Indexed, res, PolygonizeOptions::default())
}

#[test]
fn bvh_hits_equal_a_brute_force_loop_over_every_triangle() {
    let scene = Scene::parse(EVERY_NODE, "every").unwrap();
    let (_, mesh) = polygonized(&scene, 24);
    let bvh = MeshBvh::build(&mesh);
    assert!(bvh.is_valid());
    let bounds = scene.model.bounds();
    let mut rng = Rng(7);
    let mut hits = 0;
    for _ in 0..3000 {
        // From outside the bounds towards a random point inside them.
        let target = rng.point_in(bounds.min, bounds.max);
        let origin = bounds.center() + (rng.point_in(Vec3A::splat(-1.0), Vec3A::ONE)).normalize() * bounds.diagonal();
        let ray = Ray::new(origin, target - origin);
        let (fast, tests) = bvh.intersect(&ray);
        let slow = brute_force_intersect(&mesh, &ray);
        assert_eq!(fast.is_some(), slow.is_some(), "ray {ray:?}");
        if let (Some(f), Some(s)) = (fast, slow) {
            assert_eq!(f.t, s.t, "ray {ray:?}: triangle {} vs {}", f.triangle, s.triangle);
            assert!((tests as usize) < mesh.triangles.len() / 10, "{tests} tests");
            hits += 1;
        }
    }
    assert!(hits > 300, "{hits} of the rays hit");
}

#[test]
fn sphere_mesh_depth_is_within_one_cell_of_the_analytic_depth() {
    let scene = bundled("sphere.ron");
    let (polygonizer, mesh) = polygonized(&scene, 48);
    let lattice = polygonizer.lattice();
    let settings = scene.render_settings(Size(96, 72));
    let (frame, stats) = render_mesh(&StaticMesh { mesh: &mesh, bvh: &MeshBvh::build(&mesh) }, &settings, &|_| {});
    let radius = 2.0 * (1.0 - 0.5f32.cbrt()).sqrt();
    let (mut compared, mut silhouette_disagreements) = (0, 0);
    for y in 0..72 {
        for x in 0..96 {
            let ray = settings.camera.ray(x, y, 96, 72);
            // |o + t d|² = r² with the sphere at the origin.
            let b = ray.origin.dot(ray.dir);
            let disc = b * b - (ray.origin.length_squared() - radius * radius);
            let analytic = (disc >= 0.0).then(|| -b - disc.sqrt());
            let depth = frame.depth[(y * 96 + x) as usize];
            match analytic {
                Some(t) if depth.is_finite() => {
                    assert!((depth - t).abs() <= lattice.cell, "pixel {x},{y}: {depth} vs {t}");
                    compared += 1;
                }
                Some(_) | None if depth.is_finite() != analytic.is_some() => silhouette_disagreements += 1,
                _ => {}
            }
        }
    }
    assert!(compared > 1500, "{compared}");
    assert!(silhouette_disagreements < 40, "{silhouette_disagreements}");
    assert_eq!(stats.hits as usize, frame.hits());
}

#[test]
fn the_dynamic_bvh_follows_local_updates_and_stays_valid() {
    let mut scene = Scene::parse(EVERY_NODE, "every").unwrap();
    let (mut polygonizer, _) = polygonized(&scene, 32);
    // One mesh takes the cheaper of update and rebuild; the other always updates.
    let mut dynamic = DynamicMesh::build(&polygonizer);
    let mut incremental = DynamicMesh::build(&polygonizer);
    assert!(dynamic.is_valid());
    let mut choices = vec![];
    let arm = scene.model.find("arm").unwrap();
    let NodeKind::Named { child, .. } = scene.model.node(arm).kind else { panic!("arm is named") };
    let mut rng = Rng(11);
    for step in 0..4 {
        let to = Vec3::new(0.5 - 0.3 * step as f32, 0.3 + 0.4 * step as f32, -1.0 + 0.2 * step as f32);
        let placement = Placement::new(to, Vec3::new(20.0, -35.0, 50.0 + 10.0 * step as f32), Vec3::new(1.5, 0.7, 1.1));
        let change = scene.model.set_placement(child, placement.unwrap()).unwrap();
        let field = ModelField::new(&scene.model, EvalMode::Indexed);
        let seeds = skeleton_seeds(&scene.model, scene.model.root());
        let changed = polygonizer.repolygonize(&field, &change.old.union(&change.new), &seeds);
        assert!(!changed.added.is_empty() && !changed.removed.is_empty());
        choices.push(dynamic.update(&polygonizer, &changed));
        incremental.remove_and_insert(&polygonizer, &changed);
        assert!(dynamic.is_valid() && incremental.is_valid(), "step {step}");
        let (_, fresh) = polygonized(&scene, 32);
        assert_eq!(canonical_triangles(dynamic.triangles()), fresh.triangle_set(), "step {step}");
        assert_eq!(canonical_triangles(incremental.triangles()), fresh.triangle_set(), "step {step}");
        let bounds = scene.model.bounds();
        for _ in 0..300 {
            let target = rng.point_in(bounds.min, bounds.max);
            let origin = bounds.center() + rng.point_in(Vec3A::splat(-1.0), Vec3A::ONE).normalize() * bounds.diagonal();
            let ray = Ray::new(origin, target - origin);
            let expected = brute_force_intersect(&fresh, &ray).map(|h| h.t);
            assert_eq!(dynamic.hit(&ray).0.map(|h| h.t), expected, "step {step}, ray {ray:?}");
            assert_eq!(incremental.hit(&ray).0.map(|h| h.t), expected, "step {step}, ray {ray:?}");
        }
    }
    // Moving the arm across the scene changes most of the mesh: rebuilt.
    assert!(choices.contains(&BvhUpdate::Rebuilt), "{choices:?}");
}

#[test]
fn a_small_change_updates_the_bvh_in_place() {
    let mut scene = bundled("hair_point.ron");
    let (mut polygonizer, _) = polygonized(&scene, 48);
    let mut dynamic = DynamicMesh::build(&polygonizer);
    let change = scene.model.apply(&Edit::Translate { node: "probe".into(), by: Vec3::new(0.05, 0.0, 0.0) }).unwrap();
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let region = scene.model.change_region(&change, false);
    let changed = polygonizer.repolygonize(&field, &region, &skeleton_seeds(&scene.model, scene.model.root()));
    assert!(!changed.added.is_empty());
    assert_eq!(dynamic.update(&polygonizer, &changed), BvhUpdate::Incremental);
    assert!(dynamic.is_valid());
    assert_eq!(canonical_triangles(dynamic.triangles()), polygonizer.mesh().triangle_set());
}
