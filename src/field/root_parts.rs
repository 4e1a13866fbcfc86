//! The components of a model's root: the children of a root blend without an
//! index (Medusa's seven), each past its names, exactly evaluated caches and
//! frames that move nothing, with their bounds side by side.
//!
//! Every question the tracer asks starts at the root. Through the tree, each
//! child's chain of nodes is walked to reach the bounds at its end and test
//! them there, seven times per question on Medusa; here the few boxes are
//! tested in one place, and only the components they admit are asked. Each
//! answer is summed in the order and precision of the root blend's own, so
//! it is the tree's to the bit: a component left out would have added zero.

use glam::{Vec3, Vec3A};

use super::node::NodeKind;
use super::node_id::NodeId;
use super::{EvalMode, Model};
use crate::geom::{Aabb, Interval, Region};

/// Most children a root blend may have to be split into [`RootParts`].
const MAX_PARTS: usize = 8;

/// The children of a root blend without an index, past their pass-throughs.
#[derive(Clone, Copy, Debug)]
pub struct RootParts {
    len: usize,
    bounds: [Aabb; MAX_PARTS],
    ids: [NodeId; MAX_PARTS],
    /// The children themselves, which colour their parts (a colouring
    /// frame that moves nothing is a pass-through for every other answer).
    children: [NodeId; MAX_PARTS],
    /// Whether the root node is the blend itself, uncoloured: then its colour
    /// is its children's mix, and the parts give it.
    mixes_colors: bool,
}

impl RootParts {
    /// The parts of `model`'s root in `mode`: `None` unless the root is a
    /// blend without an index of at most [`MAX_PARTS`] children, none of them
    /// a blend itself (the tree sums a nested blend's terms without rounding
    /// its total, which a part would).
    #[must_use]
    pub fn of(model: &Model, mode: EvalMode) -> Option<Self> {
        let root = model.node(model.past_pass_throughs(model.root(), mode));
        let NodeKind::Blend { children, index: None } = &root.kind else { return None };
        let nested = children.iter().any(|&c| matches!(model.node(c).kind, NodeKind::Blend { .. }));
        if children.len() > MAX_PARTS || nested {
            return None;
        }
        let top = model.node(model.root());
        let mixes_colors = matches!(top.kind, NodeKind::Blend { .. }) && top.color.is_none();
        let (bounds, ids) = ([Aabb::EMPTY; MAX_PARTS], [0; MAX_PARTS]);
        let mut parts = Self { len: children.len(), bounds, ids, children: ids, mixes_colors };
        for (k, &c) in children.iter().enumerate() {
            let id = model.past_pass_throughs(c, mode);
            (parts.bounds[k], parts.ids[k], parts.children[k]) = (model.node(id).bounds, id, c);
        }
        Some(parts)
    }

    /// The parts whose bounds pass `admits`.
    #[inline]
    fn admitted<'s>(&'s self, admits: impl Fn(&Aabb) -> bool + 's) -> impl Iterator<Item = NodeId> + 's {
        let parts = self.bounds[..self.len].iter().zip(&self.ids[..self.len]);
        parts.filter(move |(b, _)| admits(b)).map(|(_, &id)| id)
    }

    /// The root's value at `p`.
    pub fn value(&self, model: &Model, p: Vec3A, mode: EvalMode) -> f32 {
        let sum = self.admitted(|b| b.contains(p)).fold(0.0f64, |s, id| s + f64::from(model.node_value(id, p, mode)));
        sum as f32
    }

    /// The root's gradient at `p`.
    pub fn gradient(&self, model: &Model, p: Vec3A, mode: EvalMode) -> Vec3A {
        self.admitted(|b| b.contains(p)).fold(Vec3A::ZERO, |s, id| s + model.node_gradient(id, p, mode))
    }

    /// The root's value and gradient at `p`, to the bits of each alone.
    pub fn value_and_gradient(&self, model: &Model, p: Vec3A, mode: EvalMode) -> (f32, Vec3A) {
        let (sum, gradient) = self.admitted(|b| b.contains(p)).fold((0.0f64, Vec3A::ZERO), |(s, g), id| {
            let (v, dv) = model.node_value_and_gradient(id, p, mode);
            (s + f64::from(v), g + dv)
        });
        (sum as f32, gradient)
    }

    /// The root's gradient and colour at `p` (the blend's mix of its
    /// children's colours, weighted by their values), where the root node is
    /// the uncoloured blend; `None` otherwise.
    pub fn gradient_and_color(&self, model: &Model, p: Vec3A, mode: EvalMode) -> Option<(Vec3A, Vec3)> {
        if !self.mixes_colors {
            return None;
        }
        let admitted = (0..self.len).filter(|&k| self.bounds[k].contains(p));
        Some(model.mixed_gradient_and_color(admitted.map(|k| (self.ids[k], self.children[k])), p, mode))
    }

    /// The root's value range over `b`.
    pub fn interval(&self, model: &Model, b: &Aabb, mode: EvalMode) -> Interval {
        self.admitted(|part| part.overlaps(b)).fold(Interval::ZERO, |s, id| s + model.node_interval(id, b, mode))
    }

    /// The root's slope bound over `region`. The sums start from `+0`, as
    /// the tree's do once a first child has added its zero.
    pub fn lipschitz(&self, model: &Model, region: &Region, mode: EvalMode) -> f32 {
        let reach = region.bounds();
        let met = self.admitted(|b| b.overlaps(&reach) && region.meets(b));
        met.fold(0.0, |s, id| s + model.met_node_lipschitz(id, region, mode))
    }

    /// The root's curvature bound over `region`.
    pub fn curvature(&self, model: &Model, region: &Region, mode: EvalMode) -> f32 {
        let reach = region.bounds();
        let met = self.admitted(|b| b.overlaps(&reach) && region.meets(b));
        met.fold(0.0, |s, id| s + model.met_node_curvature(id, region, mode))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::{Field, ModelField};
    use crate::scene::Scene;

    /// A root blend as Medusa's: named, cached, coloured components of many
    /// points, a component moved by a transform, and a bare point.
    const COMPONENTS: &str = r#"Scene(
        camera: Camera(eye: (0.0, 0.0, 6.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
        size: (32, 24),
        model: Blend([
            Named("arm", Cache(res: 32, child: Transform(color: (0.2, 0.5, 0.3), child: Blend([
                SplinePoints(control: [(-1.5, 0.0, 0.0), (-0.5, 0.6, 0.2), (0.5, 0.4, 0.0)], count: 30, radius: 0.4),
                SplinePoints(control: [(-1.0, -0.5, 0.3), (0.0, -0.2, 0.0), (1.0, -0.6, -0.2)], count: 30, radius: 0.35),
            ])))),
            Named("leg", Transform(translate: (0.3, -0.4, 0.1), rotate: (0.0, 0.0, 20.0), child: Blend([
                SplinePoints(control: [(0.0, 0.0, 0.0), (0.5, -0.5, 0.0), (1.0, -0.8, 0.2)], count: 20, radius: 0.3),
            ]))),
            Point(center: (0.8, 0.8, 0.0), radius: 0.5),
        ]),
    )"#;

    /// A point of the scene's bounds from a deterministic sequence.
    fn point_in(b: &Aabb, k: u32) -> Vec3A {
        let u = |salt: u32| ((k.wrapping_mul(2_654_435_761) ^ salt.wrapping_mul(40_503)) % 10_007) as f32 / 10_007.0;
        b.min + (b.max - b.min) * Vec3A::new(u(1), u(2), u(3))
    }

    #[test]
    fn the_parts_answer_as_the_tree_does_to_the_bit() {
        let scene = Scene::parse(COMPONENTS, "components").unwrap();
        let model = &scene.model;
        let b = model.bounds().padded(0.2);
        for mode in [EvalMode::Indexed, EvalMode::Cached] {
            let parts = RootParts::of(model, mode).expect("the root splits into its components");
            assert_eq!(parts.len, 3);
            assert!(parts.mixes_colors, "the parts shade too");
            let field = ModelField::new(model, mode);
            let root = model.root();
            let mut inside = 0;
            for k in 0..2000 {
                let (p, q) = (point_in(&b, k), point_in(&b, k + 7919));
                let v = field.value(p);
                inside += usize::from(v > 0.0);
                assert_eq!(v.to_bits(), model.node_value(root, p, mode).to_bits(), "value at {p}");
                assert_eq!(field.gradient(p), model.node_gradient(root, p, mode), "gradient at {p}");
                let (tree_v, tree_g) = model.node_value_and_gradient(root, p, mode);
                assert_eq!(field.value_and_gradient(p), (tree_v, tree_g), "value and gradient at {p}");
                let shading = model.node_gradient_and_color(root, p, mode);
                assert_eq!(field.gradient_and_color(p), shading, "gradient and colour at {p}");
                // Short segments, as the tracer's, and long ones.
                let near = p + (q - p) * 0.05;
                for region in [Region::Segment(p, near), Region::Segment(p, q)] {
                    let l = model.node_lipschitz(root, &region, mode);
                    assert_eq!(field.lipschitz(&region).to_bits(), l.to_bits(), "slope over {region:?}");
                    let c = model.node_curvature(root, &region, mode);
                    assert_eq!(field.curvature(&region), c, "curvature over {region:?}");
                }
                let cell = Aabb::new(p.min(near), p.max(near));
                assert_eq!(field.interval(&cell), model.node_interval(root, &cell, mode), "range over {cell:?}");
            }
            assert!(inside > 200, "{inside} of the points are in some support");
        }
    }

    #[test]
    fn a_root_with_a_nested_blend_or_an_index_is_not_split() {
        let nested = COMPONENTS.replace(
            "Point(center: (0.8, 0.8, 0.0), radius: 0.5)",
            "Blend([Point(center: (0.8, 0.8, 0.0), radius: 0.5)])",
        );
        let scene = Scene::parse(&nested, "nested").unwrap();
        assert!(RootParts::of(&scene.model, EvalMode::Indexed).is_none());
        let wide: Vec<String> = (0..12).map(|i| format!("Point(center: ({}.0, 0.0, 0.0), radius: 0.6)", i)).collect();
        let text = format!(
            "Scene(camera: Camera(eye: (0.0, 0.0, 9.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (32, 24), model: Blend([{}]))",
            wide.join(", ")
        );
        let scene = Scene::parse(&text, "wide").unwrap();
        assert!(RootParts::of(&scene.model, EvalMode::Indexed).is_none(), "an indexed root sums its leaves itself");
        assert!(ModelField::new(&scene.model, EvalMode::Indexed).value(Vec3A::new(3.0, 0.0, 0.0)) > 0.5);
    }
}
