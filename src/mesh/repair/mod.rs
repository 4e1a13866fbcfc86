//! Optional remedies for what [`super::quality`] reports, each off by
//! default: dropping small islands, turning normals that point against their
//! faces, and snapping vertices that land next to a lattice corner onto it
//! (the sliver remedy of marching-cubes implementations).
//!
//! - `islands`: pieces smaller than a size, removed;
//! - `normals`: normals against their faces, re-taken from another gradient or from the faces;
//! - `snap`: vertices within a fraction of a cell of a corner merged onto it;
//! - this file: dropping unused vertices after either of the others.

mod islands;
mod normals;
mod snap;

pub use islands::drop_small_components;
pub use normals::{NormalFix, fix_normals};
pub use snap::{SnapReport, snap_to_corners};

use super::Mesh;

/// Removes the vertices no triangle uses, keeping the others in order.
pub(super) fn drop_unused_vertices(mesh: &mut Mesh) {
    const UNUSED: u32 = u32::MAX;
    let mut number = vec![UNUSED; mesh.positions.len()];
    for &i in mesh.triangles.iter().flatten() {
        number[i as usize] = 0;
    }
    let mut kept = 0u32;
    for n in &mut number {
        if *n != UNUSED {
            *n = kept;
            kept += 1;
        }
    }
    let keep = |i: usize| number[i] != UNUSED;
    let retain = |values: &mut Vec<glam::Vec3>| {
        let mut i = 0;
        values.retain(|_| {
            i += 1;
            keep(i - 1)
        });
    };
    retain(&mut mesh.positions);
    retain(&mut mesh.normals);
    if let Some(colors) = &mut mesh.colors {
        retain(colors);
    }
    if let Some(error) = &mut mesh.error {
        let mut i = 0;
        error.retain(|_| {
            i += 1;
            keep(i - 1)
        });
    }
    for t in &mut mesh.triangles {
        *t = t.map(|i| number[i as usize]);
    }
}
