//! The polygonizer stage: a continuation polygonizer on a fixed global lattice
//! (cubes or body-centred-cubic tetrahedra), local re-polygonization after an
//! edit, and the indexed triangle mesh it produces, with its checks and files.
//!
//! ```
//! use blobtrace::field::{EvalMode, ModelField};
//! use blobtrace::mesh::{Lattice, Polygonizer, PolygonizeOptions, skeleton_seeds};
//! use blobtrace::scene::Scene;
//!
//! let scene = Scene::parse(
//!     "Scene(camera: Camera(eye: (0.0, 0.0, 4.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
//!            size: (8, 8), model: Point(center: (0.0, 0.0, 0.0), radius: 1.0))",
//!     "inline",
//! )?;
//! let field = ModelField::new(&scene.model, EvalMode::Indexed);
//! let mut polygonizer = Polygonizer::new(Lattice::for_model(&scene.model, 16), PolygonizeOptions::default());
//! polygonizer.polygonize(&field, &skeleton_seeds(&scene.model, scene.model.root()));
//! let mesh = polygonizer.mesh();
//! assert!(mesh.topology().is_closed_manifold());
//! // Every vertex lies on the sphere of radius R·sqrt(1 - T^(1/3)).
//! assert!(mesh.positions.iter().all(|p| (p.length() - 0.4542).abs() < 1e-3));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod bcc;
mod corners;
mod cubes;
mod digest;
mod edge_vertices;
mod export;
mod lattice;
mod polygonizer;
pub mod quality;
pub mod repair;
mod seeds;
mod slot_bits;
mod topology;
mod vertex;
mod visited;

use glam::Vec3;

pub use edge_vertices::EdgeVertex;
pub use export::{MeshFormat, write_mesh};
pub use lattice::{Cell, Lattice};
pub use polygonizer::{CellShape, PolygonizeOptions, PolygonizeStats, Polygonizer, Repolygonized};
pub use seeds::{Seed, skeleton_seeds};
pub use topology::Topology;
pub use vertex::VertexPlacement;

/// An indexed triangle mesh with a normal (and optionally a colour) per vertex.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Unit outward normals: from the field gradient (zero where it vanished),
    /// or from the faces around the vertex for a `Linear` preview.
    pub normals: Vec<Vec3>,
    /// Linear RGB colour per vertex, when the model has more than one colour.
    pub colors: Option<Vec<Vec3>>,
    /// Triangles as vertex indices, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// A per-vertex error (error_C), written to PLY files as `error`.
    pub error: Option<Vec<f32>>,
}

/// Cuts a polygon (a loop of vertex ids) into triangles: a quadrilateral along
/// its shorter diagonal, larger loops as a fan.
pub fn triangulate(ids: &[u32], position: impl Fn(u32) -> Vec3, out: &mut Vec<[u32; 3]>) {
    match *ids {
        [a, b, c] => out.push([a, b, c]),
        [a, b, c, d] => {
            if position(a).distance_squared(position(c)) <= position(b).distance_squared(position(d)) {
                out.extend([[a, b, c], [a, c, d]]);
            } else {
                out.extend([[a, b, d], [b, c, d]]);
            }
        }
        _ => {
            for i in 1..ids.len().saturating_sub(1) {
                out.push([ids[0], ids[i], ids[i + 1]]);
            }
        }
    }
}

/// A triangle as the bits of its corners' coordinates.
pub type TriangleBits = [[u32; 3]; 3];

/// Triangles as exact corner positions, each rotated to start at its smallest
/// corner (orientation kept), sorted: equal for two sets of the same triangles
/// listed in any order.
#[must_use]
pub fn canonical_triangles(triangles: impl IntoIterator<Item = [Vec3; 3]>) -> Vec<TriangleBits> {
    let mut set: Vec<TriangleBits> = triangles
        .into_iter()
        .map(|t| {
            let mut c = t.map(|p| p.to_array().map(f32::to_bits));
            let first = (0..3).min_by_key(|&i| c[i]).unwrap_or(0);
            c.rotate_left(first);
            c
        })
        .collect();
    set.sort_unstable();
    set
}

impl Mesh {
    /// Adds a vertex and returns its index.
    pub fn push_vertex(&mut self, position: Vec3, normal: Vec3, color: Option<Vec3>) -> u32 {
        self.positions.push(position);
        self.normals.push(normal);
        if let Some(c) = color {
            self.colors.get_or_insert_with(Vec::new).push(c);
        }
        (self.positions.len() - 1) as u32
    }

    /// Adds a polygon (a loop of vertex indices), cut by [`triangulate`].
    pub fn push_polygon(&mut self, ids: &[u32]) {
        let positions = &self.positions;
        triangulate(ids, |i| positions[i as usize], &mut self.triangles);
    }

    /// Replaces the vertex normals by the normalized, area-weighted sum of the
    /// normals of the triangles around each vertex.
    pub fn set_normals_from_faces(&mut self) {
        let sums = quality::face_normal_sums(&self.positions, &self.triangles);
        self.normals = sums.into_iter().map(Vec3::normalize_or_zero).collect();
    }

    /// The three corners of triangle `t`.
    #[must_use]
    pub fn corners(&self, t: usize) -> [Vec3; 3] {
        self.triangles[t].map(|i| self.positions[i as usize])
    }

    /// The triangles in canonical form (see [`canonical_triangles`]).
    #[must_use]
    pub fn triangle_set(&self) -> Vec<TriangleBits> {
        canonical_triangles((0..self.triangles.len()).map(|t| self.corners(t)))
    }

    /// Every quality figure: pieces, watertightness, genus, triangle shape,
    /// normals against faces, self-intersections.
    #[must_use]
    pub fn quality(&self) -> quality::MeshQuality {
        quality::MeshQuality::of(self)
    }

    /// Edge sharing and orientation of the triangles.
    #[must_use]
    pub fn topology(&self) -> Topology {
        Topology::of(&self.triangles)
    }
}
