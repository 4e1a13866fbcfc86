//! Whether a triangle mesh is watertight: every edge shared by exactly two
//! triangles that traverse it in opposite directions.

use rayon::prelude::*;

use super::quality::{EdgeKind, Edges, kind};

/// Edge statistics of a triangle mesh.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Topology {
    /// Distinct undirected edges.
    pub edges: usize,
    /// Edges used by one triangle only (holes).
    pub boundary_edges: usize,
    /// Edges used by more than two triangles.
    pub nonmanifold_edges: usize,
    /// Edges used twice in the same direction (inconsistent orientation).
    pub misoriented_edges: usize,
    /// Vertices used by the triangles, minus edges, plus triangles.
    pub euler_characteristic: i64,
}

impl Topology {
    /// The edge statistics of `triangles`.
    #[must_use]
    pub fn of(triangles: &[[u32; 3]]) -> Self {
        Self::from_edges(triangles, &Edges::of(triangles))
    }

    /// The edge statistics of `triangles`, whose edges are `edges`.
    #[must_use]
    pub fn from_edges(triangles: &[[u32; 3]], edges: &Edges) -> Self {
        let runs = edges.fold_groups(Topology::default, |topo, sides| {
            topo.edges += 1;
            match kind(sides) {
                EdgeKind::Manifold => {}
                EdgeKind::Boundary => topo.boundary_edges += 1,
                EdgeKind::Misoriented => topo.misoriented_edges += 1,
                EdgeKind::Nonmanifold => topo.nonmanifold_edges += 1,
            }
        });
        let mut topo = runs.iter().fold(Topology::default(), |sum, run| Topology {
            edges: sum.edges + run.edges,
            boundary_edges: sum.boundary_edges + run.boundary_edges,
            nonmanifold_edges: sum.nonmanifold_edges + run.nonmanifold_edges,
            misoriented_edges: sum.misoriented_edges + run.misoriented_edges,
            euler_characteristic: 0,
        });
        let vertices = (0..edges.vertices() as u32).into_par_iter().filter(|&v| !edges.star(v).is_empty()).count();
        topo.euler_characteristic = vertices as i64 - topo.edges as i64 + triangles.len() as i64;
        topo
    }

    /// True when every edge is shared by exactly two consistently oriented triangles.
    #[must_use]
    pub fn is_closed_manifold(&self) -> bool {
        self.boundary_edges == 0 && self.nonmanifold_edges == 0 && self.misoriented_edges == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tetrahedron_is_closed_and_an_open_fan_is_not() {
        let tetra = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]];
        let t = Topology::of(&tetra);
        assert!(t.is_closed_manifold(), "{t:?}");
        assert_eq!(t.euler_characteristic, 2);
        let open = Topology::of(&tetra[..3]);
        assert_eq!(open.boundary_edges, 3);
        let flipped = Topology::of(&[[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 2, 3]]);
        assert!(flipped.misoriented_edges > 0);
    }
}
