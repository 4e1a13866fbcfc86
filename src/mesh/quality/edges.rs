//! The mesh's edges, found by sorting every triangle side by its two vertex
//! ids: each undirected edge with the triangles that use it and the
//! direction each walks it. The sort is a counting sort by the lower vertex
//! id, then a small sort of each vertex's few sides: the same order as one
//! sort of them all, in a fraction of its time and without its buffers (a
//! comparison sort of 27 M sides took a second and 700 MB). Its order is
//! fixed, where a hash map of the edges would be neither.

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
        let side = |t: usize, k: usize| {
            let tri = triangles[t];
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            Side { edge: u64::from(a.min(b)) << 32 | u64::from(a.max(b)), triangle: t as u32, forward: a < b }
        };
        let lower = |s: &Side| (s.edge >> 32) as usize;
        let vertices = triangles.iter().flatten().max().map_or(0, |&v| v as usize + 1);
        // Where each vertex's sides (those it is the lower end of) start.
        let mut starts = vec![0u32; vertices + 1];
        for t in 0..triangles.len() {
            for k in 0..3 {
                starts[lower(&side(t, k)) + 1] += 1;
            }
        }
        for v in 0..vertices {
            starts[v + 1] += starts[v];
        }
        let mut sides = vec![Side { edge: 0, triangle: 0, forward: false }; 3 * triangles.len()];
        let mut cursor = starts.clone();
        for t in 0..triangles.len() {
            for k in 0..3 {
                let s = side(t, k);
                let at = &mut cursor[lower(&s)];
                sides[*at as usize] = s;
                *at += 1;
            }
        }
        drop(cursor);
        // Each vertex's sides by edge, then triangle: runs of vertices in parallel.
        let mut runs = Vec::new();
        let mut rest = &mut sides[..];
        for v in (0..vertices).step_by(VERTICES_PER_RUN) {
            let end = (v + VERTICES_PER_RUN).min(vertices);
            let (run, tail) = rest.split_at_mut((starts[end] - starts[v]) as usize);
            runs.push((v, end, run));
            rest = tail;
        }
        runs.into_par_iter().for_each(|(first, end, run)| {
            let base = starts[first];
            for v in first..end {
                run[(starts[v] - base) as usize..(starts[v + 1] - base) as usize].sort_unstable();
            }
        });
        Self { sides }
    }

    /// The sides of each undirected edge, one slice per edge, in edge order.
    pub fn groups(&self) -> impl Iterator<Item = &[Side]> {
        self.sides.chunk_by(|a, b| a.edge == b.edge)
    }
}

/// Vertices whose sides one task sorts.
const VERTICES_PER_RUN: usize = 1 << 16;

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

    #[test]
    fn the_sides_come_in_the_order_of_one_sort_of_them_all() {
        // A strip of triangles over many runs of vertices, some walked
        // backwards, some repeated, some degenerate.
        let n = 3 * VERTICES_PER_RUN as u32;
        let triangles: Vec<[u32; 3]> = (0..n - 2)
            .flat_map(|i| {
                let tri = if i % 7 == 0 { [i + 2, i + 1, i] } else { [i, i + 1, i + 2] };
                let extra = (i % 1000 == 0).then_some([i, i, (i * 31) % n]);
                std::iter::once(tri).chain(extra)
            })
            .collect();
        let mut all: Vec<Side> = (0..triangles.len())
            .flat_map(|t| {
                let tri = triangles[t];
                (0..3).map(move |k| {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    Side { edge: u64::from(a.min(b)) << 32 | u64::from(a.max(b)), triangle: t as u32, forward: a < b }
                })
            })
            .collect();
        all.sort_unstable();
        assert_eq!(Edges::of(&triangles).sides, all);
    }
}
