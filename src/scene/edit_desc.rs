//! Edits as edit scripts write them, checked as they parse, and their
//! conversion into the model's [`Edit`]s: the field never reads a file.

use glam::Vec3;
use serde::Deserialize;

use super::values;
use crate::field::{Edit, Operator};

/// An edit as a script writes it: its numbers are checked as they are parsed,
/// so a bad one is reported at its line and column, the same way a scene's are.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum EditDesc {
    /// Move the named subtree by `by`, in its parent's frame.
    Translate {
        /// The `Named` node.
        node: String,
        /// Displacement.
        #[serde(deserialize_with = "values::finite_vec3")]
        by: Vec3,
    },
    /// Rotate the named subtree about the centre of its bounds, in degrees about X, then Y, then Z.
    Rotate {
        /// The `Named` node.
        node: String,
        /// Angles in degrees.
        #[serde(deserialize_with = "values::finite_vec3")]
        degrees: Vec3,
    },
    /// Scale the named subtree about the centre of its bounds.
    Scale {
        /// The `Named` node.
        node: String,
        /// Per-axis factors, non-zero.
        #[serde(deserialize_with = "values::scale_factors")]
        by: Vec3,
    },
    /// Set parameters of the named warp (Twist, Taper or Bend); the rest keep their values.
    Warp {
        /// The `Named` node above the warp.
        node: String,
        /// A twist's or bend's rate.
        #[serde(default)]
        rate: Option<values::Finite>,
        /// A taper's ramp start.
        #[serde(default)]
        from: Option<values::Finite>,
        /// A taper's ramp end.
        #[serde(default)]
        to: Option<values::Finite>,
        /// A taper's scale at its start.
        #[serde(default)]
        scale_from: Option<values::Positive>,
        /// A taper's scale at its end.
        #[serde(default)]
        scale_to: Option<values::Positive>,
    },
    /// Set the support radius of the named primitive.
    Radius {
        /// The `Named` node holding a primitive.
        node: String,
        /// New radius, positive.
        #[serde(deserialize_with = "values::positive")]
        radius: f32,
    },
    /// Set the weight of the named primitive.
    Weight {
        /// The `Named` node holding a primitive.
        node: String,
        /// New weight, finite.
        #[serde(deserialize_with = "values::finite")]
        weight: f32,
    },
    /// Add a point primitive, named `name`, to the operator under the node `to`.
    AddPoint {
        /// The `Named` node above a Blend, Union, Intersection or Ricci.
        to: String,
        /// The new node's name, unused so far.
        name: String,
        /// Centre.
        #[serde(deserialize_with = "values::finite_vec3")]
        center: Vec3,
        /// Support radius, positive.
        #[serde(deserialize_with = "values::positive")]
        radius: f32,
        /// Weight (default 1).
        #[serde(default = "one", deserialize_with = "values::finite")]
        weight: f32,
    },
    /// Remove the named node from the operator holding it (which keeps at least one child).
    Remove {
        /// The `Named` node to remove.
        node: String,
    },
    /// Change the operator under the named node, keeping its children.
    Operator {
        /// The `Named` node above a Blend, Union, Intersection or Ricci.
        node: String,
        /// The new operator.
        op: OperatorDesc,
    },
}

/// An operator as a script names it.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
pub enum OperatorDesc {
    /// Sum.
    Blend,
    /// Maximum.
    Union,
    /// Minimum.
    Intersection,
    /// Ricci's blend with exponent `n ≥ 1`.
    Ricci(#[serde(deserialize_with = "values::at_least_one")] f32),
}

fn one() -> f32 {
    1.0
}

impl From<OperatorDesc> for Operator {
    fn from(op: OperatorDesc) -> Self {
        match op {
            OperatorDesc::Blend => Operator::Blend,
            OperatorDesc::Union => Operator::Union,
            OperatorDesc::Intersection => Operator::Intersection,
            OperatorDesc::Ricci(n) => Operator::Ricci(n),
        }
    }
}

impl From<EditDesc> for Edit {
    fn from(e: EditDesc) -> Self {
        match e {
            EditDesc::Translate { node, by } => Edit::Translate { node, by },
            EditDesc::Rotate { node, degrees } => Edit::Rotate { node, degrees },
            EditDesc::Scale { node, by } => Edit::Scale { node, by },
            EditDesc::Radius { node, radius } => Edit::Radius { node, radius },
            EditDesc::Weight { node, weight } => Edit::Weight { node, weight },
            EditDesc::AddPoint { to, name, center, radius, weight } => {
                Edit::AddPoint { to, name, center, radius, weight }
            }
            EditDesc::Remove { node } => Edit::Remove { node },
            EditDesc::Operator { node, op } => Edit::Operator { node, op: op.into() },
            EditDesc::Warp { node, rate, from, to, scale_from, scale_to } => Edit::Warp {
                node,
                rate: rate.map(|v| v.0),
                from: from.map(|v| v.0),
                to: to.map(|v| v.0),
                scale_from: scale_from.map(|v| v.0),
                scale_to: scale_to.map(|v| v.0),
            },
        }
    }
}
