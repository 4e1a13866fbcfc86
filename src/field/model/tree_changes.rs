//! Changes to a model's tree, by node id: moving a frame, replacing a
//! primitive, adding, removing or retyping an operator's children — the
//! steps [`Model::apply`] carries an edit by name out with
//! (`field/named_edit.rs`). Each brings bounds, indices and caches up to date
//! and reports the [`Change`] it made.

use glam::Vec3;

use super::{Change, Model, ModelError};
use crate::field::node::{Node, NodeKind, Placement};
use crate::field::node_id::NodeId;
use crate::field::primitive::Primitive;
use crate::geom::Aabb;

impl Model {
    /// Moves Transform node `id` to `placement`. Caches below it keep their
    /// samples (their frame moves with them); caches above clear the samples
    /// inside the old and new bounds.
    pub fn set_placement(&mut self, id: NodeId, placement: Placement) -> Result<Change, ModelError> {
        let old = self.node(id).bounds;
        match &mut self.nodes[id as usize].kind {
            NodeKind::Transform { placement: p, .. } => **p = placement,
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

    /// Sets warp node `id`'s parameters; caches above it clear the samples
    /// inside the old and new bounds (those below keep theirs: the child's
    /// field is unchanged).
    pub fn set_warp(&mut self, id: NodeId, warp: crate::field::Warp) -> Result<Change, ModelError> {
        let old = self.node(id).bounds;
        match &mut self.nodes[id as usize].kind {
            NodeKind::Warp { warp: w, .. } => **w = warp,
            other => return Err(wrong_kind(id, "Twist, Taper or Bend", other)),
        }
        Ok(self.edited(id, old))
    }

    /// The Transform right under `Named` node `named`, inserting an identity
    /// one the first time: edits move it, so caches below move with their frame.
    pub(in crate::field) fn transform_under(&mut self, named: NodeId) -> NodeId {
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
            kind: NodeKind::Transform { placement: Box::new(identity), child },
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
    pub(in crate::field) fn operator_under(&self, named: NodeId) -> Option<NodeId> {
        let NodeKind::Named { child, .. } = self.nodes[named as usize].kind else {
            return None;
        };
        let child = self.under_frames(child);
        is_operator(&self.nodes[child as usize].kind).then_some(child)
    }

    /// The first node at or under `id` that is neither a Transform nor a Cache.
    pub(in crate::field) fn under_frames(&self, mut id: NodeId) -> NodeId {
        while let NodeKind::Transform { child, .. } | NodeKind::Cache { child, .. } = self.nodes[id as usize].kind {
            id = child;
        }
        id
    }

    /// Adds `Named(name, primitive)` as the last child of operator `op`; returns
    /// the change (the new node's bounds, or the operator's for an intersection).
    pub(in crate::field) fn add_child(
        &mut self,
        op: NodeId,
        name: &str,
        primitive: Primitive,
    ) -> Result<Change, ModelError> {
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
    pub(in crate::field) fn remove_child(&mut self, named: NodeId) -> Result<Change, ModelError> {
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
    pub(in crate::field) fn set_operator(&mut self, op: NodeId, kind: impl FnOnce(Vec<NodeId>) -> NodeKind) -> Change {
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

    /// Brings bounds, indices and caches up to date after node `id` changed.
    fn edited(&mut self, id: NodeId, old: Aabb) -> Change {
        self.refresh_from(id);
        let new = self.node(id).bounds;
        let samples_cleared = self.invalidate_above(id, old.union(&new));
        self.change(id, (old, new), samples_cleared)
    }
}

fn wrong_kind(node: NodeId, expected: &'static str, found: &NodeKind) -> ModelError {
    ModelError::WrongKind { node: format!("node {node}"), expected, found: found.type_name() }
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
