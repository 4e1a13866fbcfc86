//! The measuring code behind `blobtrace bench`: performance figures measured
//! in one process and reported as ratios against the baseline on the same
//! scene, so a noisy machine affects both sides alike — field rendering
//! (indexed against naive, cached against exact), polygonization (the
//! caching paper's Table 1, triangle and ray rates), edits (its Figure 8
//! and Table 2), the previewer's latency per kind of event, and how load
//! time, memory and rendering grow with the number of primitives.

mod edit;
mod mesh;
mod point_sets;
mod render;
mod scale;
mod view;

pub use edit::{EditBenchReport, EditBenchSettings, ModeTotals, bench_edit};
pub use mesh::{MeshBenchReport, MeshBenchSettings, PlacementCost, RayRate, TableRow, TriangleRate, bench_mesh};
pub use point_sets::{PointModel, ply_bytes, scene_text};
pub use render::{
    CacheBenchReport, CacheBenchRuns, EvalBenchReport, EvalBenchRuns, LookupCost, RenderBenchSettings, bench_cache,
    bench_eval, lookup_costs,
};
pub use scale::{RowRunner, ScaleBenchReport, ScaleBenchSettings, ScaleRow, bench_scale, measure_point_set};
pub use view::{EventLatency, Seconds, ViewBenchReport, ViewBenchSettings, bench_view};
