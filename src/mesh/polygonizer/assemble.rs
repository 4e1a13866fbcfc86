//! The mesh of the crossed cells, assembled block by block in parallel.
//!
//! Vertices are numbered block after block (blocks by z, y, x), each block's
//! in the order of its edges: a block's first number is the count of the
//! vertices before it, so numbering is a prefix sum, and the vertex arrays
//! are copied block by block. Triangles come brick by brick of visited
//! cells, each brick's cells in lattice order: every brick counts its
//! triangles first, then writes them into its own run of one array.

use glam::{IVec3, Vec3};
use rayon::prelude::*;
use rustc_hash::FxHashMap;

use super::{CellShape, Polygonizer, crossed};
use crate::mesh::Mesh;
use crate::mesh::cubes;
use crate::mesh::edge_vertices::{EdgeBlock, EdgeVertex, VertexArrays, locate};
use crate::mesh::lattice::{Cell, EdgeKey, edge_key};
use crate::mesh::vertex::VertexPlacement;
use crate::mesh::visited::{BRICK_CUBES, cell_of};

/// A block of vertices with the number of its first.
#[derive(Clone, Copy)]
struct Numbered<'a> {
    first: u32,
    block: &'a EdgeBlock,
}

impl Polygonizer {
    /// The crossed cells, sorted by lattice position.
    #[must_use]
    pub fn crossed_cell_list(&self) -> Vec<Cell> {
        let mut cells: Vec<Cell> = self.crossed_with_masks().iter().map(|&(c, _)| c).collect();
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

    /// The mesh of the crossed cells, in a canonical order (triangles brick
    /// by brick, each brick's cells in lattice order; vertices block by
    /// block, each block's by edge), so equal polygonizations give equal meshes.
    #[must_use]
    pub fn mesh(&self) -> Mesh {
        let mut blocks: Vec<(IVec3, &EdgeBlock)> = self.vertices.blocks().collect();
        blocks.par_sort_unstable_by_key(|(b, _)| Cell { cube: *b, sub: 0 }.order_key());
        let mut vertex_count = 0u32;
        let numbered: FxHashMap<IVec3, Numbered> = blocks
            .iter()
            .map(|&(b, block)| {
                let first = vertex_count;
                vertex_count += block.len() as u32;
                (b, Numbered { first, block })
            })
            .collect();
        let triangles = self.triangles(&numbered);
        let lengths: Vec<usize> = blocks.iter().map(|(_, block)| block.len()).collect();
        let channel = |of: for<'b> fn(&'b VertexArrays, &mut [Vec3])| -> Vec<Vec3> {
            let mut out = vec![Vec3::ZERO; vertex_count as usize];
            split_by(&mut out, &lengths).into_par_iter().zip(&blocks).for_each(|(run, (_, block))| {
                of(block.vertices(), run);
            });
            out
        };
        // Linear placement takes its normals from the faces: the vertices keep none.
        let linear = self.options.vertex == VertexPlacement::Linear;
        let mut mesh = Mesh {
            positions: channel(|v, out| out.copy_from_slice(v.positions())),
            normals: if linear { vec![] } else { channel(|v, out| fill(out, v.normals())) },
            colors: (self.with_colors && vertex_count > 0).then(|| channel(|v, out| fill(out, v.colors()))),
            triangles,
            ..Mesh::default()
        };
        if linear {
            mesh.set_normals_from_faces();
        }
        mesh
    }

    /// Edge `key`'s vertex, which every crossed edge of a crossed cell has.
    fn vertex(&self, key: EdgeKey) -> EdgeVertex {
        self.vertices.get(key).unwrap_or_else(|| panic!("no vertex on the edge with key {key}"))
    }

    /// Every crossed cell's triangles, brick by brick in order, with the
    /// vertices numbered as in `numbered`.
    fn triangles(&self, numbered: &FxHashMap<IVec3, Numbered>) -> Vec<[u32; 3]> {
        let shape = self.options.cells;
        let per_cube = self.cells.cells_per_cube();
        let bricks = self.cells.bricks_in_order();
        let counts: Vec<usize> = bricks
            .par_iter()
            .map(|(_, brick)| brick.visited().map(|(_, mask)| triangle_count(shape, mask)).sum())
            .collect();
        let mut triangles = vec![[0u32; 3]; counts.iter().sum()];
        let kinds = self.vertices.kinds();
        let runs = split_by(&mut triangles, &counts);
        // Tetrahedra read positions with their numbers, through `Ids::find`.
        let table_size = if shape == CellShape::Cubes { BRICK_CUBES * kinds } else { 0 };
        let own_table = || vec![UNKNOWN; table_size];
        runs.into_par_iter().zip(&bricks).for_each_init(own_table, |own, (run, &(b, brick))| {
            let mut ids = Ids::new(numbered, kinds, b, own);
            let mut out = Out { run, next: 0 };
            for (slot, mask) in brick.visited() {
                if crossed(mask, shape) {
                    let cell = cell_of(per_cube, b, slot);
                    match shape {
                        CellShape::Cubes => out.cube(cell, mask, &mut ids),
                        CellShape::Bcc => out.polygons(shape, cell, mask, &mut ids),
                    }
                }
            }
            debug_assert_eq!(out.next, out.run.len(), "the brick's triangles were counted");
            ids.clear_own();
        });
        triangles
    }
}

/// How many triangles a cell of sign case `mask` gives.
fn triangle_count(shape: CellShape, mask: u8) -> usize {
    if !crossed(mask, shape) {
        return 0;
    }
    match shape {
        CellShape::Cubes => cubes::case_triangles(mask).len(),
        // One vertex inside or outside cuts a triangle off; two, a quadrilateral.
        CellShape::Bcc => match mask.count_ones() {
            2 => 2,
            _ => 1,
        },
    }
}

/// Writes `values` over `out`, in order.
fn fill(out: &mut [Vec3], values: impl Iterator<Item = Vec3>) {
    for (o, v) in out.iter_mut().zip(values) {
        *o = v;
    }
}

/// Cuts `all` into consecutive runs of `lengths`.
fn split_by<'a, T>(mut all: &'a mut [T], lengths: &[usize]) -> Vec<&'a mut [T]> {
    lengths
        .iter()
        .map(|&n| {
            let (run, rest) = std::mem::take(&mut all).split_at_mut(n);
            all = rest;
            run
        })
        .collect()
}

/// A vertex number not known.
const UNKNOWN: u32 = u32::MAX;

/// Finds vertex numbers by edge: those of the brick's own block in a table
/// by edge number (most of its cells' edges), the others through the blocks
/// used last, one per parity of the block's coordinates (a cell's edges lie
/// in at most eight blocks of distinct parities, and the cells of a brick
/// meet them again).
struct Ids<'a, 't> {
    numbered: &'a FxHashMap<IVec3, Numbered<'a>>,
    kinds: usize,
    own: (IVec3, Option<Numbered<'a>>),
    /// Vertex numbers of the own block's edges, by edge number ([`UNKNOWN`] elsewhere).
    own_ids: &'t mut [u32],
    recent: [(IVec3, Option<Numbered<'a>>); 8],
}

impl<'a, 't> Ids<'a, 't> {
    /// Finder for the cells of the brick `block`, with `own_ids` all
    /// [`UNKNOWN`] (or empty, to find every vertex through its block).
    fn new(numbered: &'a FxHashMap<IVec3, Numbered<'a>>, kinds: usize, block: IVec3, own_ids: &'t mut [u32]) -> Self {
        let own = numbered.get(&block).copied().filter(|_| !own_ids.is_empty());
        if let Some(n) = own {
            for (i, &number) in n.block.edges().iter().enumerate() {
                own_ids[usize::from(number)] = n.first + i as u32;
            }
        }
        Self { numbered, kinds, own: (block, own), own_ids, recent: [(IVec3::splat(i32::MIN), None); 8] }
    }

    /// Leaves the own block's table all [`UNKNOWN`] again.
    fn clear_own(&mut self) {
        if let Some(n) = self.own.1 {
            for &number in n.block.edges() {
                self.own_ids[usize::from(number)] = UNKNOWN;
            }
        }
    }

    /// The block holding edge `key`'s vertex and its index there.
    #[inline]
    fn find(&mut self, key: EdgeKey) -> (Numbered<'a>, u32) {
        let (block, number) = locate(self.kinds, key);
        let way = (block.x & 1 | (block.y & 1) << 1 | (block.z & 1) << 2) as usize;
        if self.recent[way].0 != block {
            self.recent[way] = (block, self.numbered.get(&block).copied());
        }
        self.recent[way]
            .1
            .and_then(|n| n.block.index_of(self.kinds, number).map(|i| (n, i)))
            .unwrap_or_else(|| panic!("no vertex on the edge with key {key}"))
    }

    /// The number of edge `key`'s vertex.
    #[inline]
    fn id(&mut self, key: EdgeKey) -> u32 {
        let (block, number) = locate(self.kinds, key);
        if block == self.own.0 && !self.own_ids.is_empty() {
            let id = self.own_ids[usize::from(number)];
            assert_ne!(id, UNKNOWN, "no vertex on the edge with key {key}");
            return id;
        }
        let (n, i) = self.find(key);
        n.first + i
    }
}

/// A brick's run of triangles, written in order.
struct Out<'r> {
    run: &'r mut [[u32; 3]],
    next: usize,
}

impl Out<'_> {
    fn push(&mut self, t: [u32; 3]) {
        self.run[self.next] = t;
        self.next += 1;
    }

    /// A cube's triangles, each crossed edge's number found once (its
    /// triangles share most of them).
    fn cube(&mut self, cell: Cell, mask: u8, ids: &mut Ids) {
        let mut of_edge = [UNKNOWN; 12];
        for triangle in cubes::case_triangles(mask) {
            self.push(triangle.map(|e| {
                let known = &mut of_edge[usize::from(e)];
                if *known == UNKNOWN {
                    *known = ids.id(cubes::edge_key_of(cell, e));
                }
                *known
            }));
        }
    }

    /// A cell's polygons, each cut by [`crate::mesh::triangulate`].
    fn polygons(&mut self, shape: CellShape, cell: Cell, mask: u8, ids: &mut Ids) {
        let mut local = Vec::with_capacity(4);
        shape.polygons(cell, mask, &mut |polygon| {
            let corners: Vec<(u32, Vec3)> = polygon
                .iter()
                .map(|&[a, b]| {
                    let (n, i) = ids.find(edge_key(a, b));
                    (n.first + i, n.block.vertex(i as usize).position)
                })
                .collect();
            let order: Vec<u32> = (0..corners.len() as u32).collect();
            local.clear();
            crate::mesh::triangulate(&order, |i| corners[i as usize].1, &mut local);
            for t in &local {
                self.push(t.map(|i| corners[i as usize].0));
            }
        });
    }
}
