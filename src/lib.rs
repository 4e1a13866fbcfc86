//! blobtrace renders skeletal implicit models (BlobTrees) on the CPU by tracing
//! rays through the field, and compares that exact picture with other ways of
//! showing the same surface.
//!
//! The pipeline runs one way: a scene file becomes a [`field::Model`]; the
//! tracer ([`trace`]) queries it through the [`field::Field`] interface and
//! writes a [`frame::Frame`] of colour and AOVs; the polygonizer ([`mesh`])
//! meshes it and [`bvh`] ray casts the mesh; [`compare`] measures where they
//! differ, and [`draw`] turns what it measures into heat maps, plots and
//! panels. [`pipeline`] joins the stages into the jobs a user runs (render,
//! polygonize, compare, an edit session, regression), with plain settings
//! and a [`progress`] hook; the command line (`cli`) and the previewer
//! (`viewer`) are thin layers over it. Below, one stage by hand:
//!
//! ```
//! use blobtrace::field::{ModelField, EvalMode, Field};
//! use blobtrace::scene::Scene;
//! use blobtrace::trace::{render, RenderSettings};
//!
//! let scene = Scene::parse(
//!     "Scene(camera: Camera(eye: (0.0, 0.0, 4.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
//!            size: (33, 25),
//!            model: Point(center: (0.0, 0.0, 0.0), radius: 1.0))",
//!     "inline",
//! )?;
//! let field = ModelField::new(&scene.model, EvalMode::Indexed);
//! // Inside is where the field exceeds the iso-value T = 0.5.
//! assert!(field.value(glam::Vec3A::ZERO) > field.threshold());
//!
//! let settings = scene.render_settings(scene.size);
//! let (frame, stats) = render(&field, &settings, &|_| {});
//! assert_eq!(stats.rays, 33 * 25);
//! // The centre ray meets the sphere of radius R·sqrt(1 - T^(1/3)) at 4 - 0.4542.
//! let z = frame.depth[12 * 33 + 16];
//! assert!((z - (4.0 - 0.4542)).abs() < 1e-3, "{z}");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod bench;
pub mod bvh;
pub mod cache;
pub mod camera;
#[cfg(feature = "cli")]
pub mod cli;
pub mod compare;
pub mod draw;
pub mod field;
pub mod frame;
pub mod geom;
pub mod mesh;
pub mod output;
pub mod pipeline;
pub mod progress;
pub mod scene;
pub mod slice;
pub mod trace;
#[cfg(feature = "viewer")]
pub mod viewer;
