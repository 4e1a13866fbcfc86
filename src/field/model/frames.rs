//! Where a node sits in the world: the box its field occupies there, and a
//! world point carried into the frame the node is evaluated in, and the named
//! node strongest at a point.

use glam::Vec3A;

use super::Model;
use crate::field::EvalMode;
use crate::field::node::NodeKind;
use crate::field::node_id::NodeId;
use crate::geom::Aabb;

impl Model {
    /// Node `id`'s bounds as the root sees them: carried up through the
    /// transforms and warps above it (a box holding the mapped box).
    #[must_use]
    pub fn world_bounds(&self, id: NodeId) -> Aabb {
        let (mut at, mut bounds) = (id, self.node(id).bounds);
        while let Some(parent) = self.node(at).parent {
            match &self.node(parent).kind {
                NodeKind::Transform { placement, .. } => bounds = bounds.transformed(&placement.to_world),
                NodeKind::Warp { warp, .. } => bounds = warp.forward_box(&bounds),
                _ => {}
            }
            at = parent;
        }
        bounds
    }

    /// The world point `p` in the frame node `id` is evaluated in (through
    /// the inverse of every transform and warp above it), so
    /// `node_value(id, to_local(id, p), …)` is `id`'s part of the field at `p`.
    #[must_use]
    pub fn to_local(&self, id: NodeId, p: Vec3A) -> Vec3A {
        let mut above = vec![];
        let mut at = id;
        while let Some(parent) = self.node(at).parent {
            above.push(parent);
            at = parent;
        }
        above.iter().rev().fold(p, |p, &n| match &self.node(n).kind {
            NodeKind::Transform { placement, .. } => placement.local(p),
            NodeKind::Warp { warp, .. } => warp.inverse(p),
            _ => p,
        })
    }

    /// Of the named nodes, the one whose part of the field is largest at the
    /// world point `p` (none where every named node is zero there).
    #[must_use]
    pub fn strongest_named_at(&self, p: Vec3A, mode: EvalMode) -> Option<&str> {
        self.names()
            .into_iter()
            .filter_map(|name| {
                let id = self.find(name)?;
                Some((name, self.node_value(id, self.to_local(id, p), mode)))
            })
            .filter(|&(_, v)| v > 0.0)
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(name, _)| name)
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3A;

    use crate::field::EvalMode;
    use crate::scene::Scene;

    #[test]
    fn a_nested_node_is_found_where_the_world_sees_it() {
        let text = r#"Scene(camera: Camera(eye: (0.0, 0.0, 9.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (8, 8),
            model: Blend([Point(center: (-3.0, 0.0, 0.0), radius: 1.0),
                Transform(translate: (2.0, 1.0, 0.0), rotate: (0.0, 0.0, 90.0), child: Twist(rate: 0.5,
                    child: Named("leaf", Point(center: (1.0, 0.0, 0.0), radius: 0.8))))]))"#;
        let model = Scene::parse(text, "t").unwrap().model;
        let leaf = model.find("leaf").unwrap();
        // The point at local (1, 0, 0), turned a quarter about Z and moved: world (2, 2, 0).
        let world = Vec3A::new(2.0, 2.0, 0.0);
        let local = model.to_local(leaf, world);
        assert!((local - Vec3A::new(1.0, 0.0, 0.0)).length() < 1e-5, "{local}");
        assert!(
            (model.node_value(leaf, local, EvalMode::Indexed)
                - model.node_value(model.root(), world, EvalMode::Indexed))
            .abs()
                < 1e-6
        );
        let b = model.world_bounds(leaf);
        assert!(b.contains(world) && !b.contains(Vec3A::new(-3.0, 0.0, 0.0)), "{b:?}");
    }
}
