//! The vertices placed on crossed edges: kept side by side in one array and
//! found by edge through dense bricks of their slots there.
//!
//! An edge's key (the sum of its ends, in half-cell coordinates) names a
//! cube (`key >> 2`) and, by its remainders mod 4, one of the few kinds of
//! edge a cube owns: three axis edges from its lowest corner, and for
//! tetrahedra also three between centres and eight from its centre to its
//! corners. Slots live in bricks of 4³ cubes, one array per brick, so the
//! edges of neighbouring cells are found next to each other in memory.
//!
//! A hash map from every edge to its slot made the mesh's assembly slow:
//! its million lookups, spread over a table larger than the processor's
//! caches, each missed them.

use glam::{IVec3, Vec3};
use rustc_hash::FxHashMap;

use super::lattice::EdgeKey;

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

/// Bricks hold 4³ cubes.
const BRICK_SHIFT: i32 = 2;
const BRICK_CUBES: usize = 1 << (3 * BRICK_SHIFT);
/// A slot no vertex holds.
const NONE: u32 = u32::MAX;
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

/// Vertices by edge.
#[derive(Clone, Debug)]
pub(super) struct EdgeVertices {
    /// Edge kinds per cube: 3 for cubes, 14 with centres.
    kinds: usize,
    bricks: FxHashMap<IVec3, Box<[u32]>>,
    placed: Vec<EdgeVertex>,
    /// Slots of vertices dropped, taken again before the array grows.
    free: Vec<u32>,
    held: usize,
}

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

/// The brick of edge `key` and its index there, with `kinds` edges per cube.
#[inline]
fn locate(kinds: usize, key: EdgeKey) -> (IVec3, usize) {
    let rest = key & IVec3::splat(3);
    let kind = KIND_OF_PATTERN[(rest.x + 4 * rest.y + 16 * rest.z) as usize];
    assert!(usize::from(kind) < kinds, "{key} is no edge key of this lattice");
    let cube: IVec3 = key >> 2;
    let within = cube & IVec3::splat((1 << BRICK_SHIFT) - 1);
    let index = (within.x | within.y << BRICK_SHIFT | within.z << (2 * BRICK_SHIFT)) as usize;
    (cube >> BRICK_SHIFT, index * kinds + usize::from(kind))
}

impl EdgeVertices {
    /// An empty store for the edges of cubes, or with `centres` of a body-centred lattice too.
    pub fn new(centres: bool) -> Self {
        Self {
            kinds: if centres { 14 } else { 3 },
            bricks: FxHashMap::default(),
            placed: vec![],
            free: vec![],
            held: 0,
        }
    }

    /// The brick of edge `key` and its index there.
    #[inline]
    fn locate(&self, key: EdgeKey) -> (IVec3, usize) {
        locate(self.kinds, key)
    }

    /// The key of the edge at `index` of brick `brick`, with `kinds` edges per cube.
    fn key_at(kinds: usize, brick: IVec3, index: usize) -> EdgeKey {
        let (cube, kind) = ((index / kinds) as i32, index % kinds);
        let side = (1 << BRICK_SHIFT) - 1;
        let within = IVec3::new(cube & side, cube >> BRICK_SHIFT & side, cube >> (2 * BRICK_SHIFT));
        (((brick << BRICK_SHIFT) + within) << 2) + IVec3::from_array(KINDS[kind])
    }

    /// Vertices held.
    pub fn len(&self) -> usize {
        self.held
    }

    /// Slots in the array, held or free: every slot number lies below it.
    pub fn slot_count(&self) -> usize {
        self.placed.len()
    }

    /// Whether edge `key` has a vertex.
    pub fn contains(&self, key: EdgeKey) -> bool {
        self.slot(key).is_some()
    }

    /// The slot of edge `key`'s vertex, if it has one.
    #[inline]
    pub fn slot(&self, key: EdgeKey) -> Option<u32> {
        let (brick, index) = self.locate(key);
        self.bricks.get(&brick).map(|b| b[index]).filter(|&s| s != NONE)
    }

    /// The vertex in slot `slot`.
    #[inline]
    pub fn at(&self, slot: u32) -> EdgeVertex {
        self.placed[slot as usize]
    }

    /// Edge `key`'s vertex, if it has one.
    pub fn get(&self, key: EdgeKey) -> Option<EdgeVertex> {
        self.slot(key).map(|s| self.at(s))
    }

    /// Gives each edge of `keys`, none of which has a vertex yet, the vertex
    /// at its index in `vertices`: the free slots first, then new ones (the
    /// vertices are moved in whole when the store is empty).
    pub fn insert_new(&mut self, keys: impl ExactSizeIterator<Item = EdgeKey>, mut vertices: Vec<EdgeVertex>) {
        assert_eq!(keys.len(), vertices.len(), "one vertex per edge");
        let reused = self.free.len().min(vertices.len());
        let taken: Vec<u32> = self.free.drain(self.free.len() - reused..).rev().collect();
        for (&slot, vertex) in taken.iter().zip(&vertices) {
            self.placed[slot as usize] = *vertex;
        }
        let first_new = self.placed.len();
        if self.placed.is_empty() {
            self.placed = vertices;
        } else {
            self.placed.extend(vertices.drain(reused..));
        }
        self.held += keys.len();
        let slot_of = |i: usize| taken.get(i).copied().unwrap_or_else(|| (first_new + i - reused) as u32);
        for_each_slot(self.kinds, &mut self.bricks, keys.enumerate().map(|(i, key)| (key, i)), |i, slot| {
            assert_eq!(*slot, NONE, "an edge given a new vertex had one");
            *slot = slot_of(i);
        });
    }

    /// Keeps only the vertices of the edges for which `keep` holds.
    pub fn retain(&mut self, mut keep: impl FnMut(EdgeKey) -> bool) {
        let Self { kinds, bricks, free, held, .. } = self;
        bricks.retain(|&brick, slots| {
            let mut any = false;
            for (index, slot) in slots.iter_mut().enumerate() {
                if *slot == NONE {
                    continue;
                }
                if keep(Self::key_at(*kinds, brick, index)) {
                    any = true;
                } else {
                    free.push(*slot);
                    *held -= 1;
                    *slot = NONE;
                }
            }
            any
        });
    }
}

/// Calls `visit` with each item's payload and the slot of its edge (in a
/// brick made for it if it had none). Edges listed cell by cell fall in the
/// brick of the edge before them, which is then found again without a lookup.
fn for_each_slot<T>(
    kinds: usize,
    bricks: &mut FxHashMap<IVec3, Box<[u32]>>,
    items: impl IntoIterator<Item = (EdgeKey, T)>,
    mut visit: impl FnMut(T, &mut u32),
) {
    let slots_per_brick = BRICK_CUBES * kinds;
    let mut current: Option<(IVec3, &mut Box<[u32]>)> = None;
    for (key, item) in items {
        let (brick, index) = locate(kinds, key);
        if current.as_ref().is_none_or(|(b, _)| *b != brick) {
            let slots = bricks.entry(brick).or_insert_with(|| vec![NONE; slots_per_brick].into_boxed_slice());
            current = Some((brick, slots));
        }
        let Some((_, slots)) = current.as_mut() else { unreachable!("the brick was found above") };
        visit(item, &mut slots[index]);
    }
}

/// Looks slots up through the bricks used last, one per parity of the
/// brick's coordinates: the edges of one cell lie in at most eight bricks
/// of distinct parities, and cells taken in order meet them again.
pub(super) struct SlotCursor<'a> {
    store: &'a EdgeVertices,
    recent: [(IVec3, Option<&'a [u32]>); 8],
}

impl<'a> SlotCursor<'a> {
    /// A cursor over `store`.
    pub fn new(store: &'a EdgeVertices) -> Self {
        Self { store, recent: [(IVec3::splat(i32::MIN), None); 8] }
    }

    /// The slot of edge `key`'s vertex, if it has one.
    #[inline]
    pub fn slot(&mut self, key: EdgeKey) -> Option<u32> {
        let (brick, index) = self.store.locate(key);
        let way = (brick.x & 1 | (brick.y & 1) << 1 | (brick.z & 1) << 2) as usize;
        if self.recent[way].0 != brick {
            self.recent[way] = (brick, self.store.bricks.get(&brick).map(|b| &**b));
        }
        self.recent[way].1.map(|b| b[index]).filter(|&s| s != NONE)
    }
}

#[cfg(test)]
mod tests {
    use glam::IVec3;

    use super::*;

    fn vertex(x: f32) -> EdgeVertex {
        EdgeVertex { position: Vec3::splat(x), normal: Vec3::Z, color: Vec3::ONE }
    }

    /// The key of the x edge of cube `(k, 0, 0)`.
    fn key(k: i32) -> IVec3 {
        IVec3::new(4 * k + 2, 0, 0)
    }

    #[test]
    fn vertices_are_found_by_edge_and_dropped_slots_are_taken_again() {
        let mut v = EdgeVertices::new(false);
        // Ten edges over three bricks, in one call.
        v.insert_new((0..10).map(key), (0..10).map(|k| vertex(k as f32)).collect());
        assert_eq!((v.len(), v.slot_count()), (10, 10));
        assert_eq!(v.get(key(3)), Some(vertex(3.0)));
        v.retain(|key| (key.x - 2) / 4 % 2 == 0);
        assert_eq!(v.len(), 5);
        assert!(!v.contains(key(3)) && v.contains(key(4)));
        v.insert_new((10..15).map(key), (10..15).map(|k| vertex(k as f32)).collect());
        assert_eq!((v.len(), v.slot_count()), (10, 10), "the five dropped slots were taken again");
        for k in (0..10).step_by(2).chain(10..15) {
            assert_eq!(v.get(key(k)), Some(vertex(k as f32)), "edge {k}");
        }
    }

    #[test]
    fn every_edge_of_a_body_centred_lattice_has_its_own_slot_and_key() {
        let mut v = EdgeVertices::new(true);
        let mut keys = vec![];
        for cube in [IVec3::new(-5, 3, 0), IVec3::new(7, -1, -9), IVec3::ZERO] {
            let (corner, centre) = (cube * 2, cube * 2 + IVec3::ONE);
            for axis in 0..3 {
                let mut step = IVec3::ZERO;
                step[axis] = 2;
                keys.extend([corner + corner + step, centre + centre + step]);
            }
            for i in 0..8 {
                let offset = IVec3::new(i & 1, i >> 1 & 1, i >> 2 & 1) * 2;
                keys.push(corner + offset + centre);
            }
        }
        // Edges of three cubes in three bricks, the bricks taken in turn.
        v.insert_new(keys.iter().copied(), (0..keys.len()).map(|i| vertex(i as f32)).collect());
        assert_eq!(v.len(), keys.len());
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
