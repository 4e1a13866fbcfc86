//! Cubical cells: the marching-cubes case table, generated rather than typed in.
//!
//! Each of the 256 sign cases is built face by face. On a face with two
//! crossed edges one segment joins them; on an *ambiguous* face (inside corners
//! diagonally opposite) the rule is always the same: each inside corner is cut
//! off on its own. The rule reads only the face's four signs, so the two cubes
//! sharing a face draw the same segments there and the surface is watertight.
//! Segments are oriented with the inside on their right as seen from outside
//! the cube; chained, they form closed loops, one polygon each, whose normals
//! point out of the surface (towards lower field values).

use std::sync::OnceLock;

use glam::{IVec3, Vec3};

use super::lattice::{Cell, EdgeKey, LatticePoint};

/// Corner `i` of a cube sits at offset `(i & 1, i >> 1 & 1, i >> 2 & 1)`.
#[must_use]
pub fn corner_offset(i: usize) -> IVec3 {
    IVec3::new((i & 1) as i32, (i >> 1 & 1) as i32, (i >> 2 & 1) as i32)
}

/// The twelve edges as corner pairs, lower corner first.
const EDGES: [(u8, u8); 12] =
    [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5), (2, 6), (3, 7)];

/// The edge joining corners `a` and `b`.
fn edge_between(a: usize, b: usize) -> u8 {
    let (lo, hi) = (a.min(b) as u8, a.max(b) as u8);
    EDGES.iter().position(|&e| e == (lo, hi)).expect("corners of one face edge") as u8
}

/// The four corners of face `(axis, side)` in cyclic order, and its outward normal.
fn face(axis: usize, side: usize) -> ([usize; 4], Vec3) {
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let corner = |du: usize, dv: usize| side << axis | du << u | dv << v;
    let mut normal = Vec3::ZERO;
    normal[axis] = if side == 1 { 1.0 } else { -1.0 };
    ([corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)], normal)
}

/// For every sign case (bit `i` set when corner `i` is inside), the surface's
/// triangles as triples of edge indices.
fn case_table() -> &'static [Vec<[u8; 3]>] {
    static TABLE: OnceLock<Vec<Vec<[u8; 3]>>> = OnceLock::new();
    TABLE.get_or_init(|| {
        (0..256)
            .map(|mask| {
                let mut triangles = vec![];
                for polygon in case_loops(mask as u8) {
                    assert!(triangulate(&polygon, &mut triangles), "case {mask:#010b} has a triangulation");
                }
                triangles
            })
            .collect()
    })
}

/// Cuts a loop into triangles using only diagonals between edges that share
/// no cube face. A diagonal between two points of one face would be drawn by
/// the neighbouring cube too, and the mesh would no longer be a manifold.
fn triangulate(polygon: &[u8], out: &mut Vec<[u8; 3]>) -> bool {
    let n = polygon.len();
    if n == 3 {
        out.push([polygon[0], polygon[1], polygon[2]]);
        return true;
    }
    for i in 0..n {
        for j in i + 2..n {
            if (i == 0 && j == n - 1) || share_a_face(polygon[i], polygon[j]) {
                continue;
            }
            let mark = out.len();
            let (left, right): (Vec<u8>, Vec<u8>) =
                (polygon[i..=j].to_vec(), polygon[j..].iter().chain(&polygon[..=i]).copied().collect());
            if triangulate(&left, out) && triangulate(&right, out) {
                return true;
            }
            out.truncate(mark);
        }
    }
    false
}

/// True when cube edges `a` and `b` lie on a common face.
fn share_a_face(a: u8, b: u8) -> bool {
    let (ea, eb) = (EDGES[a as usize], EDGES[b as usize]);
    let corners = [ea.0, ea.1, eb.0, eb.1];
    (0..3).any(|axis| {
        let bit = |c: u8| c >> axis & 1;
        corners.iter().all(|&c| bit(c) == bit(corners[0]))
    })
}

fn case_loops(mask: u8) -> Vec<Vec<u8>> {
    let inside = |c: usize| mask >> c & 1 == 1;
    let mut next = [u8::MAX; 12];
    for axis in 0..3 {
        for side in 0..2 {
            for (from, to) in face_segments(axis, side, &inside) {
                next[from as usize] = to;
            }
        }
    }
    let mut loops = vec![];
    let mut used = [false; 12];
    for start in 0..12 {
        if next[start] == u8::MAX || used[start] {
            continue;
        }
        let mut polygon = vec![];
        let mut e = start;
        while !used[e] {
            used[e] = true;
            polygon.push(e as u8);
            e = next[e] as usize;
        }
        loops.push(polygon);
    }
    loops
}

/// The oriented segments a face contributes, as (from edge, to edge).
fn face_segments(axis: usize, side: usize, inside: &impl Fn(usize) -> bool) -> Vec<(u8, u8)> {
    let (c, normal) = face(axis, side);
    let crossed: Vec<usize> = (0..4).filter(|&k| inside(c[k]) != inside(c[(k + 1) % 4])).collect();
    let edge = |k: usize| edge_between(c[k], c[(k + 1) % 4]);
    let pairs: Vec<(usize, usize, Vec3)> = match crossed.len() {
        2 => {
            let inner: Vec<Vec3> = c.iter().filter(|&&i| inside(i)).map(|&i| corner_offset(i).as_vec3()).collect();
            let centroid = inner.iter().sum::<Vec3>() / inner.len() as f32;
            vec![(crossed[0], crossed[1], centroid)]
        }
        // Ambiguous face: cut off each inside corner k with its two face edges k-1 and k.
        4 => (0..4).filter(|&k| inside(c[k])).map(|k| ((k + 3) % 4, k, corner_offset(c[k]).as_vec3())).collect(),
        _ => vec![],
    };
    pairs
        .into_iter()
        .map(|(ka, kb, inner)| {
            let (ea, eb) = (edge(ka), edge(kb));
            let (p, q) = (edge_midpoint(ea), edge_midpoint(eb));
            // Inside on the right of p → q seen from outside the cube.
            if (q - p).cross(inner - p).dot(normal) < 0.0 { (ea, eb) } else { (eb, ea) }
        })
        .collect()
}

fn edge_midpoint(e: u8) -> Vec3 {
    let (a, b) = EDGES[e as usize];
    (corner_offset(a as usize) + corner_offset(b as usize)).as_vec3() * 0.5
}

/// The eight corners of a cube cell in half-cell coordinates.
#[must_use]
pub fn vertices(cell: Cell) -> [LatticePoint; 8] {
    std::array::from_fn(|i| (cell.cube + corner_offset(i)) * 2)
}

/// The cube cells sharing the corner `q` (even coordinates).
pub fn cells_touching(q: LatticePoint, out: &mut Vec<Cell>) {
    let base = q / 2;
    out.extend((0..8).map(|i| Cell { cube: base - corner_offset(i), sub: 0 }));
}

/// The cubes across every face of `cell` whose corners differ in sign.
pub fn neighbours(cell: Cell, mask: u8, out: &mut Vec<Cell>) {
    let crossed = crossed_faces()[usize::from(mask)];
    for (face, step) in FACE_STEPS.iter().enumerate() {
        if crossed >> face & 1 == 1 {
            out.push(Cell { cube: cell.cube + *step, sub: 0 });
        }
    }
}

/// The step to the cube across face `2·axis + side`.
const FACE_STEPS: [IVec3; 6] = [
    IVec3::new(-1, 0, 0),
    IVec3::new(1, 0, 0),
    IVec3::new(0, -1, 0),
    IVec3::new(0, 1, 0),
    IVec3::new(0, 0, -1),
    IVec3::new(0, 0, 1),
];

/// For every sign case, bit `2·axis + side` set when that face's corners differ in sign.
fn crossed_faces() -> &'static [u8; 256] {
    static TABLE: OnceLock<[u8; 256]> = OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|mask| {
            let mut faces = 0u8;
            for axis in 0..3 {
                for side in 0..2 {
                    let (c, _) = face(axis, side);
                    let inside = c.iter().filter(|&&i| mask >> i & 1 == 1).count();
                    if inside != 0 && inside != 4 {
                        faces |= 1 << (2 * axis + side);
                    }
                }
            }
            faces
        })
    })
}

/// The crossed edges `cell` owns: those leaving its lowest corner along +x,
/// +y and +z, lower end first. Every lattice edge is owned by exactly one
/// cube, and the owner of a crossed edge is crossed (it holds both ends), so
/// the owned edges of all crossed cubes list each crossed edge once.
pub fn owned_crossed_edges(cell: Cell, mask: u8, out: &mut Vec<[LatticePoint; 2]>) {
    let lowest = cell.cube * 2;
    out.extend(owned_crossed_axes(mask).map(|axis| [lowest, lowest + corner_offset(1 << axis) * 2]));
}

/// The axes (0 for x, 1 for y, 2 for z) of the crossed edges a cube of
/// sign case `mask` owns, in order: [`owned_crossed_edges`] by axis.
pub fn owned_crossed_axes(mask: u8) -> impl Iterator<Item = usize> {
    [1, 2, 4].into_iter().enumerate().filter(move |&(_, far)| (mask ^ mask >> far) & 1 == 1).map(|(axis, _)| axis)
}

/// The triangles of sign case `mask`, each as three of the cube's edge numbers
/// (see [`edge_key_of`]), oriented outwards.
#[must_use]
pub fn case_triangles(mask: u8) -> &'static [[u8; 3]] {
    &case_table()[usize::from(mask)]
}

/// The key of edge number `e` of `cell` (the sum of its ends).
#[must_use]
pub fn edge_key_of(cell: Cell, e: u8) -> EdgeKey {
    let (a, b) = EDGES[usize::from(e)];
    cell.cube * 4 + (corner_offset(usize::from(a)) + corner_offset(usize::from(b))) * 2
}

/// Emits the cell's triangles, each as its three edges (an edge as its two
/// lattice endpoints), oriented outwards.
pub fn polygons(cell: Cell, mask: u8, emit: &mut impl FnMut(&[[LatticePoint; 2]])) {
    let v = vertices(cell);
    for triangle in &case_table()[mask as usize] {
        emit(&triangle.map(|e| {
            let (a, b) = EDGES[e as usize];
            [v[a as usize], v[b as usize]]
        }));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::lattice::ordered_edge;

    #[test]
    fn case_triangles_name_the_edges_polygons_emits() {
        let cell = Cell { cube: IVec3::new(3, -2, 7), sub: 0 };
        for mask in 1..=254u8 {
            let mut emitted = vec![];
            polygons(cell, mask, &mut |p| {
                emitted.push(p.iter().map(|&[a, b]| crate::mesh::lattice::edge_key(a, b)).collect::<Vec<_>>())
            });
            let named: Vec<Vec<EdgeKey>> =
                case_triangles(mask).iter().map(|t| t.iter().map(|&e| edge_key_of(cell, e)).collect()).collect();
            assert_eq!(emitted, named, "case {mask:#010b}");
        }
    }

    #[test]
    fn the_owned_edges_of_the_cubes_around_a_crossed_edge_list_it_once() {
        // Every sign case of the cube at the origin (all other corners
        // outside): each edge of its triangles is owned by one of the 27
        // cubes around it, once.
        for mask in 1..=254u8 {
            let at = |q: LatticePoint| (0..8).any(|i| corner_offset(i) * 2 == q && mask >> i & 1 == 1);
            let mut crossed = vec![];
            polygons(Cell { cube: IVec3::ZERO, sub: 0 }, mask, &mut |p| crossed.extend_from_slice(p));
            for [a, b] in crossed {
                let ends = ordered_edge(a, b);
                let mut owners = 0;
                for i in 0..27 {
                    let cube = Cell { cube: IVec3::new(i % 3, i / 3 % 3, i / 9) - IVec3::ONE, sub: 0 };
                    let cube_mask = (0..8).filter(|&j| at(vertices(cube)[j])).fold(0u8, |m, j| m | 1 << j);
                    let mut owned = vec![];
                    owned_crossed_edges(cube, cube_mask, &mut owned);
                    owners += owned.iter().filter(|&&e| e == ends).count();
                }
                assert_eq!(owners, 1, "mask {mask:#010b}, edge {a} {b}");
            }
        }
    }

    #[test]
    fn every_crossed_edge_lies_on_exactly_one_loop() {
        for mask in 0..=255u8 {
            let mut count = [0; 12];
            for polygon in case_loops(mask) {
                assert!(polygon.len() >= 3, "case {mask:#010b}: {polygon:?}");
                for &e in &polygon {
                    count[e as usize] += 1;
                }
            }
            for (e, &(a, b)) in EDGES.iter().enumerate() {
                let crossed = (mask >> a & 1) != (mask >> b & 1);
                assert_eq!(count[e], usize::from(crossed), "case {mask:#010b} edge {e}");
            }
        }
    }

    #[test]
    fn no_triangle_joins_two_points_of_one_face_unless_the_face_joins_them() {
        for mask in 0..=255u8 {
            let loops = case_loops(mask);
            let consecutive = |a: u8, b: u8| {
                loops.iter().any(|l| {
                    (0..l.len())
                        .any(|i| (l[i], l[(i + 1) % l.len()]) == (a, b) || (l[i], l[(i + 1) % l.len()]) == (b, a))
                })
            };
            for t in &case_table()[mask as usize] {
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    assert!(consecutive(a, b) || !share_a_face(a, b), "case {mask:#010b}: {t:?}");
                }
            }
        }
    }

    #[test]
    fn a_single_inside_corner_gives_one_outward_triangle() {
        let triangles = &case_table()[1];
        assert_eq!(triangles.len(), 1);
        let p: Vec<Vec3> = triangles[0].iter().map(|&e| edge_midpoint(e)).collect();
        let normal = (p[1] - p[0]).cross(p[2] - p[0]);
        // Corner 0 is inside, so the normal points away from it.
        assert!(normal.dot(Vec3::ONE) > 0.0, "{normal}");
    }
}
