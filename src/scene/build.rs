//! Scene description → model arena.

use glam::Vec3A;

use super::desc::NodeDesc;
use crate::cache::CacheSpec;
use crate::field::{
    Model, ModelBuilder, ModelError, NodeId, NodeKind, Placement, PointSet, Primitive, Skeleton, Warp, spline,
};

/// Most points a `SplinePoints` node is built with as a blend of point
/// nodes, which the index of the cluster of blends it sits in flattens with
/// its neighbours' (Medusa's splines have up to a few hundred each). Past
/// it, the spline's points are one `Points` node over packed arrays, as a
/// particle file's are: a million took 0.88 GB and 1 s to load as nodes.
const MAX_SPLINE_NODES: usize = 1 << 16;

/// Builds the model for the tree `root` with iso-value `threshold`, and the
/// node each description node became, in the order a depth-first walk of the
/// description meets them (parents before children).
pub fn model_with_ids(root: &NodeDesc, threshold: f32) -> Result<(Model, Vec<NodeId>), ModelError> {
    let mut b = ModelBuilder::new();
    let mut ids = vec![];
    let id = add(&mut b, root, &mut ids)?;
    Ok((b.finish(id, threshold)?, ids))
}

/// A warp node over `child`; its parameters and domain are checked once
/// the model is built ([`crate::field::Model::check_warps`]), where each is
/// reported at its place in the scene file.
fn warped(b: &mut ModelBuilder, warp: Warp, child: &NodeDesc, ids: &mut Vec<NodeId>) -> Result<NodeId, ModelError> {
    let child = add(b, child, ids)?;
    b.add(NodeKind::Warp { warp: Box::new(warp), child }, None)
}

/// Adds `desc`'s subtree, recording its node's id at its place in `ids`.
fn add(b: &mut ModelBuilder, desc: &NodeDesc, ids: &mut Vec<NodeId>) -> Result<NodeId, ModelError> {
    let slot = ids.len();
    ids.push(0);
    let id = add_node(b, desc, ids)?;
    ids[slot] = id;
    Ok(id)
}

fn add_node(b: &mut ModelBuilder, desc: &NodeDesc, ids: &mut Vec<NodeId>) -> Result<NodeId, ModelError> {
    let color = |c: &Option<super::Color>| c.map(|c| c.0);
    let prim = |skeleton, radius: f32, weight: f32, kernel| {
        NodeKind::Primitive(Primitive::new(skeleton, radius, weight, kernel))
    };
    match desc {
        NodeDesc::Point { center, radius, weight, kernel, color: c } => {
            b.add(prim(Skeleton::Point { center: center.0.into() }, radius.0, weight.0, *kernel), color(c))
        }
        NodeDesc::Segment { a, b: e, radius, weight, kernel, color: c } => {
            b.add(prim(Skeleton::Segment { a: a.0.into(), b: e.0.into() }, radius.0, weight.0, *kernel), color(c))
        }
        NodeDesc::Circle { center, normal, ring, radius, weight, kernel, color: c } => {
            let normal = Vec3A::from(normal.0).normalize();
            let skeleton = Skeleton::Circle { center: center.0.into(), normal, ring: ring.0 };
            b.add(prim(skeleton, radius.0, weight.0, *kernel), color(c))
        }
        NodeDesc::SplinePoints { control, count, radius, radius_end, weight, color: c } => {
            let control: Vec<Vec3A> = control.iter().map(|v| v.0.into()).collect();
            if control.is_empty() {
                return Err(ModelError::NoChildren("SplinePoints (control points)"));
            }
            let end = radius_end.map_or(radius.0, |r| r.0);
            let points = spline::even_points(&control, count.0 as usize);
            let radius_at = |u: f32| radius.0 + (end - radius.0) * u;
            if points.len() > MAX_SPLINE_NODES {
                let points = points.iter().map(|&(p, u)| (p.into(), radius_at(u), weight.0));
                let set = PointSet::new(points, Default::default(), None);
                return b.add(NodeKind::points(set).ok_or(ModelError::NoChildren("SplinePoints"))?, color(c));
            }
            b.reserve(points.len() + 1);
            let children = points
                .into_iter()
                .map(|(p, u)| {
                    b.add(prim(Skeleton::Point { center: p }, radius_at(u), weight.0, Default::default()), None)
                })
                .collect::<Result<Vec<_>, _>>()?;
            b.add(NodeKind::Blend { children, index: None }, color(c))
        }
        NodeDesc::Points { file, radius, weight, kernel, color: c, cloud } => {
            let cloud = cloud.0.as_ref().ok_or_else(|| ModelError::Unread(file.clone()))?;
            let points = (0..cloud.positions.len()).map(|i| {
                let r = cloud.radius.as_ref().map_or(radius.0, |r| r[i]);
                let w = cloud.weight.as_ref().map_or(weight.0, |w| w[i]);
                (cloud.positions[i], r, w)
            });
            let set = PointSet::new(points, *kernel, cloud.color.clone());
            b.add(NodeKind::points(set).ok_or(ModelError::NoChildren("Points"))?, color(c))
        }
        NodeDesc::Blend(cs) => {
            let children = add_all(b, &cs.0, ids)?;
            b.add(NodeKind::Blend { children, index: None }, None)
        }
        NodeDesc::Union(cs) => {
            let children = add_all(b, &cs.0, ids)?;
            b.add(NodeKind::Union(children), None)
        }
        NodeDesc::Intersection(cs) => {
            let children = add_all(b, &cs.0, ids)?;
            b.add(NodeKind::Intersection(children), None)
        }
        NodeDesc::Difference(x, y) => {
            let (x, y) = (add(b, x, ids)?, add(b, y, ids)?);
            b.add(NodeKind::Difference(x, y), None)
        }
        NodeDesc::Ricci { n, children } => {
            let children = add_all(b, &children.0, ids)?;
            b.add(NodeKind::Ricci { n: n.0, children }, None)
        }
        NodeDesc::Transform { translate, rotate, scale, child, color: c } => {
            let placement = Placement::new(translate.0, rotate.0, scale.0).ok_or(ModelError::ZeroScale)?;
            let child = add(b, child, ids)?;
            b.add(NodeKind::Transform { placement: Box::new(placement), child }, color(c))
        }
        NodeDesc::Twist { axis, rate, child } => {
            warped(b, Warp::Twist { axis: (*axis).into(), rate: rate.0 }, child, ids)
        }
        NodeDesc::Taper { axis, from, to, scale_from, scale_to, child } => {
            let warp = Warp::Taper {
                axis: (*axis).into(),
                from: from.0,
                to: to.0,
                scale_from: scale_from.0,
                scale_to: scale_to.0,
            };
            warped(b, warp, child, ids)
        }
        NodeDesc::Bend { rate, child } => warped(b, Warp::Bend { rate: rate.0 }, child, ids),
        NodeDesc::Named(name, child) => {
            let child = add(b, child, ids)?;
            b.add(NodeKind::Named { name: name.0.clone(), child }, None)
        }
        NodeDesc::Cache { res, value, gradient, storage, usage, child } => {
            let child = add(b, child, ids)?;
            let spec = CacheSpec { res: res.0, value: *value, gradient: *gradient, storage: *storage, usage: *usage };
            b.add(NodeKind::Cache { spec, child, grid: 0 }, None)
        }
    }
}

fn add_all(b: &mut ModelBuilder, descs: &[NodeDesc], ids: &mut Vec<NodeId>) -> Result<Vec<NodeId>, ModelError> {
    descs.iter().map(|d| add(b, d, ids)).collect()
}
