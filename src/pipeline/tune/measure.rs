//! One round of tuning's measurements on a scene: the exact surface's
//! vertices, and for every cache its auto-mode decision, error_C and the
//! gradient's angular error at the vertices it covers (its lattice alone
//! answering), the memory of the samples a render and a polygonization
//! touch, and which child of its subtree the failing vertices belong to.

use glam::{Vec3, Vec3A};
use rayon::prelude::*;
use serde::Serialize;

use super::TuneSettings;
use crate::field::{CacheDecision, EvalMode, Field, Model, ModelField, NodeId, NodeKind};
use crate::pipeline::error::{PipelineError, Result};
use crate::pipeline::polygonize::{PolygonizeSettings, polygonize};
use crate::progress::Silent;
use crate::scene::{NodeDesc, Scene, SceneDesc};
use crate::trace::render_model;

/// error_C and gradient error at the mesh vertices a cache covers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct VertexError {
    /// Vertices inside the cache's bounds.
    pub vertices: usize,
    /// Mean |f_C − f| over them.
    pub mean: f64,
    /// 99th percentile of |f_C − f|.
    pub p99: f32,
    /// Largest |f_C − f|.
    pub max: f32,
    /// 99th percentile of the angle between cached and exact gradients, in degrees.
    pub angle_p99_deg: f32,
}

/// How a cache over an operator would split into caches over its children.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct SplitPlan {
    /// Resolution of each child's cache, keeping today's cell size.
    pub child_res: Vec<u32>,
    /// The child most failing vertices belong to (its field is the largest there).
    pub top_child: usize,
    /// Share of the failing vertices that belong to it.
    pub failing_share: f32,
    /// Share of all the cache's vertices that belong to it.
    pub vertex_share: f32,
}

/// One cache as a round found it.
#[derive(Clone, Debug)]
pub(super) struct CacheMeasure {
    /// Its place in a depth-first walk of the scene description.
    pub at: usize,
    /// Its resolution.
    pub res: u32,
    /// Auto mode's decision and the estimate behind it.
    pub decision: CacheDecision,
    /// Its error at the vertices it covers.
    pub error: VertexError,
    /// Bytes of samples a render and a polygonization touched in it.
    pub bytes: u64,
    /// How it would split, where its subtree has an operator to split at.
    pub split: Option<SplitPlan>,
}

/// Every cache of a scene as one round found it.
#[derive(Clone)]
pub(super) struct Round {
    /// The caches, in depth-first order of the description.
    pub caches: Vec<CacheMeasure>,
    /// The built scene.
    pub scene: Scene,
    /// Model node of each description node, in depth-first order.
    pub ids: Vec<NodeId>,
}

impl Round {
    /// Bytes of samples all caches touched.
    pub fn bytes(&self) -> u64 {
        self.caches.iter().map(|c| c.bytes).sum()
    }
}

/// Measures every cache of `desc`.
pub(super) fn measure(desc: &SceneDesc, settings: &TuneSettings) -> Result<Round> {
    let (mut scene, ids) = Scene::from_desc_with_ids(desc).map_err(|e| PipelineError::Unsuitable(e.to_string()))?;
    let poly = PolygonizeSettings { res: settings.mesh_res, ..Default::default() };
    let vertices = polygonize(&scene.model, EvalMode::Indexed, &poly, &Silent)?.0.positions;
    let bytes = touched_bytes(&scene, &poly)?;
    let decisions = scene.model.cache_decisions();
    let mut caches = vec![];
    for (at, node) in preorder(&desc.model).into_iter().enumerate() {
        let NodeDesc::Cache { res, .. } = node else { continue };
        let id = ids[at];
        let NodeKind::Cache { grid, .. } = scene.model.node(id).kind else { return Err(not_a_cache(id)) };
        let Some(decision) = decisions.iter().find(|d| d.node == id).cloned() else { return Err(not_a_cache(id)) };
        let bounds = scene.model.world_bounds(id);
        let covered: Vec<Vec3> = vertices.iter().copied().filter(|&v| bounds.contains(Vec3A::from(v))).collect();
        let (error, failing) = vertex_error(&mut scene.model, grid, &covered, settings.tolerance);
        let split = split_plan(&scene.model, node, at, &ids, &failing, &covered, id);
        let bytes = bytes.iter().find(|(n, _)| *n == id).map_or(0, |(_, b)| *b);
        caches.push(CacheMeasure { at, res: res.0, decision, error, bytes, split });
    }
    Ok(Round { caches, scene, ids })
}

fn not_a_cache(id: NodeId) -> PipelineError {
    PipelineError::Unsuitable(format!("node {id} was built from a Cache but is not one, or was not decided"))
}

/// The description's nodes in depth-first order, parents first: the order
/// [`Scene::from_desc_with_ids`] numbers them in.
pub(super) fn preorder(root: &NodeDesc) -> Vec<&NodeDesc> {
    let (mut out, mut stack) = (vec![], vec![root]);
    while let Some(node) = stack.pop() {
        out.push(node);
        stack.extend(node.children().into_iter().rev());
    }
    out
}

/// Bytes each cache holds after a render at the scene's size and a
/// polygonization, every lattice answering, from cold.
fn touched_bytes(scene: &Scene, poly: &PolygonizeSettings) -> Result<Vec<(NodeId, u64)>> {
    let mut model = scene.model.clone();
    let settings = scene.render_settings(scene.size);
    model.with_every_lattice(|m| {
        render_model(m, EvalMode::Cached, &settings, &|_| {});
        polygonize(m, EvalMode::Cached, poly, &Silent).map(|_| ())
    })?;
    Ok(model.cache_stats().into_iter().map(|(id, _, stats)| (id, stats.bytes)).collect())
}

/// error_C and the gradient's angular error of cache `grid` alone at the
/// vertices it `covered`; and those whose error is over `tolerance`.
fn vertex_error(model: &mut Model, grid: usize, covered: &[Vec3], tolerance: f32) -> (VertexError, Vec<Vec3>) {
    let mut alone = vec![false; model.grid_count()];
    alone[grid] = true;
    let pairs: Vec<(f32, f32)> = model.with_lattices(&alone, |m| {
        let (exact, cached) = (ModelField::new(m, EvalMode::Indexed), ModelField::new(m, EvalMode::Cached));
        covered
            .par_iter()
            .map(|&v| {
                let p = Vec3A::from(v);
                let (fe, ge) = exact.value_and_gradient(p);
                let (fc, gc) = cached.value_and_gradient(p);
                ((fc - fe).abs(), angle_deg(gc, ge))
            })
            .collect()
    });
    let failing = covered.iter().zip(&pairs).filter(|(_, (e, _))| *e > tolerance).map(|(v, _)| *v).collect();
    let mut errors: Vec<f32> = pairs.iter().map(|p| p.0).collect();
    let mut angles: Vec<f32> = pairs.iter().map(|p| p.1).filter(|a| a.is_finite()).collect();
    let mean = errors.iter().map(|&e| f64::from(e)).sum::<f64>() / errors.len().max(1) as f64;
    let error = VertexError {
        vertices: covered.len(),
        mean,
        p99: percentile(&mut errors, 0.99),
        max: errors.iter().copied().fold(0.0, f32::max),
        angle_p99_deg: percentile(&mut angles, 0.99),
    };
    (error, failing)
}

/// The angle between two gradients in degrees; NaN where either vanishes.
fn angle_deg(a: Vec3A, b: Vec3A) -> f32 {
    match (a.try_normalize(), b.try_normalize()) {
        (Some(a), Some(b)) => a.dot(b).clamp(-1.0, 1.0).acos().to_degrees(),
        _ => f32::NAN,
    }
}

/// The `q` quantile of `values` (nearest rank), 0 for none.
pub(super) fn percentile(values: &mut [f32], q: f64) -> f32 {
    if values.is_empty() {
        return 0.0;
    }
    values.sort_by(f32::total_cmp);
    let rank = ((q * values.len() as f64).ceil() as usize).clamp(1, values.len());
    values[rank - 1]
}

/// The first node below a cache's pass-throughs (names, transforms, warps)
/// with several children, and its place in depth-first order.
pub(super) fn split_point(cache: &NodeDesc, at: usize) -> Option<(&NodeDesc, usize)> {
    let NodeDesc::Cache { child, .. } = cache else { return None };
    let (mut node, mut index) = (child.as_ref(), at + 1);
    loop {
        let children = node.children();
        match children.len() {
            0 => return None,
            1 if !matches!(node, NodeDesc::Cache { .. }) => (node, index) = (children[0], index + 1),
            1 => return None,
            _ => return Some((node, index)),
        }
    }
}

/// How cache `cache` (node `id`, at `at` in depth-first order) would split
/// over its operator's children: each child's resolution at today's cell
/// size, and which child the `failing` vertices among those it `covered`
/// belong to (the one whose field is largest there).
fn split_plan(
    model: &Model,
    cache: &NodeDesc,
    at: usize,
    ids: &[NodeId],
    failing: &[Vec3],
    covered: &[Vec3],
    id: NodeId,
) -> Option<SplitPlan> {
    let (op, op_at) = split_point(cache, at)?;
    if op.holds_cache() {
        return None;
    }
    let mut child_ids = vec![];
    let mut next = op_at + 1;
    for child in op.children() {
        child_ids.push(ids[next]);
        next += child.node_count();
    }
    let NodeDesc::Cache { res, .. } = cache else { return None };
    let cell = model.node(id).bounds.size().max_element() / res.0 as f32;
    let child_res = child_ids
        .iter()
        .map(|&c| ((model.node(c).bounds.size().max_element() / cell).ceil() as u32).clamp(2, super::MAX_CACHE_RES))
        .collect();
    let owner = |v: &Vec3| {
        let p = model.to_local(child_ids[0], Vec3A::from(*v));
        let values = child_ids.iter().map(|&c| model.node_value(c, p, EvalMode::Indexed));
        values.enumerate().fold((0, f32::MIN), |best, (i, f)| if f > best.1 { (i, f) } else { best }).0
    };
    let mut failing_counts = vec![0usize; child_ids.len()];
    failing.iter().for_each(|v| failing_counts[owner(v)] += 1);
    let top_child = (0..child_ids.len()).max_by_key(|&i| (failing_counts[i], usize::MAX - i)).unwrap_or(0);
    let owned = covered.iter().filter(|v| owner(v) == top_child).count();
    Some(SplitPlan {
        child_res,
        top_child,
        failing_share: failing_counts[top_child] as f32 / failing.len().max(1) as f32,
        vertex_share: owned as f32 / covered.len().max(1) as f32,
    })
}
