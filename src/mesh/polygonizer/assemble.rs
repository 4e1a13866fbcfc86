//! The mesh of the crossed cells, and the triangles of one of them, cut from
//! the cells' polygons and the vertices on their edges in a canonical order.

use glam::Vec3;
use rayon::prelude::*;

use super::{CellShape, Polygonizer, crossed};
use crate::mesh::Mesh;
use crate::mesh::cubes;
use crate::mesh::edge_vertices::{EdgeVertex, SlotCursor};
use crate::mesh::lattice::{Cell, EdgeKey, edge_key};
use crate::mesh::vertex::VertexPlacement;

impl Polygonizer {
    /// The crossed cells, sorted by lattice position.
    #[must_use]
    pub fn crossed_cell_list(&self) -> Vec<Cell> {
        let mut cells: Vec<Cell> = self.crossed_now().iter().map(|&(c, _)| c).collect();
        cells.sort_unstable_by_key(Cell::order_key);
        cells
    }

    /// The triangles of one crossed cell (none for a cell not crossed), each
    /// as its three vertices, exactly as [`Polygonizer::mesh`] cuts them.
    #[must_use]
    pub fn cell_triangles(&self, cell: Cell) -> Vec<[EdgeVertex; 3]> {
        let mut out = vec![];
        let Some(mask) = self.cells.get(cell).filter(|&m| crossed(m, self.options.cells)) else {
            return out;
        };
        let mut local = Vec::with_capacity(12);
        self.options.cells.polygons(cell, mask, &mut |polygon| {
            let vertices: Vec<EdgeVertex> = polygon.iter().map(|&[a, b]| self.vertex(edge_key(a, b))).collect();
            let ids: Vec<u32> = (0..vertices.len() as u32).collect();
            local.clear();
            crate::mesh::triangulate(&ids, |i| vertices[i as usize].position, &mut local);
            out.extend(local.iter().map(|t| t.map(|i| vertices[i as usize])));
        });
        out
    }

    /// The mesh of the crossed cells, in a canonical order (cells brick by
    /// brick, each in lattice order; vertices by first use), so equal
    /// polygonizations give equal meshes.
    #[must_use]
    pub fn mesh(&self) -> Mesh {
        let crossed_cells = self.crossed_now();
        let parts = self.polygon_loops(&crossed_cells);
        // Numbering by first use is the one serial pass, over dense slot numbers.
        const UNNUMBERED: u32 = u32::MAX;
        let mut number = vec![UNNUMBERED; self.vertices.slot_count()];
        let mut used = Vec::with_capacity(self.vertices.len());
        let mut id = |slot: u32| {
            let n = &mut number[slot as usize];
            if *n == UNNUMBERED {
                *n = used.len() as u32;
                used.push(slot);
            }
            *n
        };
        // Cubes make triangles alone: their loops are the triangles, numbered as they come.
        let only_triangles = parts.iter().all(|part| part.lengths.iter().all(|&len| len == 3));
        let (triangles, ids) = if only_triangles {
            let mut triangles = Vec::with_capacity(parts.iter().map(|part| part.lengths.len()).sum());
            for part in &parts {
                triangles.extend(part.slots.chunks_exact(3).map(|t| [id(t[0]), id(t[1]), id(t[2])]));
            }
            (triangles, vec![])
        } else {
            let mut ids = Vec::with_capacity(parts.iter().map(|part| part.slots.len()).sum());
            for part in &parts {
                ids.extend(part.slots.iter().map(|&slot| id(slot)));
            }
            (vec![], ids)
        };
        let channel = |of: fn(&EdgeVertex) -> Vec3| -> Vec<Vec3> {
            used.par_iter().map(|&slot| of(&self.vertices.at(slot))).collect()
        };
        // Linear placement takes its normals from the faces: the vertices' are not read.
        let linear = self.options.vertex == VertexPlacement::Linear;
        let mut mesh = Mesh {
            positions: channel(|v| v.position),
            normals: if linear { vec![] } else { channel(|v| v.normal) },
            colors: (self.with_colors && !used.is_empty()).then(|| channel(|v| v.color)),
            triangles,
            ..Mesh::default()
        };
        if !only_triangles {
            let lengths = parts.iter().flat_map(|part| part.lengths.iter().map(|&len| usize::from(len)));
            mesh.triangles.reserve_exact(lengths.clone().map(|len| len.saturating_sub(2)).sum());
            let mut first = 0;
            for len in lengths {
                mesh.push_polygon(&ids[first..first + len]);
                first += len;
            }
        }
        if linear {
            mesh.set_normals_from_faces();
        }
        mesh
    }

    /// Edge `key`'s vertex, which every crossed edge of a crossed cell has.
    fn vertex(&self, key: EdgeKey) -> EdgeVertex {
        self.vertices.get(key).unwrap_or_else(|| panic!("no vertex on the edge with key {key}"))
    }

    /// The polygons of `cells` as loops of their vertices' slots, in parallel:
    /// in order, part after part.
    fn polygon_loops(&self, cells: &[(Cell, u8)]) -> Vec<PolygonLoops> {
        const CELLS_PER_TASK: usize = 4096;
        let shape = self.options.cells;
        cells
            .par_chunks(CELLS_PER_TASK)
            .map(|chunk| {
                let mut part = PolygonLoops::default();
                let mut cursor = SlotCursor::new(&self.vertices);
                let mut slot =
                    |key: EdgeKey| cursor.slot(key).unwrap_or_else(|| panic!("no vertex on the edge with key {key}"));
                for &(cell, mask) in chunk {
                    if shape == CellShape::Cubes {
                        part.push_cube_triangles(cell, mask, &mut slot);
                        continue;
                    }
                    shape.polygons(cell, mask, &mut |polygon| {
                        part.slots.extend(polygon.iter().map(|&[a, b]| slot(edge_key(a, b))));
                        part.lengths.push(polygon.len() as u8);
                    });
                }
                part
            })
            .collect()
    }
}

/// Polygons as consecutive loops of their vertices' slots.
#[derive(Default)]
struct PolygonLoops {
    slots: Vec<u32>,
    lengths: Vec<u8>,
}

impl PolygonLoops {
    /// Adds the triangles of a cube, looking each crossed edge's slot up once
    /// (its triangles share most of them).
    fn push_cube_triangles(&mut self, cell: Cell, mask: u8, slot: &mut impl FnMut(EdgeKey) -> u32) {
        const UNKNOWN: u32 = u32::MAX;
        let mut of_edge = [UNKNOWN; 12];
        for triangle in cubes::case_triangles(mask) {
            for &e in triangle {
                let known = &mut of_edge[usize::from(e)];
                if *known == UNKNOWN {
                    *known = slot(cubes::edge_key_of(cell, e));
                }
                self.slots.push(*known);
            }
            self.lengths.push(3);
        }
    }
}
