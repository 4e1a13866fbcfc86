//! Tests of the blend index: its cell lists, its packed point sums and the
//! per-cell and per-box bounds taken from them.

use super::*;
use glam::Vec3;

use crate::field::kernel::Kernel;
use crate::field::{PointSet, Skeleton};

/// Eleven points of different radii and weights in a cluster, indexed.
fn cluster() -> BlendIndex {
    let leaves: Vec<IndexedLeaf> = (0..11)
        .map(|i| {
            let f = i as f32;
            let center = Vec3A::new((f * 0.37).sin(), (f * 0.71).cos(), (f * 0.23).sin() * 0.5);
            let p = Primitive::new(Skeleton::Point { center }, 0.4 + 0.05 * f, 1.0 + 0.1 * f, Kernel::Wyvill);
            IndexedLeaf { bounds: p.bounds(), leaf: Leaf::Primitive(p), color: None }
        })
        .collect();
    let bounds = leaves.iter().fold(Aabb::EMPTY, |b, l| b.union(&l.bounds));
    let prim = |l: &IndexedLeaf| match &l.leaf {
        Leaf::Primitive(p) => *p,
        Leaf::Node(_) => unreachable!("the cluster holds primitives only"),
    };
    BlendIndex::build(
        bounds,
        Leaves::Listed(leaves),
        |l, b| prim(l).interval(b),
        |l, _| prim(l).kernel.slope(0.0, prim(l).radius),
    )
}

/// The leaves of an index over listed leaves.
fn leaves_of(ix: &BlendIndex) -> &[IndexedLeaf] {
    match &ix.leaves {
        Leaves::Listed(leaves) => leaves,
        Leaves::Points(_) => unreachable!("the index lists its leaves"),
    }
}

#[test]
fn cells_list_every_leaf_reaching_them_and_the_packed_sums_match_the_plain_ones() {
    let ix = cluster();
    let prim = |i: usize| match &leaves_of(&ix)[i].leaf {
        Leaf::Primitive(p) => *p,
        Leaf::Node(_) => unreachable!(),
    };
    let mut checked = 0;
    for i in 0..ix.leaves.len() {
        let (p, Skeleton::Point { center }) = (prim(i), prim(i).skeleton) else { unreachable!() };
        // Just inside each support, in many directions: the cells there
        // are the ones a culling test could wrongly drop the leaf from.
        for k in 0..200 {
            let (a, b) = (k as f32 * 2.399, (k as f32 / 100.0) - 1.0);
            let dir = Vec3A::new(a.cos() * (1.0 - b * b).sqrt(), a.sin() * (1.0 - b * b).sqrt(), b);
            let q = center + dir * p.radius * 0.9999;
            if p.value(q) > 0.0 {
                assert!(ix.candidates(q).contains(&(i as u32)), "leaf {i} missing at {q}");
                checked += 1;
            }
            let plain: f64 = (0..ix.leaves.len()).map(|j| f64::from(prim(j).value(q))).sum();
            let packed = ix.point_sum(q).expect("all leaves are points");
            assert!((packed - plain).abs() <= 1e-6, "at {q}: packed {packed} vs plain {plain}");
            let plain = (0..ix.leaves.len()).fold(Vec3A::ZERO, |g, j| g + prim(j).gradient(q));
            let packed = ix.point_gradient(q).expect("all leaves are points");
            assert!((packed - plain).length() <= 1e-5 * (1.0 + plain.length()), "at {q}: {packed} vs {plain}");
        }
    }
    assert!(checked > 1000, "only {checked} points near support boundaries were checked");
}

#[test]
fn the_cells_packed_bounds_are_the_leaves_bounds_summed() {
    // One negative weight among the points, for the curvature's other branch.
    let mut ix = cluster();
    if let Leaves::Listed(leaves) = &mut ix.leaves
        && let Leaf::Primitive(p) = &mut leaves[4].leaf
    {
        p.weight = -0.6;
    }
    let points = PackedPoints::pack(&ix.leaves, ix.grid.cell_count()).expect("all leaves are points");
    let (mut scratch, mut compared) = (vec![], 0);
    for c in 0..ix.grid.cell_count() {
        let cell = ix.grid.cell_box(c);
        let Some((slope, bend, range)) = points.cell_bounds(ix.cell_items(c), &cell, &mut scratch) else {
            eprintln!("this processor lacks AVX2 or FMA: the leaves' own bounds serve");
            return;
        };
        let region = Region::Box(cell);
        let prims = ix.cell_items(c).iter().map(|&i| match &leaves_of(&ix)[i as usize].leaf {
            Leaf::Primitive(p) => *p,
            Leaf::Node(_) => unreachable!("the cluster holds primitives only"),
        });
        let (mut plain_slope, mut plain_bend, mut plain_range) = (0.0f32, 0.0f32, Interval::ZERO);
        // Terms of either sign, each rounding by up to its profile's
        // largest value (8·|w|/R²) times a rounding of `d²/R²`.
        let mut sizes = 0.0f32;
        for p in prims {
            plain_slope += p.lipschitz_over(&region);
            let b = p.curvature_over(&region);
            (plain_bend, sizes) = (plain_bend + b, sizes + 8.0 * p.weight.abs() / (p.radius * p.radius));
            plain_range = plain_range + p.interval(&cell);
        }
        let near = |a: f32, b: f32, size: f32| (a - b).abs() <= 1e-5 * (1.0 + size);
        assert!(near(slope, plain_slope, plain_slope), "cell {c}: slope {slope} against {plain_slope}");
        assert!(near(bend, plain_bend, sizes), "cell {c}: curvature {bend} against {plain_bend}");
        let ends = near(range.lo, plain_range.lo, plain_range.hi) && near(range.hi, plain_range.hi, plain_range.hi);
        assert!(ends, "cell {c}: {range:?} against {plain_range:?}");
        compared += usize::from(plain_slope > 0.0 && plain_bend != 0.0);
    }
    assert!(compared > 100, "{compared} cells with points reaching them");
}

#[test]
fn a_cell_is_packed_by_its_first_sum_and_no_other_cell_is() {
    let ix = cluster();
    let points = ix.points.as_ref().expect("all leaves are points");
    let Some(cells) = &points.cells else {
        eprintln!("this processor lacks AVX2 or FMA: no cell is ever packed");
        return;
    };
    let packed = || cells.iter().filter(|c| c.get().is_some()).count();
    assert_eq!(packed(), 0, "packed before any sum");
    let q = Vec3A::new(0.1, 0.2, 0.05);
    let c = ix.grid.cell_of(q).expect("inside the cluster");
    let (value, gradient) = ix.point_sum_and_gradient(q).expect("all leaves are points");
    assert_eq!(packed(), 1);
    // Eight points to a chunk, the list's own points in its order.
    let chunks = cells[c].get().expect("the cell summed in is packed");
    assert_eq!(chunks.len(), ix.cell_items(c).len().div_ceil(8));
    // Sums in the packed cell repeat the first to the bit.
    assert_eq!(ix.point_sum(q).map(f64::to_bits), Some(value.to_bits()));
    assert_eq!(ix.point_gradient(q), Some(gradient));
    assert_eq!(packed(), 1);
}
#[test]
fn the_lists_over_a_box_hold_every_leaf_reaching_it() {
    let ix = cluster();
    let (mut by_blocks, mut by_cells) = (0, 0);
    for k in 0..400 {
        let f = k as f32;
        let center = Vec3A::new((f * 0.61).sin(), (f * 0.37).cos(), (f * 0.83).sin() * 0.6);
        // From a fraction of a cell to most of the cluster.
        let b = Aabb::around(center, ix.grid.cell * (0.2 + 0.05 * (k % 60) as f32));
        let mut listed = vec![false; ix.leaves.len()];
        ix.for_each_list_over(&b, |items| items.iter().for_each(|&i| listed[i as usize] = true));
        for (i, leaf) in leaves_of(&ix).iter().enumerate() {
            let Leaf::Primitive(p) = &leaf.leaf else { unreachable!("the cluster holds primitives only") };
            assert!(listed[i] || !p.support_reaches(&b, 1.0), "leaf {i} reaches {b:?} but is not listed");
        }
        if ix.grid.cells_overlapped(&b) > MAX_CELLS_FOR_CELL_LISTS {
            by_blocks += 1;
        } else {
            by_cells += 1;
        }
    }
    assert!(by_blocks > 100 && by_cells > 20, "{by_blocks} boxes by blocks, {by_cells} by cells");
}

#[test]
fn the_cells_sums_over_a_box_hold_the_field_and_are_no_looser_than_the_leaves_bounds() {
    let ix = cluster();
    if ix.point_interval(&Aabb::around(Vec3A::ZERO, 0.1)).is_none() {
        eprintln!("this processor lacks AVX2 or FMA: boxes take the leaves' bounds");
        return;
    }
    let prims: Vec<Primitive> = leaves_of(&ix)
        .iter()
        .map(|l| match &l.leaf {
            Leaf::Primitive(p) => *p,
            Leaf::Node(_) => unreachable!("the cluster holds primitives only"),
        })
        .collect();
    let (mut tighter, mut zero) = (0, 0);
    for k in 0..300 {
        let f = k as f32;
        let center = Vec3A::new((f * 0.61).sin(), (f * 0.37).cos(), (f * 0.83).sin() * 0.6) * 1.6;
        let b = Aabb::around(center, ix.grid.cell * (0.1 + 0.04 * (k % 50) as f32));
        let range = ix.point_interval(&b).expect("the eight-wide sums run");
        let leaves = prims.iter().fold(Interval::ZERO, |s, p| s + p.interval(&b));
        assert!(range.hi <= leaves.hi * (1.0 + 1e-6) + 1e-7, "{b:?}: {range:?} looser than {leaves:?}");
        tighter += usize::from(range.hi < leaves.hi * 0.99);
        zero += usize::from(range == Interval::ZERO);
        // Every sampled value lies inside, corners and faces included.
        for s in 0..64 {
            let t = Vec3A::new((s & 3) as f32 / 3.0, ((s >> 2) & 3) as f32 / 3.0, (s >> 4) as f32 / 3.0);
            let q = b.min + t * b.size();
            let v: f32 = prims.iter().map(|p| p.value(q)).sum();
            assert!(range.lo - 1e-6 <= v && v <= range.hi + 1e-6, "{v} at {q} outside {range:?}");
        }
    }
    assert!(tighter > 30 && zero > 5, "{tighter} boxes bounded tighter, {zero} found zero");
}

#[test]
fn a_box_is_missed_exactly_where_its_cells_bound_is_zero_and_asking_packs_nothing() {
    let ix = cluster();
    let Some(cells) = ix.points.as_ref().and_then(|p| p.cells.as_ref()) else {
        eprintln!("this processor lacks AVX2 or FMA: boxes take the leaves' bounds");
        return;
    };
    // Boxes whose nearest corner sits within a few ulps of a support's
    // edge, inside and out, and boxes anywhere.
    let mut boxes = vec![];
    for leaf in leaves_of(&ix) {
        let Leaf::Primitive(p) = &leaf.leaf else { unreachable!("the cluster holds primitives only") };
        let Skeleton::Point { center } = p.skeleton else { unreachable!("the cluster holds points only") };
        for (axis, sign) in (0..3).flat_map(|axis| [(axis, -1.0f32), (axis, 1.0)]) {
            for ulps in -12i32..=12 {
                let mut corner = center;
                corner[axis] += sign * p.radius;
                for _ in 0..ulps.unsigned_abs() {
                    corner[axis] = if ulps < 0 { corner[axis].next_down() } else { corner[axis].next_up() };
                }
                let mut far = corner;
                far[axis] += sign * ix.grid.cell * 0.3;
                boxes.push(Aabb::new(corner.min(far), corner.max(far)));
            }
        }
    }
    for k in 0..200 {
        let f = k as f32;
        let center = Vec3A::new((f * 0.29).sin(), (f * 0.53).cos(), (f * 0.97).sin()) * 1.8;
        boxes.push(Aabb::around(center, ix.grid.cell * (0.05 + 0.02 * (k % 40) as f32)));
    }
    let misses: Vec<bool> = boxes.iter().map(|b| ix.points_miss(b).expect("the eight-wide bounds run")).collect();
    assert!(cells.iter().all(|c| c.get().is_none()), "asking whether a box is missed packed a cell");
    let (mut missed, mut reached) = (0, 0);
    for (b, miss) in boxes.iter().zip(misses) {
        let zero = ix.point_interval(b).expect("the eight-wide bounds run") == Interval::ZERO;
        assert_eq!(miss, zero, "{b:?}");
        (missed, reached) = (missed + usize::from(miss), reached + usize::from(!miss));
    }
    assert!(missed > 100 && reached > 100, "{missed} boxes missed, {reached} reached");
}

#[test]
fn cells_list_fewer_leaves_than_their_boxes_overlap() {
    let ix = cluster();
    let listed = ix.items.len();
    let overlapped: usize = leaves_of(&ix).iter().map(|l| ix.grid.cells_overlapped(&l.bounds)).sum();
    assert!(listed * 10 < overlapped * 8, "{listed} listings against {overlapped} overlapped cells");
}

/// `n` points of radius 2.25 on a jittered lattice of spacing `spacing`.
fn point_leaves(n: usize, spacing: f32) -> Vec<IndexedLeaf> {
    let side = (n as f32).cbrt().ceil() as usize;
    (0..n)
        .map(|i| {
            let (x, y, z) = (i % side, i / side % side, i / (side * side));
            let jitter = Vec3A::new((i as f32 * 0.37).sin(), (i as f32 * 0.71).cos(), (i as f32 * 0.23).sin()) * 0.2;
            let center = Vec3A::new(x as f32, y as f32, z as f32) * spacing + jitter;
            let p = Primitive::new(Skeleton::Point { center }, 2.25, 1.0, Kernel::Wyvill);
            IndexedLeaf { bounds: p.bounds(), leaf: Leaf::Primitive(p), color: None }
        })
        .collect()
}

#[test]
fn crowded_supports_widen_the_cells_so_the_lists_grow_with_the_leaves_not_their_overlap() {
    let bounds = |leaves: &[IndexedLeaf]| leaves.iter().fold(Aabb::EMPTY, |b, l| b.union(&l.bounds));
    // A few thousand leaves keep cells an eighth of a leaf wide, however they crowd.
    let few = point_leaves(4096, 0.5);
    assert_eq!(choose_cell_size(&bounds(&few), &Leaves::Listed(few)), CELL_PER_LEAF_SIZE * 4.5);
    // 400,000 supports each meeting hundreds of others: at an eighth of a
    // leaf, each would be listed about 380 times.
    let crowded = point_leaves(400_000, 0.5);
    let ix = BlendIndex::build(bounds(&crowded), Leaves::Listed(crowded), |_, _| Interval::ZERO, |_, _| 0.0);
    let per_leaf = ix.items.len() as f32 / ix.leaves.len() as f32;
    assert!(per_leaf <= MAX_LISTINGS_PER_LEAF, "{per_leaf} listings a leaf");
    assert!(per_leaf > MAX_LISTINGS_PER_LEAF / 3.0, "the cells stay as fine as the budget allows: {per_leaf}");
}

#[test]
fn thinly_spread_leaves_get_at_most_their_share_of_cells() {
    // Supports far apart: cells an eighth of a leaf wide would need tens of
    // millions. Up to FREE_CELLS_UP_TO leaves the grid keeps to the free
    // cells; past it, to MAX_CELLS_PER_LEAF a leaf.
    let cells = |n: usize| {
        let leaves = Leaves::Listed(point_leaves(n, 6.0));
        let bounds = (0..n).fold(Aabb::EMPTY, |b, i| b.union(&leaves.bounds(i)));
        let cell = choose_cell_size(&bounds, &leaves);
        (bounds.size() / cell).ceil().max(Vec3A::ONE).element_product() as usize
    };
    let few = cells(FREE_CELLS_UP_TO);
    assert!(few <= FREE_CELLS && few > FREE_CELLS / 2, "{few} cells");
    let many = cells(20_000);
    assert!(many <= MAX_CELLS_PER_LEAF * 20_000 && many > MAX_CELLS_PER_LEAF * 20_000 / 2, "{many} cells");
}

#[test]
fn a_point_set_is_indexed_as_its_points_listed_would_be() {
    // Thousands of points, coloured and not, radii and weights varied, so
    // that cells list many each and the layers of the sort meet.
    let n = 3000;
    let points: Vec<(Vec3, f32, f32)> = (0..n)
        .map(|i| {
            let f = i as f32;
            let center = Vec3::new((f * 0.37).sin() * 9.0, (f * 0.71).cos() * 7.0, (f * 0.13).sin() * 5.0);
            (center, 0.8 + 0.3 * (f * 0.19).sin().abs(), 1.0 + 0.5 * (f * 0.07).cos())
        })
        .collect();
    let colors: Vec<Vec3> = (0..n).map(|i| Vec3::splat(i as f32 / n as f32)).collect();
    let set = Arc::new(PointSet::new(points.iter().copied(), Kernel::Wyvill, Some(colors.clone())));
    let from_set = set.indexed();
    let leaves: Vec<IndexedLeaf> = points
        .iter()
        .zip(&colors)
        .map(|(&(center, radius, weight), &color)| {
            let p = Primitive::new(Skeleton::Point { center: center.into() }, radius, weight, Kernel::Wyvill);
            IndexedLeaf { bounds: p.bounds(), leaf: Leaf::Primitive(p), color: Some(color) }
        })
        .collect();
    let bounds = leaves.iter().fold(Aabb::EMPTY, |b, l| b.union(&l.bounds));
    assert_eq!(bounds, set.bounds());
    let listed = BlendIndex::build(
        bounds,
        Leaves::Listed(leaves),
        |l, b| match &l.leaf {
            Leaf::Primitive(p) if l.bounds.overlaps(b) => p.interval(b),
            _ => Interval::ZERO,
        },
        |l, r| match &l.leaf {
            Leaf::Primitive(p) if r.meets(&l.bounds) => p.lipschitz_over(r),
            _ => 0.0,
        },
    );
    assert_eq!(from_set.grid, listed.grid);
    assert_eq!((&from_set.offsets, &from_set.items), (&listed.offsets, &listed.items));
    assert!(from_set.items.len() > 20 * n, "{} listings", from_set.items.len());
    assert_eq!((&from_set.blocks.offsets, &from_set.blocks.items), (&listed.blocks.offsets, &listed.blocks.items));
    assert_eq!(from_set.cell_range, listed.cell_range);
    assert_eq!(from_set.cell_lipschitz, listed.cell_lipschitz);
    for i in (0..n).step_by(97) {
        assert_eq!(from_set.leaves.get(i), listed.leaves.get(i), "leaf {i}");
    }
    for k in 0..500 {
        let f = k as f32;
        let q = Vec3A::new((f * 0.29).sin() * 9.0, (f * 0.53).cos() * 7.0, (f * 0.97).sin() * 5.0);
        assert_eq!(from_set.point_sum_and_gradient(q), listed.point_sum_and_gradient(q), "at {q}");
    }
    assert_eq!(from_set.changed_since(&from_set.clone()), Aabb::EMPTY);
}

#[test]
fn the_layered_sort_lists_exactly_the_cells_each_leaf_reaches() {
    let ix = cluster();
    for c in 0..ix.grid.cell_count() {
        let cell = ix.grid.cell_box(c);
        let expected: Vec<u32> = (0..leaves_of(&ix).len() as u32)
            .filter(|&i| {
                let leaf = &leaves_of(&ix)[i as usize];
                let Leaf::Primitive(p) = &leaf.leaf else { unreachable!("the cluster holds primitives only") };
                leaf.bounds.overlaps(&cell) && p.support_reaches(&cell, SUPPORT_SLACK)
            })
            .collect();
        assert_eq!(ix.cell_items(c), &expected[..], "cell {c}");
    }
}
