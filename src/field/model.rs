//! The model: an arena of nodes with parents, bounds and blend indices kept current.

use std::collections::HashMap;

use glam::Vec3;

use super::EvalMode;
use super::index::{BlendIndex, IndexedLeaf, Leaf, MIN_INDEXED_LEAVES};
use super::node::{Node, NodeKind, Placement};
use super::node_id::NodeId;
use super::primitive::Primitive;
use crate::cache::{CacheGrid, CacheSpec, CacheStats, Refit, SLOT_BYTES, SamplePool};
use crate::geom::{Aabb, Interval, Region, Support};

/// Why a model could not be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ModelError {
    /// Two `Named` nodes share a name.
    #[error("the name {0:?} is used twice")]
    DuplicateName(String),
    /// An operator was given no children.
    #[error("{0} needs at least one child")]
    NoChildren(&'static str),
    /// The model has no nodes.
    #[error("the model is empty")]
    Empty,
    /// A transform scales an axis by zero: it has no inverse.
    #[error("a Transform scale factor is zero")]
    ZeroScale,
    /// An edit named no `Named` node.
    #[error("no node is named {0:?}")]
    UnknownName(String),
    /// An edit's numbers are unusable (NaN, a zero scale, a non-positive radius).
    #[error("bad edit: {0}")]
    BadEdit(String),
    /// The model would not fit in memory.
    #[error("the model is too large: {0}")]
    TooLarge(String),
    /// The model lies too far from the origin for its size, or too far at all.
    #[error(
        "the model reaches {far:e} from the origin and is {size:e} across: farther than {} times its size (or {:e} in all), single precision cannot resolve its surface",
        MAX_OFFSET_IN_SIZES,
        MAX_REACH
    )]
    TooFar {
        /// Largest coordinate magnitude of its bounds.
        far: f32,
        /// Longest side of its bounds.
        size: f32,
    },
    /// An edit addressed a node of another kind than it changes.
    #[error("{node} is a {found}, not a {expected}")]
    WrongKind {
        /// The node addressed, by the name the edit used where it has one.
        node: String,
        /// The kind the edit changes.
        expected: &'static str,
        /// The node's kind.
        found: &'static str,
    },
}

/// How far from the origin, in multiples of its own size, a model may reach.
/// Farther, single precision resolves less than a thousandth of the model
/// near its surface, and the polygonizer's integer lattice could overflow.
pub const MAX_OFFSET_IN_SIZES: f32 = 1e3;

/// How far from the origin any model may reach: squared distances stay far
/// inside single precision's range.
pub const MAX_REACH: f32 = 1e12;

/// What an edit changed: the edited node and its bounds before and after, in
/// the frame its parent sees. Outside `old ∪ new` no node's field changed.
#[derive(Clone, Debug, PartialEq)]
pub struct Change {
    /// The edited node.
    pub node: NodeId,
    /// Its bounds before the edit.
    pub old: Aabb,
    /// Its bounds after the edit.
    pub new: Aabb,
    /// Cached samples cleared above it.
    pub samples_cleared: u64,
    /// Regions holding the support of the field that changed, before and
    /// after (each primitive's, through transforms and caches), in the frame of
    /// `scope`: much tighter than `old ∪ new` for a large moved subtree. Empty
    /// when unknown (a change made below [`Model::apply`]).
    pub supports: Vec<Support>,
    /// The node in whose frame `supports` lie.
    pub scope: NodeId,
    /// Caches laid anew on a fresh lattice because their subtree's bounds
    /// changed too much (see [`Refit::Rebuilt`]), each with its old and new
    /// bounds together (in its parent's frame): the cached field changed all
    /// over them.
    pub rebuilt: Vec<(NodeId, Aabb)>,
    /// Indexed blends whose index lists changed, each with the box (in its
    /// parent's frame) where evaluation through it may differ, if only in
    /// its last bits (see [`crate::field::BlendIndex::changed_since`]): in
    /// exact and cached mode alike.
    pub reindexed: Vec<(NodeId, Aabb)>,
}

/// A BlobTree: nodes in an arena, children before parents' use, parents known,
/// and the lattices of its `Cache` nodes with the memory pool behind them.
#[derive(Debug)]
pub struct Model {
    nodes: Vec<Node>,
    root: NodeId,
    threshold: f32,
    names: HashMap<String, NodeId>,
    /// One lattice per `Cache` node, indexed by the node's `grid`.
    grids: Vec<Option<CacheGrid>>,
    pool: SamplePool,
    /// Caches rebuilt since the last change was reported (see [`Change::rebuilt`]).
    rebuilt: Vec<(NodeId, Aabb)>,
    /// Indices rebuilt since the last change was reported (see [`Change::reindexed`]).
    reindexed: Vec<(NodeId, Aabb)>,
}

impl Clone for Model {
    /// The same tree with cold caches on the same lattices (and the same
    /// cache budget): its cached field is this one's exactly, every sample
    /// evaluated afresh.
    fn clone(&self) -> Self {
        let pool = SamplePool::new(self.pool.budget_slots());
        let grids = self.grids.iter().map(|g| g.as_ref().map(|g| g.cold_copy(&pool))).collect();
        Self {
            nodes: self.nodes.clone(),
            root: self.root,
            threshold: self.threshold,
            names: self.names.clone(),
            grids,
            pool,
            rebuilt: Vec::new(),
            reindexed: Vec::new(),
        }
    }
}

/// Adds nodes bottom-up (children first), then seals them into a [`Model`].
#[derive(Default)]
pub struct ModelBuilder {
    nodes: Vec<Node>,
}

impl ModelBuilder {
    /// An empty builder.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a node whose children were added before; returns its id.
    pub fn add(&mut self, kind: NodeKind, color: Option<Vec3>) -> Result<NodeId, ModelError> {
        let empty = match &kind {
            NodeKind::Blend { children, .. }
            | NodeKind::Union(children)
            | NodeKind::Intersection(children)
            | NodeKind::Ricci { children, .. } => children.is_empty(),
            _ => false,
        };
        if empty {
            return Err(ModelError::NoChildren(kind.type_name()));
        }
        self.nodes.push(Node { kind, parent: None, bounds: Aabb::EMPTY, may_be_negative: false, color });
        Ok((self.nodes.len() - 1) as NodeId)
    }

    /// Seals the tree rooted at `root` with iso-value `threshold`.
    pub fn finish(self, root: NodeId, threshold: f32) -> Result<Model, ModelError> {
        if self.nodes.is_empty() {
            return Err(ModelError::Empty);
        }
        let mut model = Model {
            nodes: self.nodes,
            root,
            threshold,
            names: HashMap::new(),
            grids: Vec::new(),
            pool: SamplePool::default(),
            rebuilt: Vec::new(),
            reindexed: Vec::new(),
        };
        model.link()?;
        model.refresh();
        Ok(model)
    }
}

impl Model {
    /// The root node.
    #[must_use]
    pub fn root(&self) -> NodeId {
        self.root
    }

    /// The iso-value `T`.
    #[must_use]
    pub fn threshold(&self) -> f32 {
        self.threshold
    }

    /// A node by id.
    #[inline]
    #[must_use]
    pub fn node(&self, id: NodeId) -> &Node {
        &self.nodes[id as usize]
    }

    /// All nodes, in arena order.
    #[must_use]
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// The node called `name` by a `Named` node (the `Named` node itself).
    #[must_use]
    pub fn find(&self, name: &str) -> Option<NodeId> {
        self.names.get(name).copied()
    }

    /// The bounds of the whole model's support.
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        self.node(self.root).bounds
    }

    /// The box that sizes the lattices fixed by a model's first frame (the
    /// mesh lattice, the tracer's hit lattice): its support's bounds, or,
    /// where the support is empty (an intersection of parts that do not
    /// meet), the bounds of every primitive as placed, since a later edit
    /// may make the parts meet.
    #[must_use]
    pub fn sizing_bounds(&self) -> Aabb {
        self.sizing_bounds_of(self.root)
    }

    /// [`Self::sizing_bounds`] of node `id`, in the frame it is evaluated in:
    /// its support's bounds, or where that is empty every primitive's under it.
    #[must_use]
    pub fn sizing_bounds_of(&self, id: NodeId) -> Aabb {
        let bounds = self.node(id).bounds;
        if bounds.is_empty() { self.extent_of(id) } else { bounds }
    }

    fn extent_of(&self, id: NodeId) -> Aabb {
        match &self.node(id).kind {
            NodeKind::Primitive(p) => p.bounds(),
            NodeKind::Transform { placement, child } => self.extent_of(*child).transformed(&placement.to_world),
            kind => kind.children().iter().fold(Aabb::EMPTY, |a, &c| a.union(&self.extent_of(c))),
        }
    }

    /// Checks that the model lies near enough the origin for its size (see
    /// [`MAX_OFFSET_IN_SIZES`] and [`MAX_REACH`]); an empty model passes.
    pub fn check_reach(&self) -> Result<(), ModelError> {
        let b = self.bounds();
        if b.is_empty() {
            return Ok(());
        }
        let (far, size) = (b.min.abs().max(b.max.abs()).max_element(), b.size().max_element());
        let near = far.is_finite() && far <= MAX_REACH && far <= MAX_OFFSET_IN_SIZES * size;
        if near { Ok(()) } else { Err(ModelError::TooFar { far, size }) }
    }

    /// Names, sorted.
    #[must_use]
    pub fn names(&self) -> Vec<&str> {
        let mut v: Vec<&str> = self.names.keys().map(String::as_str).collect();
        v.sort_unstable();
        v
    }

    /// Sets parents, the name table and the caches' lattice numbers.
    fn link(&mut self) -> Result<(), ModelError> {
        for id in 0..self.nodes.len() {
            if let NodeKind::Cache { grid, .. } = &mut self.nodes[id].kind {
                *grid = self.grids.len();
                self.grids.push(None);
            }
            for c in self.nodes[id].kind.children() {
                self.nodes[c as usize].parent = Some(id as NodeId);
            }
            if let NodeKind::Named { name, .. } = &self.nodes[id].kind
                && self.names.insert(name.clone(), id as NodeId).is_some()
            {
                return Err(ModelError::DuplicateName(name.clone()));
            }
        }
        Ok(())
    }

    /// Recomputes every node's bounds and rebuilds the blend indices.
    pub fn refresh(&mut self) {
        self.update_bounds(self.root);
        self.build_indices(self.root);
    }

    /// Brings bounds and blend indices up to date after node `id` alone
    /// changed: its subtree's bounds, then each ancestor's from its children,
    /// and the indices of the blends on that path (no other index can change).
    fn refresh_from(&mut self, id: NodeId) {
        self.update_bounds(id);
        let mut path = vec![id];
        let mut at = id;
        while let Some(parent) = self.nodes[at as usize].parent {
            self.bounds_from_children(parent);
            path.push(parent);
            at = parent;
        }
        for node in path {
            let changed = self.build_index_at(node);
            if !changed.is_empty() {
                self.reindexed.push((node, changed));
            }
        }
    }

    fn update_bounds(&mut self, id: NodeId) -> Aabb {
        for c in self.nodes[id as usize].kind.children() {
            self.update_bounds(c);
        }
        self.bounds_from_children(id)
    }

    /// Node `id`'s bounds (and sign) from its children's current ones
    /// (refitting a cache).
    fn bounds_from_children(&mut self, id: NodeId) -> Aabb {
        let children: Vec<(Aabb, bool)> = self.nodes[id as usize]
            .kind
            .children()
            .iter()
            .map(|&c| (self.nodes[c as usize].bounds, self.nodes[c as usize].may_be_negative))
            .collect();
        self.nodes[id as usize].may_be_negative = may_be_negative(&self.nodes[id as usize].kind, &children);
        let kind = &self.nodes[id as usize].kind;
        let b = match kind {
            NodeKind::Primitive(p) => p.bounds(),
            NodeKind::Intersection(_) => {
                // Positive only where every child is, negative wherever any
                // child is: inside the common part and any negative child's box.
                let common = children.iter().fold(children[0].0, |a, c| a.intersection(&c.0));
                children.iter().filter(|c| c.1).fold(common, |a, c| a.union(&c.0))
            }
            NodeKind::Difference(..) => children[0].0,
            NodeKind::Transform { placement, .. } => children[0].0.transformed(&placement.to_world),
            NodeKind::Cache { spec, grid, .. } => {
                let (spec, grid) = (*spec, *grid);
                let old = self.nodes[id as usize].bounds;
                let (b, refit) = self.fit_cache(grid, spec, children[0].0);
                if refit == Refit::Rebuilt {
                    self.rebuilt.push((id, old.union(&b)));
                }
                b
            }
            _ => children.iter().fold(Aabb::EMPTY, |a, c| a.union(&c.0)),
        };
        // An empty intersection still needs a valid (degenerate) box for later queries.
        self.nodes[id as usize].bounds = b;
        b
    }

    /// Makes or refits cache `grid` for its subtree's new bounds; returns the
    /// cache's bounds and what the refit did (a new cache keeps nothing).
    fn fit_cache(&mut self, grid: usize, spec: CacheSpec, child_bounds: Aabb) -> (Aabb, Refit) {
        match &mut self.grids[grid] {
            Some(g) => {
                let refit = g.fit(child_bounds, &self.pool);
                (g.bounds(), refit)
            }
            slot @ None => (slot.insert(CacheGrid::new(spec, child_bounds, &self.pool)).bounds(), Refit::Kept),
        }
    }

    /// The lattice of cache `grid`.
    #[inline]
    #[must_use]
    pub fn cache(&self, grid: usize) -> &CacheGrid {
        self.grids[grid].as_ref().expect("every cache gets its lattice when the model is sealed")
    }

    /// The memory pool behind the caches.
    #[inline]
    #[must_use]
    pub fn pool(&self) -> &SamplePool {
        &self.pool
    }

    /// Caps the caches' sample storage at `bytes` (unbounded for `None`),
    /// evicting least-recently-used blocks beyond it. Empties every cache.
    pub fn set_cache_budget(&mut self, bytes: Option<usize>) {
        self.empty_caches(SamplePool::new(bytes.map(|b| b / SLOT_BYTES)));
    }

    /// Replaces the pool by `pool` and lays fresh, empty lattices on every cache.
    fn empty_caches(&mut self, pool: SamplePool) {
        self.pool = pool;
        self.grids.iter_mut().for_each(|g| *g = None);
        self.update_bounds(self.root);
    }

    /// Every cache: its node, the nearest name above it, and its statistics.
    #[must_use]
    pub fn cache_stats(&self) -> Vec<(NodeId, String, CacheStats)> {
        let mut out = Vec::new();
        for (id, node) in self.nodes.iter().enumerate() {
            if let NodeKind::Cache { grid, .. } = node.kind {
                let name = self.name_above(id as NodeId).unwrap_or_else(|| format!("cache{}", grid));
                out.push((id as NodeId, name, self.cache(grid).stats(&self.pool)));
            }
        }
        out
    }

    /// Moves Transform node `id` to `placement`. Caches below it keep their
    /// samples (their frame moves with them); caches above clear the samples
    /// inside the old and new bounds.
    pub fn set_placement(&mut self, id: NodeId, placement: Placement) -> Result<Change, ModelError> {
        let old = self.node(id).bounds;
        match &mut self.nodes[id as usize].kind {
            NodeKind::Transform { placement: p, .. } => *p = placement,
            other => return Err(wrong_kind(id, "Transform", other)),
        }
        Ok(self.edited(id, old))
    }

    /// Replaces primitive node `id` by `primitive`; caches above it clear the
    /// samples inside the old and new bounds.
    pub fn set_primitive(&mut self, id: NodeId, primitive: Primitive) -> Result<Change, ModelError> {
        let old = self.node(id).bounds;
        match &mut self.nodes[id as usize].kind {
            NodeKind::Primitive(p) => *p = primitive,
            other => return Err(wrong_kind(id, "Primitive", other)),
        }
        Ok(self.edited(id, old))
    }

    /// The Transform right under `Named` node `named`, inserting an identity
    /// one the first time: edits move it, so caches below move with their frame.
    pub(super) fn transform_under(&mut self, named: NodeId) -> NodeId {
        let NodeKind::Named { child, .. } = self.nodes[named as usize].kind else {
            return named;
        };
        if matches!(self.nodes[child as usize].kind, NodeKind::Transform { .. }) {
            return child;
        }
        let id = self.nodes.len() as NodeId;
        let identity = Placement::new(Vec3::ZERO, Vec3::ZERO, Vec3::ONE).expect("the identity is invertible");
        let Node { bounds, may_be_negative, .. } = self.nodes[child as usize];
        self.nodes.push(Node {
            kind: NodeKind::Transform { placement: identity, child },
            parent: Some(named),
            bounds,
            may_be_negative,
            color: None,
        });
        self.nodes[child as usize].parent = Some(id);
        if let NodeKind::Named { child: c, .. } = &mut self.nodes[named as usize].kind {
            *c = id;
        }
        id
    }

    /// The n-ary operator under `Named` node `named`, looking through transforms and caches.
    pub(super) fn operator_under(&self, named: NodeId) -> Option<NodeId> {
        let NodeKind::Named { child, .. } = self.nodes[named as usize].kind else {
            return None;
        };
        let child = self.under_frames(child);
        is_operator(&self.nodes[child as usize].kind).then_some(child)
    }

    /// The first node at or under `id` that is neither a Transform nor a Cache.
    pub(super) fn under_frames(&self, mut id: NodeId) -> NodeId {
        while let NodeKind::Transform { child, .. } | NodeKind::Cache { child, .. } = self.nodes[id as usize].kind {
            id = child;
        }
        id
    }

    /// Adds `Named(name, primitive)` as the last child of operator `op`; returns
    /// the change (the new node's bounds, or the operator's for an intersection).
    pub(super) fn add_child(&mut self, op: NodeId, name: &str, primitive: Primitive) -> Result<Change, ModelError> {
        if self.names.contains_key(name) {
            return Err(ModelError::DuplicateName(name.to_string()));
        }
        let old_op = self.nodes[op as usize].bounds;
        let leaf = self.nodes.len() as NodeId;
        let named = leaf + 1;
        let (b, may_be_negative) = (primitive.bounds(), primitive.weight < 0.0);
        let kind = NodeKind::Primitive(primitive);
        self.nodes.push(Node { kind, parent: Some(named), bounds: b, may_be_negative, color: None });
        let kind = NodeKind::Named { name: name.to_string(), child: leaf };
        self.nodes.push(Node { kind, parent: Some(op), bounds: b, may_be_negative, color: None });
        self.names.insert(name.to_string(), named);
        if let Some(children) = operator_children_mut(&mut self.nodes[op as usize].kind) {
            children.push(named);
        }
        Ok(self.children_changed(op, old_op, Aabb::EMPTY, b))
    }

    /// Detaches `Named` node `named` from its parent operator (which keeps at
    /// least one child); the name is free again.
    pub(super) fn remove_child(&mut self, named: NodeId) -> Result<Change, ModelError> {
        let parent = self.nodes[named as usize].parent.ok_or(ModelError::NoChildren("the root"))?;
        let old_op = self.nodes[parent as usize].bounds;
        let gone = self.nodes[named as usize].bounds;
        let found = self.nodes[parent as usize].kind.type_name();
        let what = format!("the parent of {:?}", self.name_above(named).unwrap_or_default());
        let children = operator_children_mut(&mut self.nodes[parent as usize].kind).ok_or(ModelError::WrongKind {
            node: what,
            expected: "Blend, Union, Intersection or Ricci",
            found,
        })?;
        if children.len() < 2 {
            return Err(ModelError::NoChildren(found));
        }
        children.retain(|&c| c != named);
        self.nodes[named as usize].parent = None;
        if let NodeKind::Named { name, .. } = &self.nodes[named as usize].kind {
            let name = name.clone();
            self.names.remove(&name);
        }
        Ok(self.children_changed(parent, old_op, gone, Aabb::EMPTY))
    }

    /// Replaces the kind of n-ary operator `op` by `kind` built from its children.
    pub(super) fn set_operator(&mut self, op: NodeId, kind: impl FnOnce(Vec<NodeId>) -> NodeKind) -> Change {
        let old = self.nodes[op as usize].bounds;
        let children = self.nodes[op as usize].kind.children();
        self.nodes[op as usize].kind = kind(children);
        self.edited(op, old)
    }

    /// After children of `op` were added or removed: refresh, and invalidate
    /// where the field changed — the child's own bounds, except under an
    /// intersection, whose minimum changes wherever the operator reaches, and
    /// a union, whose maximum goes from negative to the zero a child has
    /// outside its support wherever the other children are negative (with
    /// negative weights).
    fn children_changed(&mut self, op: NodeId, old_op: Aabb, old: Aabb, new: Aabb) -> Change {
        self.refresh_from(op);
        let new_op = self.nodes[op as usize].bounds;
        let (old, new) = if matches!(self.nodes[op as usize].kind, NodeKind::Intersection(_) | NodeKind::Union(_)) {
            (old_op, new_op)
        } else {
            (old, new)
        };
        // Caches inside the operator's own frame: the op itself may be cached above.
        let samples_cleared = self.invalidate_from(op, old.union(&new));
        self.change(op, (old, new), samples_cleared)
    }

    /// The change of node `id` from bounds `old` to `new`, after clearing
    /// `samples_cleared` samples above it; caches above a cache rebuilt on the
    /// way clear its whole bounds too.
    fn change(&mut self, id: NodeId, (old, new): (Aabb, Aabb), mut samples_cleared: u64) -> Change {
        let rebuilt = std::mem::take(&mut self.rebuilt);
        let reindexed = std::mem::take(&mut self.reindexed);
        for &(node, b) in rebuilt.iter().chain(&reindexed) {
            samples_cleared += self.invalidate_above(node, b);
        }
        Change { node: id, old, new, samples_cleared, supports: Vec::new(), scope: id, rebuilt, reindexed }
    }

    /// Clears the samples inside `region` (in `id`'s own frame) in `id` if it
    /// is a cache, then in every cache above.
    fn invalidate_from(&mut self, id: NodeId, mut region: Aabb) -> u64 {
        let own = match self.nodes[id as usize].kind {
            NodeKind::Cache { grid, .. } => self.invalidate_cache(grid, &mut region),
            _ => 0,
        };
        own + self.invalidate_above(id, region)
    }

    /// Clears the samples of cache `grid` inside `region` and widens `region`
    /// to where its reconstruction changed: by its filters' reach, since a
    /// cache above samples that reconstruction, not the field beneath it.
    fn invalidate_cache(&mut self, grid: usize, region: &mut Aabb) -> u64 {
        self.grids[grid].as_mut().map_or(0, |g| {
            let cleared = g.invalidate(region);
            *region = g.sample_reach(region);
            cleared
        })
    }

    /// Brings bounds, indices and caches up to date after node `id` changed.
    fn edited(&mut self, id: NodeId, old: Aabb) -> Change {
        self.refresh_from(id);
        let new = self.node(id).bounds;
        let samples_cleared = self.invalidate_above(id, old.union(&new));
        self.change(id, (old, new), samples_cleared)
    }

    /// Clears, in every cache above node `id`, the samples inside `changed` (a
    /// box in the frame `id`'s parent sees), carrying the box up through the
    /// transforms on the way and widening it by each cache's filter reach
    /// (an outer cache samples the inner one's reconstruction). Returns how
    /// many held samples were cleared.
    pub fn invalidate_above(&mut self, id: NodeId, changed: Aabb) -> u64 {
        let (mut at, mut region, mut cleared) = (id, changed, 0);
        while let Some(parent) = self.node(at).parent {
            match &self.node(parent).kind {
                NodeKind::Transform { placement, .. } => region = region.transformed(&placement.to_world),
                NodeKind::Cache { grid, .. } => {
                    let grid = *grid;
                    cleared += self.invalidate_cache(grid, &mut region);
                }
                _ => {}
            }
            at = parent;
        }
        cleared
    }

    /// Number of primitives in the subtree under `id`.
    #[must_use]
    pub fn primitives_under(&self, id: NodeId) -> usize {
        match &self.node(id).kind {
            NodeKind::Primitive(_) => 1,
            kind => kind.children().iter().map(|&c| self.primitives_under(c)).sum(),
        }
    }

    /// The name of the nearest `Named` ancestor of `id` (or of `id` itself).
    #[must_use]
    pub fn name_above(&self, mut id: NodeId) -> Option<String> {
        loop {
            if let NodeKind::Named { name, .. } = &self.node(id).kind {
                return Some(name.clone());
            }
            id = self.node(id).parent?;
        }
    }

    /// Indexes the top blend of every cluster of nested blends that has enough leaves.
    fn build_indices(&mut self, id: NodeId) {
        for c in self.nodes[id as usize].kind.children() {
            self.build_indices(c);
        }
        self.build_index_at(id);
    }

    /// Rebuilds the index of node `id` if it is the top blend of a cluster;
    /// returns where evaluation through it may now differ (in the frame its
    /// parent sees), empty where nothing did.
    fn build_index_at(&mut self, id: NodeId) -> Aabb {
        let is_cluster_top = matches!(self.nodes[id as usize].kind, NodeKind::Blend { .. })
            && !self.nodes[id as usize]
                .parent
                .is_some_and(|p| matches!(self.nodes[p as usize].kind, NodeKind::Blend { .. }));
        if !is_cluster_top {
            return Aabb::EMPTY;
        }
        let mut leaves = Vec::new();
        self.collect_leaves(id, None, &mut leaves);
        let index = (leaves.len() >= MIN_INDEXED_LEAVES).then(|| {
            let bounds = self.nodes[id as usize].bounds;
            Box::new(BlendIndex::build(
                bounds,
                leaves,
                // Per-cell bounds must hold for exact and cached evaluation alike.
                |leaf, b| in_every_mode(leaf, |m| self.leaf_interval(leaf, b, m), Interval::join),
                |leaf, r: &Region| in_every_mode(leaf, |m| self.leaf_lipschitz(leaf, r, m), f32::max),
            ))
        });
        let bounds = self.nodes[id as usize].bounds;
        let NodeKind::Blend { index: slot, .. } = &mut self.nodes[id as usize].kind else { return Aabb::EMPTY };
        let changed = match (&*slot, &index) {
            (Some(old), Some(new)) => new.changed_since(old),
            // Summed in child order instead of index order, or the reverse.
            (Some(ix), None) | (None, Some(ix)) => bounds.union(&ix.bounds()),
            (None, None) => Aabb::EMPTY,
        };
        *slot = index;
        changed
    }

    /// The non-blend descendants reached through nested blends, in scene order.
    fn collect_leaves(&self, id: NodeId, inherited: Option<Vec3>, out: &mut Vec<IndexedLeaf>) {
        let node = self.node(id);
        let color = node.color.or(inherited);
        match &node.kind {
            NodeKind::Blend { children, .. } => {
                for &c in children {
                    self.collect_leaves(c, color, out);
                }
            }
            NodeKind::Primitive(p) => out.push(IndexedLeaf { leaf: Leaf::Primitive(*p), bounds: node.bounds, color }),
            _ => out.push(IndexedLeaf { leaf: Leaf::Node(id), bounds: node.bounds, color }),
        }
    }

    /// Counts of primitives, caches and nodes.
    #[must_use]
    pub fn counts(&self) -> ModelCounts {
        let mut c = ModelCounts { nodes: self.nodes.len(), ..Default::default() };
        for n in &self.nodes {
            match n.kind {
                NodeKind::Primitive(_) => c.primitives += 1,
                NodeKind::Cache { .. } => c.caches += 1,
                NodeKind::Blend { index: Some(_), .. } => c.indexed_blends += 1,
                _ => {}
            }
        }
        c
    }
}

/// A bound on `leaf` that holds in every evaluation mode, the `widest` of its
/// exact and cached `bound`s: only a node leaf can hold a cache and answer
/// differently; a primitive answers alike in all.
fn in_every_mode<T>(leaf: &IndexedLeaf, bound: impl Fn(EvalMode) -> T, widest: impl Fn(T, T) -> T) -> T {
    match leaf.leaf {
        Leaf::Primitive(_) => bound(EvalMode::Naive),
        Leaf::Node(_) => widest(bound(EvalMode::Naive), bound(EvalMode::Cached)),
    }
}

fn wrong_kind(node: NodeId, expected: &'static str, found: &NodeKind) -> ModelError {
    ModelError::WrongKind { node: format!("node {node}"), expected, found: found.type_name() }
}

/// How many of each kind of node a model holds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct ModelCounts {
    /// All nodes.
    pub nodes: usize,
    /// Skeletal primitives.
    pub primitives: usize,
    /// Cache nodes.
    pub caches: usize,
    /// Blends carrying a spatial index.
    pub indexed_blends: usize,
}

/// Whether a node of `kind` over `children` (bounds, may be negative) may be
/// negative somewhere.
fn may_be_negative(kind: &NodeKind, children: &[(Aabb, bool)]) -> bool {
    let mut negative = children.iter().map(|c| c.1);
    match kind {
        NodeKind::Primitive(p) => p.weight < 0.0,
        // The maximum is negative only where every child is (a child is zero
        // outside its support).
        NodeKind::Union(_) => negative.all(|n| n),
        // Both clamp at zero.
        NodeKind::Difference(..) | NodeKind::Ricci { .. } => false,
        // A sum or minimum is negative wherever one child is; the pass-throughs
        // are their child (a cache's filters stay within its samples' range).
        _ => negative.any(|n| n),
    }
}

/// True for the n-ary operators (Blend, Union, Intersection, Ricci).
fn is_operator(kind: &NodeKind) -> bool {
    matches!(kind, NodeKind::Blend { .. } | NodeKind::Union(_) | NodeKind::Intersection(_) | NodeKind::Ricci { .. })
}

/// The children of an n-ary operator, to add or remove one.
fn operator_children_mut(kind: &mut NodeKind) -> Option<&mut Vec<NodeId>> {
    match kind {
        NodeKind::Blend { children, .. }
        | NodeKind::Union(children)
        | NodeKind::Intersection(children)
        | NodeKind::Ricci { children, .. } => Some(children),
        _ => None,
    }
}
