//! The comparison stage: per-pixel differences between two renders, judged
//! with idiff's thresholds, drawn as heat maps with printed scales.

mod diff;
mod heatmap;
mod load;
mod text;

pub use diff::{DiffReport, Metric, Thresholds, Verdict, differences, edge_mask, judge};
pub use heatmap::{MISMATCH, NO_VALUE, Scale, heat_map};
pub use load::{LoadedImage, load_image};
pub use text::{CHAR_WIDTH, LINE_HEIGHT, Rgb8Image};
