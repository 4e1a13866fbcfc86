//! What a user would check before printing or importing a mesh: its
//! connected pieces (and the small islands among them), whether it is
//! watertight, its Euler characteristic and genus, the shape of its
//! triangles, vertex normals against their faces, and self-intersections.
//!
//! - `edges`: each vertex's star, and each edge's sides gathered from its lower vertex's;
//! - `components`: pieces joined through shared edges, with χ and genus;
//! - `shape`: smallest angles and the quality histogram;
//! - `normals`: vertex normals against the faces around them;
//! - `intersections`: triangles cutting through each other, found through a tree of boxes;
//! - `cubes`: the same, cube by cube, for a mesh cut on a lattice's cubes.

mod components;
mod cubes;
mod edges;
mod intersections;
mod normals;
mod shape;

use serde::Serialize;

pub use components::{Component, Components};
pub use cubes::self_intersections_in_cubes;
pub use edges::{EdgeKind, Edges, Side, kind};
pub use intersections::{self_intersections, triangles_cross};
pub use normals::{NormalCheck, against_faces, face_normal_sums};
pub use shape::{QUALITY_BINS, QUALITY_MEASURE, ShapeQuality, triangle_shape};

use super::{Lattice, Mesh, Topology};

/// Pieces this small or smaller are counted as islands by default.
pub const DEFAULT_ISLAND_TRIANGLES: u32 = 50;
/// Pieces listed one by one in a report (the largest); the rest are counted.
pub const LISTED_COMPONENTS: usize = 16;

/// A mesh's quality, as `mesh --json` and `compare` report it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MeshQuality {
    /// Edge sharing and orientation over the whole mesh.
    pub topology: Topology,
    /// True when every edge is shared by exactly two consistently oriented triangles.
    pub watertight: bool,
    /// The connected pieces.
    pub components: ComponentSummary,
    /// Triangle shape.
    pub shape: ShapeQuality,
    /// Vertex normals against their faces.
    pub normals: NormalCheck,
    /// Pairs of triangles sharing no vertex that cut through each other
    /// (`None`: not looked for, at [`QualityLevel::Summary`]).
    pub self_intersections: Option<u64>,
}

/// How much of the quality report to compute: the self-intersections cost
/// the most of any one figure (a fifth of the report on a cube mesh, most of
/// it on other meshes, where pairs of nearby boxes are walked), so a user
/// meshing large clouds may keep the cheaper figures, or skip the report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum QualityLevel {
    /// No report.
    Off,
    /// Every figure but the self-intersections: pieces, watertightness,
    /// genus, triangle shape, normals (each linear in the triangles).
    Summary,
    /// Every figure.
    #[default]
    Full,
}

/// The connected pieces of a mesh in brief.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ComponentSummary {
    /// How many pieces.
    pub count: usize,
    /// Pieces of at most `island_triangles` triangles.
    pub islands: usize,
    /// Triangles in those islands.
    pub island_triangles_total: u64,
    /// The size bound of an island, in triangles.
    pub island_triangles: u32,
    /// Closed pieces.
    pub closed: usize,
    /// Sum of the closed pieces' genera.
    pub total_genus: i64,
    /// The largest pieces (at most [`LISTED_COMPONENTS`]), largest first.
    pub largest: Vec<Component>,
}

impl ComponentSummary {
    /// The summary of `components`, islands being pieces of at most `island_triangles`.
    #[must_use]
    pub fn of(components: &Components, island_triangles: u32) -> Self {
        let pieces = &components.pieces;
        let islands: Vec<&Component> = pieces.iter().filter(|c| c.triangles <= island_triangles).collect();
        Self {
            count: pieces.len(),
            islands: islands.len(),
            island_triangles_total: islands.iter().map(|c| u64::from(c.triangles)).sum(),
            island_triangles,
            closed: pieces.iter().filter(|c| c.closed).count(),
            total_genus: pieces.iter().filter_map(|c| c.genus).sum(),
            largest: pieces.iter().take(LISTED_COMPONENTS).copied().collect(),
        }
    }
}

impl MeshQuality {
    /// Every figure for `mesh`.
    #[must_use]
    pub fn of(mesh: &Mesh) -> Self {
        Self::measured(mesh, true, None)
    }

    /// The figures `level` asks for (`None` when it is [`QualityLevel::Off`]),
    /// for a mesh cut on the cubes of `lattice` if one is given (which only
    /// makes the self-intersections faster to find).
    #[must_use]
    pub fn at_level(mesh: &Mesh, level: QualityLevel, lattice: Option<&Lattice>) -> Option<Self> {
        match level {
            QualityLevel::Off => None,
            QualityLevel::Summary => Some(Self::measured(mesh, false, lattice)),
            QualityLevel::Full => Some(Self::measured(mesh, true, lattice)),
        }
    }

    fn measured(mesh: &Mesh, intersections: bool, lattice: Option<&Lattice>) -> Self {
        let (positions, triangles) = (&mesh.positions, &mesh.triangles);
        // Side by side: listing the stars and numbering the pieces are partly
        // serial, and the triangles' own figures keep the other core busy meanwhile.
        let ((components, normals), (shape, self_intersections)) = rayon::join(
            || {
                let edges = Edges::of(triangles);
                (Components::of(triangles, &edges), NormalCheck::of(positions, &mesh.normals, &edges))
            },
            || {
                let crossings = intersections.then(|| match lattice {
                    Some(lattice) => self_intersections_in_cubes(positions, triangles, lattice).len() as u64,
                    None => self_intersections(positions, triangles).len() as u64,
                });
                (ShapeQuality::of(positions, triangles), crossings)
            },
        );
        let topology = components.topology;
        Self {
            topology,
            // No triangles enclose nothing: an empty mesh is no closed surface.
            watertight: !triangles.is_empty() && topology.is_closed_manifold(),
            components: ComponentSummary::of(&components, DEFAULT_ISLAND_TRIANGLES),
            shape,
            normals,
            self_intersections,
        }
    }

    /// One line of the headline figures.
    #[must_use]
    pub fn headline(&self) -> String {
        if self.components.count == 0 {
            return "no triangles".to_string();
        }
        let crossings =
            self.self_intersections.map_or("self-intersections not looked for (--quality full)".to_string(), |n| {
                format!("{n} self-intersection{}", plural(n))
            });
        format!(
            "{} piece{} ({} island{} of <= {} triangles), {}, min angle {:.3} deg, {} normal{} against faces, {crossings}",
            self.components.count,
            plural(self.components.count as u64),
            self.components.islands,
            plural(self.components.islands as u64),
            self.components.island_triangles,
            if self.watertight { "watertight" } else { "NOT watertight" },
            self.shape.min_angle_degrees,
            self.normals.against_faces,
            plural(self.normals.against_faces),
        )
    }
}

fn plural(n: u64) -> &'static str {
    if n == 1 { "" } else { "s" }
}
