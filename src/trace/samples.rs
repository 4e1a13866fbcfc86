//! Where in a pixel each of its rays goes, and how a pixel's samples make
//! one [`PixelSample`]. Sample 0 is the pixel's centre, so one sample per
//! pixel is the plain render references are made of; sample k ≥ 1 is the
//! k-th point of the Halton sequence in bases 2 and 3, shifted by a
//! per-pixel offset taken from a hash of the pixel (a Cranley–Patterson
//! rotation, so neighbouring pixels do not alias alike). Every prefix of the sequence is spread
//! evenly over the pixel, so N samples are stratified for any N, and a
//! previewer that adds one sample at a time ends where a render of N does.
//! The offsets depend on the pixel and the sample index only: the image is
//! the same for any number of threads.

use glam::{Vec2, Vec3};

/// One traced pixel: what it shows and two per-pixel work counters.
#[derive(Clone, Copy, Debug)]
pub struct PixelSample {
    /// Shaded colour (linear RGB).
    pub color: Vec3,
    /// Distance to the hit; `+inf` on a miss.
    pub depth: f32,
    /// Unit world normal at the hit; zero on a miss.
    pub normal: Vec3,
    /// Coverage: 1 on a hit, 0 on a miss, the fraction of rays that hit
    /// for several samples.
    pub alpha: f32,
    /// Work counters, written to the frame's extra channels.
    pub counts: [u32; 2],
}

impl PixelSample {
    /// A missed pixel.
    #[must_use]
    pub fn miss(background: Vec3, counts: [u32; 2]) -> Self {
        Self { color: background, depth: f32::INFINITY, normal: Vec3::ZERO, alpha: 0.0, counts }
    }
}

/// Totals over traced pixels: their rays, the rays that hit, and the two
/// work counters summed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PixelTotals {
    /// Rays traced.
    pub rays: u64,
    /// Rays that hit.
    pub hits: u64,
    /// The pixels' work counters, summed.
    pub counts: [u64; 2],
}

impl PixelTotals {
    /// The totals over `pixels` of `samples` rays each.
    #[must_use]
    pub fn of(pixels: &[PixelSample], samples: u32) -> Self {
        pixels.iter().fold(Self::default(), |t, p| t.with(p, samples))
    }

    /// These totals and `p`, a pixel of `samples` rays.
    #[must_use]
    pub fn with(self, p: &PixelSample, samples: u32) -> Self {
        Self {
            rays: self.rays + u64::from(samples),
            // One ray hits or not (no rounding, a library call on builds for
            // any x86-64); several hit in the fraction alpha.
            hits: self.hits
                + if samples == 1 { u64::from(p.alpha > 0.5) } else { (p.alpha * samples as f32).round() as u64 },
            counts: [self.counts[0] + u64::from(p.counts[0]), self.counts[1] + u64::from(p.counts[1])],
        }
    }

    /// Both totals together.
    #[must_use]
    pub fn plus(self, o: Self) -> Self {
        Self {
            rays: self.rays + o.rays,
            hits: self.hits + o.hits,
            counts: [self.counts[0] + o.counts[0], self.counts[1] + o.counts[1]],
        }
    }
}

/// Most samples per pixel a render takes.
pub const MAX_SAMPLES: u32 = 1024;

/// The position in pixel (`x`, `y`) of its sample `k`, in pixel units from
/// its top-left corner.
#[must_use]
pub fn sample_offset(x: u32, y: u32, k: u32) -> Vec2 {
    if k == 0 {
        return Vec2::splat(0.5);
    }
    let shift = pixel_shift(x, y);
    let point = Vec2::new(radical_inverse(k, 2), radical_inverse(k, 3));
    (point + shift).fract()
}

/// The pixel that `samples` of one pixel make: the mean colour (misses count
/// as the background they show), the fraction that hit as alpha, the
/// nearest hit's distance, the mean of the hits' normals, and the summed
/// work counters.
#[must_use]
pub fn combine(samples: &[PixelSample]) -> PixelSample {
    if let [one] = samples {
        return *one;
    }
    let n = samples.len().max(1) as f32;
    let hits: Vec<&PixelSample> = samples.iter().filter(|s| s.depth.is_finite()).collect();
    let normal: Vec3 = hits.iter().map(|s| s.normal).sum();
    PixelSample {
        color: samples.iter().map(|s| s.color).sum::<Vec3>() / n,
        depth: hits.iter().map(|s| s.depth).fold(f32::INFINITY, f32::min),
        normal: normal.normalize_or_zero(),
        alpha: hits.len() as f32 / n,
        counts: samples.iter().fold([0, 0], |c, s| [c[0] + s.counts[0], c[1] + s.counts[1]]),
    }
}

/// The point `k` of the van der Corput sequence in `base`: its digits mirrored about the point.
fn radical_inverse(mut k: u32, base: u32) -> f32 {
    let (mut value, mut scale) = (0.0_f64, 1.0_f64);
    while k > 0 {
        scale /= f64::from(base);
        value += f64::from(k % base) * scale;
        k /= base;
    }
    value as f32
}

/// A pixel's offset of the sequence, in `[0, 1)²`, from a hash of its coordinates.
fn pixel_shift(x: u32, y: u32) -> Vec2 {
    let h = mix(u64::from(x) << 32 | u64::from(y));
    let unit = |bits: u64| (bits >> 40) as f32 / (1u64 << 24) as f32;
    Vec2::new(unit(h), unit(h << 24))
}

/// SplitMix64's finaliser: every input bit moves every output bit.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_sample_is_the_centre_and_the_rest_fill_the_pixel_evenly() {
        assert_eq!(sample_offset(3, 9, 0), Vec2::splat(0.5));
        // Sixteen samples fall about four to each quarter of the pixel.
        let points: Vec<Vec2> = (1..=16).map(|k| sample_offset(3, 9, k)).collect();
        for p in &points {
            assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y), "{p}");
        }
        for quarter in 0..4 {
            let (qx, qy) = ((quarter % 2) as f32 * 0.5, (quarter / 2) as f32 * 0.5);
            let inside = |p: &&Vec2| p.x >= qx && p.x < qx + 0.5 && p.y >= qy && p.y < qy + 0.5;
            let count = points.iter().filter(inside).count();
            assert!((2..=6).contains(&count), "quarter {quarter}: {count} of 16");
        }
        assert_ne!(sample_offset(3, 9, 1), sample_offset(4, 9, 1), "pixels are shifted apart");
    }

    #[test]
    fn samples_combine_into_mean_colour_coverage_nearest_depth_and_summed_work() {
        let hit = PixelSample { color: Vec3::ONE, depth: 2.0, normal: Vec3::Z, alpha: 1.0, counts: [3, 5] };
        let near = PixelSample { depth: 1.5, normal: Vec3::X, ..hit };
        let miss = PixelSample::miss(Vec3::ZERO, [1, 1]);
        let p = combine(&[hit, miss, near, miss]);
        assert_eq!(p.color, Vec3::splat(0.5));
        assert_eq!((p.alpha, p.depth), (0.5, 1.5));
        assert!((p.normal - Vec3::new(1.0, 0.0, 1.0).normalize()).length() < 1e-6);
        assert_eq!(p.counts, [8, 12]);
        assert_eq!(combine(&[hit]).depth, 2.0);
        assert_eq!(combine(&[miss, miss]).alpha, 0.0);
    }
}
