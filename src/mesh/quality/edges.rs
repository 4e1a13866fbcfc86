//! The mesh's edges, found by sorting every triangle side by its two vertex
//! ids: each undirected edge with the triangles that use it and the
//! direction each walks it. Sorting keeps the pass parallel and its order
//! fixed, where a hash map of half a million edges would be neither.

use rayon::prelude::*;

/// One side of one triangle: the undirected edge it lies on, the triangle,
/// and whether the triangle walks it from the lower vertex id to the higher.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Side {
    /// `min << 32 | max` of the two vertex ids.
    pub edge: u64,
    /// The triangle's index.
    pub triangle: u32,
    /// True when the triangle walks the edge from `min` to `max`.
    pub forward: bool,
}

/// Every triangle side, grouped by undirected edge.
pub struct Edges {
    sides: Vec<Side>,
}

impl Edges {
    /// The sides of `triangles`, sorted by edge (then triangle).
    #[must_use]
    pub fn of(triangles: &[[u32; 3]]) -> Self {
        let mut sides: Vec<Side> = triangles
            .par_iter()
            .enumerate()
            .flat_map_iter(|(t, tri)| {
                (0..3).map(move |k| {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    Side { edge: u64::from(a.min(b)) << 32 | u64::from(a.max(b)), triangle: t as u32, forward: a < b }
                })
            })
            .collect();
        sides.par_sort_unstable();
        Self { sides }
    }

    /// The sides of each undirected edge, one slice per edge, in edge order.
    pub fn groups(&self) -> impl Iterator<Item = &[Side]> {
        self.sides.chunk_by(|a, b| a.edge == b.edge)
    }
}

/// How a group of sides (one undirected edge) joins its triangles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EdgeKind {
    /// Two triangles walking it in opposite directions.
    Manifold,
    /// One triangle: the edge of a hole.
    Boundary,
    /// Two triangles walking it the same way: their orientations disagree.
    Misoriented,
    /// More than two triangles.
    Nonmanifold,
}

/// What kind of edge a group of sides makes.
#[must_use]
pub fn kind(sides: &[Side]) -> EdgeKind {
    match sides {
        [_] => EdgeKind::Boundary,
        [a, b] if a.forward != b.forward => EdgeKind::Manifold,
        [_, _] => EdgeKind::Misoriented,
        _ => EdgeKind::Nonmanifold,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_triangles_share_one_edge_walked_both_ways() {
        let edges = Edges::of(&[[0, 1, 2], [2, 1, 3]]);
        let groups: Vec<&[Side]> = edges.groups().collect();
        assert_eq!(groups.len(), 5);
        let shared: Vec<&[Side]> = groups.iter().copied().filter(|g| g.len() == 2).collect();
        assert_eq!(shared.len(), 1);
        assert_eq!(shared[0][0].edge, 1 << 32 | 2);
        assert_eq!(kind(shared[0]), EdgeKind::Manifold);
        assert_eq!(groups.iter().filter(|g| kind(g) == EdgeKind::Boundary).count(), 4);
        let same_way = Edges::of(&[[0, 1, 2], [1, 2, 3]]);
        assert!(same_way.groups().any(|g| kind(g) == EdgeKind::Misoriented));
    }
}
