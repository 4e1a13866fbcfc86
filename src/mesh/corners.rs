//! Field values at lattice points, kept in bricks of 8³ points.
//!
//! The polygonizer reads a cell's corners, and a march its next corner, far
//! more often than it evaluates one, and its reads move over the surface in
//! small steps. A map from each point to its value scatters neighbours over
//! memory: at res 512 it holds some 700 000 points, and nearly every read
//! misses the processor's caches. Bricks keep neighbours together and the
//! brick table small, so a read is one lookup in a table that stays cached
//! and one load next to the previous one.
//!
//! Cube corners (even coordinates in half cells) and BCC body centres (odd)
//! are kept apart, each on its own whole-cell lattice, so no brick holds
//! slots for points that cannot occur.

use glam::IVec3;
use rustc_hash::FxHashMap;

use super::lattice::LatticePoint;
use super::slot_bits;
use crate::geom::Aabb;

/// Points along each side of a brick, as a power of two.
const BRICK_SHIFT: i32 = 3;
/// Points along each side of a brick.
const BRICK_SIDE: i32 = 1 << BRICK_SHIFT;
/// Points in a brick.
const BRICK_POINTS: usize = 1 << (3 * BRICK_SHIFT);

/// A brick's key: its position in bricks and the parity of its points.
type BrickKey = (IVec3, bool);

/// The values of one brick's points, and which of them are known.
#[derive(Clone, Debug)]
struct Brick {
    known: [u64; BRICK_POINTS / 64],
    values: [f32; BRICK_POINTS],
}

impl Brick {
    const EMPTY: Self = Self { known: [0; BRICK_POINTS / 64], values: [0.0; BRICK_POINTS] };

    fn get(&self, slot: usize) -> Option<f32> {
        slot_bits::is_held(&self.known, slot).then(|| self.values[slot])
    }

    fn set(&mut self, slot: usize, value: f32) {
        slot_bits::hold(&mut self.known, slot);
        self.values[slot] = value;
    }

    fn forget(&mut self, slot: usize) {
        slot_bits::release(&mut self.known, slot);
    }

    fn is_empty(&self) -> bool {
        slot_bits::none_held(&self.known)
    }
}

/// Field values at lattice points (in half-cell coordinates), by point.
#[derive(Clone, Debug, Default)]
pub struct CornerValues {
    bricks: FxHashMap<BrickKey, Box<Brick>>,
}

/// Where point `q` lives: its brick and its slot there.
#[inline]
fn locate(q: LatticePoint) -> (BrickKey, usize) {
    // Both parities land on whole-cell coordinates (floor of half).
    let whole = q >> 1;
    let within: IVec3 = whole & IVec3::splat(BRICK_SIDE - 1);
    let slot = (within.x | within.y << BRICK_SHIFT | within.z << (2 * BRICK_SHIFT)) as usize;
    ((whole >> BRICK_SHIFT, q.x & 1 == 1), slot)
}

/// The point in slot `slot` of brick `key`.
fn point_of((brick, odd): BrickKey, slot: usize) -> LatticePoint {
    let s = slot as i32;
    let within = IVec3::new(s & (BRICK_SIDE - 1), (s >> BRICK_SHIFT) & (BRICK_SIDE - 1), s >> (2 * BRICK_SHIFT));
    ((brick << BRICK_SHIFT) + within) * 2 + IVec3::splat(i32::from(odd))
}

impl CornerValues {
    /// The value at `q`, if known.
    #[inline]
    #[must_use]
    pub fn get(&self, q: LatticePoint) -> Option<f32> {
        let (key, slot) = locate(q);
        self.bricks.get(&key).and_then(|b| b.get(slot))
    }

    /// Keeps `value` at `q`.
    #[cfg(test)]
    pub fn insert(&mut self, q: LatticePoint, value: f32) {
        let (key, slot) = locate(q);
        self.bricks.entry(key).or_insert_with(|| Box::new(Brick::EMPTY)).set(slot, value);
    }

    /// Every known point with its value, in no particular order.
    pub fn iter(&self) -> impl Iterator<Item = (LatticePoint, f32)> + '_ {
        self.bricks.iter().flat_map(|(&key, brick)| {
            (0..BRICK_POINTS).filter_map(move |slot| brick.get(slot).map(|v| (point_of(key, slot), v)))
        })
    }

    /// Forgets every point `q` with `inside(position(q))`, a region held in
    /// the box `bounds`. Bricks wholly outside the box are passed over
    /// without reading their points.
    pub fn forget_within(
        &mut self,
        bounds: &Aabb,
        position: impl Fn(LatticePoint) -> glam::Vec3A,
        inside: impl Fn(glam::Vec3A) -> bool,
    ) {
        self.bricks.retain(|&key, brick| {
            let (lo, hi) = (point_of(key, 0), point_of(key, BRICK_POINTS - 1));
            if bounds.overlaps(&Aabb::new(position(lo), position(hi))) {
                for slot in 0..BRICK_POINTS {
                    if brick.get(slot).is_some() && inside(position(point_of(key, slot))) {
                        brick.forget(slot);
                    }
                }
            }
            !brick.is_empty()
        });
    }
}

/// Reads values through the bricks read last, one per parity of the
/// brick's coordinates and of the points: edges taken cell by cell read
/// their ends from the bricks the edges before them read.
pub struct CornerCursor<'a> {
    store: &'a CornerValues,
    recent: [(BrickKey, Option<&'a Brick>); 16],
}

impl CornerValues {
    /// A cursor over these values.
    #[must_use]
    pub fn cursor(&self) -> CornerCursor<'_> {
        CornerCursor { store: self, recent: [((IVec3::splat(i32::MIN), false), None); 16] }
    }
}

impl CornerCursor<'_> {
    /// The value at `q`, which must be known.
    #[inline]
    #[must_use]
    pub fn value(&mut self, q: LatticePoint) -> f32 {
        let (key, slot) = locate(q);
        let (brick, odd) = key;
        let way = (brick.x & 1 | (brick.y & 1) << 1 | (brick.z & 1) << 2) as usize | usize::from(odd) << 3;
        if self.recent[way].0 != key {
            self.recent[way] = (key, self.store.bricks.get(&key).map(|b| &**b));
        }
        self.recent[way].1.and_then(|b| b.get(slot)).unwrap_or_else(|| panic!("no value at lattice point {q}"))
    }
}

/// Bricks a patch holds: two per axis (a block of cubes and its upper
/// neighbours), for corners and for centres.
const PATCH_BRICKS: usize = 16;

/// The corner bricks one block of cubes (the cubes of one brick of visited
/// cells) reads and writes: its own and those on its upper sides, for
/// corners and for centres. Taken out of the store, they belong to one
/// thread; blocks whose coordinates differ by two along some axis take
/// disjoint patches.
pub struct CornerPatch {
    base: IVec3,
    bricks: [Option<Box<Brick>>; PATCH_BRICKS],
}

impl CornerValues {
    /// Takes out the bricks holding the vertices of the cubes of block `base`
    /// (cube coordinates `base·8 ..= base·8 + 7`).
    pub fn take_patch(&mut self, base: IVec3) -> CornerPatch {
        let bricks = std::array::from_fn(|i| self.bricks.remove(&patch_key(base, i)));
        CornerPatch { base, bricks }
    }

    /// Puts a patch's bricks back.
    pub fn put_patch(&mut self, patch: CornerPatch) {
        for (i, brick) in patch.bricks.into_iter().enumerate() {
            if let Some(brick) = brick {
                self.bricks.insert(patch_key(patch.base, i), brick);
            }
        }
    }
}

/// The key of brick `i` of the patch at `base`: bit 3 the centres, bits 0–2 the offset.
fn patch_key(base: IVec3, i: usize) -> BrickKey {
    let offset = IVec3::new((i & 1) as i32, (i >> 1 & 1) as i32, (i >> 2 & 1) as i32);
    (base + offset, i & 8 != 0)
}

impl CornerPatch {
    #[inline]
    fn locate(&self, q: LatticePoint) -> (usize, usize) {
        let ((brick, odd), slot) = locate(q);
        let d = brick - self.base;
        assert!(d.cmpge(IVec3::ZERO).all() && d.cmple(IVec3::ONE).all(), "{q} lies outside the patch");
        ((d.x | d.y << 1 | d.z << 2) as usize | usize::from(odd) << 3, slot)
    }

    /// The value at `q`, if known.
    #[inline]
    #[must_use]
    pub fn get(&self, q: LatticePoint) -> Option<f32> {
        let (brick, slot) = self.locate(q);
        self.bricks[brick].as_ref().and_then(|b| b.get(slot))
    }

    /// Sets the value at `q`.
    #[inline]
    pub fn set(&mut self, q: LatticePoint, value: f32) {
        let (brick, slot) = self.locate(q);
        self.bricks[brick].get_or_insert_with(|| Box::new(Brick::EMPTY)).set(slot, value);
    }
}

/// The slots of a cube's eight corners, in [`super::cubes::vertices`]'
/// order, from its lowest corner's, when all lie in one brick.
const CUBE_CORNER_SLOTS: [usize; 8] = {
    let mut slots = [0; 8];
    let mut i = 0;
    while i < 8 {
        slots[i] = (i & 1) | (i >> 1 & 1) << BRICK_SHIFT | (i >> 2 & 1) << (2 * BRICK_SHIFT);
        i += 1;
    }
    slots
};

impl CornerPatch {
    /// The values at the corners of the cube whose lowest corner is
    /// `lowest`, in [`super::cubes::vertices`]' order, those not known yet
    /// taken from `evaluate` and kept; with how many were evaluated. A cube
    /// off its brick's far faces (most cubes) finds its brick once.
    #[inline]
    pub fn cube_values(
        &mut self,
        lowest: LatticePoint,
        mut evaluate: impl FnMut(LatticePoint) -> f32,
    ) -> ([f32; 8], u64) {
        let mut values = [0.0; 8];
        let mut evaluated = 0;
        let within: IVec3 = (lowest >> 1) & IVec3::splat(BRICK_SIDE - 1);
        if within.cmplt(IVec3::splat(BRICK_SIDE - 1)).all() {
            let (brick, first) = self.locate(lowest);
            let brick = self.bricks[brick].get_or_insert_with(|| Box::new(Brick::EMPTY));
            for (i, value) in values.iter_mut().enumerate() {
                let slot = first + CUBE_CORNER_SLOTS[i];
                *value = brick.get(slot).unwrap_or_else(|| {
                    let v = evaluate(lowest + super::cubes::corner_offset(i) * 2);
                    brick.set(slot, v);
                    evaluated += 1;
                    v
                });
            }
        } else {
            for (i, value) in values.iter_mut().enumerate() {
                let q = lowest + super::cubes::corner_offset(i) * 2;
                *value = self.get(q).unwrap_or_else(|| {
                    let v = evaluate(q);
                    self.set(q, v);
                    evaluated += 1;
                    v
                });
            }
        }
        (values, evaluated)
    }
}

impl Extend<(LatticePoint, f32)> for CornerValues {
    /// Keeps every value; points that follow one another in a brick (a
    /// march's, along a row) find it once.
    fn extend<I: IntoIterator<Item = (LatticePoint, f32)>>(&mut self, points: I) {
        let mut current: Option<(BrickKey, &mut Box<Brick>)> = None;
        for (q, v) in points {
            let (key, slot) = locate(q);
            if current.as_ref().is_none_or(|(k, _)| *k != key) {
                current = Some((key, self.bricks.entry(key).or_insert_with(|| Box::new(Brick::EMPTY))));
            }
            let Some((_, brick)) = current.as_mut() else { unreachable!("the brick was found above") };
            brick.set(slot, v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    /// Cube corners and body centres, negative and positive, across bricks.
    fn points() -> Vec<LatticePoint> {
        let mut out = vec![];
        for z in -20..20 {
            for y in -20..20 {
                for x in -20..20 {
                    let q = IVec3::new(x, y, z);
                    if q.x & 1 == q.y & 1 && q.y & 1 == q.z & 1 {
                        out.push(q);
                    }
                }
            }
        }
        out
    }

    #[test]
    fn every_point_keeps_its_own_value() {
        let mut values = CornerValues::default();
        let value = |q: IVec3| (q.x * 10_000 + q.y * 100 + q.z) as f32;
        let all = points();
        values.extend(all.iter().step_by(2).map(|&q| (q, value(q))));
        for (i, &q) in all.iter().enumerate() {
            assert_eq!(values.get(q), (i % 2 == 0).then(|| value(q)), "at {q}");
        }
        let mut listed: Vec<(IVec3, f32)> = values.iter().collect();
        listed.sort_by_key(|&(q, _)| q.to_array());
        let mut expected: Vec<(IVec3, f32)> = all.iter().step_by(2).map(|&q| (q, value(q))).collect();
        expected.sort_by_key(|&(q, _)| q.to_array());
        assert_eq!(listed, expected);
    }

    #[test]
    fn a_patch_reads_and_writes_the_bricks_it_took() {
        let mut values = CornerValues::default();
        let base = IVec3::new(-1, 2, 0);
        // Corners and centres of the patch's cubes, which span bricks base and base + 1.
        let cubes = (0..9).flat_map(|z| (0..9).flat_map(move |y| (0..9).map(move |x| IVec3::new(x, y, z))));
        let points: Vec<IVec3> = cubes.flat_map(|c| [(base * 8 + c) * 2, (base * 8 + c) * 2 + IVec3::ONE]).collect();
        values.insert(points[0], 7.0);
        let mut patch = values.take_patch(base);
        assert_eq!(values.get(points[0]), None, "taken out");
        assert_eq!(patch.get(points[0]), Some(7.0));
        for (i, &q) in points.iter().enumerate().skip(1) {
            patch.set(q, i as f32);
        }
        values.put_patch(patch);
        for (i, &q) in points.iter().enumerate().skip(1) {
            assert_eq!(values.get(q), Some(i as f32), "at {q}");
        }
    }

    #[test]
    fn a_cube_reads_its_corners_in_vertex_order_and_evaluates_each_once() {
        let mut values = CornerValues::default();
        let base = IVec3::new(3, -2, 1);
        let value = |q: IVec3| (q.x * 10_000 + q.y * 100 + q.z) as f32;
        // One corner known before: it is read, not evaluated.
        let first = (base * 8) * 2;
        values.insert(first, value(first));
        let mut patch = values.take_patch(base);
        let (mut evaluated, mut counted) = (vec![], 0);
        // Every cube of the block, inside its first brick or on its far faces.
        for z in 0..8 {
            for y in 0..8 {
                for x in 0..8 {
                    let cube = base * 8 + IVec3::new(x, y, z);
                    let (got, count) = patch.cube_values(cube * 2, |q| {
                        evaluated.push(q);
                        value(q)
                    });
                    let corners = crate::mesh::cubes::vertices(crate::mesh::lattice::Cell { cube, sub: 0 });
                    assert_eq!(got, corners.map(value), "cube {cube}");
                    counted += count;
                }
            }
        }
        let mut unique = evaluated.clone();
        unique.sort_by_key(|q| q.to_array());
        unique.dedup();
        assert_eq!(unique.len(), evaluated.len(), "a corner was evaluated twice");
        assert_eq!(evaluated.len(), 9 * 9 * 9 - 1, "every corner of the block but the known one");
        assert_eq!(counted, evaluated.len() as u64);
        assert!(!evaluated.contains(&first));
    }

    #[test]
    fn forgetting_a_box_forgets_exactly_the_points_inside_it() {
        let mut values = CornerValues::default();
        let all = points();
        values.extend(all.iter().map(|&q| (q, 1.0)));
        values.insert(all[0], 2.0);
        assert_eq!(values.get(all[0]), Some(2.0), "a point set again takes the new value");
        let position = |q: IVec3| q.as_vec3a() * 0.25;
        let region = Aabb::new(Vec3A::new(-1.1, -3.0, 0.3), Vec3A::new(2.0, 0.2, 9.0));
        values.forget_within(&region, position, |p| region.contains(p));
        for &q in &all {
            assert_eq!(values.get(q).is_some(), !region.contains(position(q)), "at {q}");
        }
        assert_eq!(values.iter().count(), all.iter().filter(|&&q| !region.contains(position(q))).count());
    }
}
