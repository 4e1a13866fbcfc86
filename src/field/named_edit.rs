//! Edits by name, as scripts and the previewer write them: the one door
//! through which a model changes after it is built. [`Model::apply`] checks
//! an edit, finds its node and carries it out through the tree changes of
//! `model/tree_changes.rs`; it returns the [`Change`] — what moved, its
//! bounds and supports before and after — so caches, meshes and screens can
//! update only that (`change_reach.rs` says where that is in the world).

use glam::{Affine3A, Vec3, Vec3A};

use super::MAX_MAGNITUDE;
use super::model::{Change, Model, ModelError};
use super::node::{NodeKind, Placement};
use super::node_id::NodeId;
use super::warp::Warp;

/// An edit of a named node. [`Model::apply`] checks its numbers before
/// anything changes (edit scripts check them as they parse, too, to report a
/// bad one at its line and column).
#[derive(Clone, Debug, PartialEq)]
pub enum Edit {
    /// Move the named subtree by `by`, in its parent's frame.
    Translate {
        /// The `Named` node.
        node: String,
        /// Displacement.
        by: Vec3,
    },
    /// Rotate the named subtree about the centre of its bounds, in degrees about X, then Y, then Z.
    Rotate {
        /// The `Named` node.
        node: String,
        /// Angles in degrees.
        degrees: Vec3,
    },
    /// Scale the named subtree about the centre of its bounds.
    Scale {
        /// The `Named` node.
        node: String,
        /// Per-axis factors, non-zero.
        by: Vec3,
    },
    /// Set the support radius of the named primitive.
    Radius {
        /// The `Named` node holding a primitive.
        node: String,
        /// New radius, positive.
        radius: f32,
    },
    /// Set the weight of the named primitive.
    Weight {
        /// The `Named` node holding a primitive.
        node: String,
        /// New weight, finite.
        weight: f32,
    },
    /// Add a point primitive, named `name`, to the operator under the node `to`.
    AddPoint {
        /// The `Named` node above a Blend, Union, Intersection or Ricci.
        to: String,
        /// The new node's name, unused so far.
        name: String,
        /// Centre.
        center: Vec3,
        /// Support radius, positive.
        radius: f32,
        /// Weight (default 1).
        weight: f32,
    },
    /// Remove the named node from the operator holding it (which keeps at least one child).
    Remove {
        /// The `Named` node to remove.
        node: String,
    },
    /// Set parameters of the warp under the named node (through its
    /// transforms and caches); those left `None` keep their values.
    Warp {
        /// The `Named` node above a Twist, Taper or Bend.
        node: String,
        /// A twist's or bend's rate.
        rate: Option<f32>,
        /// A taper's ramp start.
        from: Option<f32>,
        /// A taper's ramp end.
        to: Option<f32>,
        /// A taper's scale at its start.
        scale_from: Option<f32>,
        /// A taper's scale at its end.
        scale_to: Option<f32>,
    },
    /// Change the operator under the named node, keeping its children.
    Operator {
        /// The `Named` node above a Blend, Union, Intersection or Ricci.
        node: String,
        /// The new operator.
        op: Operator,
    },
}

/// `warp` with the parameters given (rate, from, to, scale_from, scale_to)
/// replaced; a parameter the warp does not have is refused.
fn with_parameters(warp: Warp, [rate, from, to, scale_from, scale_to]: [Option<f32>; 5]) -> Result<Warp, String> {
    let taper_only = from.is_some() || to.is_some() || scale_from.is_some() || scale_to.is_some();
    match warp {
        Warp::Twist { .. } | Warp::Bend { .. } if taper_only => {
            Err("from, to, scale_from and scale_to are a taper's; a twist or bend has a rate".into())
        }
        Warp::Twist { axis, rate: r } => Ok(Warp::Twist { axis, rate: rate.unwrap_or(r) }),
        Warp::Bend { rate: r } => Ok(Warp::Bend { rate: rate.unwrap_or(r) }),
        Warp::Taper { .. } if rate.is_some() => Err("a taper has no rate".into()),
        Warp::Taper { axis, from: f, to: t, scale_from: s0, scale_to: s1 } => Ok(Warp::Taper {
            axis,
            from: from.unwrap_or(f),
            to: to.unwrap_or(t),
            scale_from: scale_from.unwrap_or(s0),
            scale_to: scale_to.unwrap_or(s1),
        }),
    }
}

/// The n-ary operators an edit can switch between.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Operator {
    /// Sum.
    Blend,
    /// Maximum.
    Union,
    /// Minimum.
    Intersection,
    /// Ricci's blend with exponent `n ≥ 1`.
    Ricci(f32),
}

impl Edit {
    /// The name the edit addresses.
    #[must_use]
    pub fn node(&self) -> &str {
        match self {
            Edit::Translate { node, .. }
            | Edit::Rotate { node, .. }
            | Edit::Scale { node, .. }
            | Edit::Radius { node, .. }
            | Edit::Weight { node, .. }
            | Edit::Remove { node }
            | Edit::Warp { node, .. }
            | Edit::Operator { node, .. } => node,
            Edit::AddPoint { to, .. } => to,
        }
    }

    /// Checks the numbers before anything changes.
    fn validate(&self) -> Result<(), ModelError> {
        let bad = |what: String| Err(ModelError::BadEdit(what));
        // Finite, and within the magnitude scene files allow.
        let fine = |v: f32| v.is_finite() && v.abs() <= MAX_MAGNITUDE;
        let fine3 = |v: Vec3| v.to_array().into_iter().all(fine);
        match self {
            Edit::Translate { by: v, .. } | Edit::Rotate { degrees: v, .. } if !fine3(*v) => {
                bad(format!("{} by {v}: not finite or beyond {MAX_MAGNITUDE:e}", self.node()))
            }
            Edit::Scale { by, .. } if !fine3(*by) || by.abs().min_element() <= f32::EPSILON => bad(format!(
                "{} scaled by {by}: factors must be finite, non-zero and at most {MAX_MAGNITUDE:e}",
                self.node()
            )),
            Edit::Radius { radius, .. } if !(fine(*radius) && *radius > 0.0) => {
                bad(format!("{} radius {radius}: must be positive and at most {MAX_MAGNITUDE:e}", self.node()))
            }
            Edit::Weight { weight, .. } if !fine(*weight) => {
                bad(format!("{} weight {weight}: not finite or beyond {MAX_MAGNITUDE:e}", self.node()))
            }
            Edit::AddPoint { center, radius, weight, name, .. }
                if !(fine3(*center) && fine(*radius) && fine(*weight) && *radius > 0.0 && !name.is_empty()) =>
            {
                bad(format!(
                    "adding {name:?}: needs a name, a finite centre and weight, and a positive radius (each at most {MAX_MAGNITUDE:e})"
                ))
            }
            Edit::Warp { rate, from, to, scale_from, scale_to, .. }
                if ![rate, from, to, scale_from, scale_to].iter().all(|v| v.is_none_or(fine)) =>
            {
                bad(format!("{}: warp parameters must be finite and at most {MAX_MAGNITUDE:e}", self.node()))
            }
            Edit::Operator { op: Operator::Ricci(n), .. } if !(n.is_finite() && *n >= 1.0) => {
                bad(format!("{}: Ricci exponent {n} must be at least 1", self.node()))
            }
            _ => Ok(()),
        }
    }
}

impl Model {
    /// Applies `edit`. Moves act on the Transform right under the named node
    /// (one is inserted the first time), so a cache under it moves with its
    /// frame and keeps its samples; caches above clear the samples inside the
    /// old and new bounds. A rejected edit leaves the model as it was.
    pub fn apply(&mut self, edit: &Edit) -> Result<Change, ModelError> {
        edit.validate()?;
        let named = self.find(edit.node()).ok_or_else(|| ModelError::UnknownName(edit.node().to_string()))?;
        let NodeKind::Named { child, .. } = self.node(named).kind else {
            return Err(ModelError::UnknownName(edit.node().to_string()));
        };
        // The field can change only within the supports of this node's
        // subtree before and after; a removal can change its whole parent
        // (an intersection's minimum, say).
        let scope = match edit {
            Edit::Remove { .. } => self.node(named).parent.unwrap_or(named),
            _ => named,
        };
        let mut supports = vec![];
        self.supports(scope, &mut supports);
        let mut change = self.apply_found(edit, named, child)?;
        self.supports(scope, &mut supports);
        change.supports = supports;
        change.scope = scope;
        Ok(change)
    }

    /// [`Self::apply`] on the validated edit of `Named` node `named` over `child`.
    fn apply_found(&mut self, edit: &Edit, named: NodeId, child: NodeId) -> Result<Change, ModelError> {
        let operator = || {
            self.operator_under(named).ok_or_else(|| ModelError::WrongKind {
                node: format!("the node under {:?} (through its transforms and caches)", edit.node()),
                expected: "Blend, Union, Intersection or Ricci",
                found: self.node(self.under_frames(child)).kind.type_name(),
            })
        };
        match edit {
            Edit::AddPoint { name, center, radius, weight, .. } => {
                let op = operator()?;
                let point = super::Primitive::new(
                    super::Skeleton::Point { center: (*center).into() },
                    *radius,
                    *weight,
                    super::Kernel::default(),
                );
                self.add_child(op, name, point)
            }
            Edit::Remove { .. } => self.remove_child(named),
            Edit::Operator { op: kind, .. } => {
                let op = operator()?;
                let kind = *kind;
                Ok(self.set_operator(op, move |children| match kind {
                    Operator::Blend => NodeKind::Blend { children, index: None },
                    Operator::Union => NodeKind::Union(children),
                    Operator::Intersection => NodeKind::Intersection(children),
                    Operator::Ricci(n) => NodeKind::Ricci { n, children },
                }))
            }
            Edit::Radius { radius, .. } => self.edit_primitive(child, |p| p.with_radius(*radius)),
            Edit::Weight { weight, .. } => self.edit_primitive(child, |p| p.with_weight(*weight)),
            Edit::Translate { by, .. } => self.move_subtree(named, |_| Affine3A::from_translation(*by)),
            Edit::Rotate { degrees, .. } => {
                let r = degrees * (std::f32::consts::PI / 180.0);
                let q = glam::Quat::from_euler(glam::EulerRot::ZYX, r.z, r.y, r.x);
                self.move_subtree(named, |c| about(c, Affine3A::from_quat(q)))
            }
            Edit::Scale { by, .. } => self.move_subtree(named, |c| about(c, Affine3A::from_scale(*by))),
            Edit::Warp { rate, from, to, scale_from, scale_to, .. } => {
                let id = self.under_frames(child);
                let NodeKind::Warp { ref warp, child: warped } = self.node(id).kind else {
                    return Err(ModelError::WrongKind {
                        node: format!("the node under {:?} (through its transforms and caches)", edit.node()),
                        expected: "Twist, Taper or Bend",
                        found: self.node(id).kind.type_name(),
                    });
                };
                let changed = with_parameters(**warp, [*rate, *from, *to, *scale_from, *scale_to])
                    .and_then(|w| w.check().and_then(|()| w.check_domain(&self.sizing_bounds_of(warped))).map(|()| w))
                    .map_err(|why| ModelError::BadEdit(format!("{}: {why}", edit.node())))?;
                self.set_warp(id, changed)
            }
        }
    }

    /// Changes the primitive under `id`, looking through the transforms that
    /// moves have put above it.
    fn edit_primitive(
        &mut self,
        mut id: NodeId,
        change: impl Fn(&super::Primitive) -> super::Primitive,
    ) -> Result<Change, ModelError> {
        while let NodeKind::Transform { child, .. } = self.node(id).kind {
            id = child;
        }
        match &self.node(id).kind {
            NodeKind::Primitive(p) => {
                let p = change(p);
                self.set_primitive(id, p)
            }
            other => Err(ModelError::WrongKind {
                node: format!("the node under {:?}", self.name_above(id).unwrap_or_default()),
                expected: "Primitive",
                found: other.type_name(),
            }),
        }
    }

    /// Pre-multiplies the placement of the Transform under `named` by
    /// `motion(centre of the subtree's bounds)`.
    fn move_subtree(&mut self, named: NodeId, motion: impl Fn(Vec3A) -> Affine3A) -> Result<Change, ModelError> {
        let transform = self.transform_under(named);
        let placement = match &self.node(transform).kind {
            NodeKind::Transform { placement, .. } => **placement,
            other => {
                return Err(ModelError::WrongKind {
                    node: format!("the node under {:?}", self.name_above(named).unwrap_or_default()),
                    expected: "Transform",
                    found: other.type_name(),
                });
            }
        };
        // About the subtree's centre; a subtree whose parts do not meet (an
        // empty intersection) has no support to centre on, but its parts do.
        let m = motion(self.sizing_bounds_of(transform).center()) * placement.to_world;
        self.set_placement(transform, Placement::from_affine(m).ok_or(ModelError::ZeroScale)?)
    }
}

/// `m` about the point `c`: move `c` to the origin, apply `m`, move back.
fn about(c: Vec3A, m: Affine3A) -> Affine3A {
    Affine3A::from_translation(c.into()) * m * Affine3A::from_translation((-c).into())
}
