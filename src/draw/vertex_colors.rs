//! Vertex colours: a value per mesh vertex (such as error_C) through a heat
//! map's scale, as the linear RGB a mesh file stores.

use glam::Vec3;

use super::heatmap::Scale;
use crate::frame::srgb8_to_linear;

/// Linear RGB colours of `errors` on magma over `0..=scale`.
#[must_use]
pub fn error_colors(errors: &[f32], scale: f32) -> Vec<Vec3> {
    let s = Scale::Magnitude { max: scale };
    errors
        .iter()
        .map(|&e| {
            let [r, g, b] = s.color(e);
            Vec3::new(srgb8_to_linear(r), srgb8_to_linear(g), srgb8_to_linear(b))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn larger_errors_are_brighter() {
        let c = error_colors(&[0.0, 1.0], 0.5);
        assert!(c[1].length() > c[0].length());
    }
}
