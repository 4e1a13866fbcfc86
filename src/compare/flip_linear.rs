//! LDR-ꟻLIP of linear-light float images, NVIDIA's algorithm as its
//! `FLIP.h` (flip-evaluator 1.6 and 1.7) computes it on the CPU: YCxCz,
//! separable contrast-sensitivity filters, Hunt-adjusted HyAB colour
//! distance, edge and point feature differences.
//!
//! The `nv-flip` crate runs NVIDIA's own code, but only on 8-bit sRGB input;
//! HDR-ꟻLIP ([`super::hdr_flip`]) evaluates LDR-ꟻLIP on tone-mapped float
//! images, and rounding those to 8 bits moves the mean by about 5e-4 on the
//! bundled renders, more than the 1e-4 we hold ourselves to. So the same
//! arithmetic, in `f32` and in the same order, runs here on floats; a test
//! holds it to NVIDIA's on 8-bit input. Rows run in parallel; each pixel's
//! sums run in one fixed order, so the result is the same for any thread count.

use glam::Vec3;
use rayon::prelude::*;

/// ꟻLIP's constants: colour exponent, colour cut-off, its share of the
/// range, the feature filter's width in degrees, the feature exponent.
const GQC: f32 = 0.7;
const GPC: f32 = 0.4;
const GPT: f32 = 0.95;
const GW: f32 = 0.082;
const GQF: f32 = 0.5;
const PI: f32 = std::f32::consts::PI;
/// The contrast sensitivity functions' Gaussians (a1, b1, a2, b2 per Y, Cx, Cz).
const A1: [f32; 3] = [1.0, 1.0, 34.1];
const B1: [f32; 3] = [0.0047, 0.0053, 0.04];
const A2_CZ: f32 = 13.5;
const B2: [f32; 3] = [1.0e-5, 1.0e-5, 0.025];
const ILLUMINANT: Vec3 = Vec3::new(0.950_428_5, 1.0, 1.088_900_4);
const INV_ILLUMINANT: Vec3 = Vec3::new(1.052_156_9, 1.0, 0.918_357_7);

/// Per-pixel LDR-ꟻLIP errors of `test` against `reference`, both linear RGB
/// in `[0, 1]` (values outside are clamped, as NVIDIA's code clamps them),
/// row-major `width × height`, at `ppd` pixels per degree.
#[must_use]
pub fn flip_linear(reference: &[Vec3], test: &[Vec3], width: u32, height: u32, ppd: f32) -> Vec<f32> {
    let to_ycxcz = |img: &[Vec3]| -> Vec<Vec3> {
        img.par_iter().map(|c| xyz_to_ycxcz(linear_to_xyz(c.clamp(Vec3::ZERO, Vec3::ONE)))).collect()
    };
    let (r, t) = (to_ycxcz(reference), to_ycxcz(test));
    let (w, h) = (width as usize, height as usize);
    let colour = colour_difference(&r, &t, w, h, ppd);
    feature_difference_and_error(&r, &t, &colour, w, h, ppd)
}

/// The spatially filtered, Hunt-adjusted HyAB colour difference, remapped to `[0, 1]`.
fn colour_difference(r: &[Vec3], t: &[Vec3], w: usize, h: usize, ppd: f32) -> Vec<f32> {
    let filter = spatial_filter(ppd);
    let half = (filter.len() / 2) as isize;
    // Horizontal pass: (Y, Cx) through their filters, Cz through both of its Gaussians.
    let horizontal = |img: &[Vec3]| -> Vec<[f32; 4]> {
        let mut out = vec![[0.0; 4]; w * h];
        out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, o) in row.iter_mut().enumerate() {
                let mut s = [0.0f32; 4];
                for (k, f) in filter.iter().enumerate() {
                    let xx = (x as isize + k as isize - half).clamp(0, w as isize - 1) as usize;
                    let c = img[y * w + xx];
                    s[0] += f.ycx[0] * c.x;
                    s[1] += f.ycx[1] * c.y;
                    s[2] += f.cz[0] * c.z;
                    s[3] += f.cz[1] * c.z;
                }
                *o = s;
            }
        });
        out
    };
    let (hr, ht) = (horizontal(r), horizontal(t));
    let cmax = max_distance();
    let pccmax = GPC * cmax;
    let mut out = vec![0.0f32; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, o) in row.iter_mut().enumerate() {
            let (mut sr, mut st) = ([0.0f32; 4], [0.0f32; 4]);
            for (k, f) in filter.iter().enumerate() {
                let yy = (y as isize + k as isize - half).clamp(0, h as isize - 1) as usize;
                let (a, b) = (hr[yy * w + x], ht[yy * w + x]);
                let weights = [f.ycx[0], f.ycx[1], f.cz[0], f.cz[1]];
                for c in 0..4 {
                    sr[c] += weights[c] * a[c];
                    st[c] += weights[c] * b[c];
                }
            }
            let lab = |s: [f32; 4]| hunt_lab(Vec3::new(s[0], s[1], s[2] + s[3]));
            let d = hyab(lab(sr), lab(st)).powf(GQC);
            *o = if d < pccmax { d * (GPT / pccmax) } else { GPT + ((d - pccmax) / (cmax - pccmax)) * (1.0 - GPT) };
        }
    });
    out
}

/// A filtered YCxCz colour, clamped in linear RGB, as Hunt-adjusted L*a*b*.
fn hunt_lab(ycxcz: Vec3) -> Vec3 {
    let rgb = xyz_to_linear(ycxcz_to_xyz(ycxcz)).clamp(Vec3::ZERO, Vec3::ONE);
    let lab = xyz_to_lab(linear_to_xyz(rgb));
    Vec3::new(lab.x, hunt(lab.x, lab.y), hunt(lab.x, lab.z))
}

/// Combines the colour difference with the edge and point differences of the achromatic channel.
fn feature_difference_and_error(r: &[Vec3], t: &[Vec3], colour: &[f32], w: usize, h: usize, ppd: f32) -> Vec<f32> {
    let filter = feature_filter(ppd);
    let half = (filter.len() / 2) as isize;
    // Horizontal pass: first and second x-derivatives and the Gaussian of Y normalised to [0, 1].
    let horizontal = |img: &[Vec3]| -> Vec<Vec3> {
        let mut out = vec![Vec3::ZERO; w * h];
        out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, o) in row.iter_mut().enumerate() {
                let (mut dx, mut ddx, mut g) = (0.0f32, 0.0f32, 0.0f32);
                for (k, f) in filter.iter().enumerate() {
                    let xx = (x as isize + k as isize - half).clamp(0, w as isize - 1) as usize;
                    let yn = img[y * w + xx].x * (1.0 / 116.0) + 16.0 / 116.0;
                    dx += f.y * yn;
                    ddx += f.z * yn;
                    g += f.x * yn;
                }
                *o = Vec3::new(dx, ddx, g);
            }
        });
        out
    };
    let (hr, ht) = (horizontal(r), horizontal(t));
    let mut out = vec![0.0f32; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, o) in row.iter_mut().enumerate() {
            // Per image: dx, ddx (Gaussian in y), dy, ddy (derivatives in y of the Gaussian in x).
            let (mut fr, mut ft) = ([0.0f32; 4], [0.0f32; 4]);
            for (k, f) in filter.iter().enumerate() {
                let yy = (y as isize + k as isize - half).clamp(0, h as isize - 1) as usize;
                for (s, v) in [(&mut fr, hr[yy * w + x]), (&mut ft, ht[yy * w + x])] {
                    s[0] += f.x * v.x;
                    s[1] += f.x * v.y;
                    s[2] += f.y * v.z;
                    s[3] += f.z * v.z;
                }
            }
            let edge = |s: [f32; 4]| (s[0] * s[0] + s[2] * s[2]).sqrt();
            let point = |s: [f32; 4]| (s[1] * s[1] + s[3] * s[3]).sqrt();
            let edge_difference = (edge(fr) - edge(ft)).abs();
            let point_difference = (point(fr) - point(ft)).abs();
            let feature = ((1.0 / 2.0f32.sqrt()) * edge_difference.max(point_difference)).powf(GQF);
            *o = colour[y * w + x].powf(1.0 - feature);
        }
    });
    out
}

/// One tap of the separated spatial filters: (Y, Cx) weights and Cz's two Gaussians.
struct SpatialTap {
    ycx: [f32; 2],
    cz: [f32; 2],
}

/// The separated contrast-sensitivity filters, normalised as NVIDIA normalises them.
fn spatial_filter(ppd: f32) -> Vec<SpatialTap> {
    let max_scale = B1.iter().chain(&B2).copied().fold(f32::MIN, f32::max);
    let radius = (3.0 * (max_scale / (2.0 * PI * PI)).sqrt() * ppd).ceil() as i32;
    let mut taps: Vec<SpatialTap> = (-radius..=radius)
        .map(|i| {
            let ix = i as f32 * (1.0 / ppd);
            let x2 = ix * ix;
            SpatialTap {
                ycx: [gaussian_ab(x2, A1[0], B1[0]), gaussian_ab(x2, A1[1], B1[1])],
                cz: [gaussian_sqrt(x2, A1[2], B1[2]), gaussian_sqrt(x2, A2_CZ, B2[2])],
            }
        })
        .collect();
    let sum = |f: &dyn Fn(&SpatialTap) -> f32| taps.iter().fold(0.0f32, |s, t| s + f(t));
    let (sy, sx) = (sum(&|t| t.ycx[0]), sum(&|t| t.ycx[1]));
    let (sz1, sz2) = (sum(&|t| t.cz[0]), sum(&|t| t.cz[1]));
    let (ny, nx, nz) = (1.0 / sy, 1.0 / sx, 1.0 / (sz1 * sz1 + sz2 * sz2).sqrt());
    for t in &mut taps {
        t.ycx = [t.ycx[0] * ny, t.ycx[1] * nx];
        t.cz = [t.cz[0] * nz, t.cz[1] * nz];
    }
    taps
}

/// The feature filter's taps: Gaussian, first and second derivative (x, y, z),
/// the derivatives' positive and negative weights each summing to ±1.
fn feature_filter(ppd: f32) -> Vec<Vec3> {
    let sd = 0.5 * GW * ppd;
    let radius = (3.0 * sd).ceil() as i32;
    let taps: Vec<Vec3> = (-radius..=radius)
        .map(|i| {
            let x = i as f32;
            let g = (-(x * x) / (2.0 * sd * sd)).exp();
            Vec3::new(g, -x * g, (x * x / (sd * sd) - 1.0) * g)
        })
        .collect();
    let (mut g_sum, mut dg_pos, mut dg_neg, mut ddg_pos, mut ddg_neg) = (0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
    for t in &taps {
        g_sum += t.x;
        if t.y > 0.0 {
            dg_pos += t.y
        } else {
            dg_neg -= t.y
        }
        if t.z > 0.0 { ddg_pos += t.z } else { ddg_neg -= t.z }
    }
    taps.iter()
        .map(|t| {
            let dg = t.y / if t.y > 0.0 { dg_pos } else { dg_neg };
            Vec3::new(t.x / g_sum, dg, t.z / if t.z > 0.0 { ddg_pos } else { ddg_neg })
        })
        .collect()
}

fn gaussian_ab(x2: f32, a: f32, b: f32) -> f32 {
    a * (PI / b).sqrt() * (-(PI * PI) * x2 / b).exp()
}

fn gaussian_sqrt(x2: f32, a: f32, b: f32) -> f32 {
    (a * (PI / b).sqrt()).sqrt() * (-(PI * PI) * x2 / b).exp()
}

fn linear_to_xyz(c: Vec3) -> Vec3 {
    let row = |a: f32, b: f32, d: f32, n: f32| (a / n) * c.x + (b / n) * c.y + (d / n) * c.z;
    Vec3::new(
        row(10_135_552.0, 8_788_810.0, 4_435_075.0, 24_577_794.0),
        row(2_613_072.0, 8_788_810.0, 887_015.0, 12_288_897.0),
        row(1_425_312.0, 8_788_810.0, 70_074_185.0, 73_733_382.0),
    )
}

fn xyz_to_linear(c: Vec3) -> Vec3 {
    Vec3::new(
        3.241_003_3 * c.x + -1.537_398_9 * c.y + -0.498_615_87 * c.z,
        -0.969_224_3 * c.x + 1.875_930_1 * c.y + 0.041_554_224 * c.z,
        0.055_639_423 * c.x + -0.204_011_2 * c.y + 1.057_148_9 * c.z,
    )
}

fn xyz_to_ycxcz(xyz: Vec3) -> Vec3 {
    let v = xyz * INV_ILLUMINANT;
    Vec3::new(116.0 * v.y - 16.0, 500.0 * (v.x - v.y), 200.0 * (v.y - v.z))
}

fn ycxcz_to_xyz(c: Vec3) -> Vec3 {
    let y = (c.x + 16.0) / 116.0;
    let (cx, cz) = (c.y / 500.0, c.z / 200.0);
    Vec3::new(y + cx, y, y - cz) * ILLUMINANT
}

fn xyz_to_lab(xyz: Vec3) -> Vec3 {
    const DELTA: f32 = 6.0 / 29.0;
    let (delta_cube, factor, term) = (DELTA * DELTA * DELTA, 1.0 / (3.0 * DELTA * DELTA), 4.0 / 29.0);
    let f = |t: f32| if t > delta_cube { t.powf(1.0 / 3.0) } else { factor * t + term };
    let v = xyz * INV_ILLUMINANT;
    let (x, y, z) = (f(v.x), f(v.y), f(v.z));
    Vec3::new(116.0 * y - 16.0, 500.0 * (x - y), 200.0 * (y - z))
}

fn hunt(luminance: f32, chrominance: f32) -> f32 {
    0.01 * luminance * chrominance
}

fn hyab(a: Vec3, b: Vec3) -> f32 {
    (a.x - b.x).abs() + ((a.y - b.y) * (a.y - b.y) + (a.z - b.z) * (a.z - b.z)).sqrt()
}

/// The largest colour distance, green against blue, to the power `GQC`.
fn max_distance() -> f32 {
    let lab = |c: Vec3| {
        let l = xyz_to_lab(linear_to_xyz(c));
        Vec3::new(l.x, hunt(l.x, l.y), hunt(l.x, l.z))
    };
    hyab(lab(Vec3::Y), lab(Vec3::Z)).powf(GQC)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compare::flip::tests::pattern;
    use crate::compare::{default_pixels_per_degree, flip_whole};
    use crate::frame::srgb8_to_linear;

    #[test]
    fn float_flip_equals_nvidias_on_eight_bit_images() {
        let (w, h) = (53, 41);
        let (a, b) = (pattern(w, h, 3), pattern(w, h, 77));
        let ppd = default_pixels_per_degree();
        let linear = |s: &[u8]| -> Vec<Vec3> {
            s.chunks_exact(3)
                .map(|p| Vec3::new(srgb8_to_linear(p[0]), srgb8_to_linear(p[1]), srgb8_to_linear(p[2])))
                .collect()
        };
        let ours = flip_linear(&linear(&a), &linear(&b), w, h, ppd);
        let nvidia = flip_whole(&a, &b, w, h, ppd);
        let worst = ours.iter().zip(&nvidia).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
        let mean = |v: &[f32]| v.iter().map(|&e| f64::from(e)).sum::<f64>() / v.len() as f64;
        assert!(worst < 1e-4, "largest per-pixel difference from NVIDIA's {worst}");
        assert!(mean(&nvidia) > 0.05, "a real difference: {}", mean(&nvidia));
        assert!((mean(&ours) - mean(&nvidia)).abs() < 1e-6, "{} against {}", mean(&ours), mean(&nvidia));
        assert!(flip_linear(&linear(&a), &linear(&a), w, h, ppd).iter().all(|&e| e == 0.0));
    }
}
