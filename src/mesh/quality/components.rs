//! Connected pieces of a mesh: triangles joined through shared edges, each
//! piece with its own Euler characteristic and, when it is closed, its genus.

use serde::Serialize;

use super::edges::{EdgeKind, Edges, kind};

/// One connected piece of a mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Component {
    /// Triangles in the piece.
    pub triangles: u32,
    /// Vertices its triangles use.
    pub vertices: u32,
    /// Distinct edges of its triangles.
    pub edges: u32,
    /// Edges of its triangles used by no other triangle (its holes).
    pub boundary_edges: u32,
    /// V − E + F.
    pub euler_characteristic: i64,
    /// True when every edge is shared by exactly two consistently oriented triangles.
    pub closed: bool,
    /// Handles, `(2 − χ) / 2`, for a closed piece.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub genus: Option<i64>,
}

/// The connected pieces of a mesh, largest first (ties in order of their
/// first triangle), and which piece each triangle belongs to.
pub struct Components {
    /// The pieces, largest first.
    pub pieces: Vec<Component>,
    /// The index in `pieces` of each triangle's piece.
    pub of_triangle: Vec<u32>,
}

impl Components {
    /// The pieces of `triangles`, whose edges are `edges`.
    #[must_use]
    pub fn of(triangles: &[[u32; 3]], edges: &Edges) -> Self {
        let mut sets = DisjointSets::new(triangles.len());
        for sides in edges.groups() {
            for side in &sides[1..] {
                sets.join(sides[0].triangle, side.triangle);
            }
        }
        let roots: Vec<u32> = (0..triangles.len() as u32).map(|t| sets.root(t)).collect();
        // Pieces numbered by first triangle, then renumbered largest first.
        let mut first_number = vec![u32::MAX; triangles.len()];
        let mut numbered = 0u32;
        let mut of_triangle: Vec<u32> = roots
            .iter()
            .map(|&r| {
                let n = &mut first_number[r as usize];
                if *n == u32::MAX {
                    *n = numbered;
                    numbered += 1;
                }
                *n
            })
            .collect();
        let mut pieces = vec![Tally::default(); numbered as usize];
        for &c in &of_triangle {
            pieces[c as usize].triangles += 1;
        }
        for sides in edges.groups() {
            let piece = &mut pieces[of_triangle[sides[0].triangle as usize] as usize];
            piece.edges += 1;
            match kind(sides) {
                EdgeKind::Manifold => {}
                EdgeKind::Boundary => piece.boundary_edges += 1,
                EdgeKind::Misoriented | EdgeKind::Nonmanifold => piece.other_open_edges += 1,
            }
        }
        for (c, _) in vertex_uses(triangles, &of_triangle) {
            pieces[c as usize].vertices += 1;
        }
        let mut order: Vec<u32> = (0..numbered).collect();
        order.sort_by_key(|&c| std::cmp::Reverse(pieces[c as usize].triangles));
        let mut rank = vec![0u32; order.len()];
        for (r, &c) in order.iter().enumerate() {
            rank[c as usize] = r as u32;
        }
        for c in &mut of_triangle {
            *c = rank[*c as usize];
        }
        Self { pieces: order.iter().map(|&c| pieces[c as usize].component()).collect(), of_triangle }
    }
}

/// Each (piece, vertex) pair once: a vertex belongs to the piece of the
/// first triangle using it, and, rarely (pieces touching at a vertex), to others.
fn vertex_uses(triangles: &[[u32; 3]], of_triangle: &[u32]) -> Vec<(u32, u32)> {
    const NONE: u32 = u32::MAX;
    let mut first = vec![NONE; triangles.iter().flatten().max().map_or(0, |&v| v as usize + 1)];
    let mut uses = vec![];
    let mut shared = vec![];
    for (tri, &c) in triangles.iter().zip(of_triangle) {
        for &v in tri {
            match first[v as usize] {
                NONE => {
                    first[v as usize] = c;
                    uses.push((c, v));
                }
                owner if owner != c => shared.push((c, v)),
                _ => {}
            }
        }
    }
    shared.sort_unstable();
    shared.dedup();
    uses.extend(shared);
    uses
}

/// Counts gathered for one piece.
#[derive(Clone, Copy, Default)]
struct Tally {
    triangles: u32,
    vertices: u32,
    edges: u32,
    boundary_edges: u32,
    other_open_edges: u32,
}

impl Tally {
    fn component(self) -> Component {
        let euler = i64::from(self.vertices) - i64::from(self.edges) + i64::from(self.triangles);
        let closed = self.boundary_edges == 0 && self.other_open_edges == 0;
        Component {
            triangles: self.triangles,
            vertices: self.vertices,
            edges: self.edges,
            boundary_edges: self.boundary_edges,
            euler_characteristic: euler,
            closed,
            genus: closed.then(|| (2 - euler) / 2),
        }
    }
}

/// Union–find over triangle indices, with path halving and union by size.
struct DisjointSets {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl DisjointSets {
    fn new(n: usize) -> Self {
        Self { parent: (0..n as u32).collect(), size: vec![1; n] }
    }

    fn root(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let grand = self.parent[self.parent[x as usize] as usize];
            self.parent[x as usize] = grand;
            x = grand;
        }
        x
    }

    fn join(&mut self, a: u32, b: u32) {
        let (mut a, mut b) = (self.root(a), self.root(b));
        if a == b {
            return;
        }
        if self.size[a as usize] < self.size[b as usize] {
            std::mem::swap(&mut a, &mut b);
        }
        self.parent[b as usize] = a;
        self.size[a as usize] += self.size[b as usize];
    }
}
