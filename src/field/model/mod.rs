//! The model: an arena of nodes with parents, bounds and blend indices kept current.
//!
//! - `tree_changes`: the changes to the tree a named edit is carried out by, each reported as a [`Change`];
//! - `caches`: the lattices of its `Cache` nodes, and what an edit clears in them;
//! - `indices`: the blend indices over its clusters of nested blends;
//! - `frames`: where a node sits in the world.

mod caches;
mod frames;
mod indices;
mod tree_changes;

use std::collections::HashMap;

use glam::Vec3;

use super::EvalMode;
use super::node::{Node, NodeKind};
use super::node_id::NodeId;
use crate::cache::{CacheGrid, Refit, SamplePool};
use crate::geom::{Aabb, Support};

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
    /// A warp's parameters are unusable, or its child leaves its domain:
    /// the `occurrence`-th node of that kind (0-based, in scene order).
    #[error("{kind}: {message}")]
    BadWarp {
        /// `Twist`, `Taper` or `Bend`.
        kind: &'static str,
        /// Which of that kind, in the order a scene file writes them.
        occurrence: usize,
        /// What is wrong.
        message: String,
    },
    /// A transform scales an axis by zero: it has no inverse.
    #[error("a Transform scale factor is zero")]
    ZeroScale,
    /// An edit named no `Named` node.
    #[error("no node is named {0:?}")]
    UnknownName(String),
    /// An edit's numbers are unusable (NaN, a zero scale, a non-positive radius).
    #[error("bad edit: {0}")]
    BadEdit(String),
    /// A `Points` node was built before its particle file was read.
    #[error("the particle file {0:?} was not read")]
    Unread(String),
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
    /// Per lattice: whether its cache answers from it in cached evaluation
    /// (all, unless auto mode's decisions say otherwise).
    in_use: Vec<bool>,
    /// Which ray tracer renders the model.
    tracer: TracerChoice,
}

/// Which ray tracer renders a model: the kernel tracer finds hits as roots
/// of each ray's polynomial where the field is a sum of polynomial kernels,
/// the segment tracer marches any field.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TracerChoice {
    /// The kernel tracer wherever it applies, else the segment tracer.
    #[default]
    Auto,
    /// The kernel tracer (where it cannot apply, the choice is refused before rendering).
    Kernel,
    /// The segment tracer.
    Segment,
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
            in_use: self.in_use.clone(),
            tracer: self.tracer,
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

    /// Makes room for `additional` more nodes at once (a million points'
    /// nodes then take their own size, not up to twice it while the arena
    /// grows by doubling, nor the copies).
    pub fn reserve(&mut self, additional: usize) {
        self.nodes.reserve_exact(additional);
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
            in_use: Vec::new(),
            tracer: TracerChoice::Auto,
        };
        model.link()?;
        model.refresh();
        model.check_warps()?;
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

    /// Which ray tracer renders the model.
    #[must_use]
    pub fn tracer(&self) -> TracerChoice {
        self.tracer
    }

    /// Chooses the ray tracer that renders the model.
    pub fn set_tracer(&mut self, tracer: TracerChoice) {
        self.tracer = tracer;
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
            NodeKind::Points { set, .. } => set.bounds(),
            NodeKind::Transform { placement, child } => self.extent_of(*child).transformed(&placement.to_world),
            NodeKind::Warp { warp, child } => warp.forward_box(&self.extent_of(*child)),
            kind => kind.children().iter().fold(Aabb::EMPTY, |a, &c| a.union(&self.extent_of(c))),
        }
    }

    /// Checks every warp's parameters and that each bend's child lies in
    /// its domain (see [`crate::field::Warp::check_domain`]).
    pub fn check_warps(&self) -> Result<(), ModelError> {
        let mut seen: Vec<&'static str> = vec![];
        let mut stack = vec![self.root];
        while let Some(id) = stack.pop() {
            let node = self.node(id);
            if let NodeKind::Warp { warp, child } = &node.kind {
                let kind = node.kind.type_name();
                let occurrence = seen.iter().filter(|&&k| k == kind).count();
                seen.push(kind);
                let bounds = self.sizing_bounds_of(*child);
                warp.check().and_then(|()| warp.check_domain(&bounds)).map_err(|message| ModelError::BadWarp {
                    kind,
                    occurrence,
                    message,
                })?;
            }
            // Children pushed last-first, so they are visited in scene order.
            stack.extend(node.kind.children().into_iter().rev());
        }
        Ok(())
    }

    /// Checks that the model lies near enough the origin for its size (see
    /// `MAX_OFFSET_IN_SIZES` and `MAX_REACH`); an empty model passes.
    pub fn check_reach(&self) -> Result<(), ModelError> {
        let b = self.bounds();
        if b.is_empty() {
            return Ok(());
        }
        let (far, size) = (b.min.abs().max(b.max.abs()).max_element(), b.size().max_element());
        let near = far.is_finite() && far <= MAX_REACH && far <= MAX_OFFSET_IN_SIZES * size;
        if near { Ok(()) } else { Err(ModelError::TooFar { far, size }) }
    }

    /// How many lattices (cache nodes) the model has.
    #[must_use]
    pub fn grid_count(&self) -> usize {
        self.grids.len()
    }

    /// True when cache lattice `grid` answers in `mode`: in cached
    /// evaluation, unless auto mode's decisions took it out of use.
    #[inline]
    #[must_use]
    pub fn answers_from_lattice(&self, grid: usize, mode: EvalMode) -> bool {
        mode == EvalMode::Cached && self.in_use[grid]
    }

    /// Puts every cache's lattice in use (`--mode cached`), or only those
    /// [`Self::cache_decisions`] says pay (`--mode auto`); returns how many are in use.
    pub fn use_lattices(&mut self, decided: bool) -> usize {
        self.in_use.fill(true);
        if decided {
            for d in self.cache_decisions() {
                let NodeKind::Cache { grid, .. } = self.node(d.node).kind else { continue };
                self.in_use[grid] = d.uses_lattice;
            }
        }
        self.in_use.iter().filter(|&&u| u).count()
    }

    /// Runs `f` with every cache answering from its lattice in cached
    /// evaluation (as when measuring the caches' own error), then restores
    /// auto mode's choices.
    pub fn with_every_lattice<R>(&mut self, f: impl FnOnce(&Model) -> R) -> R {
        self.with_lattices(&vec![true; self.grids.len()], f)
    }

    /// Runs `f` with the caches whose lattice `in_use` marks answering from
    /// it in cached evaluation (one cache alone, to measure its own error),
    /// then restores auto mode's choices.
    pub fn with_lattices<R>(&mut self, in_use: &[bool], f: impl FnOnce(&Model) -> R) -> R {
        debug_assert_eq!(in_use.len(), self.grids.len());
        let saved = std::mem::replace(&mut self.in_use, in_use.to_vec());
        let result = f(self);
        self.in_use = saved;
        result
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
                self.in_use.push(true);
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
            NodeKind::Points { set, .. } => set.bounds(),
            NodeKind::Intersection(_) => {
                // Positive only where every child is, negative wherever any
                // child is: inside the common part and any negative child's box.
                let common = children.iter().fold(children[0].0, |a, c| a.intersection(&c.0));
                children.iter().filter(|c| c.1).fold(common, |a, c| a.union(&c.0))
            }
            NodeKind::Difference(..) => children[0].0,
            NodeKind::Transform { placement, .. } => children[0].0.transformed(&placement.to_world),
            NodeKind::Warp { warp, .. } => warp.forward_box(&children[0].0),
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

    /// Number of primitives in the subtree under `id`.
    #[must_use]
    pub fn primitives_under(&self, id: NodeId) -> usize {
        match &self.node(id).kind {
            NodeKind::Primitive(_) => 1,
            NodeKind::Points { set, .. } => set.len(),
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

    /// Counts of primitives, caches and nodes.
    #[must_use]
    pub fn counts(&self) -> ModelCounts {
        let mut c = ModelCounts { nodes: self.nodes.len(), ..Default::default() };
        for n in &self.nodes {
            match n.kind {
                NodeKind::Primitive(_) => c.primitives += 1,
                NodeKind::Points { ref set, .. } => {
                    c.primitives += set.len();
                    c.indexed_blends += 1;
                }
                NodeKind::Cache { .. } => c.caches += 1,
                NodeKind::Blend { index: Some(_), .. } => c.indexed_blends += 1,
                _ => {}
            }
        }
        c
    }
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
        NodeKind::Points { set, .. } => set.has_negative_weight(),
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
