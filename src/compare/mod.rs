//! The comparison stage: per-pixel differences between two renders (idiff's
//! channels, ꟻLIP, HDR-ꟻLIP), judged with idiff's thresholds, their
//! statistics, and error_C at points. Drawing the results (heat maps, plots,
//! panels) is [`crate::draw`]'s.

mod cache_error;
mod channel_diff;
mod channels;
mod diff;
mod difference_image;
mod flip;
mod flip_linear;
mod hdr_flip;
mod idiff_stats;
mod load;
mod thresholds;

pub use cache_error::{CacheErrorStats, cache_error_at, cache_error_stats};
pub use channel_diff::compare_channels;
pub use channels::{ChannelImage, Decoding, load_channels};
pub use diff::{DiffReport, MaxAt, Metric, Totals, Verdict, difference_at, differences, edge_mask, judge, report};
pub use difference_image::{DifferenceForm, difference_planes, planes_png_bytes};
pub use flip::{FLIP_BUCKETS, FlipStats, default_pixels_per_degree, flip_errors, flip_stats, flip_whole};
pub use flip_linear::flip_linear;
pub use hdr_flip::{Exposures, hdr_flip};
pub use idiff_stats::{IdiffAccumulator, IdiffStats};
pub use load::{LoadedImage, load_image};
pub use thresholds::Thresholds;
