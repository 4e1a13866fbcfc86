//! Self-intersections of a mesh cut on a lattice's cubes, found cube by cube.
//!
//! Two different closed cubes of one lattice lie on either side of one
//! lattice plane. Take a triangle inside one and a triangle inside the
//! other. If the second is not in that plane, its open interior lies
//! strictly on its own side, where no side of the first reaches. If it is
//! in the plane, a side of the first meets it only by lying in the plane
//! too (coplanar, which is not counted) or at an end, which an open side
//! does not hold. So triangles inside different cubes never cross, and only
//! the triangles of one cube need trying against each other. (Trying two
//! triangles of different cubes that touch in the plane, the
//! double-precision test could count them where rounding decides; here they
//! are never tried, which is the exact answer.)
//!
//! A polygonizer's cube meshes put every triangle in its cube, and emit a
//! cube's triangles together, in the order [`cube_key`] sorts. Triangles
//! that fit in no one cube (moved by a repair, or cut on tetrahedra) are
//! tried against the cubes their boxes meet and against each other; when
//! they are many, the walk over the whole mesh is cheaper.

use glam::{IVec3, Vec3, Vec3A};
use rayon::prelude::*;

use super::intersections::{Box3, self_intersections, unshared_cross};
use crate::mesh::Lattice;
use crate::mesh::visited::{BRICK_SHIFT, cube_slot};

/// Above this share of triangles in no one cube, the whole mesh is walked instead.
const MOST_LOOSE: f64 = 0.25;

/// The key of a triangle in no one cube (or in a cube too far from the origin).
const LOOSE: u64 = u64::MAX;

/// Bits of a brick coordinate in a cube key (bricks as the polygonizer's).
const BRICK_BITS: u32 = 18;

/// Largest distance of a cube coordinate from the origin that [`cube_key`] encodes.
const REACH: i32 = 1 << (BRICK_BITS - 1 + BRICK_SHIFT as u32);

/// Pairs `(s, t)`, `s < t`, of triangles that share no vertex and cross, in
/// order, found cube by cube of `lattice`, the lattice the mesh was cut on
/// (see the module's documentation): the pairs of [`self_intersections`],
/// but for triangles in different cubes that only touch in a lattice plane,
/// which that test's rounding could count.
#[must_use]
pub fn self_intersections_in_cubes(positions: &[Vec3], triangles: &[[u32; 3]], lattice: &Lattice) -> Vec<(u32, u32)> {
    let mesh = CutMesh { positions, triangles, lattice };
    in_emitted_order(&mesh, CHUNK).unwrap_or_else(|| in_any_order(positions, triangles, lattice))
}

/// Triangles one task starts runs in, in [`in_emitted_order`].
const CHUNK: usize = 1 << 14;

/// The crossing pairs of a mesh whose every triangle is in a cube and
/// whose cubes' triangles come together, in cube order, as a polygonizer
/// emits them (`None` for any other mesh), found in one pass without a list of keys.
///
/// The triangles are cut into runs, each as long as one cube holds all of
/// it; if the runs' cubes rise from run to run, no cube has two runs, and
/// only pairs within a run need trying. (A run that several cubes hold,
/// such as a triangle alone in a face, takes the lowest above the run
/// before's.) Tasks take `chunk` triangles each; a task starts at the first
/// triangle that no cube holds together with the one before it, where every
/// run breaks, and finishes its last run past its chunk's end.
fn in_emitted_order(mesh: &CutMesh, chunk: usize) -> Option<Vec<(u32, u32)>> {
    let n = mesh.triangles.len();
    let chunks: Option<Vec<Chunk>> =
        (0..n.div_ceil(chunk)).into_par_iter().map(|c| mesh.chunk(c * chunk, ((c + 1) * chunk).min(n))).collect();
    let chunks = chunks?;
    let keys: Vec<u64> = chunks.iter().flat_map(|c| c.first.into_iter().chain(c.last)).collect();
    keys.windows(2).all(|w| w[0] <= w[1]).then(|| chunks.into_iter().flat_map(|c| c.pairs).collect())
}

/// A mesh and the lattice it was cut on.
struct CutMesh<'a> {
    positions: &'a [Vec3],
    triangles: &'a [[u32; 3]],
    lattice: &'a Lattice,
}

impl CutMesh<'_> {
    fn box_of(&self, t: usize) -> Box3 {
        Box3::of(self.positions, self.triangles[t])
    }

    /// True when no cube holds triangles `t − 1` and `t` both: every run breaks there.
    fn breaks(&self, t: usize) -> bool {
        cube_holding(self.lattice, &self.box_of(t - 1).union(self.box_of(t))).is_none()
    }

    /// The runs that start from the first break at or after `start` (or at
    /// 0) up to the first break at or after `end`, where the next task starts.
    fn chunk(&self, start: usize, end: usize) -> Option<Chunk> {
        let n = self.triangles.len();
        let mut at = start;
        while at > 0 && at < n && !self.breaks(at) {
            at += 1;
        }
        let mut chunk = Chunk { first: None, last: None, pairs: vec![] };
        let mut run: Vec<(u32, Box3)> = Vec::with_capacity(8);
        while at < n && (at < end || !self.breaks(at)) {
            let holders = self.run_from(at, &mut run)?;
            at += run.len();
            let key = holders.lowest_key_above(chunk.last)?;
            (chunk.first, chunk.last) = (chunk.first.or(Some(key)), Some(key));
            chunk.pairs.extend(crossings_among(self.positions, self.triangles, &run));
        }
        Some(chunk)
    }

    /// The run starting at triangle `at`, with each triangle's box, into
    /// `run`, and the cubes holding all of it (`None` when none holds its first).
    fn run_from(&self, at: usize, run: &mut Vec<(u32, Box3)>) -> Option<Holders> {
        let b = self.box_of(at);
        let mut holders = Holders::of(self.lattice, &b)?;
        run.clear();
        run.push((at as u32, b));
        for t in at + 1..self.triangles.len() {
            let b = self.box_of(t);
            let narrowed = holders.narrowed(self.lattice, &b);
            if narrowed.mask == 0 {
                break;
            }
            holders = narrowed;
            run.push((t as u32, b));
        }
        Some(holders)
    }
}

/// What one task of [`in_emitted_order`] found: the keys of its first and
/// last runs' cubes, and the crossing pairs in its runs.
struct Chunk {
    first: Option<u64>,
    last: Option<u64>,
    pairs: Vec<(u32, u32)>,
}

/// The closed cubes holding a run of triangles: `k − d` for each `d` in
/// {0, 1}³ whose bit `d.x | d.y << 1 | d.z << 2` is set in `mask` (more than
/// `k` alone only for triangles in a face, an edge or at a corner of `k`).
#[derive(Clone, Copy)]
struct Holders {
    k: IVec3,
    mask: u8,
    /// The bounds of cube `k`.
    bounds: Box3,
}

impl Holders {
    /// The cubes holding box `b` (`None` when none does).
    fn of(lattice: &Lattice, b: &Box3) -> Option<Self> {
        let (k, bounds) = cube_and_bounds(lattice, b)?;
        // Flat on the cube's lower plane in an axis: the cube below holds it too.
        let flat = b.hi.cmple(bounds.lo).bitmask() as u8;
        let mask = (0..8u8).filter(|&d| d & !flat == 0).fold(0, |m, d| m | 1 << d);
        Some(Self { k, mask, bounds })
    }

    /// The cube `k − d` for bit `d`.
    fn cube(&self, d: u8) -> IVec3 {
        self.k - IVec3::new(i32::from(d & 1), i32::from(d >> 1 & 1), i32::from(d >> 2))
    }

    /// Those of these cubes that hold box `b` too.
    fn narrowed(self, lattice: &Lattice, b: &Box3) -> Self {
        if self.mask == 1 {
            // The common case, one cube: its bounds at hand.
            let inside = self.bounds.lo.cmple(b.lo).all() && b.hi.cmple(self.bounds.hi).all();
            return Self { mask: u8::from(inside), ..self };
        }
        let held = (0..8u8).filter(|&d| self.mask & 1 << d != 0 && fits(lattice, b, self.cube(d)));
        Self { mask: held.fold(0, |m, d| m | 1 << d), ..self }
    }

    /// The key of the lowest of these cubes above the cube keyed `last`, if any.
    fn lowest_key_above(&self, last: Option<u64>) -> Option<u64> {
        let keys = (0..8u8).filter(|&d| self.mask & 1 << d != 0).map(|d| key_of(self.cube(d)));
        keys.filter(|&key| last.is_none_or(|last| key > last)).min()
    }
}

/// The crossing pairs of any mesh: triangles in no one cube (and their
/// number) found first, the rest sorted by cube unless they come in order.
fn in_any_order(positions: &[Vec3], triangles: &[[u32; 3]], lattice: &Lattice) -> Vec<(u32, u32)> {
    let keys: Vec<u64> = triangles.par_iter().map(|&t| cube_key(lattice, &Box3::of(positions, t))).collect();
    let loose: Vec<u32> = (0..keys.len() as u32).into_par_iter().filter(|&t| keys[t as usize] == LOOSE).collect();
    if loose.len() as f64 > MOST_LOOSE * keys.len() as f64 {
        return self_intersections(positions, triangles);
    }
    let cubes = Cubes::of(&keys);
    let mut found: Vec<(u32, u32)> = (0..cubes.len())
        .into_par_iter()
        .with_min_len(1 << 12)
        .flat_map_iter(|c| {
            let members: Vec<(u32, Box3)> =
                cubes.members(c).iter().map(|&t| (t, Box3::of(positions, triangles[t as usize]))).collect();
            crossings_among(positions, triangles, &members)
        })
        .collect();
    found.extend(loose_crossings(positions, triangles, lattice, &cubes, &loose));
    found.par_sort_unstable();
    found
}

/// The crossing pairs among the triangles `members`.
fn crossings_among(positions: &[Vec3], triangles: &[[u32; 3]], members: &[(u32, Box3)]) -> Vec<(u32, u32)> {
    let mut pairs = vec![];
    for (i, (s, bs)) in members.iter().enumerate() {
        for (t, bt) in &members[i + 1..] {
            if bs.meets(bt) && unshared_cross(positions, triangles[*s as usize], triangles[*t as usize]) {
                pairs.push((*s.min(t), *s.max(t)));
            }
        }
    }
    pairs
}

/// The crossing pairs with a triangle of `loose` in them: each loose
/// triangle against the cubes its box meets, and the loose ones among themselves.
fn loose_crossings(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    lattice: &Lattice,
    cubes: &Cubes,
    loose: &[u32],
) -> Vec<(u32, u32)> {
    let mut found: Vec<(u32, u32)> = loose
        .par_iter()
        .flat_map_iter(|&s| {
            let (tri, b) = (triangles[s as usize], Box3::of(positions, triangles[s as usize]));
            let mut pairs = vec![];
            for c in cubes.meeting(lattice, &b) {
                for &t in cubes.members(c) {
                    let other = triangles[t as usize];
                    if b.meets(&Box3::of(positions, other)) && unshared_cross(positions, tri, other) {
                        pairs.push((s.min(t), s.max(t)));
                    }
                }
            }
            pairs
        })
        .collect();
    let among: Vec<[u32; 3]> = loose.iter().map(|&t| triangles[t as usize]).collect();
    found
        .extend(self_intersections(positions, &among).into_iter().map(|(s, t)| (loose[s as usize], loose[t as usize])));
    found
}

/// The triangles that fit in one cube, grouped by cube, cubes in key order.
struct Cubes {
    /// Triangle numbers, cube after cube.
    members: Vec<u32>,
    /// The key of each cube.
    keys: Vec<u64>,
    /// Where each cube's triangles start in `members`, and one past the last.
    starts: Vec<u32>,
}

impl Cubes {
    /// The cubes of triangles whose keys are `keys` ([`LOOSE`] ones left out).
    fn of(keys: &[u64]) -> Self {
        let key = |t: u32| keys[t as usize];
        let mut members: Vec<u32> = (0..keys.len() as u32).into_par_iter().filter(|&t| key(t) != LOOSE).collect();
        // A polygonizer's triangles come in key order already; others are sorted.
        if !members.par_windows(2).all(|w| key(w[0]) <= key(w[1])) {
            members.par_sort_by_key(|&t| key(t));
        }
        let mut starts: Vec<u32> = (0..members.len() as u32)
            .into_par_iter()
            .filter(|&i| i == 0 || key(members[i as usize]) != key(members[i as usize - 1]))
            .collect();
        let keys = starts.par_iter().map(|&i| key(members[i as usize])).collect();
        starts.push(members.len() as u32);
        Self { members, keys, starts }
    }

    fn len(&self) -> usize {
        self.keys.len()
    }

    /// The triangles of cube `c`.
    fn members(&self, c: usize) -> &[u32] {
        &self.members[self.starts[c] as usize..self.starts[c + 1] as usize]
    }

    /// The cubes holding triangles among those `b` may meet: found one by
    /// one in the box's range of cubes, or all of them when fewer.
    fn meeting(&self, lattice: &Lattice, b: &Box3) -> Vec<usize> {
        // One cube more each way than the box's covers rounding in the
        // division; no cube holding triangles lies beyond two short of the reach.
        let reach = |k: IVec3| k.clamp(IVec3::splat(2 - REACH), IVec3::splat(REACH - 2));
        let (lo, hi) = (reach(lattice.cube_of(b.lo)) - 1, reach(lattice.cube_of(b.hi)) + 1);
        let span = (hi - lo + 1).as_i64vec3();
        if span.x.saturating_mul(span.y).saturating_mul(span.z) > self.len() as i64 {
            return (0..self.len()).collect();
        }
        let mut found = vec![];
        for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                found.extend((lo.x..=hi.x).filter_map(|x| self.keys.binary_search(&key_of(IVec3::new(x, y, z))).ok()));
            }
        }
        found
    }
}

/// The key of the closed cube of `lattice` holding box `b`, or [`LOOSE`].
fn cube_key(lattice: &Lattice, b: &Box3) -> u64 {
    cube_holding(lattice, b).map_or(LOOSE, key_of)
}

/// The closed cube of `lattice` holding box `b` (the upper one of two
/// when `b` lies in their common face), if any within [`REACH`].
fn cube_holding(lattice: &Lattice, b: &Box3) -> Option<IVec3> {
    cube_and_bounds(lattice, b).map(|(k, _)| k)
}

/// [`cube_holding`] with the cube's bounds. Cube numbers stay floats
/// until the end (exact below [`REACH`]), their planes computed as
/// [`Lattice::position`] does, bit for bit.
fn cube_and_bounds(lattice: &Lattice, b: &Box3) -> Option<(IVec3, Box3)> {
    let half = 0.5 * lattice.cell;
    let plane = |k: Vec3A| (k * 2.0) * half;
    let mut k = (b.lo / lattice.cell).floor();
    // Two short of the reach: a cube below may hold it too (see [`Holders`]).
    if !k.is_finite() || k.abs().max_element() >= (REACH - 2) as f32 {
        return None;
    }
    // The division may round onto the next cube either way.
    k -= Vec3A::select(plane(k).cmpgt(b.lo), Vec3A::ONE, Vec3A::ZERO);
    k += Vec3A::select(plane(k + 1.0).cmple(b.lo), Vec3A::ONE, Vec3A::ZERO);
    let bounds = Box3 { lo: plane(k), hi: plane(k + 1.0) };
    (bounds.lo.cmple(b.lo).all() && b.hi.cmple(bounds.hi).all()).then(|| (k.as_ivec3(), bounds))
}

/// True when box `b` lies in the closed cube `k` of `lattice`.
fn fits(lattice: &Lattice, b: &Box3, k: IVec3) -> bool {
    lattice.position(k * 2).cmple(b.lo).all() && b.hi.cmple(lattice.position((k + 1) * 2)).all()
}

/// The key of cube `k` (each coordinate within [`REACH`] of the origin).
fn key_of(k: IVec3) -> u64 {
    let brick = ((k >> BRICK_SHIFT) + IVec3::splat(1 << (BRICK_BITS - 1))).as_uvec3();
    let slot = cube_slot(k) as u64;
    let wide = |v: u32, shift: u32| u64::from(v) << shift;
    let slot_bits = 3 * BRICK_SHIFT as u32;
    wide(brick.z, slot_bits + 2 * BRICK_BITS) | wide(brick.y, slot_bits + BRICK_BITS) | wide(brick.x, slot_bits) | slot
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A seeded stream of numbers in [0, 1).
    fn stream(mut seed: u64) -> impl FnMut() -> f32 {
        move || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    /// Triangles crowded into a few cubes of side `cell` (twelve side by
    /// side, or, `spread`, 150 scattered over 30³), crossing each other
    /// often: most inside one cube (some flat in a face, an edge or at a
    /// corner), some across several; in cube order when `ordered`.
    fn soup(ordered: bool, spread: bool) -> (Lattice, Vec<Vec3>, Vec<[u32; 3]>) {
        let lattice = Lattice { cell: if spread { 0.1 } else { 1.0 } };
        let mut next = stream(11);
        let cubes: Vec<Vec3> = if spread {
            (0..150)
                .map(|_| Vec3::new(next(), next(), next()).mul_add(Vec3::splat(30.0), Vec3::splat(-15.0)).floor())
                .collect()
        } else {
            (0..12).map(|i| Vec3::new((i % 3) as f32 - 1.0, (i / 3 % 2) as f32, (i / 6) as f32 - 1.0)).collect()
        };
        let mut triangles: Vec<[Vec3; 3]> = vec![];
        for k in 0..900 {
            let cube = cubes[(next() * cubes.len() as f32) as usize % cubes.len()];
            let mut corner = || cube + Vec3::new(next(), next(), next());
            let mut t = [corner(), corner(), corner()];
            match k % 9 {
                // Flat in the cube's lower x face, or on its lower x–y edge.
                0 => t.iter_mut().for_each(|p| p.x = cube.x),
                1 => t.iter_mut().for_each(|p| (p.x, p.y) = (cube.x, cube.y)),
                // Across two or more cubes.
                2 => t[0] += Vec3::new(next(), next(), 0.0) * 1.5,
                _ => {}
            }
            triangles.push(t.map(|p| p * lattice.cell));
        }
        if ordered {
            triangles.retain(|t| cube_key(&lattice, &Box3::of(t, [0, 1, 2])) != LOOSE);
            triangles.sort_by_key(|t| cube_key(&lattice, &Box3::of(t, [0, 1, 2])));
        }
        let positions = triangles.iter().flatten().copied().collect();
        (lattice, positions, (0..triangles.len() as u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect())
    }

    #[test]
    fn cube_by_cube_finds_what_the_walk_over_all_finds() {
        for (ordered, spread) in [(false, false), (true, false), (false, true), (true, true)] {
            let (lattice, positions, triangles) = soup(ordered, spread);
            let what = format!("ordered {ordered}, spread {spread}");
            let walked = self_intersections(&positions, &triangles);
            assert!(walked.len() > 20, "{what}: the soup crosses itself: {}", walked.len());
            assert_eq!(self_intersections_in_cubes(&positions, &triangles, &lattice), walked, "{what}");
            let mesh = CutMesh { positions: &positions, triangles: &triangles, lattice: &lattice };
            assert_eq!(in_emitted_order(&mesh, CHUNK).is_some(), ordered, "{what}: one pass only in cube order");
            if ordered {
                // Chunks of every size break where runs break, and miss no pair.
                for chunk in [1, 2, 3, 5, 64] {
                    assert_eq!(in_emitted_order(&mesh, chunk), Some(walked.clone()), "{what}, chunks of {chunk}");
                }
            } else {
                let keys: Vec<u64> = triangles.iter().map(|&t| cube_key(&lattice, &Box3::of(&positions, t))).collect();
                let loose = keys.iter().filter(|&&k| k == LOOSE).count();
                assert!(loose > 50 && loose < triangles.len() / 4, "{what}: {loose} loose of {}", triangles.len());
                // Spread out, a loose triangle's box covers fewer cubes than hold
                // triangles, so they are looked up one by one.
                let cubes = Cubes::of(&keys);
                let b = Box3::of(&positions, triangles[keys.iter().position(|&k| k == LOOSE).unwrap()]);
                assert_eq!(cubes.meeting(&lattice, &b).len() < cubes.len(), spread, "{what}");
            }
        }
    }

    #[test]
    fn a_polygonizers_cube_mesh_takes_the_one_pass() {
        let scene = crate::scene::Scene::load(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/particles.ron")).unwrap();
        for vertex in [crate::mesh::VertexPlacement::default(), crate::mesh::VertexPlacement::Linear] {
            let lattice = Lattice::across(&scene.model.bounds(), 48);
            let options = crate::mesh::PolygonizeOptions { vertex, ..Default::default() };
            let m =
                crate::pipeline::polygonizer_on(&scene.model, crate::field::EvalMode::Indexed, lattice, options).mesh();
            assert!(m.triangles.len() > 3 * 64);
            let mesh = CutMesh { positions: &m.positions, triangles: &m.triangles, lattice: &lattice };
            let walked = self_intersections(&m.positions, &m.triangles);
            assert_eq!(in_emitted_order(&mesh, CHUNK), Some(walked.clone()), "{vertex:?}");
            assert_eq!(in_emitted_order(&mesh, 64), Some(walked), "{vertex:?}, chunks of 64");
        }
    }

    #[test]
    fn a_triangle_in_a_face_belongs_to_either_cube() {
        let lattice = Lattice { cell: 0.5 };
        let on_face = Box3 { lo: Vec3A::new(1.0, 0.1, 0.2), hi: Vec3A::new(1.0, 0.3, 0.4) };
        let holders = Holders::of(&lattice, &on_face).unwrap();
        assert_eq!((holders.k, holders.mask), (IVec3::new(2, 0, 0), 0b11), "the cubes either side of x = 1");
        let inside_upper = Box3 { lo: Vec3A::new(1.0, 0.1, 0.2), hi: Vec3A::new(1.2, 0.3, 0.4) };
        assert_eq!(holders.narrowed(&lattice, &inside_upper).mask, 0b01);
        assert_eq!(holders.lowest_key_above(None), Some(key_of(IVec3::new(1, 0, 0))));
        assert_eq!(holders.lowest_key_above(Some(key_of(IVec3::new(1, 0, 0)))), Some(key_of(IVec3::new(2, 0, 0))));
        let across = Box3 { lo: Vec3A::new(0.9, 0.1, 0.2), hi: Vec3A::new(1.1, 0.3, 0.4) };
        assert!(Holders::of(&lattice, &across).is_none());
    }

    #[test]
    fn keys_rise_with_every_coordinate_across_bricks() {
        for k in [IVec3::new(-9, 3, 7), IVec3::new(7, -1, -8), IVec3::new(0, 0, 0)] {
            for axis in [IVec3::X, IVec3::Y, IVec3::Z] {
                assert!(key_of(k) < key_of(k + axis), "{k} {axis}");
            }
        }
    }
}
