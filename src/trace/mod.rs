//! The field ray caster: segment tracing with local Lipschitz bounds, root
//! refinement, shading from the analytic gradient, rows rendered in parallel.

mod render;
mod segment;
mod shade;

pub use render::{RenderSettings, RenderStats, outward_normal, render};
pub use segment::{TraceOptions, TraceResult, trace_ray};
pub use shade::Lighting;
