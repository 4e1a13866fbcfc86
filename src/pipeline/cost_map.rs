//! Where a field render spent its time: heat maps of the field evaluations
//! and the tracing steps each pixel's ray took (for the kernel tracer, the
//! supports it crossed), side by side in one picture, each on magma with
//! its scale, from the render's work AOVs.

use super::error::{PipelineError, Result};
use crate::draw::{Rgb8Image, Scale, SpecialLabels, heat_map_labelled, panel};
use crate::frame::Frame;

/// The work counters drawn, by AOV name, with their titles and units: the
/// evaluations, then the segment tracer's steps or the kernel tracer's supports.
const COUNTERS: [[(&str, &str, &str); 2]; 2] = [
    [("evals.Y", "field evaluations per pixel", "evaluations"); 2],
    [("steps.Y", "tracing steps per pixel", "steps"), ("supports.Y", "supports crossed per pixel", "supports")],
];

/// The cost picture of a field render: evaluations and steps per pixel, each
/// scaled to its 99th percentile rounded up (pixels beyond it marked).
pub fn cost_map(frame: &Frame) -> Result<Rgb8Image> {
    let labels = SpecialLabels { no_value: "no value", infinite: "unbounded" };
    let mut items = vec![];
    for choices in COUNTERS {
        let found = choices.iter().find_map(|&(aov, title, unit)| Some((frame.aov(aov)?, title, unit)));
        let (values, title, unit) = found.ok_or_else(|| {
            PipelineError::Unsuitable(format!("the cost picture needs a field render's `{}` counts", choices[0].0))
        })?;
        let scale = Scale::from_data(values, false, 1.0);
        let (mean, max) = mean_and_max(values);
        let heading = format!("{title}: mean {mean:.1}, max {max:.0}");
        let image = heat_map_labelled(values, (frame.width, frame.height), scale, (title, unit), &labels);
        items.push((heading, image));
    }
    Ok(panel(&items, 2))
}

fn mean_and_max(values: &[f32]) -> (f64, f32) {
    let sum: f64 = values.iter().map(|&v| f64::from(v)).sum();
    (sum / values.len().max(1) as f64, values.iter().copied().fold(0.0, f32::max))
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    #[test]
    fn the_cost_picture_draws_both_counters_and_needs_them() {
        let mut frame = Frame::new(40, 30, Vec3::ZERO);
        assert!(matches!(cost_map(&frame), Err(PipelineError::Unsuitable(_))), "a frame without counts");
        let ramp: Vec<f32> = (0..1200).map(|i| (i % 40) as f32).collect();
        frame.extra.push(("evals.Y".into(), ramp.clone()));
        frame.extra.push(("steps.Y".into(), ramp.iter().map(|v| v / 4.0).collect()));
        let image = cost_map(&frame).expect("both counts are there");
        let single = heat_map_labelled(
            &ramp,
            (40, 30),
            Scale::from_data(&ramp, false, 1.0),
            ("t", "u"),
            &SpecialLabels::default(),
        );
        assert!(
            image.width >= 2 * single.width,
            "two heat maps side by side: {} against {}",
            image.width,
            single.width
        );
        assert!(image.height > single.height, "under their headings");
    }
}
