//! Connected pieces of a mesh: triangles joined through shared edges, each
//! piece with its own Euler characteristic and, when it is closed, its genus;
//! and, from the same pass over the edges, the whole mesh's [`Topology`].

use std::sync::atomic::{AtomicU8, AtomicU32, Ordering};

use rayon::prelude::*;
use serde::Serialize;

use super::edges::{EdgeKind, Edges, kind};
use crate::mesh::Topology;

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
    /// Edge sharing and orientation over the whole mesh.
    pub topology: Topology,
}

impl Components {
    /// The pieces of `triangles`, whose edges are `edges`.
    #[must_use]
    pub fn of(triangles: &[[u32; 3]], edges: &Edges) -> Self {
        let n = triangles.len();
        let parents: Vec<AtomicU32> = (0..n as u32).into_par_iter().map(AtomicU32::new).collect();
        // For each triangle, the edges it comes first on: how many, and how
        // many of them are boundary, misoriented or nonmanifold edges (at most
        // three each: two bits).
        let firsts: Vec<AtomicU8> = (0..n).into_par_iter().map(|_| AtomicU8::new(0)).collect();
        edges.par_for_each_group(|sides| {
            for side in &sides[1..] {
                join(&parents, sides[0].triangle, side.triangle);
            }
            let open = match kind(sides) {
                EdgeKind::Manifold => 0,
                EdgeKind::Boundary => 1 << 2,
                EdgeKind::Misoriented => 1 << 4,
                EdgeKind::Nonmanifold => 1 << 6,
            };
            firsts[sides[0].triangle as usize].fetch_add(1 | open, Ordering::Relaxed);
        });
        let roots: Vec<u32> = (0..n as u32).into_par_iter().map(|t| root(&parents, t)).collect();
        drop(parents);
        // Pieces numbered by first triangle, which is each piece's root.
        let mut of_triangle = vec![0u32; n];
        let mut numbered = 0u32;
        for (t, &r) in roots.iter().enumerate() {
            of_triangle[t] = if r as usize == t {
                numbered += 1;
                numbered - 1
            } else {
                of_triangle[r as usize]
            };
        }
        drop(roots);
        let mut pieces = vec![Tally::default(); numbered as usize];
        for (&c, first) in of_triangle.iter().zip(&firsts) {
            let (piece, first) = (&mut pieces[c as usize], u32::from(first.load(Ordering::Relaxed)));
            piece.triangles += 1;
            piece.edges += first & 3;
            piece.boundary_edges += first >> 2 & 3;
            piece.misoriented_edges += first >> 4 & 3;
            piece.nonmanifold_edges += first >> 6;
        }
        let vertices = count_vertices(edges, &of_triangle, &mut pieces);
        let topology = Topology {
            edges: pieces.iter().map(|p| p.edges as usize).sum(),
            boundary_edges: pieces.iter().map(|p| p.boundary_edges as usize).sum(),
            nonmanifold_edges: pieces.iter().map(|p| p.nonmanifold_edges as usize).sum(),
            misoriented_edges: pieces.iter().map(|p| p.misoriented_edges as usize).sum(),
            euler_characteristic: 0,
        };
        let topology =
            Topology { euler_characteristic: vertices as i64 - topology.edges as i64 + n as i64, ..topology };
        let mut order: Vec<u32> = (0..numbered).collect();
        order.sort_by_key(|&c| std::cmp::Reverse(pieces[c as usize].triangles));
        let mut rank = vec![0u32; order.len()];
        for (r, &c) in order.iter().enumerate() {
            rank[c as usize] = r as u32;
        }
        of_triangle.par_iter_mut().for_each(|c| *c = rank[*c as usize]);
        Self { pieces: order.iter().map(|&c| pieces[c as usize].component()).collect(), of_triangle, topology }
    }
}

/// Adds to each piece the vertices its triangles use: a vertex counts once
/// for each piece among its star's (more than one only where pieces touch
/// at it). Returns how many vertices the triangles use.
fn count_vertices(edges: &Edges, of_triangle: &[u32], pieces: &mut [Tally]) -> usize {
    let mut used = 0;
    let mut seen: Vec<u32> = Vec::with_capacity(8);
    for v in 0..edges.vertices() as u32 {
        let star = edges.star(v);
        let Some(&first) = star.first() else { continue };
        let piece = of_triangle[first as usize];
        pieces[piece as usize].vertices += 1;
        used += 1;
        if star.iter().all(|&t| of_triangle[t as usize] == piece) {
            continue;
        }
        seen.clear();
        seen.push(piece);
        for &t in star {
            let other = of_triangle[t as usize];
            if !seen.contains(&other) {
                seen.push(other);
                pieces[other as usize].vertices += 1;
            }
        }
    }
    used
}

/// Counts gathered for one piece.
#[derive(Clone, Copy, Default)]
struct Tally {
    triangles: u32,
    vertices: u32,
    edges: u32,
    boundary_edges: u32,
    misoriented_edges: u32,
    nonmanifold_edges: u32,
}

impl Tally {
    fn component(self) -> Component {
        let euler = i64::from(self.vertices) - i64::from(self.edges) + i64::from(self.triangles);
        let closed = self.boundary_edges == 0 && self.misoriented_edges == 0 && self.nonmanifold_edges == 0;
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

/// The root of `x`'s set in a union–find forest shared between threads,
/// halving the path on the way.
fn root(parents: &[AtomicU32], mut x: u32) -> u32 {
    loop {
        let parent = parents[x as usize].load(Ordering::Relaxed);
        if parent == x {
            return x;
        }
        let grand = parents[parent as usize].load(Ordering::Relaxed);
        // Another thread may have moved `x` on meanwhile; either way it
        // points to an ancestor still.
        let _ = parents[x as usize].compare_exchange(parent, grand, Ordering::Relaxed, Ordering::Relaxed);
        x = grand;
    }
}

/// Joins the sets of `a` and `b`: the root with the higher index is hung
/// below the other, so whatever the order of the joins, each set's root
/// ends as its least member.
fn join(parents: &[AtomicU32], a: u32, b: u32) {
    loop {
        let (ra, rb) = (root(parents, a), root(parents, b));
        if ra == rb {
            return;
        }
        let (low, high) = (ra.min(rb), ra.max(rb));
        // Fails only when another thread hung `high` first: try again from the roots.
        if parents[high as usize].compare_exchange(high, low, Ordering::Relaxed, Ordering::Relaxed).is_ok() {
            return;
        }
    }
}
