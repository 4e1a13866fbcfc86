//! blobtrace's continuation polygonizer against fast-surface-nets on the
//! Segment Tracing particles (1001 Wyvill points, R = 2.25, T = 0.5), on
//! the same lattice (`blobtrace mesh --res 256`: origin-anchored, the same
//! cell), timed in one process so the ratio is re-measured on every machine.
//!
//! fast-surface-nets meshes a dense grid, so its side samples the field the
//! fastest way a user of it would: each point splats its falloff into the
//! samples inside its support (checked against blobtrace's field before
//! timing). Its time counts the grid's allocation, the sampling and the
//! meshing; blobtrace's counts polygonizing and assembling the mesh.
//! `cargo bench --bench surface_nets`.

/// The allocator the `blobtrace` command uses.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

use blobtrace::field::{EvalMode, Field, ModelField};
use blobtrace::mesh::{Lattice, Mesh, PolygonizeOptions, Polygonizer, VertexPlacement, skeleton_seeds};
use blobtrace::scene::{NodeDesc, Scene, parse_desc};
use criterion::{Criterion, criterion_group, criterion_main};
use fast_surface_nets::ndshape::{RuntimeShape, Shape};
use fast_surface_nets::{SurfaceNetsBuffer, surface_nets};
use glam::{IVec3, Vec3, Vec3A};
use rayon::prelude::*;

const RES: u32 = 256;

/// The particles' centres and their shared radius, read from the scene file.
fn particles(text: &str) -> (Vec<Vec3>, f32) {
    let desc = parse_desc(text, "particles.ron").expect("the bundled scene parses");
    let NodeDesc::Blend(children) = desc.model else { panic!("the particles are one blend") };
    let mut radius = 0.0;
    let centres = children
        .0
        .iter()
        .map(|c| match c {
            NodeDesc::Point { center, radius: r, .. } => {
                radius = r.0;
                center.0
            }
            _ => panic!("the particles are points"),
        })
        .collect();
    (centres, radius)
}

/// A dense grid of `T − f` (negative inside) over the lattice cells
/// `lo..=hi`, filled by splatting each point's Wyvill falloff, in parallel over z slabs.
struct Grid {
    lo: IVec3,
    dims: [u32; 3],
    cell: f32,
}

impl Grid {
    fn around(centres: &[Vec3], radius: f32, cell: f32) -> Self {
        let (min, max) = centres.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), &p| (a.min(p), b.max(p)));
        let lo = ((min - radius) / cell).floor().as_ivec3() - IVec3::ONE;
        let hi = ((max + radius) / cell).ceil().as_ivec3() + IVec3::ONE;
        let d = hi - lo + IVec3::ONE;
        Self { lo, dims: [d.x as u32, d.y as u32, d.z as u32], cell }
    }

    fn sample(&self, centres: &[Vec3], radius: f32, threshold: f32) -> Vec<f32> {
        let [nx, ny, nz] = self.dims.map(|d| d as usize);
        let mut samples = vec![0.0f32; nx * ny * nz];
        // Fresh pages touched in order first, as the peer program does: two
        // threads faulting them in at once take several times longer here.
        // (Volatile: a plain store of zero into zeroed memory may be dropped.)
        for page in samples.chunks_mut(1024) {
            // SAFETY: `page` is a live, non-empty slice of `f32`.
            unsafe { std::ptr::write_volatile(page.as_mut_ptr(), 0.0) };
        }
        let (r2, inv_r2, h) = (radius * radius, 1.0 / (radius * radius), self.cell);
        samples.par_chunks_mut(nx * ny).enumerate().for_each(|(k, plane)| {
            let z = (self.lo.z + k as i32) as f32 * h;
            for p in centres {
                let dz2 = (z - p.z) * (z - p.z);
                if dz2 >= r2 {
                    continue;
                }
                let span = |c: f32, lo: i32, n: usize| {
                    let first = (((c - radius) / h).floor() as i32 - lo).max(0);
                    let last = (((c + radius) / h).ceil() as i32 - lo).min(n as i32 - 1);
                    first..=last
                };
                for j in span(p.y, self.lo.y, ny) {
                    let dy = (self.lo.y + j) as f32 * h - p.y;
                    let dyz = dy * dy + dz2;
                    if dyz >= r2 {
                        continue;
                    }
                    let row = &mut plane[j as usize * nx..][..nx];
                    for i in span(p.x, self.lo.x, nx) {
                        let dx = (self.lo.x + i) as f32 * h - p.x;
                        let d2 = dx * dx + dyz;
                        if d2 < r2 {
                            let t = 1.0 - d2 * inv_r2;
                            row[i as usize] += t * t * t;
                        }
                    }
                }
            }
            for v in plane.iter_mut() {
                *v = threshold - *v;
            }
        });
        samples
    }

    fn mesh(&self, samples: &[f32], buffer: &mut SurfaceNetsBuffer) {
        let shape = RuntimeShape::<u32, 3>::new(self.dims);
        assert_eq!(shape.size() as usize, samples.len());
        surface_nets(samples, &shape, [0; 3], self.dims.map(|d| d - 1), buffer);
    }
}

fn blobtrace_mesh(scene: &Scene, lattice: Lattice, vertex: VertexPlacement) -> Mesh {
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let mut polygonizer = Polygonizer::new(lattice, PolygonizeOptions { vertex, ..Default::default() });
    polygonizer.polygonize(&field, &skeleton_seeds(&scene.model, scene.model.root()));
    polygonizer.mesh()
}

fn against_surface_nets(c: &mut Criterion) {
    let path = format!("{}/scenes/particles.ron", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).expect("the bundled scene reads");
    let scene = Scene::parse(&text, &path).expect("the bundled scene loads");
    let (centres, radius) = particles(&text);
    let lattice = Lattice::for_model(&scene.model, RES);
    let grid = Grid::around(&centres, radius, lattice.cell);
    let threshold = scene.model.threshold();

    // The same field: the splatted grid agrees with blobtrace's evaluation.
    let samples = grid.sample(&centres, radius, threshold);
    let field = ModelField::new(&scene.model, EvalMode::Indexed);
    let [nx, ny, _] = grid.dims.map(|d| d as usize);
    for index in (0..samples.len()).step_by(9973) {
        let at = IVec3::new((index % nx) as i32, (index / nx % ny) as i32, (index / (nx * ny)) as i32);
        let p = Vec3A::from((grid.lo + at).as_vec3() * lattice.cell);
        let expected = threshold - field.value(p);
        assert!((samples[index] - expected).abs() < 1e-4, "the grids differ at {at}");
    }

    let mut group = c.benchmark_group("particles_res256");
    group.sample_size(10);
    group.bench_function("fast_surface_nets", |b| {
        b.iter(|| {
            let samples = grid.sample(&centres, radius, threshold);
            let mut buffer = SurfaceNetsBuffer::default();
            grid.mesh(&samples, &mut buffer);
            buffer.indices.len()
        })
    });
    for (name, vertex) in
        [("blobtrace_linear", VertexPlacement::Linear), ("blobtrace_root", VertexPlacement::default())]
    {
        group.bench_function(name, |b| b.iter(|| blobtrace_mesh(&scene, lattice, vertex).triangles.len()));
    }
    group.finish();
}

criterion_group!(benches, against_surface_nets);
criterion_main!(benches);
