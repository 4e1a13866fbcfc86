//! Whether a triangle mesh is watertight: every edge shared by exactly two
//! triangles that traverse it in opposite directions.

use rustc_hash::FxHashMap;

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
        // Per undirected edge: uses in the a<b direction and in the b<a direction.
        let mut uses: FxHashMap<(u32, u32), (u32, u32)> = FxHashMap::default();
        let mut vertices = rustc_hash::FxHashSet::default();
        for t in triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                vertices.insert(a);
                let entry = uses.entry((a.min(b), a.max(b))).or_default();
                if a < b {
                    entry.0 += 1;
                } else {
                    entry.1 += 1;
                }
            }
        }
        let mut topo = Topology { edges: uses.len(), ..Default::default() };
        for &(forward, backward) in uses.values() {
            match forward + backward {
                1 => topo.boundary_edges += 1,
                2 if forward != 1 => topo.misoriented_edges += 1,
                2 => {}
                _ => topo.nonmanifold_edges += 1,
            }
        }
        topo.euler_characteristic = vertices.len() as i64 - uses.len() as i64 + triangles.len() as i64;
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
