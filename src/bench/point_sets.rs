//! The point sets the scale benchmark loads, as `scenes/tools/make_points.py`
//! makes them (the same models; not the same points, the generators differ):
//! sparse chains at the particles scene's density at any count, or one dense
//! branching random walk; written as a binary PLY and a scene that frames it.

use std::fmt::Write as _;
use std::path::Path;

use glam::Vec3;

/// Support radius of every point (the particles scene's).
pub const RADIUS: f32 = 2.25;
/// Step of the random walks.
const STEP: f32 = 1.8;
/// Points per chain of the sparse model.
const CHAIN: usize = 50;

/// Which point set.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PointModel {
    /// Chains of 50 random-walk points, step 1.8, started uniformly in a cube
    /// of side 28·(N/1000)^(1/3): the particles scene's density at any N.
    Sparse,
    /// One branching random walk, step 1.8: each point steps from the one
    /// before, or with probability 0.3 from a uniformly chosen earlier one.
    Dense,
    /// One `SplinePoints` node: a Catmull-Rom curve through a random walk
    /// of one control point per [`SPLINE_SPAN`] points, its points about
    /// half a step (0.9) apart, so each support meets about five along it.
    Spline,
}

/// Spline points per control point of the spline model.
pub const SPLINE_SPAN: usize = 64;

impl PointModel {
    /// Every point set, in the order `bench scale` measures them.
    pub const ALL: [PointModel; 3] = [PointModel::Sparse, PointModel::Dense, PointModel::Spline];

    /// The model's name, as `make_points.py` takes it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            PointModel::Sparse => "sparse",
            PointModel::Dense => "dense",
            PointModel::Spline => "spline",
        }
    }

    /// `n` points of the model, the same for the same `seed`; for the
    /// spline, the control points of a spline of `n` points.
    #[must_use]
    pub fn points(self, n: usize, seed: u64) -> Vec<Vec3> {
        let mut rng = SplitMix(seed);
        let mut points = Vec::with_capacity(n);
        match self {
            PointModel::Sparse => {
                let half = 14.0 * (n as f32 / 1000.0).cbrt();
                while points.len() < n {
                    let mut p = Vec3::new(rng.symmetric(half), rng.symmetric(half), rng.symmetric(half));
                    for _ in 0..CHAIN.min(n - points.len()) {
                        points.push(p);
                        p += rng.step();
                    }
                }
            }
            PointModel::Spline => {
                // A control step as long as the half steps of the points between.
                let mut p = Vec3::ZERO;
                for _ in 0..n / SPLINE_SPAN + 2 {
                    points.push(p);
                    p += rng.step() * (SPLINE_SPAN as f32 / 2.0);
                }
            }
            PointModel::Dense => {
                points.push(Vec3::ZERO);
                while points.len() < n {
                    let from = if rng.unit() >= 0.3 { points.len() - 1 } else { rng.below(points.len()) };
                    let next = points[from] + rng.step();
                    points.push(next);
                }
            }
        }
        points
    }
}

/// SplitMix64: a small, good generator, so the point sets need no crate.
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in `[-half, half)`.
    fn symmetric(&mut self, half: f32) -> f32 {
        (2.0 * self.unit() - 1.0) * half
    }

    /// Uniform in `0..n`.
    fn below(&mut self, n: usize) -> usize {
        ((self.next() >> 11) as f64 / (1u64 << 53) as f64 * n as f64) as usize % n
    }

    /// A step of length [`STEP`] in a uniformly random direction.
    fn step(&mut self) -> Vec3 {
        let theta = self.unit() * std::f32::consts::TAU;
        let z = 2.0 * self.unit() - 1.0;
        let r = (1.0 - z * z).max(0.0).sqrt();
        STEP * Vec3::new(r * theta.cos(), r * theta.sin(), z)
    }
}

/// `points` as a binary little-endian PLY of `x y z` floats.
#[must_use]
pub fn ply_bytes(points: &[Vec3]) -> Vec<u8> {
    let header = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
        points.len()
    );
    let mut bytes = Vec::with_capacity(header.len() + 12 * points.len());
    bytes.extend_from_slice(header.as_bytes());
    for p in points {
        for v in p.to_array() {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    bytes
}

/// A scene of the points in the PLY file `ply` (named relative to the
/// scene's folder), blended, seen whole from above one corner.
#[must_use]
pub fn scene_text(ply: &Path, points: &[Vec3], size: (u32, u32)) -> String {
    let model = format!("Points(file: {:?}, radius: {RADIUS})", ply.display().to_string());
    scene_around(points, size, &model)
}

/// A scene of a spline of `n` points through `control` (see
/// [`PointModel::Spline`]), seen whole from above one corner.
#[must_use]
pub fn spline_scene_text(control: &[Vec3], n: usize, size: (u32, u32)) -> String {
    let v = |p: &Vec3| format!("({}, {}, {})", p.x, p.y, p.z);
    let listed: Vec<String> = control.iter().map(v).collect();
    let model = format!("SplinePoints(control: [{}], count: {n}, radius: {RADIUS})", listed.join(", "));
    scene_around(control, size, &model)
}

/// A scene of `model`, framing the points `around`.
fn scene_around(around: &[Vec3], size: (u32, u32), model: &str) -> String {
    let (lo, hi) = around.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let (center, radius) = ((lo + hi) / 2.0, ((hi - lo).length() / 2.0 + RADIUS).max(1.0));
    // Far enough that the bounding sphere fits a 40° view.
    let eye = center + Vec3::new(0.35, 0.45, 1.0).normalize() * radius / (20f32.to_radians().sin());
    let v = |p: Vec3| format!("({}, {}, {})", p.x, p.y, p.z);
    let mut text = String::new();
    let _ = write!(
        text,
        "Scene(\n    camera: Camera(eye: {}, target: {}, fov_y: 40.0),\n    size: ({}, {}),\n    model: {model},\n)\n",
        v(eye),
        v(center),
        size.0,
        size.1,
    );
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_models_have_their_counts_steps_and_spread() {
        for model in [PointModel::Sparse, PointModel::Dense] {
            let points = model.points(5000, 7);
            assert_eq!(points.len(), 5000);
            assert_eq!(points, model.points(5000, 7), "the same seed, the same points");
            // Consecutive points of a chain, and a dense point and its parent, are a step apart.
            let steps = points.windows(2).filter(|w| (w[1].distance(w[0]) - STEP).abs() < 1e-4).count();
            assert!(steps > 5000 * 6 / 10, "{model:?}: {steps} steps");
        }
        let sparse = PointModel::Sparse.points(5000, 1);
        let half = 14.0 * 5f32.cbrt() + 50.0 * STEP;
        assert!(sparse.iter().all(|p| p.abs().max_element() < half));
        assert!(sparse.iter().any(|p| p.x > 14.0) && sparse.iter().any(|p| p.x < -14.0), "spread over the cube");
    }

    #[test]
    fn the_spline_model_is_one_node_of_its_count_with_points_half_a_step_apart() {
        let control = PointModel::Spline.points(100_000, 5);
        assert_eq!(control.len(), 100_000 / SPLINE_SPAN + 2);
        let scene = crate::scene::Scene::parse(&spline_scene_text(&control, 100_000, (64, 48)), "spline").unwrap();
        assert_eq!(scene.model.counts().primitives, 100_000);
        let root = &scene.model.node(scene.model.root()).kind;
        let crate::field::NodeKind::Points { set, .. } = root else { panic!("a spline this long is a point set") };
        let gaps: Vec<f32> = (1..set.len()).map(|i| set.ball(i).0.distance(set.ball(i - 1).0)).collect();
        let mean = gaps.iter().sum::<f32>() / gaps.len() as f32;
        assert!((0.5..1.3).contains(&mean), "the points are {mean} apart");
    }

    #[test]
    fn a_ply_of_the_points_reads_back_as_a_scene_point_file() {
        let dir = std::env::temp_dir().join(format!("blobtrace-point-sets-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let points = PointModel::Dense.points(300, 3);
        std::fs::write(dir.join("p.ply"), ply_bytes(&points)).unwrap();
        let cloud = crate::scene::read_points(&dir.join("p.ply")).unwrap();
        assert_eq!(cloud.positions.len(), 300);
        std::fs::write(dir.join("p.ron"), scene_text(Path::new("p.ply"), &points, (64, 48))).unwrap();
        let scene = crate::scene::Scene::load(dir.join("p.ron")).unwrap();
        assert_eq!(scene.model.counts().primitives, 300);
        std::fs::remove_dir_all(dir).unwrap();
    }
}
