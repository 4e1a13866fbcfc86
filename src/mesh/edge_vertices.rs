//! The vertices placed on crossed edges: kept side by side in one array and
//! found by edge through a map of their slots there.
//!
//! A map of whole vertices made the polygonizer's two serial passes slow at
//! res 512: inserting each vertex moved 48-byte entries through a 20 MB
//! table, and numbering the mesh's vertices by first use looked two million
//! polygon edges up in a map built as it went. Slots keep the map small, and
//! the mesh looks its edges' slots up in parallel, leaving the serial pass
//! to walk dense slot numbers.

use glam::Vec3;
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

/// Vertices by edge.
#[derive(Clone, Debug, Default)]
pub(super) struct EdgeVertices {
    slots: FxHashMap<EdgeKey, u32>,
    placed: Vec<EdgeVertex>,
    /// Slots of vertices dropped, taken again before the array grows.
    free: Vec<u32>,
}

impl EdgeVertices {
    /// Vertices held.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// Slots in the array, held or free: every slot number lies below it.
    pub fn slot_count(&self) -> usize {
        self.placed.len()
    }

    /// Whether edge `key` has a vertex.
    pub fn contains(&self, key: EdgeKey) -> bool {
        self.slots.contains_key(&key)
    }

    /// The slot of edge `key`'s vertex, if it has one.
    #[inline]
    pub fn slot(&self, key: EdgeKey) -> Option<u32> {
        self.slots.get(&key).copied()
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

    /// Gives edge `key` the vertex `vertex`, in place of any it had.
    pub fn insert(&mut self, key: EdgeKey, vertex: EdgeVertex) {
        let Self { slots, placed, free } = self;
        let slot = *slots.entry(key).or_insert_with(|| {
            free.pop().unwrap_or_else(|| {
                placed.push(vertex);
                (placed.len() - 1) as u32
            })
        });
        placed[slot as usize] = vertex;
    }

    /// Keeps only the vertices of the edges for which `keep` holds.
    pub fn retain(&mut self, mut keep: impl FnMut(EdgeKey) -> bool) {
        let Self { slots, free, .. } = self;
        slots.retain(|&key, &mut slot| {
            let kept = keep(key);
            if !kept {
                free.push(slot);
            }
            kept
        });
    }
}

#[cfg(test)]
mod tests {
    use glam::IVec3;

    use super::*;

    fn vertex(x: f32) -> EdgeVertex {
        EdgeVertex { position: Vec3::splat(x), normal: Vec3::Z, color: Vec3::ONE }
    }

    #[test]
    fn vertices_are_found_by_edge_and_dropped_slots_are_taken_again() {
        let mut v = EdgeVertices::default();
        for k in 0..10 {
            v.insert(IVec3::new(k, 0, 0), vertex(k as f32));
        }
        v.insert(IVec3::new(3, 0, 0), vertex(30.0));
        assert_eq!((v.len(), v.slot_count()), (10, 10));
        assert_eq!(v.get(IVec3::new(3, 0, 0)), Some(vertex(30.0)));
        v.retain(|key| key.x % 2 == 0);
        assert_eq!(v.len(), 5);
        assert!(!v.contains(IVec3::new(3, 0, 0)) && v.contains(IVec3::new(4, 0, 0)));
        for k in 10..15 {
            v.insert(IVec3::new(k, 0, 0), vertex(k as f32));
        }
        assert_eq!((v.len(), v.slot_count()), (10, 10), "the five dropped slots were taken again");
        for k in (0..10).step_by(2).chain(10..15) {
            assert_eq!(v.get(IVec3::new(k, 0, 0)), Some(vertex(k as f32)), "edge {k}");
        }
    }
}
