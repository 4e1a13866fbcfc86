//! The reconstruction a cache answers with: the value and gradient filters
//! applied to the samples of one gather.

use glam::{IVec3, Vec3A};

use super::{CacheGrid, Sampled};
use crate::cache::pool::SamplePool;

impl CacheGrid {
    /// The reconstructed value at `p` (cache frame), with the value filter.
    pub fn value(&self, p: Vec3A, pool: &SamplePool, eval: &impl Sampled) -> f32 {
        self.lookups.add_one_unsynchronized();
        let weights = self.spec.value.at(p * self.inv_cell);
        weights.value(&self.gather(weights.footprint(), pool, eval))
    }

    /// The reconstructed gradient at `p` (cache frame), with the gradient filter.
    pub fn gradient(&self, p: Vec3A, pool: &SamplePool, eval: &impl Sampled) -> Vec3A {
        self.lookups.add_one_unsynchronized();
        let weights = self.spec.gradient.at(p * self.inv_cell);
        weights.gradient(&self.gather(weights.footprint(), pool, eval)) * self.inv_cell
    }

    /// [`Self::value`] and [`Self::gradient`] at `p` together, to the same
    /// bits, from one gather: one filter's samples always hold the other's
    /// (the tri-linear cube lies in the tri-quadratic one around the same
    /// point). A shaded hit or a coloured vertex weighs a cache's colour by
    /// its value and takes its gradient there.
    pub fn value_and_gradient(&self, p: Vec3A, pool: &SamplePool, eval: &impl Sampled) -> (f32, Vec3A) {
        let u = p * self.inv_cell;
        let (value, gradient) = (self.spec.value.at(u), self.spec.gradient.at(u));
        let gradient_is_wide = gradient.footprint().1 >= value.footprint().1;
        let (wide, narrow) = if gradient_is_wide { (gradient, value) } else { (value, gradient) };
        let ((first, n), (inner, m)) = (wide.footprint(), narrow.footprint());
        let offset = inner - first;
        debug_assert!(offset.min_element() >= 0 && (offset + IVec3::splat(m as i32)).max_element() <= n as i32);
        self.lookups.add_one_unsynchronized();
        self.lookups.add_one_unsynchronized();
        let outer = self.gather((first, n), pool, eval);
        let sub = match (n, m) {
            (3, 2) => inner_cube::<3, 2>(&outer, offset),
            (3, 3) => inner_cube::<3, 3>(&outer, offset),
            _ => inner_cube::<2, 2>(&outer, offset),
        };
        let (value_samples, gradient_samples) = if gradient_is_wide { (&sub, &outer) } else { (&outer, &sub) };
        (value.value(value_samples), gradient.gradient(gradient_samples) * self.inv_cell)
    }
}

/// The `M³` samples at `offset` within the `N³` samples `outer`, both x fastest.
#[inline]
fn inner_cube<const N: usize, const M: usize>(outer: &[f32; 27], offset: IVec3) -> [f32; 27] {
    let o = offset.as_uvec3();
    let (ox, oy, oz) = (o.x as usize, o.y as usize, o.z as usize);
    let mut sub = [0.0; 27];
    for z in 0..M {
        for y in 0..M {
            for x in 0..M {
                sub[(z * M + y) * M + x] = outer[((oz + z) * N + oy + y) * N + ox + x];
            }
        }
    }
    sub
}
