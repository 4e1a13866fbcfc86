//! Hierarchical spatial caching (the caching paper, sections 4 and 5): a
//! `Cache` node stores exact samples of its subtree on a lattice in the
//! subtree's own frame and answers values and gradients by reconstruction, so
//! a lookup costs O(1) whatever the subtree's size.
//!
//! - [`filter`]: tri-linear and tri-quadratic reconstruction, and why their
//!   bounds are safe for tracing;
//! - [`grid`]: the lattice of one cache, its block table, lazy fill,
//!   invalidation and the resize rule;
//! - [`pool`]: the slots behind every block, shared by a model's caches under
//!   one budget, with lock-free reads and least-recently-used eviction.

pub mod filter;
pub mod grid;
mod memo;
pub mod pool;

pub use filter::Filter;
pub use grid::{CacheGrid, CacheStats, Refit};
pub use pool::{SLOT_BYTES, SamplePool};

/// How a cache stores its samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
pub enum Storage {
    /// Four-byte floats: the samples exactly as evaluated.
    #[default]
    F32,
    /// Two-byte floats (the paper's section 5 encoding): half the memory,
    /// about three decimal digits. A block then spans 8×8×16 lattice points,
    /// so every block occupies the same slot size.
    F16,
}

/// The largest relative rounding error of a two-byte float (2⁻¹¹).
const F16_RELATIVE_ERROR: f32 = 1.0 / 2048.0;
/// The spacing of two-byte floats near zero (subnormals), a floor on their absolute error.
const F16_ABSOLUTE_ERROR: f32 = 6.0e-8;

impl Storage {
    /// How many more bits of z a block spans than of x and y.
    #[must_use]
    pub fn z_extra_shift(self) -> i32 {
        match self {
            Storage::F32 => 0,
            Storage::F16 => 1,
        }
    }

    /// `v` as it reads back after storing: what a lookup returns, cold or warm.
    #[must_use]
    pub fn round_trip(self, v: f32) -> f32 {
        let v = if v.is_nan() { 0.0 } else { v };
        match self {
            Storage::F32 => v,
            Storage::F16 => half::f16::from_f32(v).to_f32(),
        }
    }

    /// The most a stored sample may differ from the value evaluated, for values up to `max_abs`.
    #[must_use]
    pub fn rounding_error(self, max_abs: f32) -> f32 {
        match self {
            Storage::F32 => 0.0,
            Storage::F16 => max_abs * F16_RELATIVE_ERROR + F16_ABSOLUTE_ERROR,
        }
    }

    /// The stored bits of a round-tripped value.
    fn encode(self, v: f32) -> u32 {
        match self {
            Storage::F32 => v.to_bits(),
            Storage::F16 => u32::from(half::f16::from_f32(v).to_bits()),
        }
    }

    /// The sample in half `half` of `word`, or `None` while unset. The unset word
    /// [`pool::UNSET`] is a NaN both as one four-byte and as two two-byte floats,
    /// and no stored sample is a NaN.
    #[inline]
    fn decode(self, word: u32, half: u32) -> Option<f32> {
        match self {
            Storage::F32 => (word != pool::UNSET).then(|| f32::from_bits(word)),
            Storage::F16 => {
                let h = half::f16::from_bits((word >> (16 * half)) as u16);
                (!h.is_nan()).then(|| h.to_f32())
            }
        }
    }

    /// `old` with `bits` stored in half `half`, or `None` if that half is already set.
    fn store(self, old: u32, half: u32, bits: u32) -> Option<u32> {
        self.decode(old, half).is_none().then(|| match self {
            Storage::F32 => bits,
            Storage::F16 => (old & !(0xffff << (16 * half))) | (bits << (16 * half)),
        })
    }

    /// `word` with half `half` unset again.
    fn clear(self, word: u32, half: u32) -> u32 {
        match self {
            Storage::F32 => pool::UNSET,
            Storage::F16 => (word & !(0xffff << (16 * half))) | (pool::UNSET & (0xffff << (16 * half))),
        }
    }
}

/// A cache's options, as written in a scene: `Cache(res: 128, value: Trilinear,
/// gradient: Triquadratic, storage: F32, child: …)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct CacheSpec {
    /// Cells along the longest side of the subtree's bounds: `c = s / res`.
    pub res: u32,
    /// The filter for values (what the tracer and polygonizer see).
    pub value: Filter,
    /// The filter for gradients (shading normals).
    pub gradient: Filter,
    /// How samples are stored.
    pub storage: Storage,
    /// Whether auto mode answers from the lattice: decided by the cost
    /// model, or pinned by the scene.
    pub usage: CacheUse,
}

/// A scene's say in whether a cache answers from its lattice in auto mode.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
pub enum CacheUse {
    /// As the cost model decides (`field::cache_cost`).
    #[default]
    Auto,
    /// Always from the lattice.
    Always,
    /// Never: the cache passes through to its subtree (except in `--mode cached`).
    Never,
}

impl CacheSpec {
    /// The paper's choice at resolution `res`: tri-linear values, tri-quadratic gradients, four-byte samples.
    #[must_use]
    pub fn new(res: u32) -> Self {
        Self {
            res,
            value: Filter::Trilinear,
            gradient: Filter::Triquadratic,
            storage: Storage::F32,
            usage: CacheUse::Auto,
        }
    }
}
