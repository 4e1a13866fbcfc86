//! How fast could per-ray segment tracing get if every ray started right
//! next to its hit? This measures it: each tile of `k × k` pixels walks its
//! frustum in depth slabs as wide as the tile, from the nearest distance the
//! coverage gives, until the field's interval bound over a slab's box can
//! reach the threshold; the tile's rays then start there (a proven start:
//! the hits stay bit for bit those of a render). With `k = 1` the starts are
//! about the best interval bounds can give; larger tiles cost fewer bounds.
//!
//! For each tile size it prints the time and bounds spent finding the
//! starts, then the tracing time and evaluations from them, against tracing
//! from the coverage as `render` does:
//!
//! ```text
//! cargo run --release --example tracing_ceiling -- scenes/particles.ron 500x500
//! ```

use std::time::Instant;

use blobtrace::camera::Camera;
use blobtrace::field::{EmptySpace, EvalMode, Field, ModelField, outside_margin};
use blobtrace::geom::Aabb;
use blobtrace::scene::Scene;
use blobtrace::trace::{Coverage, TraceResult, trace_ray_from};
use glam::Vec3A;
use rayon::prelude::*;

/// Tile sizes tried, in pixels.
const TILES: [u32; 4] = [1, 2, 4, 8];
/// Timed rounds of each tracing; the fastest is printed.
const ROUNDS: usize = 5;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args.first().map_or("scenes/particles.ron", String::as_str);
    let scene = Scene::load(path)?;
    let (width, height) = match args.get(1) {
        Some(size) => {
            let (w, h) = size.split_once('x').ok_or_else(|| anyhow::anyhow!("size is WIDTHxHEIGHT"))?;
            (w.parse::<u32>()?, h.parse::<u32>()?)
        }
        None => (scene.size.0, scene.size.1),
    };
    let settings = scene.render_settings(blobtrace::frame::Size(width, height));
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let empty = EmptySpace::build(&field);
    let coverage = Coverage::of(&empty, &scene.model.bounds(), &settings.camera, width, height);
    let skipping = field.skipping(&empty);
    let view = View { camera: settings.camera, width, height };
    let coverage_starts: Vec<f32> = (0..width * height).map(|i| coverage.near(i % width, i / width)).collect();
    let trace = |starts: &[f32]| -> (f64, Vec<TraceResult>) {
        let mut best = f64::INFINITY;
        let mut results = vec![];
        for _ in 0..ROUNDS {
            let start = Instant::now();
            results = (0..width * height)
                .into_par_iter()
                .map(|i| match starts[i as usize] {
                    near if near.is_finite() => {
                        let ray = settings.camera.ray(i % width, i / width, width, height);
                        trace_ray_from(&skipping, &ray, &settings.trace, near)
                    }
                    _ => TraceResult::default(),
                })
                .collect();
            best = best.min(start.elapsed().as_secs_f64());
        }
        (best, results)
    };
    let (today_s, today) = trace(&coverage_starts);
    let evals = |r: &[TraceResult]| r.iter().map(|t| u64::from(t.evals)).sum::<u64>();
    let hits = today.iter().filter(|t| t.hit.is_some()).count();
    println!("{path} at {width}x{height}, {} threads: {hits} hits", rayon::current_num_threads());
    println!("{:<24} {:>12} {:>10} {:>12} {:>14}", "starts", "bounds", "find ms", "trace ms", "evaluations");
    println!("{:<24} {:>12} {:>10} {:>12.1} {:>14}", "coverage (render's)", "-", "-", today_s * 1e3, evals(&today));
    for k in TILES {
        let start = Instant::now();
        let (starts, bounds) = view.tile_starts(&field, &coverage_starts, k);
        let find_s = start.elapsed().as_secs_f64();
        let (trace_s, results) = trace(&starts);
        let same = results.iter().zip(&today).all(|(a, b)| a.hit.map(f32::to_bits) == b.hit.map(f32::to_bits));
        anyhow::ensure!(same, "tiles of {k}: a hit moved, so a start was not proven");
        let name = format!("tiles of {k}x{k} px");
        println!("{name:<24} {bounds:>12} {:>10.1} {:>12.1} {:>14}", find_s * 1e3, trace_s * 1e3, evals(&results));
    }
    println!("every tile size finds the same hits as the render, bit for bit");
    Ok(())
}

/// The camera and the image it makes.
struct View {
    camera: Camera,
    width: u32,
    height: u32,
}

impl View {
    /// Per pixel, the start each `k × k` tile proves for its rays (no later
    /// than the coverage's), and the interval bounds spent finding them.
    fn tile_starts<F: Field + Sync>(&self, field: &F, coverage: &[f32], k: u32) -> (Vec<f32>, u64) {
        let (across, down) = (self.width.div_ceil(k), self.height.div_ceil(k));
        let tiles: Vec<(f32, u64)> = (0..across * down)
            .into_par_iter()
            .map(|t| self.tile_start(field, coverage, (t % across, t / across), k))
            .collect();
        let starts = (0..self.width * self.height)
            .map(|i| {
                let (x, y) = (i % self.width, i / self.width);
                let near = coverage[i as usize];
                if near.is_finite() { tiles[((y / k) * across + x / k) as usize].0.max(near) } else { near }
            })
            .collect();
        (starts, tiles.iter().map(|t| t.1).sum())
    }

    /// The distance along every ray of tile (`tx`, `ty`) before which no slab
    /// of its frustum can hold the surface, and the bounds taken.
    fn tile_start<F: Field>(&self, field: &F, coverage: &[f32], (tx, ty): (u32, u32), k: u32) -> (f32, u64) {
        let (x0, y0) = (tx * k, ty * k);
        let (x1, y1) = ((x0 + k).min(self.width), (y0 + k).min(self.height));
        let near = (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .map(|(x, y)| coverage[(y * self.width + x) as usize])
            .fold(f32::INFINITY, f32::min);
        if near.is_infinite() {
            return (near, 0);
        }
        let corners = self.directions((x0, y0), (x1, y1));
        // A point at distance `t` along a direction `d` one unit of depth long
        // lies at depth `t / |d|`; `|d|` is largest at a corner of the tile.
        let longest = corners.iter().map(|&(_, length)| length).fold(0.0, f32::max);
        let nearest = self.nearest_length((x0, y0), (x1, y1));
        let bounds_box = field.bounds();
        let far = (bounds_box.min - self.camera.eye).abs().max((bounds_box.max - self.camera.eye).abs()).length();
        let below = field.threshold() - outside_margin(field.threshold());
        let slab_per_depth = k as f32 * 2.0 * self.camera.tan_half_fov() / self.height as f32;
        let mut z = near / longest * (1.0 - 1e-4);
        let mut bounds = 0;
        while z * nearest <= far {
            let slab = (slab_per_depth * z).max(1e-6);
            bounds += 1;
            if field.interval(&self.chunk(&corners, z, z + slab)).hi >= below {
                // The nearest point of the slab along any of the tile's rays.
                return ((z * nearest * (1.0 - 1e-4)).max(near), bounds);
            }
            z += slab;
        }
        (f32::INFINITY, bounds)
    }

    /// The directions (one unit of depth long) through the corners of the
    /// pixels `(x0, y0)..(x1, y1)`, with their lengths.
    fn directions(&self, (x0, y0): (u32, u32), (x1, y1): (u32, u32)) -> [(Vec3A, f32); 4] {
        [(x0, y0), (x1, y0), (x0, y1), (x1, y1)].map(|(x, y)| {
            let (sx, sy) = self.screen(x, y);
            let d = self.camera.forward() + self.camera.right() * sx + self.camera.up() * sy;
            (d, d.length())
        })
    }

    /// The screen-plane coordinates of pixel corner (`x`, `y`) at unit depth.
    fn screen(&self, x: u32, y: u32) -> (f32, f32) {
        let aspect = self.width as f32 / self.height as f32;
        let tan = self.camera.tan_half_fov();
        ((2.0 * x as f32 / self.width as f32 - 1.0) * tan * aspect, (1.0 - 2.0 * y as f32 / self.height as f32) * tan)
    }

    /// The length of the shortest direction through the pixels `(x0, y0)..(x1, y1)`.
    fn nearest_length(&self, (x0, y0): (u32, u32), (x1, y1): (u32, u32)) -> f32 {
        let ((ax, ay), (bx, by)) = (self.screen(x0, y0), self.screen(x1, y1));
        let nearest = |a: f32, b: f32| if a * b <= 0.0 { 0.0 } else { a.abs().min(b.abs()) };
        let (sx, sy) = (nearest(ax, bx), nearest(ay, by));
        (1.0 + sx * sx + sy * sy).sqrt()
    }

    /// A box holding the tile's frustum between depths `z0` and `z1`.
    fn chunk(&self, corners: &[(Vec3A, f32); 4], z0: f32, z1: f32) -> Aabb {
        let points = corners.iter().flat_map(|&(d, _)| [self.camera.eye + d * z0, self.camera.eye + d * z1]);
        let (lo, hi) = points.fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |(lo, hi), p| (lo.min(p), hi.max(p)));
        // Padded against rounding in the corners.
        let pad = Vec3A::splat((hi - lo).max_element() * 1e-4 + 1e-5 * hi.abs().max(lo.abs()).max_element());
        Aabb::new(lo - pad, hi + pad)
    }
}
