//! The mesh quality report and the remedies, against hand-built meshes whose
//! answers are known and against independent recomputations on real meshes.

mod common;

use std::collections::{HashMap, HashSet};

use blobtrace::field::EvalMode;
use blobtrace::mesh::Mesh;
use blobtrace::mesh::quality::{
    ComponentSummary, Components, Edges, MeshQuality, self_intersections, self_intersections_in_cubes,
};
use blobtrace::mesh::repair::{drop_small_components, fix_normals, snap_to_corners};
use blobtrace::mesh::{CellShape, Lattice, PolygonizeOptions, VertexPlacement};
use blobtrace::pipeline::{MeshRepair, PolygonizeSettings, Silent, polygonize};
use blobtrace::scene::Scene;
use common::{blobtrace, bundled, scratch};
use glam::Vec3;

/// A mesh from positions and triangles, with normals from the faces.
fn mesh(positions: &[[f32; 3]], triangles: &[[u32; 3]]) -> Mesh {
    let mut m = Mesh {
        positions: positions.iter().map(|&p| Vec3::from(p)).collect(),
        triangles: triangles.to_vec(),
        ..Mesh::default()
    };
    m.set_normals_from_faces();
    m
}

/// A mesh's positions and triangles, before they are joined into one.
type Part = (Vec<[f32; 3]>, Vec<[u32; 3]>);

/// An outward-facing tetrahedron with corner `at` and side `s`.
fn tetrahedron(at: [f32; 3], s: f32) -> Part {
    let [x, y, z] = at;
    (vec![[x, y, z], [x + s, y, z], [x, y + s, z], [x, y, z + s]], vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
}

/// An outward-facing axis-aligned cube of side `s` at `at`.
fn cube(at: [f32; 3], s: f32) -> Part {
    let p: Vec<[f32; 3]> = (0..8)
        .map(|i| [at[0] + s * (i & 1) as f32, at[1] + s * (i >> 1 & 1) as f32, at[2] + s * (i >> 2 & 1) as f32])
        .collect();
    let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let t = quads.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]).collect();
    (p, t)
}

/// Several meshes in one.
fn joined(parts: &[Part]) -> Mesh {
    let (mut positions, mut triangles) = (vec![], vec![]);
    for (p, t) in parts {
        let base = positions.len() as u32;
        positions.extend_from_slice(p);
        triangles.extend(t.iter().map(|tri| tri.map(|i| i + base)));
    }
    mesh(&positions, &triangles)
}

/// A torus of `n × n` quads (each cut in two), outward facing.
fn torus(n: u32) -> Mesh {
    let (big, small) = (2.0f32, 0.6f32);
    let mut positions = vec![];
    for i in 0..n {
        for j in 0..n {
            let (u, v) = (i as f32 / n as f32 * std::f32::consts::TAU, j as f32 / n as f32 * std::f32::consts::TAU);
            let r = big + small * v.cos();
            positions.push([r * u.cos(), r * u.sin(), small * v.sin()]);
        }
    }
    let id = |i: u32, j: u32| (i % n) * n + (j % n);
    let mut triangles = vec![];
    for i in 0..n {
        for j in 0..n {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            triangles.extend([[a, b, c], [a, c, d]]);
        }
    }
    mesh(&positions, &triangles)
}

#[test]
fn a_cube_and_a_small_tetrahedron_are_two_closed_pieces_one_an_island() {
    let m = joined(&[cube([0.0; 3], 1.0), tetrahedron([3.0, 0.0, 0.0], 0.5)]);
    let q = MeshQuality::of(&m);
    assert!(q.watertight, "{q:?}");
    // Both are islands under the default bound of 50 triangles; under 4, the tetrahedron alone.
    assert_eq!((q.components.count, q.components.islands, q.components.island_triangles_total), (2, 2, 16));
    let pieces = Components::of(&m.triangles, &Edges::of(&m.triangles));
    let under_four = ComponentSummary::of(&pieces, 4);
    assert_eq!((under_four.islands, under_four.island_triangles_total), (1, 4));
    assert_eq!(pieces.of_triangle, [vec![0; 12], vec![1; 4]].concat(), "the larger piece first");
    let [big, small] = [q.components.largest[0], q.components.largest[1]];
    assert_eq!((big.triangles, big.vertices, big.edges, big.euler_characteristic, big.genus), (12, 8, 18, 2, Some(0)));
    assert_eq!((small.triangles, small.vertices, small.edges, small.euler_characteristic), (4, 4, 6, 2));
    assert_eq!(q.topology.euler_characteristic, 4);
    assert_eq!((q.normals.against_faces, q.self_intersections), (0, Some(0)));
}

#[test]
fn a_torus_has_genus_one() {
    let q = MeshQuality::of(&torus(8));
    assert!(q.watertight);
    let piece = q.components.largest[0];
    assert_eq!((piece.euler_characteristic, piece.genus), (0, Some(1)));
    assert_eq!(q.components.total_genus, 1);
}

#[test]
fn holes_and_edges_shared_three_times_are_not_watertight() {
    let (p, t) = tetrahedron([0.0; 3], 1.0);
    let open = MeshQuality::of(&mesh(&p, &t[..3]));
    assert!(!open.watertight);
    assert_eq!(open.topology.boundary_edges, 3);
    let piece = open.components.largest[0];
    assert_eq!((piece.boundary_edges, piece.closed, piece.genus), (3, false, None));
    // Three triangles on the edge 0–1.
    let fan = mesh(
        &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]],
        &[[0, 1, 2], [1, 0, 3], [0, 1, 4]],
    );
    let q = MeshQuality::of(&fan);
    assert_eq!((q.topology.nonmanifold_edges, q.components.count), (1, 1));
}

#[test]
fn a_sliver_sets_the_smallest_angle_and_the_lowest_quality_bin() {
    let h = 0.001f32;
    let m = mesh(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, h, 0.0], [0.5, 0.8660254, 0.0]], &[[0, 1, 2], [0, 1, 3]]);
    let shape = MeshQuality::of(&m).shape;
    let expected = f64::from(h).atan2(0.5).to_degrees();
    assert!((shape.min_angle_degrees - expected).abs() < 1e-4, "{} against {expected}", shape.min_angle_degrees);
    assert_eq!(shape.below_1_degree, 1);
    assert_eq!(shape.histogram[0], 1, "the sliver");
    assert_eq!(shape.histogram[9], 1, "the equilateral triangle");
    assert_eq!(shape.histogram.iter().sum::<u64>(), 2);
    assert!(shape.measure.contains("area"));
}

#[test]
fn a_normal_turned_inwards_is_counted_and_fixed() {
    let (p, t) = tetrahedron([0.0; 3], 1.0);
    let mut m = mesh(&p, &t);
    let outward = m.normals[3];
    m.normals[3] = -outward;
    let q = MeshQuality::of(&m);
    assert_eq!(q.normals.against_faces, 1);
    assert!((q.normals.smallest_cosine + 1.0).abs() < 1e-6, "{}", q.normals.smallest_cosine);
    // A gradient pointing inwards (a field growing outwards) agrees with the faces.
    let mut by_gradient = m.clone();
    let fix = fix_normals(&mut by_gradient, |p| -(p - Vec3::splat(0.25)));
    assert_eq!((fix.against_faces, fix.from_gradient, fix.from_faces), (1, 1, 0));
    assert!(by_gradient.normals[3].dot(outward) > 0.9);
    // A gradient that disagrees too leaves the faces to decide.
    let fix = fix_normals(&mut m, |p| p - Vec3::splat(0.25));
    assert_eq!((fix.from_gradient, fix.from_faces), (0, 1));
    assert!((m.normals[3] - outward).length() < 1e-6);
    assert_eq!(MeshQuality::of(&m).normals.against_faces, 0);
}

#[test]
fn triangles_cutting_through_each_other_are_found_and_neighbours_are_not() {
    // A cube pierced by a thin triangle whose corners lie outside it.
    let pierce = (vec![[0.2, 0.6, -1.0], [0.2, 0.7, 2.0], [0.3, 0.6, 2.0]], vec![[0, 1, 2]]);
    let m = joined(&[cube([0.0; 3], 1.0), pierce]);
    let pairs = self_intersections(&m.positions, &m.triangles);
    assert_eq!(pairs.len(), 2, "through the bottom and the top: {pairs:?}");
    assert_eq!(pairs, [(0, 12), (3, 12)], "one half of the bottom and one of the top");
    assert_eq!(MeshQuality::of(&m).self_intersections, Some(2));
    assert!(self_intersections(&torus(12).positions, &torus(12).triangles).is_empty());
}

#[test]
fn every_bundled_scene_crosses_itself_cube_by_cube_as_the_walk_over_all_finds() {
    // Cube meshes take the one pass over their triangles in order; reversed,
    // they are sorted by cube first; tetrahedra lie across cubes and are walked.
    let mut crossings = 0;
    let scenes =
        ["bottle", "crown", "example", "hair_point", "medusa", "pair", "particles", "sharp", "sphere", "warps"];
    for scene in scenes.map(|s| format!("{s}.ron")) {
        let model = bundled(&scene).model;
        for (cells, vertex) in [
            (CellShape::Cubes, VertexPlacement::default()),
            (CellShape::Cubes, VertexPlacement::Linear),
            (CellShape::Bcc, VertexPlacement::Linear),
        ] {
            let (_, m) = common::polygonize(&model, EvalMode::Indexed, 48, PolygonizeOptions { cells, vertex });
            let lattice = Lattice::across(&model.bounds(), 48);
            let walked = self_intersections(&m.positions, &m.triangles);
            let what = format!("{scene} {cells:?} {vertex:?}");
            assert_eq!(self_intersections_in_cubes(&m.positions, &m.triangles, &lattice), walked, "{what}");
            let n = m.triangles.len() as u32;
            let reversed: Vec<[u32; 3]> = m.triangles.iter().rev().copied().collect();
            let mut back: Vec<(u32, u32)> = walked.iter().map(|&(s, t)| (n - 1 - t, n - 1 - s)).collect();
            back.sort_unstable();
            assert_eq!(self_intersections_in_cubes(&m.positions, &reversed, &lattice), back, "{what}, reversed");
            crossings += walked.len();
        }
    }
    assert!(crossings > 0, "some bundled mesh crosses itself");
}

#[test]
fn the_pieces_pass_counts_every_kind_of_edge_as_the_topology_does() {
    let hair = bundled("hair_point.ron").model;
    let (_, real) = common::polygonize(&hair, EvalMode::Indexed, 64, PolygonizeOptions::default());
    let cases = [
        // (what, triangles, [boundary, misoriented, nonmanifold] edges)
        ("a closed tetrahedron", vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]], [0, 0, 0]),
        ("one face turned", vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 2, 3]], [0, 3, 0]),
        ("three triangles on one edge", vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]], [6, 0, 1]),
        ("a corner used twice", vec![[0, 0, 1], [0, 1, 2]], [3, 0, 1]),
        ("the point/hair mesh at res 64", real.triangles.clone(), [0, 0, 0]),
    ];
    for (what, triangles, [boundary, misoriented, nonmanifold]) in cases {
        let topology = Components::of(&triangles, &Edges::of(&triangles)).topology;
        assert_eq!(topology, blobtrace::mesh::Topology::of(&triangles), "{what}");
        let counted = [topology.boundary_edges, topology.misoriented_edges, topology.nonmanifold_edges];
        assert_eq!(counted, [boundary, misoriented, nonmanifold], "{what}: {topology:?}");
    }
}

#[test]
fn dropping_small_pieces_keeps_the_others_whole() {
    let mut m = joined(&[tetrahedron([3.0, 0.0, 0.0], 0.5), cube([0.0; 3], 1.0), tetrahedron([-3.0, 0.0, 0.0], 0.2)]);
    let cube_positions: Vec<Vec3> = m.positions[4..12].to_vec();
    assert_eq!(drop_small_components(&mut m, 5), 2);
    assert_eq!((m.triangles.len(), m.positions.len(), m.normals.len()), (12, 8, 8));
    assert_eq!(m.positions, cube_positions, "the kept vertices in order");
    assert!(MeshQuality::of(&m).watertight);
    assert_eq!(drop_small_components(&mut m, 5), 0);
}

#[test]
fn snapping_merges_the_vertices_next_to_a_corner_and_keeps_the_mesh_closed() {
    // A sphere through the polygonizer, then snapped: every vertex either sits
    // on a lattice corner or lies farther than the snap distance from every corner.
    let scene = Scene::parse(
        "Scene(camera: Camera(eye: (0.0, 0.0, 5.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (8, 8),
               model: Point(center: (0.1, 0.2, 0.3), radius: 1.0))",
        "inline",
    )
    .unwrap();
    let settings = PolygonizeSettings { res: 24, ..Default::default() };
    let (mut m, report) = polygonize(&scene.model, EvalMode::Indexed, &settings, &Silent).unwrap();
    let cell = report.cell_size;
    let before = MeshQuality::of(&m);
    let snap = snap_to_corners(&mut m, cell, 0.2);
    let after = MeshQuality::of(&m);
    assert!(snap.corners > 0 && snap.moved >= snap.corners && snap.dropped_triangles > 0, "{snap:?}");
    assert!(after.watertight && after.components.count == 1, "{after:?}");
    assert_eq!(after.topology.euler_characteristic, 2);
    assert!(after.shape.min_angle_degrees > before.shape.min_angle_degrees.max(1.0), "{after:?}");
    for p in &m.positions {
        let k = (*p / cell).round();
        let on_corner = (*p / cell - k).abs().max_element() < 1e-4;
        let nearest = p.distance(k * cell) / cell;
        assert!(on_corner || nearest > 0.2 - 1e-4, "{p} is {nearest} cells from a corner");
    }
}

#[test]
fn the_pipeline_reports_what_each_remedy_did() {
    let scene = Scene::load(format!("{}/scenes/medusa.ron", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let repair = MeshRepair { snap: Some(0.1), min_component: Some(50), fix_normals: true };
    let settings = PolygonizeSettings { res: 64, repair, ..Default::default() };
    let (m, report) = polygonize(&scene.model, EvalMode::Indexed, &settings, &Silent).unwrap();
    let repairs = report.repairs.expect("remedies were asked for");
    let snap = repairs.snap.expect("snapped");
    assert!(snap.snap.corners > 0 && snap.max_distance_cells[1] <= 0.11, "{snap:?}");
    assert!(snap.min_angle_degrees[1] > snap.min_angle_degrees[0], "{snap:?}");
    assert!(repairs.dropped_components.is_some());
    let quality = report.quality.as_ref().expect("the full report by default");
    assert!(quality.components.largest.iter().all(|c| c.triangles >= 50));
    assert!(quality.watertight && quality.normals.against_faces == 0, "{quality:?}");
    assert_eq!(report.triangles, m.triangles.len());
}

/// Pieces and their Euler characteristics by a different route: flood fill
/// over triangles sharing an edge, counted with hash sets.
fn pieces_by_flood_fill(m: &Mesh) -> Vec<(usize, i64)> {
    let mut by_edge: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
    for (t, tri) in m.triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            by_edge.entry((a.min(b), a.max(b))).or_default().push(t);
        }
    }
    let mut seen = vec![false; m.triangles.len()];
    let mut pieces = vec![];
    for start in 0..m.triangles.len() {
        if seen[start] {
            continue;
        }
        seen[start] = true;
        let (mut stack, mut tris) = (vec![start], vec![]);
        while let Some(t) = stack.pop() {
            tris.push(t);
            let tri = m.triangles[t];
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                for &n in &by_edge[&(a.min(b), a.max(b))] {
                    if !std::mem::replace(&mut seen[n], true) {
                        stack.push(n);
                    }
                }
            }
        }
        let vertices: HashSet<u32> = tris.iter().flat_map(|&t| m.triangles[t]).collect();
        let edges: HashSet<(u32, u32)> = tris
            .iter()
            .flat_map(|&t| {
                let tri = m.triangles[t];
                (0..3).map(move |k| (tri[k].min(tri[(k + 1) % 3]), tri[k].max(tri[(k + 1) % 3])))
            })
            .collect();
        pieces.push((tris.len(), vertices.len() as i64 - edges.len() as i64 + tris.len() as i64));
    }
    pieces.sort_by(|a, b| b.cmp(a));
    pieces
}

#[test]
fn pieces_of_real_meshes_match_a_flood_fill() {
    let scene = Scene::load(format!("{}/scenes/hair_point.ron", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let (m, report) =
        polygonize(&scene.model, EvalMode::Indexed, &PolygonizeSettings { res: 64, ..Default::default() }, &Silent)
            .unwrap();
    let expected = pieces_by_flood_fill(&m);
    let summary = &report.quality.as_ref().expect("the full report by default").components;
    assert!(expected.len() > 1, "the scene has islands at res 64");
    assert_eq!(summary.count, expected.len());
    let mut listed: Vec<(usize, i64)> =
        summary.largest.iter().map(|c| (c.triangles as usize, c.euler_characteristic)).collect();
    listed.sort_by(|a, b| b.cmp(a));
    assert_eq!(listed, expected[..listed.len()].to_vec());
}

#[test]
fn mesh_json_carries_the_quality_report_and_remedies_are_checked() {
    let dir = common::scratch("mesh-quality");
    let out_path = dir.join("m.ply");
    let out = blobtrace(&[
        "mesh",
        "scenes/medusa.ron",
        "--res",
        "48",
        "--snap",
        "0.1",
        "--min-component",
        "20",
        "-o",
        out_path.to_str().unwrap(),
        "--json",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let q = &v["quality"];
    for key in ["topology", "watertight", "components", "shape", "normals", "self_intersections"] {
        assert!(!q[key].is_null(), "quality.{key} in {q}");
    }
    assert_eq!(q["shape"]["histogram"].as_array().unwrap().len(), 10);
    assert!(v["repairs"]["snap"]["corners"].as_u64().unwrap() > 0);
    for (args, flag) in [
        (vec!["--snap", "0.6"], "--snap"),
        (vec!["--snap", "0.1", "--cells", "bcc"], "--snap"),
        (vec!["--min-component", "0"], "--min-component"),
    ] {
        let mut all = vec!["mesh", "scenes/sphere.ron", "-o", out_path.to_str().unwrap()];
        all.extend(args);
        let out = blobtrace(&all);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(64), "{all:?}: {err}");
        assert!(err.contains(flag), "{all:?}: {err}");
    }
}

#[test]
fn the_quality_report_can_keep_its_cheap_figures_or_be_skipped_and_the_mesh_is_the_same() {
    let dir = scratch("mesh-quality-levels");
    let run = |level: &str| {
        let out_path = dir.join(format!("{level}.ply"));
        let args = ["mesh", "scenes/pair.ron", "--res", "40", "--quality", level, "-o", out_path.to_str().unwrap()];
        let out = blobtrace(&[&args[..], &["--json"]].concat());
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        (v, std::fs::read(out_path).unwrap())
    };
    let ((full, full_mesh), (summary, summary_mesh), (off, off_mesh)) = (run("full"), run("summary"), run("off"));
    assert!(full_mesh == summary_mesh && full_mesh == off_mesh, "the report never changes the mesh");
    assert_eq!(full["quality"]["self_intersections"], 0);
    assert!(summary["quality"]["self_intersections"].is_null(), "summary does not look for them");
    for key in ["topology", "watertight", "components", "shape", "normals"] {
        assert_eq!(summary["quality"][key], full["quality"][key], "{key}");
    }
    assert!(off.get("quality").is_none() && off["closed_manifold"] == full["closed_manifold"]);
    assert_eq!(full["closed_manifold"], true);
    let bad = blobtrace(&["mesh", "scenes/pair.ron", "--quality", "some"]);
    assert_eq!(bad.status.code(), Some(64));
    std::fs::remove_dir_all(dir).unwrap();
}
