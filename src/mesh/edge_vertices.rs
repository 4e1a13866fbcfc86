//! The vertices placed on crossed edges, kept block by block: each block of
//! 8³ cubes (the bricks visited cells are kept in) owns the vertices of the
//! edges its cubes own, in one array sorted by edge, with a table of where
//! each cube's edges start in it.
//!
//! An edge's key (the sum of its ends, in half-cell coordinates) names a
//! cube (`key >> 2`) and, by its remainders mod 4, one of the few kinds of
//! edge a cube owns: three axis edges from its lowest corner, and for
//! tetrahedra also three between centres and eight from its centre to its
//! corners. Within its block an edge is numbered `cube · kinds + kind`, the
//! cube counted x fastest, so the array's order is a pure function of which
//! edges hold vertices: the vertices can be numbered block after block
//! without a pass over the cells, and a local update that ends with the same
//! edges as a fresh polygonization numbers them the same way.
//!
//! Blocks are filled and read whole, one thread each: a block is found with
//! one lookup, and an edge inside it with a table read and a step or two.

use glam::{IVec3, Vec3};
use rustc_hash::FxHashMap;

use super::lattice::{EdgeKey, LatticePoint, ordered_edge};
use super::visited::{BRICK_CUBES, BRICK_SHIFT, cube_at, cube_slot};
use crate::field::DEFAULT_COLOR;

/// A vertex on a crossed edge: position, unit outward normal, colour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeVertex {
    /// Position on the surface.
    pub position: Vec3,
    /// Unit outward normal from the field gradient (zero where it vanished).
    pub normal: Vec3,
    /// Linear RGB colour ([`crate::field::DEFAULT_COLOR`] when the model has one colour).
    pub color: Vec3,
}

/// A remainder pattern no edge has.
const NO_KIND: u8 = u8::MAX;

/// The remainders mod 4 of the keys of the edges a cube owns: its axis
/// edges, then (on a body-centred lattice) the edges between centres and
/// from its centre to its eight corners.
const KINDS: [[i32; 3]; 14] = [
    [2, 0, 0],
    [0, 2, 0],
    [0, 0, 2],
    [0, 2, 2],
    [2, 0, 2],
    [2, 2, 0],
    [1, 1, 1],
    [3, 1, 1],
    [1, 3, 1],
    [3, 3, 1],
    [1, 1, 3],
    [3, 1, 3],
    [1, 3, 3],
    [3, 3, 3],
];

/// The kind of an edge by its key's remainders, `x + 4y + 16z`.
const KIND_OF_PATTERN: [u8; 64] = {
    let mut table = [NO_KIND; 64];
    let mut kind = 0;
    while kind < KINDS.len() {
        let [x, y, z] = KINDS[kind];
        table[(x + 4 * y + 16 * z) as usize] = kind as u8;
        kind += 1;
    }
    table
};

/// An edge's number within its block.
pub(super) type EdgeNumber = u16;

// Every edge of a block, with the most kinds, has a number (and `starts` a count).
const _: () = assert!(BRICK_CUBES * KINDS.len() <= 1 << 16);

/// The kind of the edge with key `key` (an index into [`KINDS`]), or [`NO_KIND`].
#[inline]
fn kind_of(key: EdgeKey) -> u8 {
    let rest = key & IVec3::splat(3);
    KIND_OF_PATTERN[(rest.x + 4 * rest.y + 16 * rest.z) as usize]
}

/// The block of edge `key` and the edge's number there, with `kinds` edges per cube.
#[inline]
pub(super) fn locate(kinds: usize, key: EdgeKey) -> (IVec3, EdgeNumber) {
    let kind = kind_of(key);
    assert!(usize::from(kind) < kinds, "{key} is no edge key of this lattice");
    let cube: IVec3 = key >> 2;
    (cube >> BRICK_SHIFT, (cube_slot(cube) * kinds + usize::from(kind)) as EdgeNumber)
}

/// The key of edge `number` of block `block`, with `kinds` edges per cube.
pub(super) fn key_at(kinds: usize, block: IVec3, number: EdgeNumber) -> EdgeKey {
    let (cube, kind) = (usize::from(number) / kinds, usize::from(number) % kinds);
    (cube_at(block, cube) << 2) + IVec3::from_array(KINDS[kind])
}

/// The ends of the edge with key `key`, in [`ordered_edge`]'s order: two
/// corners or two centres (kinds 0–2 and 3–5, along x, y and z in turn) sit
/// one step either side of the midpoint `key / 2`; a corner and a centre are
/// the unique even point `(key − d) / 2`, `d ∈ {±1}³`, and the rest of the sum.
#[must_use]
pub fn ends_of(key: EdgeKey) -> [LatticePoint; 2] {
    let kind = kind_of(key);
    if kind < 6 {
        let mut step = IVec3::ZERO;
        step[usize::from(kind % 3)] = 1;
        let half = key >> 1;
        return ordered_edge(half - step, half + step);
    }
    // (key − d) / 2 even for each axis: d ≡ key (mod 4) picks d = ±1.
    let d = IVec3::select((key & IVec3::splat(3)).cmpeq(IVec3::ONE), IVec3::ONE, IVec3::NEG_ONE);
    let corner = (key - d) >> 1;
    ordered_edge(corner, key - corner)
}

/// Which channels the vertices keep beside their positions: normals unless
/// the mesh takes its normals from its faces, colours where the model has
/// more than one. A vertex costs only what its channels need.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct Channels {
    pub normals: bool,
    pub colors: bool,
}

/// Vertices as one array per channel; a channel not kept reads as a zero
/// normal or the default colour.
#[derive(Clone, Debug, Default)]
pub(super) struct VertexArrays {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    colors: Vec<Vec3>,
}

impl VertexArrays {
    fn len(&self) -> usize {
        self.positions.len()
    }

    fn reserve(&mut self, channels: Channels, n: usize) {
        self.positions.reserve_exact(n);
        if channels.normals {
            self.normals.reserve_exact(n);
        }
        if channels.colors {
            self.colors.reserve_exact(n);
        }
    }

    /// Every channel's array.
    fn arrays(&mut self) -> [&mut Vec<Vec3>; 3] {
        [&mut self.positions, &mut self.normals, &mut self.colors]
    }

    /// Adds `v`, keeping the channels asked for. A block is filled whole with
    /// one set of channels (see [`EdgeBlock::add`]), so each channel holds
    /// every vertex or none.
    fn push(&mut self, channels: Channels, v: EdgeVertex) {
        if channels.normals {
            self.normals.push(v.normal);
        }
        if channels.colors {
            self.colors.push(v.color);
        }
        self.positions.push(v.position);
    }

    /// Vertex `i`.
    #[inline]
    fn get(&self, i: usize) -> EdgeVertex {
        EdgeVertex {
            position: self.positions[i],
            normal: self.normals.get(i).copied().unwrap_or(Vec3::ZERO),
            color: self.colors.get(i).copied().unwrap_or(DEFAULT_COLOR),
        }
    }

    /// The positions, in order.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// The normals, in order.
    pub fn normals(&self) -> impl Iterator<Item = Vec3> + '_ {
        self.normals.iter().copied().chain(std::iter::repeat(Vec3::ZERO)).take(self.len())
    }

    /// The colours, in order.
    pub fn colors(&self) -> impl Iterator<Item = Vec3> + '_ {
        self.colors.iter().copied().chain(std::iter::repeat(DEFAULT_COLOR)).take(self.len())
    }
}

/// One block's vertices.
#[derive(Clone, Debug, Default)]
pub(super) struct EdgeBlock {
    /// The numbers of the edges holding vertices, ascending.
    edges: Vec<EdgeNumber>,
    /// Their vertices, in the same order.
    vertices: VertexArrays,
    /// `starts[c]`: how many of `edges` belong to cubes before cube `c`
    /// (`BRICK_CUBES + 1` entries; empty while the block is).
    starts: Vec<u16>,
}

impl EdgeBlock {
    /// The vertices, in the order of their edges.
    pub fn vertices(&self) -> &VertexArrays {
        &self.vertices
    }

    /// The numbers of the edges holding vertices, ascending.
    pub fn edges(&self) -> &[EdgeNumber] {
        &self.edges
    }

    /// Vertex `i`, in the order of the edges.
    #[inline]
    pub fn vertex(&self, i: usize) -> EdgeVertex {
        self.vertices.get(i)
    }

    /// Vertices held.
    pub fn len(&self) -> usize {
        self.edges.len()
    }

    /// The index in [`Self::vertices`] of edge `number`'s vertex, if it has one.
    #[inline]
    pub fn index_of(&self, kinds: usize, number: EdgeNumber) -> Option<u32> {
        if self.starts.is_empty() {
            return None;
        }
        let cube = usize::from(number) / kinds;
        let (first, last) = (usize::from(self.starts[cube]), usize::from(self.starts[cube + 1]));
        (first..last).find(|&i| self.edges[i] == number).map(|i| i as u32)
    }

    /// Adds the edges `wanted` (ascending, without repeats) that hold no
    /// vertex yet, their vertices taken from `place` and kept in `channels`;
    /// the rest of `wanted` keep theirs.
    pub fn add(
        &mut self,
        kinds: usize,
        channels: Channels,
        wanted: impl IntoIterator<Item = EdgeNumber>,
        mut place: impl FnMut(EdgeNumber) -> EdgeVertex,
    ) {
        let mut wanted = wanted.into_iter().peekable();
        if wanted.peek().is_none() {
            return;
        }
        // The block is rebuilt whole, merging the edges it holds with those wanted.
        let (old_edges, old) = (std::mem::take(&mut self.edges), std::mem::take(&mut self.vertices));
        let more = old_edges.len() + wanted.size_hint().0;
        self.edges.reserve_exact(more);
        self.vertices.reserve(channels, more);
        let mut old_edges = old_edges.into_iter().enumerate().peekable();
        loop {
            let take_old = match (old_edges.peek(), wanted.peek()) {
                (None, None) => break,
                (Some(_), None) => true,
                (None, Some(_)) => false,
                (Some(&(_, o)), Some(&w)) => {
                    if o == w {
                        wanted.next();
                    }
                    o <= w
                }
            };
            let (number, vertex) = if take_old {
                let (i, number) = old_edges.next().expect("peeked");
                (number, old.get(i))
            } else {
                let number = wanted.next().expect("peeked");
                (number, place(number))
            };
            self.edges.push(number);
            self.vertices.push(channels, vertex);
        }
        debug_assert!(self.edges.is_sorted_by(|a, b| a < b), "edges wanted ascending, without repeats");
        self.index(kinds);
    }

    /// Keeps the vertices of the edges for which `keep` holds.
    fn retain(&mut self, kinds: usize, mut keep: impl FnMut(EdgeNumber) -> bool) {
        let mut kept = 0;
        let before = self.edges.len();
        for i in 0..before {
            if keep(self.edges[i]) {
                self.edges[kept] = self.edges[i];
                // A channel not kept is empty.
                for array in self.vertices.arrays().into_iter().filter(|a| !a.is_empty()) {
                    array[kept] = array[i];
                }
                kept += 1;
            }
        }
        self.edges.truncate(kept);
        for array in self.vertices.arrays() {
            array.truncate(kept);
        }
        if kept < before {
            self.index(kinds);
        }
    }

    /// Rebuilds `starts` from `edges`.
    fn index(&mut self, kinds: usize) {
        self.starts.clear();
        if self.edges.is_empty() {
            return;
        }
        self.starts.reserve_exact(BRICK_CUBES + 1);
        let mut i = 0;
        for cube in 0..=BRICK_CUBES {
            while i < self.edges.len() && usize::from(self.edges[i]) < cube * kinds {
                i += 1;
            }
            self.starts.push(i as u16);
        }
    }
}

/// Vertices by edge, in blocks.
#[derive(Clone, Debug)]
pub(super) struct EdgeVertices {
    /// Edge kinds per cube: 3 for cubes, 14 with centres.
    kinds: usize,
    blocks: FxHashMap<IVec3, EdgeBlock>,
}

impl EdgeVertices {
    /// An empty store for the edges of cubes, or with `centres` of a body-centred lattice too.
    pub fn new(centres: bool) -> Self {
        Self { kinds: if centres { 14 } else { 3 }, blocks: FxHashMap::default() }
    }

    /// Edge kinds per cube.
    pub fn kinds(&self) -> usize {
        self.kinds
    }

    /// Every block holding vertices.
    pub fn blocks(&self) -> impl Iterator<Item = (IVec3, &EdgeBlock)> {
        self.blocks.iter().map(|(&b, block)| (b, block))
    }

    /// Whether no edge holds a vertex.
    pub fn is_empty(&self) -> bool {
        self.blocks.is_empty()
    }

    /// Whether edge `key` holds a vertex.
    pub fn contains(&self, key: EdgeKey) -> bool {
        let (block, number) = locate(self.kinds, key);
        self.blocks.get(&block).is_some_and(|b| b.index_of(self.kinds, number).is_some())
    }

    /// Edge `key`'s vertex, if it has one.
    pub fn get(&self, key: EdgeKey) -> Option<EdgeVertex> {
        let (block, number) = locate(self.kinds, key);
        let b = self.blocks.get(&block)?;
        b.index_of(self.kinds, number).map(|i| b.vertex(i as usize))
    }

    /// Takes out block `block` (an empty one where none was) for one thread to fill.
    pub fn take(&mut self, block: IVec3) -> EdgeBlock {
        self.blocks.remove(&block).unwrap_or_default()
    }

    /// Puts a block taken out back (nothing, if it is empty).
    pub fn put(&mut self, block: IVec3, vertices: EdgeBlock) {
        if vertices.len() > 0 {
            self.blocks.insert(block, vertices);
        }
    }

    /// Keeps only the vertices of the edges for which `keep` holds.
    pub fn retain(&mut self, mut keep: impl FnMut(EdgeKey) -> bool) {
        let kinds = self.kinds;
        self.blocks.retain(|&block, vertices| {
            vertices.retain(kinds, |number| keep(key_at(kinds, block, number)));
            vertices.len() > 0
        });
    }
}

#[cfg(test)]
mod tests {
    use glam::IVec3;

    use super::*;
    use crate::mesh::lattice::edge_key;

    fn vertex(x: f32) -> EdgeVertex {
        EdgeVertex { position: Vec3::splat(x), normal: Vec3::Z, color: Vec3::ONE }
    }

    /// Puts the vertices `(key, vertex)` into `v`, block by block.
    fn add(v: &mut EdgeVertices, items: &[(EdgeKey, EdgeVertex)]) {
        let kinds = v.kinds();
        let mut by_block: Vec<(IVec3, EdgeNumber, EdgeVertex)> =
            items.iter().map(|&(k, x)| (locate(kinds, k).0, locate(kinds, k).1, x)).collect();
        by_block.sort_by_key(|&(b, n, _)| (b.to_array(), n));
        for run in by_block.chunk_by(|a, b| a.0 == b.0) {
            let mut block = v.take(run[0].0);
            let vertex_of = |n: EdgeNumber| run.iter().find(|r| r.1 == n).expect("wanted").2;
            block.add(kinds, Channels { normals: true, colors: true }, run.iter().map(|r| r.1), vertex_of);
            v.put(run[0].0, block);
        }
    }

    fn held(v: &EdgeVertices) -> usize {
        v.blocks().map(|(_, b)| b.len()).sum()
    }

    /// The key of the x edge of cube `(k, 0, 0)`.
    fn key(k: i32) -> IVec3 {
        IVec3::new(4 * k + 2, 0, 0)
    }

    #[test]
    fn vertices_are_found_by_edge_kept_as_placed_and_dropped() {
        let mut v = EdgeVertices::new(false);
        // Ten edges over two blocks.
        add(&mut v, &(0..10).map(|k| (key(k), vertex(k as f32))).collect::<Vec<_>>());
        assert_eq!(held(&v), 10);
        assert_eq!(v.get(key(3)), Some(vertex(3.0)));
        v.retain(|key| (key.x - 2) / 4 % 2 == 0);
        assert_eq!(held(&v), 5);
        assert!(v.get(key(3)).is_none() && v.get(key(4)).is_some());
        // Edges already holding a vertex keep it; the others get theirs.
        add(&mut v, &(0..15).map(|k| (key(k), vertex(100.0 + k as f32))).collect::<Vec<_>>());
        assert_eq!(held(&v), 15);
        for k in 0..15 {
            let kept = k < 10 && k % 2 == 0;
            assert_eq!(v.get(key(k)), Some(vertex(if kept { k as f32 } else { 100.0 + k as f32 })), "edge {k}");
        }
        // A block's vertices run in the order of their edges.
        let (_, first) = v.blocks().find(|(b, _)| *b == IVec3::ZERO).expect("block 0");
        let xs: Vec<f32> = first.vertices().positions().iter().map(|p| p.x).collect();
        assert_eq!(xs, [0.0, 101.0, 2.0, 103.0, 4.0, 105.0, 6.0, 107.0]);
    }

    #[test]
    fn a_block_keeps_only_the_channels_asked_for_and_fills_in_one_taken_on_later() {
        let mut block = EdgeBlock::default();
        let v = |x: f32| EdgeVertex { position: Vec3::splat(x), normal: Vec3::X, color: Vec3::ONE };
        let bare = Channels::default();
        block.add(3, bare, [0, 4], |n| v(f32::from(n)));
        assert_eq!(
            block.vertex(1),
            EdgeVertex { position: Vec3::splat(4.0), normal: Vec3::ZERO, color: DEFAULT_COLOR }
        );
        assert!(
            block.vertices().normals.is_empty() && block.vertices().colors.is_empty(),
            "nothing kept but positions"
        );
        // Colours from now on: the vertices before read the default colour.
        block.add(3, Channels { normals: false, colors: true }, [2], |n| v(f32::from(n)));
        let colors: Vec<Vec3> = block.vertices().colors().collect();
        assert_eq!(colors, [DEFAULT_COLOR, Vec3::ONE, DEFAULT_COLOR]);
        assert_eq!(block.vertices().positions(), [Vec3::ZERO, Vec3::splat(2.0), Vec3::splat(4.0)]);
        block.retain(3, |n| n != 0);
        assert_eq!(block.vertices().colors().collect::<Vec<_>>(), [Vec3::ONE, DEFAULT_COLOR]);
        assert_eq!(block.index_of(3, 4), Some(1));
        assert_eq!(block.index_of(3, 0), None);
    }

    #[test]
    fn every_edge_of_a_body_centred_lattice_has_its_own_number_key_and_ends() {
        let mut v = EdgeVertices::new(true);
        let mut edges = vec![];
        for cube in [IVec3::new(-5, 3, 0), IVec3::new(7, -1, -9), IVec3::ZERO, IVec3::new(-8, -1, 15)] {
            let (corner, centre) = (cube * 2, cube * 2 + IVec3::ONE);
            for axis in 0..3 {
                let mut step = IVec3::ZERO;
                step[axis] = 2;
                edges.extend([[corner, corner + step], [centre, centre + step]]);
            }
            for i in 0..8 {
                let offset = IVec3::new(i & 1, i >> 1 & 1, i >> 2 & 1) * 2;
                edges.push([corner + offset, centre]);
            }
        }
        for &[a, b] in &edges {
            assert_eq!(ends_of(edge_key(a, b)), ordered_edge(a, b), "{a} {b}");
        }
        let keys: Vec<EdgeKey> = edges.iter().map(|&[a, b]| edge_key(a, b)).collect();
        add(&mut v, &keys.iter().enumerate().map(|(i, &k)| (k, vertex(i as f32))).collect::<Vec<_>>());
        assert_eq!(held(&v), keys.len());
        for (i, &k) in keys.iter().enumerate() {
            assert_eq!(v.get(k), Some(vertex(i as f32)), "{k}");
        }
        let mut listed = vec![];
        v.retain(|k| {
            listed.push(k.to_array());
            true
        });
        listed.sort_unstable();
        let mut expected: Vec<[i32; 3]> = keys.iter().map(|k| k.to_array()).collect();
        expected.sort_unstable();
        assert_eq!(listed, expected);
    }
}
