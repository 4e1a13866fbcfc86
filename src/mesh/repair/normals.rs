//! Turning vertex normals that point against their faces. The polygonizer's
//! normals come from the field being meshed; a cached lattice's tri-linear
//! gradient can point the wrong way next to features thinner than a cell.
//! A disagreeing normal is re-taken from a second gradient (the exact
//! field's), and where that disagrees too (or vanishes), from the faces.

use glam::Vec3;
use serde::Serialize;

use crate::mesh::Mesh;
use crate::mesh::quality::{against_faces, face_normal_sums};

/// What [`fix_normals`] changed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct NormalFix {
    /// Normals that pointed against their faces (or were zero) before.
    pub against_faces: u64,
    /// Of those, re-taken from the second gradient.
    pub from_gradient: u64,
    /// Of those, re-taken from the faces around the vertex.
    pub from_faces: u64,
}

/// Re-takes every normal of `mesh` that points against its faces or is
/// zero: from `-gradient(p)` when that agrees with the faces, otherwise from
/// the faces' area-weighted normal.
pub fn fix_normals(mesh: &mut Mesh, gradient: impl Fn(Vec3) -> Vec3) -> NormalFix {
    let sums = face_normal_sums(&mesh.positions, &mesh.triangles);
    let mut wrong = against_faces(&mesh.normals, &sums);
    wrong.extend(
        (0..mesh.normals.len() as u32)
            .filter(|&i| mesh.normals[i as usize] == Vec3::ZERO && sums[i as usize] != Vec3::ZERO),
    );
    let mut fix = NormalFix { against_faces: wrong.len() as u64, ..NormalFix::default() };
    for i in wrong {
        let (i, faces) = (i as usize, sums[i as usize]);
        let exact = (-gradient(mesh.positions[i])).normalize_or_zero();
        if exact.dot(faces) > 0.0 {
            mesh.normals[i] = exact;
            fix.from_gradient += 1;
        } else {
            mesh.normals[i] = faces.normalize_or_zero();
            fix.from_faces += 1;
        }
    }
    fix
}
