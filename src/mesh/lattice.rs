//! The polygonizer's lattice: one global family of cubic lattices anchored at
//! the world origin, so cells found from different seeds, by a full or a local
//! polygonization, or at a coarse and a fine resolution all line up.
//!
//! Points are named by integer coordinates in *half* cells: cube corners have
//! even coordinates and cube centres (the body-centred points of the BCC
//! lattice) odd ones. An edge between lattice points `a` and `b` is named by
//! `a + b`, which is unique for every edge either decomposition uses (see
//! [`edge_key`]).

use glam::{IVec3, Vec3A};

use crate::field::Model;
use crate::geom::Aabb;

/// A lattice point in half-cell integer coordinates.
pub type LatticePoint = IVec3;

/// The name of a lattice edge: the sum of its two endpoints.
pub type EdgeKey = IVec3;

/// One lattice of the family: cubes of side `cell` with a corner at the origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lattice {
    /// Side of a cube in scene units.
    pub cell: f32,
}

impl Lattice {
    /// The lattice with `res` cubes along the longest side of `bounds`.
    #[must_use]
    pub fn across(bounds: &Aabb, res: u32) -> Self {
        Self { cell: bounds.size().max_element() / res.max(1) as f32 }
    }

    /// The lattice with `res` cubes along the longest side of `model`'s
    /// sizing bounds (its support's, or its parts' where that is empty).
    #[must_use]
    pub fn for_model(model: &Model, res: u32) -> Self {
        Self::across(&model.sizing_bounds(), res)
    }

    /// The lattice `2^k` times finer: its corners include every corner of this one.
    #[must_use]
    pub fn refined(&self, k: u32) -> Self {
        Self { cell: self.cell / (1u32 << k) as f32 }
    }

    /// World position of a lattice point.
    #[inline]
    #[must_use]
    pub fn position(&self, p: LatticePoint) -> Vec3A {
        p.as_vec3a() * (0.5 * self.cell)
    }

    /// The cube corner (even coordinates) nearest to `x`.
    #[must_use]
    pub fn nearest_corner(&self, x: Vec3A) -> LatticePoint {
        (x / self.cell).round().as_ivec3() * 2
    }

    /// The cube (by its lowest corner / 2) holding `x`.
    #[must_use]
    pub fn cube_of(&self, x: Vec3A) -> IVec3 {
        (x / self.cell).floor().as_ivec3()
    }

    /// The range of cubes `lo..=hi` overlapping `b`.
    #[must_use]
    pub fn cubes_overlapping(&self, b: &Aabb) -> (IVec3, IVec3) {
        (self.cube_of(b.min), self.cube_of(b.max))
    }
}

/// The key of the edge `a`–`b`.
///
/// Unique because every edge is one of: two even points one step apart along
/// an axis (sum ≡ (2,0,0) mod 4 up to axis order), two odd points one step
/// apart (sum ≡ (0,2,2)), or an even corner and an odd centre next to it (all
/// sum coordinates odd; the corner is recovered as the unique even point
/// `(sum - d) / 2` with `d ∈ {±1}³`).
#[inline]
#[must_use]
pub fn edge_key(a: LatticePoint, b: LatticePoint) -> EdgeKey {
    a + b
}

/// The edge `a`–`b` with its ends in one fixed order (lexicographic by
/// coordinates), whichever end a caller names first.
#[inline]
#[must_use]
pub fn ordered_edge(a: LatticePoint, b: LatticePoint) -> [LatticePoint; 2] {
    if a.to_array() < b.to_array() { [a, b] } else { [b, a] }
}

/// A sort key for lattice points (and edge keys): one integer, in the order
/// of their coordinates as unsigned words. Sorting by it only has to bring
/// equal points together; comparing one integer is far cheaper than three.
#[inline]
#[must_use]
pub fn sort_key(q: IVec3) -> u128 {
    (u128::from(q.x as u32) << 64) | (u128::from(q.y as u32) << 32) | u128::from(q.z as u32)
}

/// A cell of a decomposition: a cube, or one of the twelve BCC tetrahedra whose
/// lower body centre is the centre of `cube`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Cell {
    /// The cube, by its lowest corner / 2 (z, y, x order is irrelevant to identity).
    pub cube: IVec3,
    /// Which cell of the cube: 0 for cubes, `axis * 4 + edge` for tetrahedra.
    pub sub: u8,
}

impl Cell {
    /// A key that sorts cells by z, then y, then x, then sub-cell.
    #[must_use]
    pub fn order_key(&self) -> u128 {
        // Flipping the sign bit maps i32 order onto u32 order.
        let ordered = |v: i32| u128::from((v as u32) ^ 0x8000_0000);
        (ordered(self.cube.z) << 72) | (ordered(self.cube.y) << 40) | (ordered(self.cube.x) << 8) | u128::from(self.sub)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refined_lattices_share_the_coarse_corners() {
        let coarse = Lattice { cell: 0.3 };
        let fine = coarse.refined(2);
        let p = IVec3::new(2, -4, 6);
        assert!((coarse.position(p) - fine.position(p * 4)).length() < 1e-6);
    }

    #[test]
    fn edge_keys_are_unique_over_a_bcc_neighbourhood() {
        let mut seen = std::collections::HashMap::new();
        let pts: Vec<IVec3> = (-3..=3)
            .flat_map(|x| (-3..=3).flat_map(move |y| (-3..=3).map(move |z| IVec3::new(x, y, z))))
            .filter(|p| (p.x & 1 == p.y & 1) && (p.y & 1 == p.z & 1))
            .collect();
        for &a in &pts {
            for &b in &pts {
                let d = (b - a).abs();
                let axis_step = d.element_sum() == 2 && d.max_element() == 2;
                let diagonal = d == IVec3::ONE && (a.x & 1) != (b.x & 1);
                if a != b && (axis_step || diagonal) {
                    let ends = ordered_edge(a, b);
                    let prev = seen.insert(edge_key(a, b), ends);
                    assert!(prev.is_none() || prev == Some(ends), "{a} {b} collide with {prev:?}");
                }
            }
        }
    }
}
