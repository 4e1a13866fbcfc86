//! Vertex normals against the faces around them. A normal taken from the
//! field's gradient can point into the surface where the gradient is
//! unreliable (near a cached lattice's thin features, or where it nearly
//! vanishes); shading then turns dark or inside out there.

use glam::Vec3;
use serde::Serialize;

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
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a);
        for &i in t {
            sums[i as usize] += n;
        }
    }
    sums
}

/// The vertices of `normals` that point against `face_sums`.
#[must_use]
pub fn against_faces(normals: &[Vec3], face_sums: &[Vec3]) -> Vec<u32> {
    (0..normals.len() as u32).filter(|&i| normals[i as usize].dot(face_sums[i as usize]) < 0.0).collect()
}

impl NormalCheck {
    /// Checks `normals` against the faces of `triangles`.
    #[must_use]
    pub fn of(positions: &[Vec3], normals: &[Vec3], triangles: &[[u32; 3]]) -> Self {
        let sums = face_normal_sums(positions, triangles);
        let mut check = Self { against_faces: 0, smallest_cosine: 1.0, zero: 0 };
        for (n, s) in normals.iter().zip(&sums) {
            if *s == Vec3::ZERO {
                continue;
            }
            if *n == Vec3::ZERO {
                check.zero += 1;
                continue;
            }
            let cosine = f64::from(n.normalize().dot(s.normalize()));
            check.against_faces += u64::from(cosine < 0.0);
            check.smallest_cosine = check.smallest_cosine.min(cosine);
        }
        check
    }
}
