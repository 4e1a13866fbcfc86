//! The field ray caster: segment tracing with local Lipschitz bounds, root
//! refinement, shading from the analytic gradient, rows rendered in parallel,
//! or stale pixels refined progressively (`progressive`).

mod changed_space;
mod coverage;
mod dirty_rects;
pub mod kernel;
pub mod progressive;
mod render;
pub mod samples;
mod segment;
mod shade;

pub use changed_space::ChangedSpace;
pub use coverage::Coverage;
pub use dirty_rects::{PixelRect, merge_rects, screen_rect};
pub use progressive::{PASS_STEPS, PixelState, Refinement};
pub use render::{
    CENTRE, KeptPixel, RenderSettings, RenderStats, Rerendered, Retrace, blank_field_frame, blank_frame, changed_space,
    kernel_tracer, outward_normal, refine, render, render_covered, render_model, render_model_into, render_pixels,
    rerender, rerender_pixels, retrace_listed, retrace_whole, trace_sample_rows,
};
pub use samples::{PixelSample, PixelTotals};
pub use segment::{Crossing, TraceOptions, TraceResult, march, trace_ray, trace_ray_from};
pub use shade::Lighting;
