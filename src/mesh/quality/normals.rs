//! Vertex normals against the faces around them. A normal taken from the
//! field's gradient can point into the surface where the gradient is
//! unreliable (near a cached lattice's thin features, or where it nearly
//! vanishes); shading then turns dark or inside out there.

use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

use super::edges::Edges;

/// How the vertex normals agree with the faces around them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct NormalCheck {
    /// Vertices whose normal points against the area-weighted normal of their faces.
    pub against_faces: u64,
    /// The smallest cosine between a vertex normal and its faces' normal (1 for a mesh without vertices).
    pub smallest_cosine: f64,
    /// Vertices with no normal (a vanished gradient).
    pub zero: u64,
}

/// The area-weighted normal of the faces around each vertex (unnormalized;
/// zero for a vertex no triangle uses).
#[must_use]
pub fn face_normal_sums(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut sums = vec![Vec3::ZERO; positions.len()];
    for t in triangles {
        let n = face_normal(positions, *t);
        for &i in t {
            sums[i as usize] += n;
        }
    }
    sums
}

/// Triangle `t`'s normal, twice its area long.
fn face_normal(positions: &[Vec3], t: [u32; 3]) -> Vec3 {
    let [a, b, c] = t.map(|i| positions[i as usize]);
    (b - a).cross(c - a)
}

/// The vertices of `normals` that point against `face_sums`.
#[must_use]
pub fn against_faces(normals: &[Vec3], face_sums: &[Vec3]) -> Vec<u32> {
    (0..normals.len() as u32).filter(|&i| normals[i as usize].dot(face_sums[i as usize]) < 0.0).collect()
}

impl NormalCheck {
    /// Checks `normals` against the faces around each vertex, found through
    /// the stars of `edges`, vertex by vertex in parallel (each vertex's
    /// faces added in the order of [`face_normal_sums`], so the figures are the same).
    #[must_use]
    pub fn of(positions: &[Vec3], normals: &[Vec3], edges: &Edges) -> Self {
        let triangles = edges.triangles();
        let runs: Vec<Self> = edges
            .vertex_runs()
            .into_par_iter()
            .map(|run| {
                let mut check = Self { against_faces: 0, smallest_cosine: 1.0, zero: 0 };
                for v in run.filter(|&v| (v as usize) < normals.len()) {
                    let sum = edges
                        .star(v)
                        .iter()
                        .fold(Vec3::ZERO, |sum, &t| sum + face_normal(positions, triangles[t as usize]));
                    check.add(normals[v as usize], sum);
                }
                check
            })
            .collect();
        runs.into_iter().fold(Self { against_faces: 0, smallest_cosine: 1.0, zero: 0 }, |a, b| Self {
            against_faces: a.against_faces + b.against_faces,
            smallest_cosine: a.smallest_cosine.min(b.smallest_cosine),
            zero: a.zero + b.zero,
        })
    }

    /// Checks one vertex's normal `n` against the sum of its faces' normals.
    fn add(&mut self, n: Vec3, sum: Vec3) {
        if sum == Vec3::ZERO {
            return;
        }
        if n == Vec3::ZERO {
            self.zero += 1;
            return;
        }
        let cosine = f64::from(n.normalize().dot(sum.normalize()));
        self.against_faces += u64::from(cosine < 0.0);
        self.smallest_cosine = self.smallest_cosine.min(cosine);
    }
}
