//! Placing a mesh vertex on a crossed lattice edge.
//!
//! The paper's polygonizer bisects ten times (ten evaluations, a position
//! good to 2⁻¹⁰ of the edge). The Illinois variant of regula falsi starts from
//! the corner values it already has, converges superlinearly on the smooth
//! fields of skeletal primitives, and keeps the bracket, so it reaches a far
//! tighter tolerance in two or three evaluations. `Linear` stops before the
//! first evaluation: the classic marching-cubes interpolation, for previews
//! (which also take their normals from the mesh rather than the gradient).

use glam::Vec3A;

use crate::field::Field;

/// How a vertex is placed on its edge.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum VertexPlacement {
    /// Root finding until the position is known to within `tolerance` × the edge length.
    Root {
        /// Relative position tolerance along the edge.
        tolerance: f32,
    },
    /// Linear interpolation of the corner values: no evaluation.
    Linear,
}

impl Default for VertexPlacement {
    fn default() -> Self {
        VertexPlacement::Root { tolerance: 1e-4 }
    }
}

/// Most evaluations one root may take; the bracket then holds it to 2⁻ᴺ anyway.
const MAX_ROOT_EVALS: u32 = 24;

/// The point on `a → b` where the field crosses the threshold, given the
/// corner values, and the evaluations spent.
///
/// The result depends only on the edge and its values, never on the caller, so
/// cells sharing the edge agree bit for bit.
pub fn place_on_edge<F: Field + ?Sized>(
    field: &F,
    (a, fa): (Vec3A, f32),
    (b, fb): (Vec3A, f32),
    placement: VertexPlacement,
) -> (Vec3A, u32) {
    let t0 = field.threshold();
    let (mut lo, mut glo, mut hi, mut ghi) = (0.0f32, fa - t0, 1.0f32, fb - t0);
    let secant = |lo: f32, glo: f32, hi: f32, ghi: f32| {
        let s = lo - glo * (hi - lo) / (ghi - glo);
        if s.is_finite() { s.clamp(lo, hi) } else { 0.5 * (lo + hi) }
    };
    let mut t = secant(lo, glo, hi, ghi);
    let VertexPlacement::Root { tolerance } = placement else {
        return (a.lerp(b, t), 0);
    };
    let mut evals = 0;
    // Which end was kept last: Illinois halves its value when it is kept twice.
    let mut kept = 0i8;
    while evals < MAX_ROOT_EVALS && hi - lo > tolerance {
        let g = field.value(a.lerp(b, t)) - t0;
        evals += 1;
        if g == 0.0 {
            break;
        }
        // Estimated distance to the root from the local slope, in edge units.
        let slope = (ghi - glo) / (hi - lo);
        let converged = (g / slope).abs() < 0.5 * tolerance;
        if (g > 0.0) == (glo > 0.0) {
            (lo, glo) = (t, g);
            if kept == 1 {
                ghi *= 0.5;
            }
            kept = 1;
        } else {
            (hi, ghi) = (t, g);
            if kept == -1 {
                glo *= 0.5;
            }
            kept = -1;
        }
        let next = secant(lo, glo, hi, ghi);
        if converged {
            t = next;
            break;
        }
        t = next;
    }
    (a.lerp(b, t), evals)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::{EvalMode, ModelField};
    use crate::scene::Scene;

    #[test]
    fn finds_the_sphere_radius_in_few_evaluations() {
        let scene = Scene::parse("Scene(camera: Camera(eye: (0.0, 0.0, 4.0), target: (0.0, 0.0, 0.0), fov_y: 40.0), size: (8, 8), model: Point(center: (0.0, 0.0, 0.0), radius: 1.0))", "inline").unwrap();
        let field = ModelField::new(&scene.model, EvalMode::Indexed);
        let iso = (1.0 - 0.5f32.cbrt()).sqrt();
        let (a, b) = (Vec3A::new(0.3, 0.1, 0.0), Vec3A::new(0.6, 0.1, 0.0));
        let (p, evals) = place_on_edge(&field, (a, field.value(a)), (b, field.value(b)), VertexPlacement::default());
        assert!((p.length() - iso).abs() < 1e-5, "{} vs {iso}", p.length());
        assert!(evals <= 4, "{evals}");
        let (q, none) = place_on_edge(&field, (a, field.value(a)), (b, field.value(b)), VertexPlacement::Linear);
        assert_eq!(none, 0);
        assert!((q.length() - iso).abs() < 0.02);
    }
}
