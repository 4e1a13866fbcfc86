//! The scene file's grammar: serde types that mirror the RON text one to one,
//! both ways (the scene writer serializes them; fields at their defaults are
//! left out, as a person would write the file).

use serde::de::{self, Deserializer};
use serde::{Deserialize, Serialize};

use super::point_files::{LoadedCloud, read_points};
use super::values::{AtLeastOne, Color, Direction, Finite, Name, Positive, Scale, V3};
use crate::cache::{CacheGrid, CacheUse, Filter, Storage};
use crate::camera::LookAt;
use crate::field::{Kernel, ModelError};
use crate::frame::Size;

/// A whole scene file: `Scene(camera: …, size: …, threshold: …, model: …)`.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(rename = "Scene", deny_unknown_fields)]
pub struct SceneDesc {
    /// The viewpoint.
    pub camera: CameraDesc,
    /// Default image size `(width, height)`.
    pub size: Size,
    /// Iso-value `T`; inside is where `f > T`.
    #[serde(default = "half")]
    pub threshold: Positive,
    /// Background colour (linear RGB) of pixels whose ray misses.
    #[serde(default, skip_serializing_if = "Option::is_none", serialize_with = "some")]
    pub background: Option<Color>,
    /// The BlobTree.
    pub model: NodeDesc,
}

/// Most primitives a scene may build: about 7 GB at the peak of loading
/// (ten million points at the particles scene's density; `bench scale`).
pub const MAX_PRIMITIVES: u64 = 10_000_000;

/// Most bytes a scene's caches may allocate up front, before any sample.
pub const MAX_CACHE_TABLE_BYTES: u64 = 2 << 30;

impl SceneDesc {
    /// Reads the particle file of every `Points` node, each path taken
    /// relative to `folder` (the scene file's); `Err` with the file and what
    /// is wrong in it.
    pub fn read_point_files(&mut self, folder: &std::path::Path) -> Result<(), (String, String)> {
        fn visit(node: &mut NodeDesc, folder: &std::path::Path) -> Result<(), (String, String)> {
            if let NodeDesc::Points { file, cloud, .. } = node {
                let path = folder.join(&*file);
                let read = read_points(&path).map_err(|why| (path.display().to_string(), why))?;
                cloud.0 = Some(std::sync::Arc::new(read));
            }
            node.children_mut().into_iter().try_for_each(|c| visit(c, folder))
        }
        visit(&mut self.model, folder)
    }

    /// Checks, before anything is built, that the model fits in memory: its
    /// primitives and the block tables its caches lay down at once.
    pub fn check_size(&self) -> Result<(), ModelError> {
        let primitives = self.model.primitive_count();
        if primitives > MAX_PRIMITIVES {
            return Err(ModelError::TooLarge(format!("{primitives} primitives, more than {MAX_PRIMITIVES}")));
        }
        let tables = self.model.cache_table_bytes();
        if tables > MAX_CACHE_TABLE_BYTES {
            let gib = |b: u64| b as f64 / f64::from(1u32 << 30);
            return Err(ModelError::TooLarge(format!(
                "its caches would lay down {:.1} GiB of block tables at once, more than {:.0} GiB: lower their res",
                gib(tables),
                gib(MAX_CACHE_TABLE_BYTES)
            )));
        }
        Ok(())
    }
}

/// Writes an optional field's value bare (scene files read `color: (…)`, not `Some(…)`).
fn some<T: Serialize, S: serde::Serializer>(value: &Option<T>, s: S) -> Result<S::Ok, S::Error> {
    match value {
        Some(v) => v.serialize(s),
        None => s.serialize_unit(),
    }
}

fn is_default<T: Default + PartialEq>(v: &T) -> bool {
    *v == T::default()
}

fn is_one(v: &Finite) -> bool {
    v.0 == 1.0
}

fn is_one_positive(v: &Positive) -> bool {
    v.0 == 1.0
}

fn is_zero3(v: &V3) -> bool {
    v.0 == glam::Vec3::ZERO
}

fn is_one3(v: &Scale) -> bool {
    v.0 == glam::Vec3::ONE
}

fn is_y_direction(v: &Direction) -> bool {
    v.0 == glam::Vec3::Y
}

fn is_triquadratic(f: &Filter) -> bool {
    *f == Filter::Triquadratic
}

fn half() -> Positive {
    Positive(0.5)
}

fn one() -> Finite {
    Finite(1.0)
}

fn one_positive() -> Positive {
    Positive(1.0)
}

/// A warp's axis as scene files name it.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(deny_unknown_fields)]
pub enum AxisDesc {
    /// X.
    X,
    /// Y.
    #[default]
    Y,
    /// Z.
    Z,
}

impl From<AxisDesc> for crate::field::Axis {
    fn from(a: AxisDesc) -> Self {
        match a {
            AxisDesc::X => Self::X,
            AxisDesc::Y => Self::Y,
            AxisDesc::Z => Self::Z,
        }
    }
}

fn zero3() -> V3 {
    V3(glam::Vec3::ZERO)
}

fn one3() -> Scale {
    Scale(glam::Vec3::ONE)
}

fn y_axis() -> V3 {
    V3(glam::Vec3::Y)
}

fn y_direction() -> Direction {
    Direction(glam::Vec3::Y)
}

/// `Camera(eye: …, target: …, up: …, fov_y: …)`: a look-at pinhole camera.
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(try_from = "RawCamera", rename = "Camera")]
pub struct CameraDesc {
    /// Eye position.
    pub eye: V3,
    /// Point looked at.
    pub target: V3,
    /// Up direction (need not be orthogonal to the view direction).
    pub up: V3,
    /// Vertical field of view in degrees, in `(0, 180)`.
    pub fov_y: Positive,
}

#[derive(Debug, Deserialize)]
#[serde(rename = "Camera", deny_unknown_fields)]
struct RawCamera {
    eye: V3,
    target: V3,
    #[serde(default = "y_axis")]
    up: V3,
    fov_y: Positive,
}

impl TryFrom<RawCamera> for CameraDesc {
    type Error = String;
    fn try_from(r: RawCamera) -> Result<Self, String> {
        LookAt { eye: r.eye.0, target: r.target.0, up: r.up.0, fov_y: r.fov_y.0 }.check()?;
        Ok(CameraDesc { eye: r.eye, target: r.target, up: r.up, fov_y: r.fov_y })
    }
}

/// Most nodes a path from the model's root down to a primitive may pass
/// through. Parsing, building and evaluating a model recurse once a level;
/// this many levels fit the stacks they run on with room to spare.
pub const MAX_DEPTH: usize = 512;

thread_local! {
    /// Nodes being read on this thread, from the root to the one being read.
    static DEPTH: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// One level of nodes being read, counted in [`DEPTH`] while it lives.
struct Level;

impl Level {
    /// Enters a node's level, or refuses one past [`MAX_DEPTH`] where it begins.
    fn enter<E: de::Error>() -> Result<Level, E> {
        DEPTH.with(|depth| {
            if depth.get() >= MAX_DEPTH {
                return Err(E::custom(format!("the model nests deeper than {MAX_DEPTH} nodes")));
            }
            depth.set(depth.get() + 1);
            Ok(Level)
        })
    }
}

impl Drop for Level {
    fn drop(&mut self) {
        DEPTH.with(|depth| depth.set(depth.get() - 1));
    }
}

/// A node of the BlobTree as written in a scene file. (The derived grammar
/// is wrapped by the impls below, which count the levels of nodes.)
#[derive(Clone, Debug, PartialEq, Deserialize, Serialize)]
#[serde(remote = "Self", rename = "node", deny_unknown_fields)]
pub enum NodeDesc {
    /// A point skeleton: a blob.
    Point {
        /// The point.
        center: V3,
        /// Support radius.
        radius: Positive,
        /// Field weight.
        #[serde(default = "one", skip_serializing_if = "is_one")]
        weight: Finite,
        /// Falloff.
        #[serde(default, skip_serializing_if = "is_default")]
        kernel: Kernel,
        /// Surface colour.
        #[serde(default, skip_serializing_if = "Option::is_none", serialize_with = "some")]
        color: Option<Color>,
    },
    /// A segment skeleton: a capsule.
    Segment {
        /// First end.
        a: V3,
        /// Second end.
        b: V3,
        /// Support radius.
        radius: Positive,
        /// Field weight.
        #[serde(default = "one", skip_serializing_if = "is_one")]
        weight: Finite,
        /// Falloff.
        #[serde(default, skip_serializing_if = "is_default")]
        kernel: Kernel,
        /// Surface colour.
        #[serde(default, skip_serializing_if = "Option::is_none", serialize_with = "some")]
        color: Option<Color>,
    },
    /// A circle skeleton: a torus.
    Circle {
        /// Centre of the circle.
        center: V3,
        /// Normal of the circle's plane (any non-zero length).
        #[serde(default = "y_direction", skip_serializing_if = "is_y_direction")]
        normal: Direction,
        /// Radius of the circle itself.
        ring: Positive,
        /// Support radius around the circle.
        radius: Positive,
        /// Field weight.
        #[serde(default = "one", skip_serializing_if = "is_one")]
        weight: Finite,
        /// Falloff.
        #[serde(default, skip_serializing_if = "is_default")]
        kernel: Kernel,
        /// Surface colour.
        #[serde(default, skip_serializing_if = "Option::is_none", serialize_with = "some")]
        color: Option<Color>,
    },
    /// `count` points spaced evenly along a Catmull-Rom spline through `control`,
    /// blended: how the paper builds the Medusa model.
    SplinePoints {
        /// Control points the spline passes through.
        control: Vec<V3>,
        /// Number of point primitives.
        count: Count,
        /// Support radius of each point (at the start of the spline).
        radius: Positive,
        /// Support radius at the end; radii taper linearly when given.
        #[serde(default, skip_serializing_if = "Option::is_none", serialize_with = "some")]
        radius_end: Option<Positive>,
        /// Field weight of each point.
        #[serde(default = "one", skip_serializing_if = "is_one")]
        weight: Finite,
        /// Surface colour.
        #[serde(default, skip_serializing_if = "Option::is_none", serialize_with = "some")]
        color: Option<Color>,
    },
    /// Points read from a particle file (PLY, XYZ or CSV text, or NumPy
    /// `.npy`), blended; per-point radii, weights and colours in the file
    /// override the node's.
    Points {
        /// The file, relative to the scene file's folder.
        file: String,
        /// Support radius of each point the file gives none.
        radius: Positive,
        /// Field weight of each point the file gives none.
        #[serde(default = "one", skip_serializing_if = "is_one")]
        weight: Finite,
        /// Falloff.
        #[serde(default, skip_serializing_if = "is_default")]
        kernel: Kernel,
        /// Surface colour of the points the file gives none.
        #[serde(default, skip_serializing_if = "Option::is_none", serialize_with = "some")]
        color: Option<Color>,
        /// The points, once read (see [`SceneDesc::read_point_files`]).
        #[serde(skip)]
        cloud: LoadedCloud,
    },
    /// Sum of the children.
    Blend(Children),
    /// `max` of the children.
    Union(Children),
    /// `min` of the children.
    Intersection(Children),
    /// The first child with the second carved out.
    Difference(Box<NodeDesc>, Box<NodeDesc>),
    /// Ricci's blend with exponent `n`, read by place or by name.
    #[serde(deserialize_with = "ricci_fields")]
    Ricci {
        /// Exponent, at least 1.
        n: AtLeastOne,
        /// Children.
        children: Children,
    },
    /// The child placed by `translate · rotate · scale`.
    Transform {
        /// Translation.
        #[serde(default = "zero3", skip_serializing_if = "is_zero3")]
        translate: V3,
        /// Rotation in degrees about X, then Y, then Z.
        #[serde(default = "zero3", skip_serializing_if = "is_zero3")]
        rotate: V3,
        /// Per-axis scale, non-zero.
        #[serde(default = "one3", skip_serializing_if = "is_one3")]
        scale: Scale,
        /// The placed subtree.
        child: Box<NodeDesc>,
        /// Surface colour.
        #[serde(default, skip_serializing_if = "Option::is_none", serialize_with = "some")]
        color: Option<Color>,
    },
    /// The child twisted about an axis: turned by `rate · h` radians at height `h`.
    Twist {
        /// The axis (default `Y`).
        #[serde(default)]
        axis: AxisDesc,
        /// Radians per scene unit.
        rate: Finite,
        /// The twisted subtree.
        child: Box<NodeDesc>,
    },
    /// The child's cross-sections scaled from `scale_from` at `from` to `scale_to` at `to` along an axis.
    Taper {
        /// The axis (default `Y`).
        #[serde(default)]
        axis: AxisDesc,
        /// Where the ramp starts.
        from: Finite,
        /// Where it ends, above `from`.
        to: Finite,
        /// Scale at and below `from` (default 1).
        #[serde(default = "one_positive", skip_serializing_if = "is_one_positive")]
        scale_from: Positive,
        /// Scale at and above `to`.
        scale_to: Positive,
        /// The tapered subtree.
        child: Box<NodeDesc>,
    },
    /// The child's X axis bent onto a circle of radius `1/rate` in the XY plane.
    Bend {
        /// Curvature (toward +Y when positive); 0 is the identity.
        rate: Finite,
        /// The bent subtree.
        child: Box<NodeDesc>,
    },
    /// A named subtree, for edits.
    Named(Name, Box<NodeDesc>),
    /// A cache of the child's field.
    Cache {
        /// Grid resolution along the longest side.
        res: Resolution,
        /// Reconstruction filter for values (default tri-linear).
        #[serde(default, skip_serializing_if = "is_default")]
        value: Filter,
        /// Reconstruction filter for gradients (default tri-quadratic).
        #[serde(default = "triquadratic", skip_serializing_if = "is_triquadratic")]
        gradient: Filter,
        /// Sample storage (default four-byte floats).
        #[serde(default, skip_serializing_if = "is_default")]
        storage: Storage,
        /// Whether auto mode answers from the lattice: `Auto` (the cost
        /// model decides, the default), `Always` or `Never`.
        #[serde(default, rename = "use", skip_serializing_if = "is_default")]
        usage: CacheUse,
        /// The cached subtree.
        child: Box<NodeDesc>,
    },
}

impl<'de> Deserialize<'de> for NodeDesc {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let _level = Level::enter()?;
        NodeDesc::deserialize(d)
    }
}

impl Serialize for NodeDesc {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        NodeDesc::serialize(self, s)
    }
}

/// `Ricci(n, [children])` or `Ricci(n: …, children: […])`: the exponent and
/// the children, by place or by name (the variant's contents, unwrapped).
fn ricci_fields<'de, D: Deserializer<'de>>(d: D) -> Result<(AtLeastOne, Children), D::Error> {
    d.deserialize_any(RicciVisitor)
}

/// Reads Ricci's values in either form.
struct RicciVisitor;

/// Ricci's values by name.
#[derive(Deserialize)]
#[serde(rename = "Ricci", deny_unknown_fields)]
struct RicciByName {
    n: AtLeastOne,
    children: Children,
}

impl<'de> de::Visitor<'de> for RicciVisitor {
    type Value = (AtLeastOne, Children);

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("Ricci's exponent and children: Ricci(n, [children]) or Ricci(n: …, children: […])")
    }

    fn visit_seq<A: de::SeqAccess<'de>>(self, seq: A) -> Result<Self::Value, A::Error> {
        Deserialize::deserialize(de::value::SeqAccessDeserializer::new(seq))
    }

    fn visit_map<A: de::MapAccess<'de>>(self, map: A) -> Result<Self::Value, A::Error> {
        let r = RicciByName::deserialize(de::value::MapAccessDeserializer::new(map))?;
        Ok((r.n, r.children))
    }
}

/// The one match over which kinds of node have children and where they are:
/// [`NodeDesc::children`] expands it with `iter`, [`NodeDesc::children_mut`]
/// with `iter_mut` (Rust cannot be generic over a borrow's mutability), so a
/// new kind of node is placed here once. The leaves are listed, not matched
/// by `_`, so a new kind cannot be forgotten.
macro_rules! child_slots {
    ($node:expr, $iter:ident) => {
        match $node {
            NodeDesc::Blend(c)
            | NodeDesc::Union(c)
            | NodeDesc::Intersection(c)
            | NodeDesc::Ricci { children: c, .. } => c.0.$iter().collect(),
            NodeDesc::Difference(a, b) => vec![a, b],
            NodeDesc::Transform { child, .. }
            | NodeDesc::Twist { child, .. }
            | NodeDesc::Taper { child, .. }
            | NodeDesc::Bend { child, .. }
            | NodeDesc::Named(_, child)
            | NodeDesc::Cache { child, .. } => vec![child],
            NodeDesc::Point { .. }
            | NodeDesc::Segment { .. }
            | NodeDesc::Circle { .. }
            | NodeDesc::SplinePoints { .. }
            | NodeDesc::Points { .. } => vec![],
        }
    };
}

impl NodeDesc {
    /// The nodes right below this one, in the order the file writes them.
    #[must_use]
    pub fn children(&self) -> Vec<&NodeDesc> {
        child_slots!(self, iter)
    }

    /// The nodes right below this one, to change them.
    pub fn children_mut(&mut self) -> Vec<&mut NodeDesc> {
        child_slots!(self, iter_mut)
    }

    /// Nodes in this subtree, itself included.
    #[must_use]
    pub fn node_count(&self) -> usize {
        1 + self.children().iter().map(|c| c.node_count()).sum::<usize>()
    }

    /// True when this subtree holds a `Cache` node.
    #[must_use]
    pub fn holds_cache(&self) -> bool {
        matches!(self, NodeDesc::Cache { .. }) || self.children().iter().any(|c| c.holds_cache())
    }

    /// Primitives this subtree builds (a spline generator builds `count`).
    #[must_use]
    pub fn primitive_count(&self) -> u64 {
        match self {
            NodeDesc::SplinePoints { count, .. } => u64::from(count.0),
            NodeDesc::Points { cloud, .. } => cloud.0.as_ref().map_or(0, |c| c.positions.len() as u64),
            node if node.children().is_empty() => 1,
            node => node.children().iter().map(|c| c.primitive_count()).sum(),
        }
    }

    /// Bytes the caches of this subtree allocate up front (see [`CacheGrid::table_bytes_at`]).
    #[must_use]
    pub fn cache_table_bytes(&self) -> u64 {
        let own = match self {
            NodeDesc::Cache { res, .. } => CacheGrid::table_bytes_at(res.0),
            _ => 0,
        };
        own + self.children().iter().map(|c| c.cache_table_bytes()).sum::<u64>()
    }

    /// Calls `f` on the resolution and the value and gradient filters of every
    /// `Cache` in this subtree, so experiments can vary them.
    pub fn for_each_cache(&mut self, f: &mut impl FnMut(&mut Resolution, &mut Filter, &mut Filter)) {
        if let NodeDesc::Cache { res, value, gradient, .. } = self {
            f(res, value, gradient);
        }
        for child in self.children_mut() {
            child.for_each_cache(f);
        }
    }
}

/// A non-empty list of child nodes.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(transparent)]
pub struct Children(pub Vec<NodeDesc>);

impl<'de> serde::Deserialize<'de> for Children {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = Vec::<NodeDesc>::deserialize(d)?;
        if v.is_empty() {
            return Err(de::Error::custom("an operator needs at least one child, got an empty list"));
        }
        Ok(Children(v))
    }
}

/// Most points a `SplinePoints` node may have.
pub const MAX_SPLINE_POINTS: u64 = 1_000_000;

/// A primitive count in `1..=MAX_SPLINE_POINTS`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(transparent)]
pub struct Count(pub u32);

impl<'de> serde::Deserialize<'de> for Count {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = u32::deserialize(d)?;
        if (1..=MAX_SPLINE_POINTS).contains(&u64::from(v)) {
            Ok(Count(v))
        } else {
            Err(de::Error::custom(format!("count must lie in 1..=1000000, got {v}")))
        }
    }
}

fn triquadratic() -> Filter {
    Filter::Triquadratic
}

/// A cache resolution in `2..=1024` (the block table holds up to 130 blocks per axis).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(transparent)]
pub struct Resolution(pub u32);

impl<'de> serde::Deserialize<'de> for Resolution {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let v = u32::deserialize(d)?;
        if (2..=1024).contains(&v) {
            Ok(Resolution(v))
        } else {
            Err(de::Error::custom(format!("cache resolution must lie in 2..=1024, got {v}")))
        }
    }
}
