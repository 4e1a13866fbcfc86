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

/// A vertex no triangle uses.
const UNUSED: u32 = u32::MAX;

/// Removes the vertices no triangle uses, keeping the others in order.
pub(super) fn drop_unused_vertices(mesh: &mut Mesh) {
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
    keep_used(&mut mesh.positions, &number);
    keep_used(&mut mesh.normals, &number);
    if let Some(colors) = &mut mesh.colors {
        keep_used(colors, &number);
    }
    if let Some(error) = &mut mesh.error {
        keep_used(error, &number);
    }
    for t in &mut mesh.triangles {
        *t = t.map(|i| number[i as usize]);
    }
}

/// Keeps the entries of `values` whose vertex `number` does not mark unused.
fn keep_used<T>(values: &mut Vec<T>, number: &[u32]) {
    let mut i = 0;
    values.retain(|_| {
        i += 1;
        number[i - 1] != UNUSED
    });
}
