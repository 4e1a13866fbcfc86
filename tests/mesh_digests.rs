//! The polygonizer's meshes held to fingerprints recorded from an earlier
//! version of its stores: every bundled scene at res 64, 128 and 256, with
//! cubes and BCC tetrahedra, root and linear vertices, gives the same set of
//! triangles and vertices (exact bits) however the vertices are numbered.
//!
//! `BLOBTRACE_RECORD_DIGESTS=1 cargo test --release --test mesh_digests`
//! rewrites the record from the code as it is.

mod common;

use blobtrace::field::EvalMode;
use blobtrace::mesh::{CellShape, Lattice, PolygonizeOptions, VertexPlacement};
use blobtrace::pipeline::polygonizer_on;
use common::bundled;

const RECORD: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/mesh_digests.txt");

/// One line of the record: what was polygonized and what came out.
fn line(scene: &str, res: u32, cells: CellShape, vertex: VertexPlacement) -> String {
    let model = bundled(scene).model;
    let options = PolygonizeOptions { cells, vertex };
    let mesh = polygonizer_on(&model, EvalMode::Indexed, Lattice::for_model(&model, res), options).mesh();
    let vertex = if vertex == VertexPlacement::Linear { "linear" } else { "root" };
    format!(
        "{scene} {res} {cells:?} {vertex}: {} triangles, {} vertices, {:016x}",
        mesh.triangles.len(),
        mesh.positions.len(),
        mesh.digest()
    )
}

fn scenes() -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".ron"))
        .collect();
    names.sort();
    names
}

#[test]
fn every_bundled_scene_meshes_as_recorded() {
    let mut runs = vec![];
    for scene in scenes() {
        for res in [64, 128, 256] {
            for cells in [CellShape::Cubes, CellShape::Bcc] {
                for vertex in [VertexPlacement::Linear, VertexPlacement::default()] {
                    runs.push((scene.clone(), res, cells, vertex));
                }
            }
        }
    }
    // Polygonizations run one after another, each with every thread.
    let lines: Vec<String> = runs.iter().map(|(s, r, c, v)| line(s, *r, *c, *v)).collect();
    if std::env::var_os("BLOBTRACE_RECORD_DIGESTS").is_some() {
        std::fs::write(RECORD, lines.join("\n") + "\n").unwrap();
        return;
    }
    let recorded = std::fs::read_to_string(RECORD).expect("the record exists");
    let recorded: Vec<&str> = recorded.lines().collect();
    assert_eq!(recorded.len(), lines.len(), "one line per polygonization");
    let differing: Vec<String> = recorded
        .iter()
        .zip(&lines)
        .filter(|(r, l)| r != l)
        .map(|(r, l)| format!("recorded {r}\n     now {l}"))
        .collect();
    assert!(differing.is_empty(), "{} meshes differ:\n{}", differing.len(), differing.join("\n"));
}
