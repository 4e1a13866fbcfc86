//! Each screen tile's list of the supports its rays can cross (Kanamori,
//! Szego and Nishita 2008): every support's world box is projected onto
//! the rectangle of pixels whose rays can meet it (as dirty rectangles are,
//! with a pixel of slack, so any ray through any point of a pixel is
//! covered), and listed in every tile that rectangle touches.
//!
//! The lists keep, once a support, the cone from the eye that holds its
//! bounding sphere: every ray of a pinhole camera starts at the eye, so a
//! ray whose direction falls outside the cone misses the support, known
//! from one dot product.
//!
//! A list is ordered by the distance from the eye to each support's sphere
//! (no ray meets a support nearer than that), so a ray can gather its
//! crossings front to back and stop once its hit is settled: a ray through a
//! deep cloud crosses a hundred supports, its hit comes after five.

use glam::{Vec3A, Vec4};
use rayon::prelude::*;

use super::supports::KernelSupports;
use crate::camera::Camera;
use crate::trace::{PixelRect, screen_rect};

/// Pixels along a tile's side.
pub const TILE: u32 = 8;

/// Supports listed per tile of `TILE × TILE` pixels.
#[derive(Clone, Debug, Default)]
pub struct TileLists {
    columns: u32,
    /// Where each tile's list starts in `entries`; one more than the tiles.
    starts: Vec<u32>,
    entries: Vec<Entry>,
    /// The cone from the eye holding each support (see `cone`), kept once
    /// rather than in every tile listing it: a million supports list six
    /// million times, and eight bytes an entry instead of thirty-two is most
    /// of what building the lists costs (fresh pages, faulted in one by one).
    cones: Vec<Vec4>,
}

/// A support listed in a tile.
#[derive(Clone, Copy, Debug, Default)]
pub struct Entry {
    /// No ray meets the support nearer the eye than this.
    pub near: f32,
    /// The support.
    pub support: u32,
}

/// The cone from the eye holding a support's sphere: its unit axis and the
/// cosine of its half-angle, lowered a little against rounding; a support
/// around the eye gets a cosine no direction is below.
fn cone(eye: Vec3A, (centre, radius): (Vec3A, f32)) -> Vec4 {
    let v = centre - eye;
    let distance = v.length();
    // Widened by a part in 10⁵ and a little more than the rounding of a unit
    // direction's dot product.
    let r = radius * (1.0 + 1e-5);
    if distance <= r {
        return Vec4::new(0.0, 0.0, 1.0, -2.0);
    }
    let cos = (1.0 - (r / distance) * (r / distance)).max(0.0).sqrt() - 16.0 * f32::EPSILON;
    (v / distance).extend(cos)
}

/// No ray from the eye meets a support with bounding sphere (`centre`,
/// `radius`) nearer than this: shortened a little, as the coverage's
/// distances are, against rounding.
fn near_of(eye: Vec3A, (centre, radius): (Vec3A, f32)) -> f32 {
    (((centre - eye).length() - radius) * (1.0 - 1e-4)).max(0.0)
}

impl TileLists {
    /// The lists of `supports` seen through `camera` at `width × height`.
    #[must_use]
    pub fn new(supports: &KernelSupports, camera: &Camera, width: u32, height: u32) -> Self {
        let (columns, rows) = (width.div_ceil(TILE), height.div_ceil(TILE));
        let tiles = (columns * rows) as usize;
        let eye = camera.eye;
        let (rects, cones): (Vec<Option<PixelRect>>, Vec<Vec4>) = (0..supports.len())
            .into_par_iter()
            .map(|i| (screen_rect(camera, width, height, &supports.world_box(i)), cone(eye, supports.world_sphere(i))))
            .unzip();
        let tile_span = |r: &PixelRect| (r.x0 / TILE, r.y0 / TILE, (r.x1 - 1) / TILE + 1, (r.y1 - 1) / TILE + 1);
        let mut starts = vec![0u32; tiles + 1];
        for r in rects.iter().flatten() {
            let (tx0, ty0, tx1, ty1) = tile_span(r);
            for ty in ty0..ty1 {
                for tx in tx0..tx1 {
                    starts[(ty * columns + tx) as usize + 1] += 1;
                }
            }
        }
        for i in 0..tiles {
            starts[i + 1] += starts[i];
        }
        let mut fill = starts.clone();
        let mut entries = vec![Entry::default(); starts[tiles] as usize];
        for (i, r) in rects.iter().enumerate() {
            let Some(r) = r else { continue };
            let (tx0, ty0, tx1, ty1) = tile_span(r);
            let entry = Entry { near: near_of(eye, supports.world_sphere(i)), support: i as u32 };
            for ty in ty0..ty1 {
                for tx in tx0..tx1 {
                    let slot = &mut fill[(ty * columns + tx) as usize];
                    entries[*slot as usize] = entry;
                    *slot += 1;
                }
            }
        }
        let mut lists: Vec<&mut [Entry]> = Vec::with_capacity(tiles);
        let mut rest = entries.as_mut_slice();
        for t in 0..tiles {
            let (list, after) = rest.split_at_mut((starts[t + 1] - starts[t]) as usize);
            lists.push(list);
            rest = after;
        }
        lists.par_iter_mut().for_each(|list| list.sort_unstable_by(|a, b| a.near.total_cmp(&b.near)));
        Self { columns, starts, entries, cones }
    }

    /// True when `dir`, a unit direction from the eye, lies inside the cone
    /// holding support `e`: a ray along it may cross the support.
    #[inline]
    #[must_use]
    pub fn may_cross(&self, e: &Entry, dir: Vec4) -> bool {
        let cone = self.cones[e.support as usize];
        dir.dot(cone) >= cone.w
    }

    /// The supports the rays through pixel (`x`, `y`) can cross, nearest first.
    #[inline]
    #[must_use]
    pub fn at(&self, x: u32, y: u32) -> &[Entry] {
        let tile = ((y / TILE) * self.columns + x / TILE) as usize;
        &self.entries[self.starts[tile] as usize..self.starts[tile + 1] as usize]
    }
}
