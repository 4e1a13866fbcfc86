//! Body-centred-cubic tetrahedral cells (the second paper's cell).
//!
//! The BCC lattice is the cube corners plus the cube centres. Its tetrahedra
//! are all congruent: each joins two neighbouring centres `C` and `C + 2·e_axis`
//! with one edge of the square face between them, so each cube owns twelve
//! (three axes × four face edges), named by the lower centre's cube. A
//! tetrahedron's neighbour across a face is found by mirroring: the face has
//! two vertices of one kind (`p`, `q`) and the opposite vertex `v` goes to
//! `p + q - v`.
//!
//! A crossed tetrahedron holds one triangle (one vertex apart) or one
//! quadrilateral (two and two); no case is ambiguous, so the surface is
//! watertight without a rule.

use glam::{I64Vec3, IVec3};

use super::lattice::{Cell, LatticePoint};

/// The four vertices of tetrahedron `cell`: the two centres, then the face edge.
#[must_use]
pub fn vertices(cell: Cell) -> [LatticePoint; 4] {
    let axis = usize::from(cell.sub / 4);
    let k = usize::from(cell.sub % 4);
    let e = unit(axis);
    let centre = cell.cube * 2 + IVec3::ONE;
    let square = face_square(cell.cube, axis);
    [centre, centre + e * 2, square[k], square[(k + 1) % 4]]
}

fn unit(axis: usize) -> IVec3 {
    let mut e = IVec3::ZERO;
    e[axis] = 1;
    e
}

/// The corners of the face between cube `cube` and its neighbour along `axis`, in cyclic order.
fn face_square(cube: IVec3, axis: usize) -> [LatticePoint; 4] {
    let (u, v) = (unit((axis + 1) % 3) * 2, unit((axis + 2) % 3) * 2);
    let base = (cube + unit(axis)) * 2;
    [base, base + u, base + u + v, base + v]
}

/// The tetrahedron with these four vertices (two odd centres, two even corners).
fn cell_of(vertices: [LatticePoint; 4]) -> Cell {
    let is_centre = |p: &IVec3| p.x & 1 == 1;
    let mut centres = vertices.iter().filter(|p| is_centre(p));
    let (c0, c1) = (*centres.next().expect("two centres"), *centres.next().expect("two centres"));
    let low = c0.min(c1);
    let axis = (c1 - c0).abs().to_array().iter().position(|&d| d == 2).expect("centres one step apart");
    let cube = (low - IVec3::ONE).div_euclid(IVec3::splat(2));
    let square = face_square(cube, axis);
    let mut corners = vertices.iter().filter(|p| !is_centre(p)).map(|p| square.iter().position(|q| q == p));
    let (i, j) = (corners.next().flatten().expect("corner on the face"), corners.next().flatten().expect("corner"));
    // The edge (k, k+1 mod 4) holding both corners.
    let k = if (i + 1) % 4 == j { i } else { j };
    Cell { cube, sub: (axis * 4 + k) as u8 }
}

/// The tetrahedra having the cube corner `q` as a vertex.
pub fn cells_touching(q: LatticePoint, out: &mut Vec<Cell>) {
    // A tetrahedron's corners lie on the +axis face of its own cube, so its cube holds q.
    let base = q / 2;
    for i in 0..8 {
        let cube = base - super::cubes::corner_offset(i);
        for sub in 0..12 {
            let cell = Cell { cube, sub };
            if vertices(cell)[2..].contains(&q) {
                out.push(cell);
            }
        }
    }
}

/// The four tetrahedra having the centre–centre edge `a`–`b` (odd points one step apart).
pub fn cells_around_centre_edge(a: LatticePoint, b: LatticePoint, out: &mut Vec<Cell>) {
    let low = a.min(b);
    let axis = (b - a).abs().to_array().iter().position(|&d| d == 2).expect("centres one step apart");
    let cube = (low - IVec3::ONE).div_euclid(IVec3::splat(2));
    out.extend((0..4).map(|k| Cell { cube, sub: (axis * 4 + k) as u8 }));
}

/// The tetrahedra across every face of `cell` whose vertices differ in sign.
pub fn neighbours(cell: Cell, mask: u8, out: &mut Vec<Cell>) {
    let v = vertices(cell);
    for opposite in 0..4 {
        let face: Vec<usize> = (0..4).filter(|&i| i != opposite).collect();
        let signs = face.iter().map(|&i| mask >> i & 1).sum::<u8>();
        if signs == 0 || signs == 3 {
            continue;
        }
        // Of the face's three vertices, two are of one kind (centres or corners).
        let kind = |i: usize| v[i].x & 1;
        let (p, q) = match (kind(face[0]) == kind(face[1]), kind(face[0]) == kind(face[2])) {
            (true, _) => (face[0], face[1]),
            (false, true) => (face[0], face[2]),
            (false, false) => (face[1], face[2]),
        };
        let mirrored = v[p] + v[q] - v[opposite];
        out.push(cell_of([v[face[0]], v[face[1]], v[face[2]], mirrored]));
    }
}

/// Emits the cell's polygon (a triangle or a quadrilateral) as a loop of
/// edges, oriented so its normal points from the inside vertices outwards.
pub fn polygons(cell: Cell, mask: u8, emit: &mut impl FnMut(&[[LatticePoint; 2]])) {
    let v = vertices(cell);
    let (inside, outside): (Vec<usize>, Vec<usize>) = (0..4).partition(|&i| mask >> i & 1 == 1);
    let mut edges: Vec<[LatticePoint; 2]> = match (inside.len(), outside.len()) {
        (1, 3) => outside.iter().map(|&o| [v[inside[0]], v[o]]).collect(),
        (3, 1) => inside.iter().map(|&i| [v[i], v[outside[0]]]).collect(),
        (2, 2) => {
            let (i, j, k, l) = (inside[0], inside[1], outside[0], outside[1]);
            vec![[v[i], v[k]], [v[i], v[l]], [v[j], v[l]], [v[j], v[k]]]
        }
        _ => return,
    };
    // Orientation from exact integer geometry on the edge midpoints (a + b):
    // the normal must point away from the inside vertices.
    let m: Vec<I64Vec3> = edges.iter().map(|[a, b]| (*a + *b).as_i64vec3()).collect();
    let normal = (m[1] - m[0]).cross(m[2] - m[0]);
    // A point strictly on the inside of the polygon's plane, in the midpoints' scale.
    let inner = match (inside.len(), outside.len()) {
        (1, _) => v[inside[0]].as_i64vec3() * 2,
        (3, _) => m[0] * 2 - v[outside[0]].as_i64vec3() * 2,
        _ => (v[inside[0]] + v[inside[1]]).as_i64vec3(),
    };
    if normal.dot(inner - m[0]) > 0 {
        edges.reverse();
    }
    emit(&edges);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mirroring_names_a_tetrahedron_sharing_the_face() {
        for sub in 0..12 {
            let cell = Cell { cube: IVec3::new(1, -2, 3), sub };
            let v = vertices(cell);
            let mut out = vec![];
            // Mask 0b0001 makes every face holding vertex 0 mixed: three neighbours.
            neighbours(cell, 0b0001, &mut out);
            assert_eq!(out.len(), 3);
            for n in out {
                let w = vertices(n);
                assert_ne!(n, cell);
                assert_eq!(v.iter().filter(|p| w.contains(p)).count(), 3, "{cell:?} {n:?}");
                // The lattice is tiled, so the neighbour's own neighbour list names us back.
                assert_eq!(cell_of(w), n);
            }
        }
    }

    #[test]
    fn every_tetrahedron_edge_is_one_cell_or_half_a_diagonal_long() {
        for sub in 0..12 {
            let v = vertices(Cell { cube: IVec3::ZERO, sub });
            for a in 0..4 {
                for b in a + 1..4 {
                    let d = (v[a] - v[b]).abs();
                    assert!(d == IVec3::ONE || (d.element_sum() == 2 && d.max_element() == 2), "{d}");
                }
            }
        }
    }
}
