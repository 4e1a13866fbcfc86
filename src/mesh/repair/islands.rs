//! Dropping islands: connected pieces with fewer triangles than a bound.
//! Off by default, because a thin feature sampled coarsely also falls apart
//! into small pieces, and those are real.

use crate::mesh::Mesh;
use crate::mesh::quality::{Components, Edges};

/// Removes the pieces of fewer than `min_triangles` triangles (and the
/// vertices only they used); returns how many pieces were removed.
pub fn drop_small_components(mesh: &mut Mesh, min_triangles: u32) -> usize {
    let components = Components::of(&mesh.triangles, &Edges::of(&mesh.triangles));
    let small = |c: u32| components.pieces[c as usize].triangles < min_triangles;
    let removed = components.pieces.iter().filter(|p| p.triangles < min_triangles).count();
    if removed == 0 {
        return 0;
    }
    let mut t = 0;
    mesh.triangles.retain(|_| {
        t += 1;
        !small(components.of_triangle[t - 1])
    });
    super::drop_unused_vertices(mesh);
    removed
}
