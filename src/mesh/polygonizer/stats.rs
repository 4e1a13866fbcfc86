//! The work a polygonizer has done, by kind of evaluation.

/// Work done so far, by kind of evaluation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct PolygonizeStats {
    /// Field values at lattice corners (and body centres).
    pub corner_evals: u64,
    /// Field values spent placing vertices on edges.
    pub root_evals: u64,
    /// Gradients for vertex normals, and for the uphill walks of seeds
    /// starting outside the surface.
    pub gradient_evals: u64,
    /// Colour queries for vertex colours (none when the model has one colour).
    pub color_evals: u64,
    /// Cells examined.
    pub cells_visited: u64,
}

impl PolygonizeStats {
    /// The work of two runs together.
    #[must_use]
    pub fn plus(&self, o: &PolygonizeStats) -> PolygonizeStats {
        PolygonizeStats {
            corner_evals: self.corner_evals + o.corner_evals,
            root_evals: self.root_evals + o.root_evals,
            gradient_evals: self.gradient_evals + o.gradient_evals,
            color_evals: self.color_evals + o.color_evals,
            cells_visited: self.cells_visited + o.cells_visited,
        }
    }

    /// Every evaluation of the field: values, gradients and colours.
    #[must_use]
    pub fn field_evals(&self) -> u64 {
        self.corner_evals + self.root_evals + self.gradient_evals + self.color_evals
    }
}
