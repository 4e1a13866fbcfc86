//! The mesh's edges, found through each vertex's star (the triangles using
//! it): an undirected edge belongs to its lower vertex, and the triangles
//! using it are those of that vertex's star that also use its other end. So
//! each edge's sides are gathered from a handful of triangles, vertex by
//! vertex in parallel, without sorting every side of the mesh (which took
//! 0.4 s and 436 MB for 9.1 M triangles); the star lists are 4 bytes a
//! corner. The groups come in a fixed order, by edge and then triangle.

use std::ops::Range;

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

/// The edges of a triangle mesh, through its vertices' stars.
pub struct Edges<'a> {
    triangles: &'a [[u32; 3]],
    /// Where each vertex's star starts in `stars`, and one past the last.
    starts: Vec<u32>,
    /// Each vertex's triangles, in order (a triangle using a vertex twice once).
    stars: Vec<u32>,
}

impl<'a> Edges<'a> {
    /// The edges of `triangles`.
    #[must_use]
    pub fn of(triangles: &'a [[u32; 3]]) -> Self {
        let vertices = triangles.iter().flatten().max().map_or(0, |&v| v as usize + 1);
        // A corner counts unless an earlier corner of its triangle is the same vertex.
        let corners = |t: &[u32; 3]| {
            let [a, b, c] = *t;
            [Some(a), (b != a).then_some(b), (c != a && c != b).then_some(c)].into_iter().flatten()
        };
        let mut starts = vec![0u32; vertices + 1];
        for t in triangles {
            corners(t).for_each(|v| starts[v as usize + 1] += 1);
        }
        for v in 0..vertices {
            starts[v + 1] += starts[v];
        }
        let mut stars = vec![0u32; starts[vertices] as usize];
        let mut cursor = starts.clone();
        for (i, t) in triangles.iter().enumerate() {
            for v in corners(t) {
                stars[cursor[v as usize] as usize] = i as u32;
                cursor[v as usize] += 1;
            }
        }
        Self { triangles, starts, stars }
    }

    /// The triangles whose edges these are.
    #[must_use]
    pub fn triangles(&self) -> &'a [[u32; 3]] {
        self.triangles
    }

    /// The number of vertices (one past the highest id a triangle uses).
    #[must_use]
    pub fn vertices(&self) -> usize {
        self.starts.len() - 1
    }

    /// The triangles using vertex `v`, in order.
    #[must_use]
    pub fn star(&self, v: u32) -> &[u32] {
        &self.stars[self.starts[v as usize] as usize..self.starts[v as usize + 1] as usize]
    }

    /// Calls `visit` with the sides of each undirected edge, one slice per
    /// edge, in edge order.
    pub fn for_each_group(&self, mut visit: impl FnMut(&[Side])) {
        let mut sides = Vec::with_capacity(16);
        for v in 0..self.vertices() as u32 {
            self.groups_of(v, &mut sides, &mut visit);
        }
    }

    /// Folds the groups of sides of the vertices in runs, in parallel: one
    /// state per run, in the order of the runs, from `init` and `visit`.
    pub fn fold_groups<T: Send>(
        &self,
        init: impl Fn() -> T + Sync + Send,
        visit: impl Fn(&mut T, &[Side]) + Sync + Send,
    ) -> Vec<T> {
        self.vertex_runs()
            .into_par_iter()
            .map(|run| {
                let (mut state, mut sides) = (init(), Vec::with_capacity(16));
                for v in run {
                    self.groups_of(v, &mut sides, &mut |group: &[Side]| visit(&mut state, group));
                }
                state
            })
            .collect()
    }

    /// Calls `visit` with the sides of each undirected edge, in parallel, in no order.
    pub fn par_for_each_group(&self, visit: impl Fn(&[Side]) + Sync + Send) {
        self.fold_groups(|| (), |(), sides| visit(sides));
    }

    /// The vertices in runs of [`VERTICES_PER_RUN`].
    #[must_use]
    pub fn vertex_runs(&self) -> Vec<Range<u32>> {
        let n = self.vertices() as u32;
        (0..n).step_by(VERTICES_PER_RUN).map(|v| v..(v + VERTICES_PER_RUN as u32).min(n)).collect()
    }

    /// Calls `visit` with each group of sides of the edges whose lower end is
    /// `v`, in edge order (`sides` is scratch space).
    fn groups_of(&self, v: u32, sides: &mut Vec<Side>, visit: &mut impl FnMut(&[Side])) {
        sides.clear();
        for &t in self.star(v) {
            let tri = self.triangles[t as usize];
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                if a.min(b) == v {
                    sides.push(Side { edge: u64::from(v) << 32 | u64::from(a.max(b)), triangle: t, forward: a < b });
                }
            }
        }
        sides.sort_unstable();
        sides.chunk_by(|a, b| a.edge == b.edge).for_each(visit);
    }
}

/// Vertices whose edges one task gathers.
const VERTICES_PER_RUN: usize = 1 << 14;

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
        let triangles = [[0, 1, 2], [2, 1, 3]];
        let edges = Edges::of(&triangles);
        let groups = all_groups(&edges);
        assert_eq!(groups.len(), 5);
        let shared: Vec<&Vec<Side>> = groups.iter().filter(|g| g.len() == 2).collect();
        assert_eq!(shared.len(), 1);
        assert_eq!(shared[0][0].edge, 1 << 32 | 2);
        assert_eq!(kind(shared[0]), EdgeKind::Manifold);
        assert_eq!(groups.iter().filter(|g| kind(g) == EdgeKind::Boundary).count(), 4);
        let same_way = [[0, 1, 2], [1, 2, 3]];
        assert!(all_groups(&Edges::of(&same_way)).iter().any(|g| kind(g) == EdgeKind::Misoriented));
    }

    fn all_groups(edges: &Edges) -> Vec<Vec<Side>> {
        let mut groups = vec![];
        edges.for_each_group(|g| groups.push(g.to_vec()));
        groups
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
        let edges = Edges::of(&triangles);
        assert_eq!(all_groups(&edges).concat(), all);
        let folded: Vec<Vec<Side>> = edges.fold_groups(Vec::new, |sides, g| sides.extend_from_slice(g));
        assert!(folded.len() > 2, "several runs");
        assert_eq!(folded.concat(), all, "folded in parallel, the runs in order");
    }
}
