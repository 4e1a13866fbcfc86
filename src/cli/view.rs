//! `blobtrace view`: the interactive previewer. A window shows the field
//! render, the mesh render or their depth difference; keys move a named node
//! along the screen or play an edit script, and each move updates only what
//! it changed (the `edit` command's incremental frame: dirty rectangles,
//! local mesh cells, BVH2 triangles, the difference in those rectangles).
//! Other keys orbit and zoom the camera about the model, which renders the
//! images again whole (the empty space and the mesh stay). `--headless` runs the
//! same loop on a list of keys instead of a window and writes the last view,
//! so the previewer runs where there is no display (and under `cargo test`).

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use glam::Vec3;

use super::edit::{EditState, check_names, initial_state, outline, set_camera, step};
use super::mesh::PolygonizeArgs;
use super::{EvalOptions, worker_pool};
use crate::camera::Camera;
use crate::compare::{Rgb8Image, Scale, frame_image};
use crate::field::Edit;
use crate::scene::{Scene, Script, Size, load_script};
use crate::trace::PixelRect;

/// Options of `blobtrace view`.
#[derive(Debug, Args)]
pub struct ViewArgs {
    /// Scene file (RON).
    pub scene: PathBuf,
    /// Image size WIDTHxHEIGHT (default: the scene's).
    #[arg(long, value_parser = super::parse_size)]
    pub size: Option<Size>,
    /// Edit script (RON) whose frames Space steps through.
    #[arg(long)]
    pub script: Option<PathBuf>,
    /// The named node the arrow keys move first (default: the first name).
    #[arg(long)]
    pub node: Option<String>,
    /// Run without a window: apply `--keys` in order, then write the view to `--output`.
    #[arg(long)]
    pub headless: bool,
    /// Keys for `--headless`, comma-separated: left, right, up, down, pageup,
    /// pagedown (move the node), tab (next node), v (next view), space (next
    /// script frame), r (outline the dirty rectangles), a, d, w, s (orbit),
    /// z, x (zoom in, out), p (snapshot).
    #[arg(long, value_delimiter = ',', requires = "headless")]
    pub keys: Vec<String>,
    /// The PNG `--headless` writes at the end; P writes snapshots beside it
    /// (`view-0001.png`, …).
    #[arg(short, long, default_value = "view.png")]
    pub output: PathBuf,
    /// Polygonizer options.
    #[command(flatten)]
    pub polygonize: PolygonizeArgs,
    /// Field evaluation.
    #[command(flatten)]
    pub field: EvalOptions,
}

/// The keys' meanings.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Action {
    /// Move the selected node one step along the screen's right (0), up (1)
    /// or depth away from the viewer (2), in a direction (±1).
    Move(usize, f32),
    /// Select the next named node.
    NextNode,
    /// Show the next view.
    NextView,
    /// Apply the script's next frame.
    NextScriptFrame,
    /// Outline the last frame's dirty rectangles, or stop.
    ToggleRectangles,
    /// Turn the camera about the model's centre: degrees about the up axis
    /// (positive: the camera moves to its right) and towards the up axis.
    Orbit(f32, f32),
    /// Bring the camera this factor of its distance to the model's centre.
    Zoom(f32),
    /// Write the view to the next numbered file beside `--output`.
    Snapshot,
}

/// Degrees an orbit key turns the camera.
const ORBIT_DEGREES: f32 = 10.0;
/// The factor a zoom key moves the camera in by (its inverse, out).
const ZOOM_FACTOR: f32 = 0.9;

/// Every key: its name for `--keys`, the window's key, and what it does.
const KEYS: [(&str, minifb::Key, Action); 17] = {
    use minifb::Key;
    [
        ("left", Key::Left, Action::Move(0, -1.0)),
        ("right", Key::Right, Action::Move(0, 1.0)),
        ("down", Key::Down, Action::Move(1, -1.0)),
        ("up", Key::Up, Action::Move(1, 1.0)),
        ("pagedown", Key::PageDown, Action::Move(2, -1.0)),
        ("pageup", Key::PageUp, Action::Move(2, 1.0)),
        ("tab", Key::Tab, Action::NextNode),
        ("v", Key::V, Action::NextView),
        ("space", Key::Space, Action::NextScriptFrame),
        ("r", Key::R, Action::ToggleRectangles),
        ("a", Key::A, Action::Orbit(-ORBIT_DEGREES, 0.0)),
        ("d", Key::D, Action::Orbit(ORBIT_DEGREES, 0.0)),
        ("w", Key::W, Action::Orbit(0.0, ORBIT_DEGREES)),
        ("s", Key::S, Action::Orbit(0.0, -ORBIT_DEGREES)),
        ("z", Key::Z, Action::Zoom(ZOOM_FACTOR)),
        ("x", Key::X, Action::Zoom(1.0 / ZOOM_FACTOR)),
        ("p", Key::P, Action::Snapshot),
    ]
};

impl Action {
    /// The action of a key named on the command line.
    fn named(key: &str) -> anyhow::Result<Self> {
        let key = key.trim().to_lowercase();
        KEYS.iter().find(|(name, ..)| *name == key).map(|&(.., action)| action).with_context(|| {
            let names: Vec<&str> = KEYS.iter().map(|(name, ..)| *name).collect();
            format!("--keys: unknown key {key:?} (known: {})", names.join(", "))
        })
    }

    /// The action of a key pressed in the window.
    fn of_key(key: minifb::Key) -> Option<Self> {
        KEYS.iter().find(|(_, k, _)| *k == key).map(|&(.., action)| action)
    }
}

/// What the window shows.
#[derive(Clone, Copy, Debug, PartialEq)]
enum View {
    Field,
    Mesh,
    /// Mesh depth less field depth, red where the mesh lies behind.
    Difference,
}

/// Moves through a model's edits one key at a time, keeping every image up to date.
struct Viewer {
    scene: Scene,
    state: EditState,
    /// The named nodes, sorted; the arrow keys move `names[selected]`.
    names: Vec<String>,
    selected: usize,
    view: View,
    /// The arrow keys' step: a fiftieth of the model's first bounding diagonal.
    step_length: f32,
    script: Script,
    next_script_frame: usize,
    frames: usize,
    /// The last frame's time and dirty fraction.
    last: Option<(f64, f64)>,
    /// The last frame's dirty rectangles, and whether the view outlines them.
    dirty: (Vec<PixelRect>, bool),
    orbit: Orbit,
    /// Where snapshots go (numbered from this name), and how many were taken.
    snapshots: (PathBuf, usize),
}

/// The camera as it orbits the model's first centre: its eye, the up axis it
/// keeps, and its field of view.
struct Orbit {
    centre: Vec3,
    eye: Vec3,
    up: Vec3,
    fov_y: f32,
}

/// Closest the camera's view comes to the up axis, in degrees.
const MIN_POLE_DEGREES: f32 = 5.0;

impl Orbit {
    fn new(camera: &Camera, centre: Vec3) -> Self {
        let fov_y = 2.0 * camera.tan_half_fov().atan().to_degrees();
        Self { centre, eye: camera.eye.into(), up: camera.up().into(), fov_y }
    }

    /// Applies an orbit or zoom and returns the camera looking at the centre.
    fn moved(&mut self, action: Action) -> Camera {
        let offset = self.eye - self.centre;
        let offset = match action {
            Action::Orbit(yaw, pitch) => {
                let turned = glam::Quat::from_axis_angle(self.up, yaw.to_radians()) * offset;
                let right = turned.cross(self.up).normalize_or_zero();
                // Stop short of the poles, where the view would flip over.
                let from_up = turned.angle_between(self.up).to_degrees();
                let pitch = pitch.clamp(from_up - (180.0 - MIN_POLE_DEGREES), from_up - MIN_POLE_DEGREES);
                glam::Quat::from_axis_angle(right, pitch.to_radians()) * turned
            }
            Action::Zoom(factor) => offset * factor,
            _ => offset,
        };
        self.eye = self.centre + offset;
        Camera::look_at(self.eye, self.centre, self.up, self.fov_y)
    }
}

impl Viewer {
    fn new(
        scene: Scene,
        state: EditState,
        script: Script,
        node: Option<&str>,
        snapshot_path: PathBuf,
    ) -> anyhow::Result<Self> {
        let names: Vec<String> = scene.model.names().into_iter().map(String::from).collect();
        let selected = match node {
            Some(n) => names.iter().position(|m| m == n).with_context(|| match names.is_empty() {
                true => format!("--node: no node is named {n:?} (the scene names none)"),
                false => format!("--node: no node is named {n:?} (names: {})", names.join(", ")),
            })?,
            None => 0,
        };
        let bounds = scene.model.bounds();
        let step_length = bounds.diagonal() / 50.0;
        let orbit = Orbit::new(&state.settings.camera, bounds.center().into());
        Ok(Self {
            scene,
            state,
            names,
            selected,
            view: View::Field,
            step_length,
            script,
            next_script_frame: 0,
            frames: 0,
            last: None,
            dirty: (vec![], false),
            orbit,
            snapshots: (snapshot_path, 0),
        })
    }

    /// Carries out `action`; a move the frame's work cannot take (a node
    /// carried too far for the mesh lattice) is taken back and reported.
    fn act(&mut self, action: Action) -> anyhow::Result<()> {
        match action {
            Action::Move(axis, sign) => {
                let Some(node) = self.names.get(self.selected).cloned() else {
                    eprintln!("the scene names no node to move");
                    return Ok(());
                };
                let by = Vec3::from(self.screen_axis(axis) * (sign * self.step_length));
                let bounds = |v: &Self| v.scene.model.find(&node).map(|id| v.scene.model.node(id).bounds);
                let before = bounds(self);
                if let Err(e) = self.apply(&[Edit::Translate { node: node.clone(), by }]) {
                    eprintln!("move refused: {e:#}");
                    // Refused after the model moved (by the frame's checks): move it back.
                    if bounds(self) != before {
                        self.apply(&[Edit::Translate { node, by: -by }]).context("taking the refused move back")?;
                    }
                }
            }
            Action::NextNode => self.selected = (self.selected + 1) % self.names.len().max(1),
            Action::NextView => {
                self.view = match self.view {
                    View::Field => View::Mesh,
                    View::Mesh => View::Difference,
                    View::Difference => View::Field,
                }
            }
            Action::NextScriptFrame => {
                if let Some(edits) = self.script.frames.get(self.next_script_frame).cloned() {
                    self.apply(&edits).with_context(|| self.script.frame_label(self.next_script_frame))?;
                    self.next_script_frame += 1;
                }
            }
            Action::ToggleRectangles => self.dirty.1 = !self.dirty.1,
            Action::Snapshot => {
                self.snapshots.1 += 1;
                let path = numbered(&self.snapshots.0, self.snapshots.1);
                self.image().save_png(&path)?;
                eprintln!("wrote {}", path.display());
            }
            Action::Orbit(..) | Action::Zoom(_) => {
                let camera = self.orbit.moved(action);
                set_camera(&self.scene, &mut self.state, camera);
                self.dirty.0.clear();
            }
        }
        Ok(())
    }

    /// The camera's right (0), up (1) or forward (2) direction: a move is
    /// along the screen whichever way the camera has turned.
    fn screen_axis(&self, axis: usize) -> glam::Vec3A {
        let camera = &self.state.settings.camera;
        [camera.right(), camera.up(), camera.forward()][axis]
    }

    /// One incremental frame.
    fn apply(&mut self, edits: &[Edit]) -> anyhow::Result<()> {
        let (row, rects) = step(&mut self.scene, &mut self.state, edits, self.frames)?;
        self.dirty.0 = rects;
        self.frames += 1;
        self.last = Some((row.incremental_s, row.dirty_fraction));
        Ok(())
    }

    /// The current view, as an image of the render's size.
    fn image(&self) -> Rgb8Image {
        let mut image = self.view_image();
        if self.dirty.1 {
            outline(&mut image, &self.dirty.0);
        }
        image
    }

    fn view_image(&self) -> Rgb8Image {
        match self.view {
            View::Field => frame_image(&self.state.field_frame),
            View::Mesh => frame_image(&self.state.mesh_frame),
            View::Difference => {
                let (w, h) = (self.state.field_frame.width, self.state.field_frame.height);
                // A lattice cell either way is the strongest colour.
                let scale = Scale::Signed { max: self.state.polygonizer.lattice().cell };
                let pixels = self.state.depth_diff.iter().flat_map(|&d| scale.color(d)).collect();
                Rgb8Image { width: w, height: h, pixels }
            }
        }
    }

    /// The window's title: what is shown and what the last frame cost.
    fn title(&self) -> String {
        let view = match self.view {
            View::Field => "field",
            View::Mesh => "mesh",
            View::Difference => "mesh − field depth (±1 cell)",
        };
        let node = self.names.get(self.selected).map_or("no named node", String::as_str);
        let last = self.last.map_or(String::new(), |(s, dirty)| {
            format!(" · frame {}: {:.1} ms, {:.1}% dirty", self.frames, 1e3 * s, 100.0 * dirty)
        });
        format!("blobtrace view · {view} · moving {node}{last}")
    }
}

/// Runs `blobtrace view`.
pub fn run(a: &ViewArgs) -> anyhow::Result<()> {
    let actions = a.keys.iter().map(|k| Action::named(k)).collect::<anyhow::Result<Vec<_>>>()?;
    super::check_output_file(&a.output, "png")?;
    let mut scene = Scene::load(&a.scene)?;
    let mode = a.field.apply(&mut scene.model)?;
    a.polygonize.check_unrefined(&scene, "view")?;
    let script = match &a.script {
        Some(path) => {
            let script = load_script(path)?;
            check_names(&scene, &script)?;
            script
        }
        None => Script::default(),
    };
    let size = a.size.unwrap_or(scene.size);
    // The window stays on this thread (some systems draw windows from the
    // main thread alone); the frames' work runs on the pool.
    let pool = worker_pool(None)?;
    let state = pool.install(|| initial_state(&scene, mode, size, &a.polygonize));
    let mut viewer = Viewer::new(scene, state, script, a.node.as_deref(), a.output.clone())?;
    if a.headless {
        for action in actions {
            pool.install(|| viewer.act(action))?;
        }
        eprintln!("{}", viewer.title());
        viewer.image().save_png(&a.output)
    } else {
        show(&mut viewer, &pool)
    }
}

/// `dir/stem-NNNN.png` for `dir/stem.png` (checked to end in `.png`).
fn numbered(path: &std::path::Path, n: usize) -> PathBuf {
    let stem = path.file_stem().unwrap_or_default().to_string_lossy();
    path.with_file_name(format!("{stem}-{n:04}.png"))
}

/// The window loop: keys in, the current view out, until the window closes or Escape.
fn show(viewer: &mut Viewer, pool: &rayon::ThreadPool) -> anyhow::Result<()> {
    use minifb::{Key, KeyRepeat, Window, WindowOptions};
    let image = viewer.image();
    let (w, h) = (image.width as usize, image.height as usize);
    let mut window = Window::new(&viewer.title(), w, h, WindowOptions::default()).map_err(|e| {
        anyhow::anyhow!("could not open a window ({e}); where there is no display, run with --headless --keys …")
    })?;
    window.set_target_fps(60);
    let mut buffer = to_window_pixels(&image);
    while window.is_open() && !window.is_key_down(Key::Escape) {
        let actions: Vec<Action> =
            window.get_keys_pressed(KeyRepeat::Yes).into_iter().filter_map(Action::of_key).collect();
        if !actions.is_empty() {
            for action in actions {
                pool.install(|| viewer.act(action))?;
            }
            buffer = to_window_pixels(&viewer.image());
            window.set_title(&viewer.title());
        }
        window.update_with_buffer(&buffer, w, h).context("drawing the window")?;
    }
    Ok(())
}

/// `0RGB` words, as the window takes them.
fn to_window_pixels(image: &Rgb8Image) -> Vec<u32> {
    image.pixels.chunks_exact(3).map(|p| u32::from_be_bytes([0, p[0], p[1], p[2]])).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::mesh::{CellsArg, VertexArg};
    use crate::field::{EvalMode, ModelField};
    use crate::mesh::{Polygonizer, canonical_triangles, skeleton_seeds};
    use crate::trace::render_model;

    const SCENE: &str = "Scene(
        camera: Camera(eye: (0.0, 0.5, 5.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
        size: (48, 36),
        model: Blend([
            Named(\"left\", Point(center: (-0.6, 0.0, 0.0), radius: 1.0)),
            Named(\"right\", Cache(res: 32, child: Point(center: (0.6, 0.0, 0.0), radius: 1.0))),
        ]),
    )";

    fn viewer(mode: EvalMode) -> (Viewer, PolygonizeArgs) {
        let scene = Scene::parse(SCENE, "inline").unwrap();
        let polygonize = PolygonizeArgs { res: 24, cells: CellsArg::Cubes, vertex: VertexArg::Root, refine: 0 };
        let state = initial_state(&scene, mode, scene.size, &polygonize);
        let snapshots = std::env::temp_dir().join(format!("blobtrace-view-test-{}.png", std::process::id()));
        (Viewer::new(scene, state, Script::default(), None, snapshots).unwrap(), polygonize)
    }

    #[test]
    fn after_moves_by_key_the_views_equal_a_render_and_a_mesh_from_scratch() {
        for mode in [EvalMode::Indexed, EvalMode::Cached] {
            let (mut v, polygonize) = viewer(mode);
            let keys = ["right", "right", "a", "up", "tab", "w", "left", "z", "pagedown", "tab", "down"];
            // Where each move should take its node: along the screen as the camera then was.
            let mut expected = [glam::Vec3A::ZERO; 2];
            for key in keys {
                let action = Action::named(key).unwrap();
                if let Action::Move(axis, sign) = action {
                    expected[v.selected] += v.screen_axis(axis) * sign * v.step_length;
                }
                v.act(action).unwrap();
            }
            assert_eq!(v.frames, 6, "every move is a frame; tab is none");
            let full = render_model(&v.scene.model, mode, &v.state.settings, &|_| {}).0;
            assert!(full.same_image(&v.state.field_frame), "{mode:?}: the field view differs from a full render");
            let mut fresh = Polygonizer::new(v.state.polygonizer.lattice(), polygonize.options());
            let field = ModelField::new(&v.scene.model, mode);
            fresh.polygonize(&field, &skeleton_seeds(&v.scene.model, v.scene.model.root()));
            assert_eq!(fresh.mesh().triangle_set(), canonical_triangles(v.state.dynamic.triangles()));
            // The moves went where the keys said.
            let centre =
                |model: &crate::field::Model, name: &str| model.node(model.find(name).unwrap()).bounds.center();
            let start = Scene::parse(SCENE, "inline").unwrap();
            for (name, expected) in ["left", "right"].iter().zip(expected) {
                let moved = centre(&v.scene.model, name) - centre(&start.model, name);
                assert!((moved - expected).length() < 1e-5, "{name}: {moved} against {expected}");
                assert!(expected.length() > 0.5 * v.step_length, "{name} moved");
            }
        }
    }

    #[test]
    fn a_move_too_far_is_refused_and_leaves_the_views_consistent() {
        let (mut v, _) = viewer(EvalMode::Cached);
        let start = v.scene.model.node(v.scene.model.find("left").unwrap()).bounds;
        // Far past where a model may reach (a thousand times its size).
        v.step_length = 1.0e5;
        v.act(Action::Move(0, 1.0)).unwrap();
        let now = v.scene.model.node(v.scene.model.find("left").unwrap()).bounds;
        assert!((now.center() - start.center()).length() < 0.02, "{start:?} -> {now:?}");
        let full = render_model(&v.scene.model, EvalMode::Cached, &v.state.settings, &|_| {}).0;
        assert!(full.same_image(&v.state.field_frame));
    }

    #[test]
    fn orbit_keys_turn_the_camera_about_the_centre_and_stop_short_of_the_pole() {
        let camera = Camera::look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 40.0);
        let mut orbit = Orbit::new(&camera, Vec3::ZERO);
        let right = orbit.moved(Action::Orbit(ORBIT_DEGREES, 0.0));
        assert!(right.eye.x > 0.0 && (right.eye.length() - 5.0).abs() < 1e-4, "d moves the camera to its right");
        let up = orbit.moved(Action::Orbit(0.0, ORBIT_DEGREES));
        assert!(up.eye.y > 0.0 && (up.eye.length() - 5.0).abs() < 1e-4, "w moves the camera up");
        assert!((up.forward() + up.eye.normalize()).length() < 1e-5, "it keeps looking at the centre");
        for _ in 0..30 {
            orbit.moved(Action::Orbit(0.0, ORBIT_DEGREES));
        }
        let top = orbit.moved(Action::Zoom(ZOOM_FACTOR));
        let from_up = top.eye.angle_between(glam::Vec3A::Y).to_degrees();
        assert!((from_up - MIN_POLE_DEGREES).abs() < 1e-3, "{from_up}");
        assert!((top.eye.length() - 5.0 * ZOOM_FACTOR).abs() < 1e-4);
        assert!((top.tan_half_fov() - camera.tan_half_fov()).abs() < 1e-6);
    }

    #[test]
    fn the_views_cycle_and_differ_and_unknown_keys_are_refused() {
        let (mut v, _) = viewer(EvalMode::Indexed);
        let field = v.image();
        v.act(Action::NextView).unwrap();
        let mesh = v.image();
        v.act(Action::NextView).unwrap();
        let difference = v.image();
        v.act(Action::NextView).unwrap();
        assert_eq!(v.image().pixels, field.pixels, "three presses come back to the field");
        assert_ne!(mesh.pixels, field.pixels);
        assert_ne!(difference.pixels, field.pixels);
        for image in [&field, &mesh, &difference] {
            assert_eq!((image.width, image.height), (48, 36));
        }
        v.act(Action::Move(0, 1.0)).unwrap();
        let moved = v.image();
        v.act(Action::ToggleRectangles).unwrap();
        let outlined = v.image();
        let yellow = |img: &Rgb8Image| img.pixels.chunks(3).filter(|p| p == &[255, 220, 0]).count();
        assert!(yellow(&outlined) > yellow(&moved), "r outlines the move's dirty rectangles");
        v.act(Action::Snapshot).unwrap();
        let snapshot = numbered(&v.snapshots.0, 1);
        let written = image::open(&snapshot).expect("p writes a snapshot").to_rgb8();
        assert_eq!(written.as_raw(), &outlined.pixels, "the snapshot is the view");
        std::fs::remove_file(snapshot).unwrap();
        let err = Action::named("F13").unwrap_err().to_string();
        assert!(err.contains("unknown key") && err.contains("f13"), "{err}");
    }
}
