//! Tuning's changes to a scene description: a cache's resolution set, a
//! cache removed, split into caches over its operator's children, or
//! inserted over an expensive subtree. Each change is addressed by the
//! node's place in a depth-first walk of the description; the rewrite keeps
//! every cache's label (which cache of the original scene it descends from).

use std::collections::BTreeMap;

use crate::cache::{CacheUse, Filter, Storage};
use crate::scene::{NodeDesc, Resolution};

/// What to do with one node.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Change {
    /// A cache takes a new resolution.
    SetRes(u32),
    /// A cache goes; its subtree stays.
    Remove,
    /// A cache moves down onto each child of the first operator below it,
    /// at these resolutions.
    Split(Vec<u32>),
    /// A new cache over this subtree, at this resolution.
    Insert(u32),
}

/// Changes by depth-first place.
pub(super) type Plan = BTreeMap<usize, Change>;

/// Labels of the caches in depth-first order, before and after a rewrite.
pub(super) struct Labels<'a> {
    old: std::slice::Iter<'a, String>,
    /// The rewritten scene's cache labels, in depth-first order.
    pub new: Vec<String>,
}

/// `root` with `plan` carried out; `labels` names its caches in depth-first
/// order, and the result's labels are returned beside it.
pub(super) fn rewrite(root: &NodeDesc, plan: &Plan, labels: &[String]) -> (NodeDesc, Vec<String>) {
    let mut names = Labels { old: labels.iter(), new: vec![] };
    let node = rewrite_node(root, &mut 0, plan, &mut names, "scene");
    (node, names.new)
}

fn rewrite_node(node: &NodeDesc, at: &mut usize, plan: &Plan, labels: &mut Labels, above: &str) -> NodeDesc {
    let here = *at;
    *at += 1;
    let name = match node {
        NodeDesc::Named(n, _) => n.0.as_str(),
        _ => above,
    };
    if let Some(Change::Insert(res)) = plan.get(&here) {
        *at += node.node_count() - 1;
        labels.new.push(format!("{name} (new)"));
        return new_cache(*res, node.clone(), None);
    }
    if let NodeDesc::Cache { res, value, gradient, storage, usage, child } = node {
        let label = labels.old.next().cloned().unwrap_or_else(|| name.to_string());
        let spec = (*value, *gradient, *storage, *usage);
        return match plan.get(&here) {
            Some(Change::Remove) => rewrite_node(child, at, plan, labels, name),
            Some(Change::Split(child_res)) => {
                *at += child.node_count();
                let mut inner = (**child).clone();
                cache_each_child(&mut inner, child_res, spec, &label, labels);
                inner
            }
            change => {
                let res = match change {
                    Some(Change::SetRes(r)) => *r,
                    _ => res.0,
                };
                labels.new.push(label);
                let child = rewrite_node(child, at, plan, labels, name);
                new_cache(res, child, Some(spec))
            }
        };
    }
    let mut out = node.clone();
    for c in out.children_mut() {
        let new = rewrite_node(c, at, plan, labels, name);
        *c = new;
    }
    out
}

/// A cache's filters, storage and pin, as a split passes them on.
type Spec = (Filter, Filter, Storage, CacheUse);

fn new_cache(res: u32, child: NodeDesc, spec: Option<Spec>) -> NodeDesc {
    let (value, gradient, storage, usage) =
        spec.unwrap_or((Filter::Trilinear, Filter::Triquadratic, Storage::default(), CacheUse::Auto));
    NodeDesc::Cache { res: Resolution(res), value, gradient, storage, usage, child: Box::new(child) }
}

/// Puts a cache over each child of the first operator at or below `node`
/// (past names, transforms and warps), the `i`-th at `child_res[i]`.
fn cache_each_child(node: &mut NodeDesc, child_res: &[u32], spec: Spec, label: &str, labels: &mut Labels) {
    let mut children = node.children_mut();
    if children.len() == 1 {
        return cache_each_child(children.remove(0), child_res, spec, label, labels);
    }
    for (i, c) in children.into_iter().enumerate() {
        labels.new.push(format!("{label}/{i}"));
        *c = new_cache(child_res.get(i).copied().unwrap_or(2), c.clone(), Some(spec));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::parse_desc;

    fn model(text: &str) -> NodeDesc {
        let scene = format!(
            "Scene(camera: Camera(eye: (0.0, 0.0, 9.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (8, 8), model: {text})"
        );
        parse_desc(&scene, "t").unwrap().model
    }

    #[test]
    fn caches_are_resized_removed_split_and_inserted_by_place() {
        let root = model(
            r#"Blend([Named("a", Cache(res: 64, use: Always, child: Transform(translate: (1.0, 0.0, 0.0), child: Blend([
                Point(center: (0.0, 0.0, 0.0), radius: 1.0), Point(center: (0.5, 0.0, 0.0), radius: 1.0)])))),
              Cache(res: 32, child: Point(center: (3.0, 0.0, 0.0), radius: 1.0)),
              Union([Point(center: (-3.0, 0.0, 0.0), radius: 1.0), Point(center: (-3.5, 0.0, 0.0), radius: 1.0)])])"#,
        );
        let labels = vec!["a".to_string(), "b".to_string()];
        // Places: 0 Blend, 1 Named, 2 Cache, 3 Transform, 4 Blend, 5-6 points, 7 Cache, 8 point, 9 Union.
        let plan = Plan::from([(2, Change::Split(vec![20, 30])), (7, Change::Remove), (9, Change::Insert(16))]);
        let (out, new) = rewrite(&root, &plan, &labels);
        assert_eq!(new, ["a/0", "a/1", "scene (new)"]);
        let expected = model(
            r#"Blend([Named("a", Transform(translate: (1.0, 0.0, 0.0), child: Blend([
                Cache(res: 20, use: Always, child: Point(center: (0.0, 0.0, 0.0), radius: 1.0)),
                Cache(res: 30, use: Always, child: Point(center: (0.5, 0.0, 0.0), radius: 1.0))]))),
              Point(center: (3.0, 0.0, 0.0), radius: 1.0),
              Cache(res: 16, child: Union([Point(center: (-3.0, 0.0, 0.0), radius: 1.0), Point(center: (-3.5, 0.0, 0.0), radius: 1.0)]))])"#,
        );
        assert_eq!(out, expected);
        let (resized, names) = rewrite(&root, &Plan::from([(7, Change::SetRes(48))]), &labels);
        assert_eq!(names, ["a", "b"]);
        assert!(format!("{resized:?}").contains("Resolution(48)"));
    }
}
