//! Checking a session against work from scratch: a render and a
//! polygonization of its model as it stands, on cold caches.

use std::time::Instant;

use super::EditSession;
use crate::frame::Frame;
use crate::mesh::canonical_triangles;
use crate::pipeline::polygonize::polygonizer_on;
use crate::trace::render_model;

/// A check of the session against a render and a polygonization from scratch.
#[derive(Clone, Debug)]
pub struct Verification {
    /// Seconds the full render took.
    pub render_s: f64,
    /// Seconds the full render and polygonization took together.
    pub full_s: f64,
    /// How the session's field image or mesh differ from them, if they do.
    pub mismatch: Option<String>,
}

impl EditSession {
    /// Renders and polygonizes from scratch, on a copy of the model with cold
    /// caches on the same lattices (so a sample an edit should have cleared and
    /// did not shows), and compares the session's images and mesh with them
    /// (as [`Self::finish`] leaves them).
    #[must_use]
    pub fn verify(&self) -> Verification {
        let fresh_model = self.scene.model.clone();
        let clock = Instant::now();
        let full = render_model(&fresh_model, self.mode, &self.settings, &|_| {}).0;
        let render_s = clock.elapsed().as_secs_f64();
        let mesh =
            polygonizer_on(&fresh_model, self.mode, self.polygonizer.lattice(), self.polygonize.options()).mesh();
        let full_s = clock.elapsed().as_secs_f64();
        let mut mismatch = image_mismatch(&full, &self.field_frame);
        if mesh.triangle_set() != canonical_triangles(self.dynamic.triangles()) {
            mismatch = Some(mismatch.map_or(String::new(), |m| m + "; ") + "the meshes differ");
        }
        Verification { render_s, full_s, mismatch }
    }
}

/// How the incremental image `kept` differs from the full render `full`, if it does.
fn image_mismatch(full: &Frame, kept: &Frame) -> Option<String> {
    if full.same_image(kept) {
        return None;
    }
    let differs = |i: usize| {
        full.color[i] != kept.color[i]
            || full.depth[i].to_bits() != kept.depth[i].to_bits()
            || full.normal[i] != kept.normal[i]
    };
    let pixels: Vec<usize> = (0..full.len()).filter(|&i| differs(i)).collect();
    let first = pixels.first().copied().unwrap_or(0);
    let (x, y) = (first as u32 % full.width, first as u32 / full.width);
    Some(format!(
        "{} pixels, the first at ({x}, {y}) with depth {} incrementally against {}",
        pixels.len(),
        kept.depth[first],
        full.depth[first]
    ))
}
