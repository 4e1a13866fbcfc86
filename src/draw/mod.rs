//! The drawing stage: 8-bit RGB images with text, heat maps with their colour
//! keys and printed scales, line plots, log–log scaling plots, histograms, panels of titled images,
//! and vertex colours on a heat map's scale. It draws what other stages
//! measure and measures nothing itself.

mod heatmap;
mod histogram;
mod panel;
mod plot;
mod rgb8_image;
mod scaling_plot;
mod vertex_colors;

pub use heatmap::{
    ColourKey, MISMATCH, NO_VALUE, OVER_RANGE, SILHOUETTE_COLORS, Scale, SpecialLabels, heat_map, heat_map_labelled,
    heat_map_zoomed, silhouette_map,
};
pub use histogram::histogram_plot;
pub use panel::{frame_image, panel};
pub use plot::line_plot;
pub use rgb8_image::{CHAR_WIDTH, LINE_HEIGHT, Rgb8Image};
pub use scaling_plot::{Panel, scaling_plot};
pub use vertex_colors::error_colors;
