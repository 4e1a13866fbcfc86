//! The comparison stage: per-pixel differences between two renders, judged
//! with idiff's thresholds, drawn as heat maps with printed scales.

mod cache_error;
mod channel_diff;
mod channels;
mod diff;
mod difference_image;
mod flip;
mod flip_linear;
mod hdr_flip;
mod heatmap;
mod histogram;
mod idiff_stats;
mod load;
mod panel;
mod plot;
mod rgb8_image;

pub use cache_error::{CacheErrorStats, cache_error_at, cache_error_stats, error_colors};
pub use channel_diff::compare_channels;
pub use channels::{ChannelImage, Decoding, load_channels};
pub use diff::{
    DiffReport, MaxAt, Metric, Thresholds, Totals, Verdict, difference_at, differences, edge_mask, judge, report,
};
pub use difference_image::{DifferenceForm, difference_planes, planes_png_bytes};
pub use flip::{FLIP_BUCKETS, FlipStats, default_pixels_per_degree, flip_errors, flip_stats, flip_whole};
pub use flip_linear::flip_linear;
pub use hdr_flip::{Exposures, hdr_flip};
pub use heatmap::{
    ColourKey, MISMATCH, NO_VALUE, OVER_RANGE, SILHOUETTE_COLORS, Scale, SpecialLabels, heat_map, heat_map_labelled,
    silhouette_map,
};
pub use histogram::histogram_plot;
pub use idiff_stats::{IdiffAccumulator, IdiffStats};
pub use load::{LoadedImage, load_image};
pub use panel::{frame_image, panel};
pub use plot::line_plot;
pub use rgb8_image::{CHAR_WIDTH, LINE_HEIGHT, Rgb8Image};
