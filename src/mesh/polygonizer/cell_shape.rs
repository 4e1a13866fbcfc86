//! How space is cut into cells, cubes or body-centred-cubic tetrahedra, and
//! what the polygonizer asks of a cell of either shape.

use crate::mesh::lattice::{Cell, LatticePoint, ordered_edge};
use crate::mesh::{bcc, cubes};

/// How space is cut into cells.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CellShape {
    /// Cubes with a generated, watertight marching-cubes case table.
    #[default]
    Cubes,
    /// The body-centred-cubic tetrahedra of Levinski and Sourin.
    Bcc,
}

impl CellShape {
    /// The cell's vertices (8 for a cube, 4 for a tetrahedron) in half-cell coordinates.
    pub(super) fn vertices(self, cell: Cell) -> ([LatticePoint; 8], usize) {
        match self {
            CellShape::Cubes => (cubes::vertices(cell), 8),
            CellShape::Bcc => {
                let v = bcc::vertices(cell);
                ([v[0], v[1], v[2], v[3], v[0], v[0], v[0], v[0]], 4)
            }
        }
    }

    pub(super) fn cells_touching(self, corner: LatticePoint, out: &mut Vec<Cell>) {
        match self {
            CellShape::Cubes => cubes::cells_touching(corner, out),
            CellShape::Bcc => bcc::cells_touching(corner, out),
        }
    }

    /// Cells having the lattice edge `a`–`b` (plus, harmlessly, a few that
    /// only touch one of its ends).
    pub(super) fn cells_around_edge(self, a: LatticePoint, b: LatticePoint, out: &mut Vec<Cell>) {
        let even = |p: LatticePoint| p.x & 1 == 0;
        match (self, even(a), even(b)) {
            (CellShape::Bcc, false, false) => bcc::cells_around_centre_edge(a, b, out),
            (_, true, _) => self.cells_touching(a, out),
            _ => self.cells_touching(b, out),
        }
    }

    /// Crossed edges of `cell` to place vertices on, lower end first (so a
    /// root never depends on which cell asked): for cubes only those the cell
    /// owns, which every crossed edge is for one crossed cube; for tetrahedra
    /// all of them, repeated across the cells that share them.
    pub(super) fn crossed_edges(self, cell: Cell, mask: u8, out: &mut Vec<[LatticePoint; 2]>) {
        match self {
            CellShape::Cubes => cubes::owned_crossed_edges(cell, mask, out),
            CellShape::Bcc => {
                bcc::polygons(cell, mask, &mut |polygon| out.extend(polygon.iter().map(|&[a, b]| ordered_edge(a, b))))
            }
        }
    }

    pub(super) fn neighbours(self, cell: Cell, mask: u8, out: &mut Vec<Cell>) {
        match self {
            CellShape::Cubes => cubes::neighbours(cell, mask, out),
            CellShape::Bcc => bcc::neighbours(cell, mask, out),
        }
    }

    pub(super) fn polygons(self, cell: Cell, mask: u8, emit: &mut impl FnMut(&[[LatticePoint; 2]])) {
        match self {
            CellShape::Cubes => cubes::polygons(cell, mask, emit),
            CellShape::Bcc => bcc::polygons(cell, mask, emit),
        }
    }

    /// Cells per cube: the cube itself, or its twelve tetrahedra.
    pub(super) fn cells_per_cube(self) -> usize {
        match self {
            CellShape::Cubes => 1,
            CellShape::Bcc => 12,
        }
    }

    /// The inside mask of a cell whose vertices are all inside.
    fn full_mask(self) -> u8 {
        match self {
            CellShape::Cubes => 0xff,
            CellShape::Bcc => 0x0f,
        }
    }
}

/// True when a cell's vertices differ in sign.
pub(super) fn crossed(mask: u8, shape: CellShape) -> bool {
    mask != 0 && mask != shape.full_mask()
}
