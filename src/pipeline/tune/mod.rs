//! `tune`: caches that place and size themselves, the caching paper's future
//! work (§4.3, §7). Each round polygonizes the exact surface, samples every
//! cache's error_C = |f_C − f| and gradient error at the vertices it covers,
//! and changes the scene description:
//!
//! - a cache the cost model says does not pay is removed (unless pinned);
//! - one whose error is over the tolerance `E` at too many vertices (99th
//!   percentile over `E`, or any vertex over `4E`) takes a finer lattice —
//!   trilinear error shrinks with the square of the cell, so the resolution
//!   grows by `√(error / 0.7E)` — or, where the failing vertices belong
//!   mostly to one child of a small share, splits into caches over its
//!   operator's children (each keeps today's cell, so a small part gets a
//!   lattice of its own: the paper's Figure 7, Medusa's hand);
//! - one far below `E` (99th percentile under `E/4`) takes a coarser lattice;
//! - an expensive uncached subtree gets a cache, starting coarse;
//! - raises stay within the memory budget, measured as the bytes of samples a
//!   render and a polygonization touch (growing as the square of the resolution).
//!
//! Rounds repeat until nothing changes. The band between `E/4` and `E` makes a
//! tuned scene a fixed point: tuning it again changes nothing.

mod measure;
mod report;
mod rewrite;

use serde::Serialize;

use crate::field::LATTICE_COST;
use crate::pipeline::error::{PipelineError, Result};
use crate::progress::Progress;
use crate::scene::{NodeDesc, SceneDesc};
pub use measure::VertexError;
use measure::{CacheMeasure, Round, measure, preorder};
pub use report::error_slices;
use rewrite::{Change, Plan, rewrite};

/// How to tune.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TuneSettings {
    /// The tolerance `E` on error_C at mesh vertices, in field units.
    pub tolerance: f32,
    /// Most megabytes of samples the caches may touch (none: unbounded).
    pub budget_mb: Option<f64>,
    /// Resolution of the exact polygonization whose vertices are sampled.
    pub mesh_res: u32,
    /// Most rounds of measuring and changing.
    pub max_rounds: u32,
}

impl Default for TuneSettings {
    fn default() -> Self {
        Self { tolerance: 1e-3, budget_mb: None, mesh_res: 128, max_rounds: 6 }
    }
}

/// Resolution a new cache starts at; rounds then raise it to what `E` needs.
pub const INSERT_RES: u32 = 32;
/// Where a raise aims, as a share of `E`.
const AIM: f32 = 0.7;
/// A cache whose 99th percentile is under this share of `E` is lowered.
const LOWER_BELOW: f32 = 0.25;
/// Largest resolution a cache may take.
const MAX_CACHE_RES: u32 = 1024;

impl TuneSettings {
    /// Checks the settings before any work.
    pub fn check(&self) -> Result<()> {
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(PipelineError::setting(
                "tolerance",
                format!("must be a positive number, got {}", self.tolerance),
            ));
        }
        if let Some(mb) = self.budget_mb
            && !(mb.is_finite() && mb > 0.0)
        {
            return Err(PipelineError::setting("budget", format!("must be a positive number of megabytes, got {mb}")));
        }
        if !(8..=1024).contains(&self.mesh_res) {
            return Err(PipelineError::setting("res", format!("must lie in 8..=1024, got {}", self.mesh_res)));
        }
        Ok(())
    }

    fn budget_bytes(&self) -> Option<u64> {
        self.budget_mb.map(|mb| (mb * crate::pipeline::MB) as u64)
    }
}

/// One cache of the original or the tuned scene, before and after.
#[derive(Clone, Debug, Serialize)]
pub struct TuneRow {
    /// Its label: the nearest name above it; `/i` for the `i`-th child of a
    /// split, `(new)` for an inserted cache.
    pub cache: String,
    /// Resolution in the original scene (none: inserted).
    pub res_before: Option<u32>,
    /// Resolution in the tuned scene (none: removed).
    pub res_after: Option<u32>,
    /// Error at vertices in the original scene.
    pub before: Option<VertexError>,
    /// Error at vertices in the tuned scene.
    pub after: Option<VertexError>,
    /// Bytes of samples touched in the original scene.
    pub bytes_before: u64,
    /// Bytes of samples touched in the tuned scene.
    pub bytes_after: u64,
    /// The cost model's exact / lattice estimate (above 1: the lattice pays).
    pub cost_ratio: f32,
    /// What tuning did, round by round (`kept` when nothing).
    pub decision: String,
    /// Why.
    pub reason: String,
}

/// What tuning found and did.
#[derive(Clone, Debug, Serialize)]
pub struct TuneReport {
    /// The tolerance `E`.
    pub tolerance: f32,
    /// The memory budget in megabytes, if any.
    pub budget_mb: Option<f64>,
    /// Rounds of measuring run.
    pub rounds: u32,
    /// One row per cache of either scene.
    pub rows: Vec<TuneRow>,
    /// Bytes of samples touched, original scene.
    pub bytes_before: u64,
    /// Bytes of samples touched, tuned scene.
    pub bytes_after: u64,
    /// True when every cache of the tuned scene that answers meets `E`
    /// (99th percentile within `E`, largest within `4E`) and the budget holds.
    pub met: bool,
    /// What could not be met, and why.
    pub unmet: Vec<String>,
}

/// A tuned scene and its report.
pub struct Tuned {
    /// The tuned scene.
    pub desc: SceneDesc,
    /// What was found and done.
    pub report: TuneReport,
    /// Labels of the tuned scene's caches, in depth-first order.
    pub labels: Vec<String>,
    /// Labels of the original scene's caches, in depth-first order.
    pub original_labels: Vec<String>,
}

/// Tunes the caches of `desc` (see the module documentation).
pub fn tune(desc: &SceneDesc, settings: &TuneSettings, progress: &dyn Progress) -> Result<Tuned> {
    settings.check()?;
    let mut desc = desc.clone();
    let mut labels: Vec<String> = vec![];
    let mut original_labels: Vec<String> = vec![];
    let mut events: Vec<Event> = vec![];
    let mut first: Option<Round> = None;
    let mut rounds = 0;
    let last = loop {
        progress.update("tuning caches (rounds)", u64::from(rounds), u64::from(settings.max_rounds));
        let round = measure(&desc, settings)?;
        rounds += 1;
        if first.is_none() {
            original_labels = first_labels(&round);
            labels.clone_from(&original_labels);
            first = Some(round.clone());
        }
        let (plan, round_events) = plan_round(&round, &desc, &labels, settings);
        let done = plan.is_empty();
        if done || rounds >= settings.max_rounds {
            events.extend(round_events.into_iter().map(|e| {
                if done || e.what.starts_with("kept") {
                    e
                } else {
                    Event {
                        what: "kept (out of rounds)".into(),
                        why: format!("{}; it would be {}", e.why, e.what),
                        ..e
                    }
                }
            }));
            break round;
        }
        events.extend(round_events);
        let (model, new_labels) = rewrite(&desc.model, &plan, &labels);
        (desc.model, labels) = (model, new_labels);
    };
    let Some(first) = first else { return Err(PipelineError::Unsuitable("no round was measured".into())) };
    let report = report((&first, &original_labels), (&last, &labels), &events, settings, rounds);
    Ok(Tuned { desc, report, labels, original_labels })
}

/// What a round did to one cache, in words.
struct Event {
    /// The cache's label.
    label: String,
    /// What: `removed`, `raised 96->160`, `kept`, ….
    what: String,
    /// Why.
    why: String,
}

/// Labels for the caches of the original scene: their nearest name, numbered
/// where names repeat.
fn first_labels(round: &Round) -> Vec<String> {
    let mut out: Vec<String> = vec![];
    for c in &round.caches {
        let base = c.decision.name.clone();
        let n = out.iter().filter(|l| **l == base || l.starts_with(&format!("{base}#"))).count();
        out.push(if n == 0 { base } else { format!("{base}#{n}") });
    }
    out
}

/// What to change after `round`, and a line per cache saying what and why.
fn plan_round(round: &Round, desc: &SceneDesc, labels: &[String], s: &TuneSettings) -> (Plan, Vec<Event>) {
    let mut plan = Plan::new();
    let mut events = vec![];
    let mut raises = vec![];
    for (c, label) in round.caches.iter().zip(labels) {
        let (change, what, why) = decide(c, s);
        if let Some(Change::SetRes(r)) = change
            && r > c.res
        {
            raises.push(Raise { at: c.at, from: c.res, to: r, bytes: c.bytes, event: events.len() });
        }
        if let Some(change) = change {
            plan.insert(c.at, change);
        }
        events.push(Event { label: label.clone(), what, why });
    }
    hold_to_budget(&mut plan, &mut events, raises, round.bytes(), s);
    for at in expensive_uncached(&desc.model, round) {
        plan.insert(at, Change::Insert(INSERT_RES));
    }
    (plan, events)
}

/// The change one cache needs, what it is in words, and why.
fn decide(c: &CacheMeasure, s: &TuneSettings) -> (Option<Change>, String, String) {
    let (e, d) = (s.tolerance, &c.decision);
    if !d.uses_lattice {
        if d.reason == "pinned" {
            return (None, "kept".into(), "pinned use: Never: it never answers in auto mode".into());
        }
        let why = format!("does not pay: exact {:.0} ≤ lattice {:.0} point terms", d.exact_cost, d.lattice_cost);
        return (Some(Change::Remove), "removed".into(), why);
    }
    let err = &c.error;
    let need = (err.p99 / (AIM * e)).max(err.max / (4.0 * AIM * e));
    if err.p99 > e || err.max > 4.0 * e {
        let over = format!("p99 {:.2e} / max {:.2e} over E {:.0e} / 4E", err.p99, err.max, e);
        if let Some(split) = c.split.as_ref().filter(|p| p.failing_share >= 0.5 && p.vertex_share <= 1.0 / 3.0) {
            let why = format!(
                "{over}; {:.0}% of the failing vertices lie on child {}, which holds {:.0}% of them",
                100.0 * split.failing_share,
                split.top_child,
                100.0 * split.vertex_share
            );
            let what = format!("split into {}", split.child_res.len());
            return (Some(Change::Split(split.child_res.clone())), what, why);
        }
        if c.res >= MAX_CACHE_RES {
            return (None, "kept".into(), format!("{over}, at the largest resolution"));
        }
        let res = ((c.res as f32 * need.sqrt()).ceil() as u32).clamp(c.res + 1, MAX_CACHE_RES);
        return (Some(Change::SetRes(res)), format!("raised {}->{res}", c.res), over);
    }
    if err.p99 < LOWER_BELOW * e && err.max < e {
        let res = ((c.res as f32 * need.sqrt()).floor() as u32).max(2);
        if res < c.res {
            let why = format!("p99 {:.2e} is under E/4: a coarser lattice meets E", err.p99);
            return (Some(Change::SetRes(res)), format!("lowered {}->{res}", c.res), why);
        }
    }
    let why = if d.reason == "pinned" { "pinned use: Always".to_string() } else { "it pays".to_string() };
    (None, "kept".into(), format!("meets E: p99 {:.2e}, max {:.2e}; {why}", err.p99, err.max))
}

/// A planned raise of one cache's resolution.
struct Raise {
    /// The cache's depth-first place.
    at: usize,
    /// Resolution now.
    from: u32,
    /// Resolution planned.
    to: u32,
    /// Bytes of samples it touched at `from`.
    bytes: u64,
    /// Its line among the round's events.
    event: usize,
}

impl Raise {
    /// Bytes it would add at `to`: samples near the surface grow as the
    /// square of the resolution.
    fn growth(&self) -> u64 {
        let grown = self.bytes as f64 * (f64::from(self.to) / f64::from(self.from)).powi(2);
        (grown as u64).saturating_sub(self.bytes)
    }
}

/// Withdraws raises, the largest growth first, until the predicted bytes fit
/// the budget.
fn hold_to_budget(plan: &mut Plan, events: &mut [Event], mut raises: Vec<Raise>, bytes: u64, s: &TuneSettings) {
    let Some(budget) = s.budget_bytes() else { return };
    let mut predicted = bytes + raises.iter().map(Raise::growth).sum::<u64>();
    raises.sort_by_key(|r| std::cmp::Reverse(r.growth()));
    for r in raises {
        if predicted <= budget {
            break;
        }
        plan.remove(&r.at);
        predicted -= r.growth();
        let e = &mut events[r.event];
        let mb = budget as f64 / crate::pipeline::MB;
        e.why = format!("{}; not raised to {}: the budget of {mb:.1} MB would not hold it", e.why, r.to);
        e.what = "kept (budget)".into();
    }
}

/// Places of the outermost subtrees holding no cache and under none whose
/// exact answer costs more than a lattice answer.
fn expensive_uncached(root: &NodeDesc, round: &Round) -> Vec<usize> {
    let nodes = preorder(root);
    let mut out = vec![];
    let mut at = 0;
    while at < nodes.len() {
        let node = nodes[at];
        if matches!(node, NodeDesc::Cache { .. }) {
            at += node.node_count();
            continue;
        }
        let worth =
            !node.holds_cache() && (!node.children().is_empty() || matches!(node, NodeDesc::SplinePoints { .. }));
        if worth {
            let (value, steps) = round.scene.model.exact_answer_cost(round.ids[at]);
            if value * steps > LATTICE_COST {
                out.push(at);
                at += node.node_count();
                continue;
            }
        }
        at += 1;
    }
    out
}

/// The report: a row per label of either scene, from the first round (with
/// its labels) and the last.
fn report(
    (first, first_labels): (&Round, &[String]),
    (last, labels): (&Round, &[String]),
    events: &[Event],
    s: &TuneSettings,
    rounds: u32,
) -> TuneReport {
    let mut names: Vec<String> = first_labels.to_vec();
    names.extend(labels.iter().filter(|l| !first_labels.contains(l)).cloned());
    let rows: Vec<TuneRow> = names
        .iter()
        .map(|name| {
            let before = first_labels.iter().position(|l| l == name).map(|i| &first.caches[i]);
            let after = labels.iter().position(|l| l == name).map(|i| &last.caches[i]);
            let own: Vec<&Event> = events.iter().filter(|e| &e.label == name).collect();
            let changes: Vec<&str> = own.iter().map(|e| e.what.as_str()).filter(|w| !w.starts_with("kept")).collect();
            let decision = if changes.is_empty() {
                own.last().map_or("new".to_string(), |e| e.what.clone())
            } else {
                changes.join(", ")
            };
            let latest = after.or(before).map(|c| &c.decision);
            TuneRow {
                cache: name.clone(),
                res_before: before.map(|c| c.res),
                res_after: after.map(|c| c.res),
                before: before.map(|c| c.error),
                after: after.map(|c| c.error),
                bytes_before: before.map_or(0, |c| c.bytes),
                bytes_after: after.map_or(0, |c| c.bytes),
                cost_ratio: latest.map_or(0.0, |d| d.exact_cost / d.lattice_cost),
                decision,
                reason: own.last().map_or(String::new(), |e| e.why.clone()),
            }
        })
        .collect();
    let mut unmet: Vec<String> = last
        .caches
        .iter()
        .zip(labels)
        .filter(|(c, _)| c.decision.uses_lattice && (c.error.p99 > s.tolerance || c.error.max > 4.0 * s.tolerance))
        .map(|(c, l)| format!("{l}: p99 {:.2e}, max {:.2e} against E {:.1e}", c.error.p99, c.error.max, s.tolerance))
        .collect();
    if let Some(budget) = s.budget_bytes()
        && last.bytes() > budget
    {
        unmet.push(format!(
            "samples touched {:.1} MB, over the budget of {:.1} MB",
            last.bytes() as f64 / crate::pipeline::MB,
            budget as f64 / crate::pipeline::MB
        ));
    }
    TuneReport {
        tolerance: s.tolerance,
        budget_mb: s.budget_mb,
        rounds,
        rows,
        bytes_before: first.bytes(),
        bytes_after: last.bytes(),
        met: unmet.is_empty(),
        unmet,
    }
}
