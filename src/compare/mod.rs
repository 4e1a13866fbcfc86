//! The comparison stage: per-pixel differences between two renders, judged
//! with idiff's thresholds, drawn as heat maps with printed scales.

mod cache_error;
mod diff;
mod heatmap;
mod load;
mod panel;
mod plot;
mod rgb8_image;

pub use cache_error::{CacheErrorStats, cache_error_at, cache_error_stats, error_colors};
pub use diff::{DiffReport, Metric, Thresholds, Verdict, difference_at, differences, edge_mask, judge};
pub use heatmap::{
    MISMATCH, NO_VALUE, OVER_RANGE, SILHOUETTE_COLORS, Scale, SpecialLabels, heat_map, heat_map_labelled,
    silhouette_map,
};
pub use load::{LoadedImage, load_image};
pub use panel::{frame_image, panel};
pub use plot::line_plot;
pub use rgb8_image::{CHAR_WIDTH, LINE_HEIGHT, Rgb8Image};
