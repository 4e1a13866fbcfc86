//! The field ray caster: segment tracing with local Lipschitz bounds, root
//! refinement, shading from the analytic gradient, rows rendered in parallel.

mod changed;
mod dirty;
mod render;
mod segment;
mod shade;

pub use changed::ChangedSpace;
pub use dirty::{PixelRect, merge_rects, screen_rect};
pub use render::{
    KeptPixel, PixelSample, RenderSettings, RenderStats, Rerendered, Retrace, assemble, changed_space, outward_normal,
    render, render_model, render_pixels, rerender, rerender_pixels,
};
pub use segment::{Crossing, TraceOptions, TraceResult, march, trace_ray};
pub use shade::Lighting;
