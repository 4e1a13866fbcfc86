//! The interactive previewer. A window shows the field render, the mesh
//! render or their depth difference; keys move a named node along the
//! screen or play an edit script, and each move updates only what it
//! changed (an [`EditSession`] frame: dirty rectangles, local mesh cells,
//! BVH2 triangles, the difference in those rectangles). Other keys and the
//! mouse orbit, pan and zoom the camera about the model, which renders the
//! images again whole (the empty space and the mesh stay); a click selects
//! the named node strongest at the surface under the pointer. Views: the
//! field, the mesh, their depth difference, the angle between their normals,
//! and the field evaluations per pixel. A status line, a colour bar over the
//! heat-map views and a help card are drawn over the view (`hud`).
//! Headless, the same loop runs on a list of keys instead of a window, so the
//! previewer runs where there is no display (and under `cargo test`).

mod hud;
mod input;
mod window;
mod worker;

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use glam::Vec3;

use crate::camera::{CameraMove, Orbit};
use crate::compare::{Metric, differences};
use crate::draw::{ColourKey, Rgb8Image, Scale, SpecialLabels};
use crate::field::Edit;
use crate::frame::srgb8_of;
use crate::pipeline::{EditSession, IDLE_SAMPLES, PlaneView, SliceView, outline_dirty, plane_view};
use crate::scene::Script;
use crate::slice::SlicePlane;
use crate::trace::PixelRect;
use hud::StatusPart;

pub use window::show;
pub use worker::background_pool;

/// The keys' meanings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Action {
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
    /// Show or hide the card listing every key.
    ToggleHelp,
    /// Slide the camera and the point it orbits by this many pixels right and down.
    Pan(f32, f32),
    /// Select the named node strongest at the surface under this pixel.
    SelectAt(u32, u32),
    /// Move the slice plane this many steps away from the viewer.
    MoveSlice(f32),
    /// Show the next thing on the slice plane: f, the sharp view, error_C,
    /// the cached gradient's error.
    NextSliceView,
}

/// The normal-error view's full scale: 30°, beyond which pixels are marked.
const NORMAL_ERROR_SCALE: Scale = Scale::Magnitude { max: 30.0 };

/// Degrees of orbit per pixel a mouse drag moves.
pub const DRAG_DEGREES_PER_PIXEL: f32 = 0.4;

/// Degrees an orbit key turns the camera.
const ORBIT_DEGREES: f32 = 10.0;
/// The factor a zoom key moves the camera in by (its inverse, out).
const ZOOM_FACTOR: f32 = 0.9;

/// How the help card says held keys repeat (see [`input::REPEAT_DELAY`]).
const REPEAT_HELP: &str = "moves, orbits, zooms and slice steps repeat after 0.3 s, 20 a second";

/// Every key: its name for `--keys`, the window's key, and what it does.
const KEYS: [(&str, minifb::Key, Action); 22] = {
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
        ("h", Key::H, Action::ToggleHelp),
        ("f1", Key::F1, Action::ToggleHelp),
        ("comma", Key::Comma, Action::MoveSlice(-1.0)),
        ("period", Key::Period, Action::MoveSlice(1.0)),
        ("n", Key::N, Action::NextSliceView),
    ]
};

impl Action {
    /// The action of a key named on the command line, or of a mouse gesture:
    /// `drag:DX:DY` (left button, pixels), `pan:DX:DY` (right button),
    /// `wheel:N` (notches, positive away from the user), `click:X:Y`.
    pub fn named(key: &str) -> anyhow::Result<Self> {
        let key = key.trim().to_lowercase();
        if let Some((gesture, args)) = key.split_once(':') {
            return Self::gesture(gesture, args).with_context(|| format!("--keys: {key:?}"));
        }
        KEYS.iter().find(|(name, ..)| *name == key).map(|&(.., action)| action).with_context(|| {
            let names: Vec<&str> = KEYS.iter().map(|(name, ..)| *name).collect();
            format!("--keys: unknown key {key:?} (known: {})", names.join(", "))
        })
    }

    /// A mouse gesture's action.
    fn gesture(gesture: &str, args: &str) -> anyhow::Result<Self> {
        let numbers: Vec<f32> = args.split(':').map(str::parse).collect::<Result<_, _>>()?;
        let finite = numbers.iter().all(|v| v.is_finite());
        anyhow::ensure!(finite, "the numbers must be finite");
        Ok(match (gesture, numbers.as_slice()) {
            ("drag", &[dx, dy]) => Self::drag(dx, dy),
            ("pan", &[dx, dy]) => Action::Pan(dx, dy),
            ("wheel", &[notches]) => Self::wheel(notches),
            ("click", &[x, y]) if x >= 0.0 && y >= 0.0 => Action::SelectAt(x as u32, y as u32),
            _ => anyhow::bail!("expected drag:DX:DY, pan:DX:DY, wheel:N or click:X:Y"),
        })
    }

    /// The orbit a left-button drag by `dx, dy` pixels makes: the model turns with the pointer.
    #[must_use]
    pub fn drag(dx: f32, dy: f32) -> Self {
        Action::Orbit(-dx * DRAG_DEGREES_PER_PIXEL, dy * DRAG_DEGREES_PER_PIXEL)
    }

    /// The zoom `notches` of the wheel make (positive: in).
    #[must_use]
    pub fn wheel(notches: f32) -> Self {
        Action::Zoom(ZOOM_FACTOR.powf(notches))
    }

    /// Whether a held key repeats the action: moves of the node, the
    /// camera and the slice plane do; switches and toggles do not.
    #[must_use]
    pub fn repeats(self) -> bool {
        matches!(self, Action::Move(..) | Action::Orbit(..) | Action::Zoom(_) | Action::MoveSlice(_))
    }

    /// The one camera move that `self` then `next` make, where both are
    /// orbits, pans or zooms.
    #[must_use]
    pub fn merged_with(self, next: Action) -> Option<Action> {
        match (self, next) {
            (Action::Orbit(a, b), Action::Orbit(c, d)) => Some(Action::Orbit(a + c, b + d)),
            (Action::Pan(a, b), Action::Pan(c, d)) => Some(Action::Pan(a + c, b + d)),
            (Action::Zoom(a), Action::Zoom(b)) => Some(Action::Zoom(a * b)),
            _ => None,
        }
    }

    /// The camera move of an orbit, zoom or pan.
    fn camera_move(self) -> Option<CameraMove> {
        match self {
            Action::Orbit(yaw, pitch) => Some(CameraMove::Orbit(yaw, pitch)),
            Action::Zoom(factor) => Some(CameraMove::Zoom(factor)),
            Action::Pan(dx, dy) => Some(CameraMove::Pan(dx, dy)),
            _ => None,
        }
    }

    /// What the action does, as the help card says it.
    #[must_use]
    pub fn describe(self) -> &'static str {
        match self {
            Action::Move(0, _) => "move the node along the screen",
            Action::Move(1, _) => "move the node up or down the screen",
            Action::Move(..) => "move the node away or nearer",
            Action::NextNode => "move the next named node",
            Action::NextView => "next view: field, mesh, depth and normal differences, cost, slice",
            Action::NextScriptFrame => "apply the script's next frame",
            Action::ToggleRectangles => "outline the last frame's dirty rectangles",
            Action::Orbit(..) => "orbit the camera about the model",
            Action::Zoom(f) if f < 1.0 => "zoom in",
            Action::Zoom(_) => "zoom out",
            Action::Snapshot => "write the view beside --output (numbered)",
            Action::ToggleHelp => "show this card, its next page, or hide it",
            Action::Pan(..) => "pan the camera",
            Action::SelectAt(..) => "select the named node under the pointer",
            Action::MoveSlice(d) if d < 0.0 => "move the slice plane nearer",
            Action::MoveSlice(_) => "move the slice plane away",
            Action::NextSliceView => "slice shows: f, sharp view, error_C, gradient error",
        }
    }

    /// Every key, grouped with the keys that do the same, and what they do.
    #[must_use]
    pub fn help() -> Vec<(String, &'static str)> {
        let mut lines: Vec<(String, &'static str)> = vec![];
        for (name, _, action) in KEYS {
            match lines.last_mut() {
                Some((names, what)) if *what == action.describe() => *names = format!("{names}, {name}"),
                _ => lines.push((name.to_string(), action.describe())),
            }
        }
        lines.extend([
            ("left drag".to_string(), "orbit the camera about the model"),
            ("wheel".to_string(), "zoom in or out"),
            ("right or shift drag".to_string(), "pan the camera"),
            ("click".to_string(), "select the named node under the pointer"),
            ("escape".to_string(), "close the window"),
            ("a held key".to_string(), REPEAT_HELP),
        ]);
        lines
    }
}

/// What the window shows.
#[derive(Clone, Copy, Debug, PartialEq)]
enum View {
    Field,
    Mesh,
    /// Mesh depth less field depth, red where the mesh lies behind.
    Difference,
    /// The angle between the mesh's and the field's normals, on magma.
    NormalError,
    /// Field evaluations per pixel, on magma.
    Cost,
    /// A plane facing the camera through the model: f, the sharp view,
    /// error_C or the cached gradient's error on it.
    Slice,
}

/// The slice view's plane and what it shows.
struct Slice {
    /// Steps the plane lies beyond the point the camera orbits, away from
    /// the viewer (counted, so that moves and their opposites come back to
    /// the same plane).
    steps: i32,
    /// What it shows.
    shows: SliceView,
    /// The picture, drawn when the plane, the camera or the model last changed.
    drawn: Option<PlaneView>,
    /// The model with every cache answering from its lattice, as of frame
    /// number `.0`: error_C and the gradient error show what the caches
    /// would answer, whether or not auto mode uses them.
    lattices: Option<(usize, crate::field::Model)>,
}

/// Moves through a model's edits one key at a time, keeping every image up to date.
pub struct Viewer {
    session: EditSession,
    /// The named nodes, sorted; the arrow keys move `names[selected]`.
    names: Vec<String>,
    selected: usize,
    view: View,
    /// The arrow keys' step: a fiftieth of the model's first bounding diagonal.
    step_length: f32,
    script: Script,
    next_script_frame: usize,
    frames: usize,
    /// The last edit's or camera move's timing.
    last: Option<EventTiming>,
    /// The last frame's dirty rectangles, and whether the view outlines them.
    dirty: (Vec<PixelRect>, bool),
    orbit: Orbit,
    /// Where snapshots go (numbered from this name), and how many were taken.
    snapshots: (PathBuf, usize),
    /// The page of the help card that shows, if it does.
    help: Option<usize>,
    slice: Slice,
}

/// How long the last edit or camera move took to show, coarse and refined.
#[derive(Clone, Debug)]
struct EventTiming {
    /// "frame N" or "camera".
    what: String,
    start: Instant,
    /// Seconds until its first, coarse pass showed.
    first_pass_s: f64,
    /// Seconds until everything was up to date, with the rays traced per
    /// second then and the field evaluations per ray of the image.
    refined_s: Option<(f64, f64, f64)>,
    /// The fraction of the image its dirty rectangles cover, and how many
    /// there are (edits only).
    dirty: Option<(f64, usize)>,
}

impl Viewer {
    /// A viewer of `session`, stepping through `script`, moving `node` first,
    /// snapshots numbered from `snapshot_path`.
    pub fn new(
        session: EditSession,
        script: Script,
        node: Option<&str>,
        snapshot_path: PathBuf,
    ) -> anyhow::Result<Self> {
        let names: Vec<String> = session.scene().model.names().into_iter().map(String::from).collect();
        let selected = match node {
            Some(n) => names.iter().position(|m| m == n).with_context(|| match names.is_empty() {
                true => format!("--node: no node is named {n:?} (the scene names none)"),
                false => format!("--node: no node is named {n:?} (names: {})", names.join(", ")),
            })?,
            None => 0,
        };
        let bounds = session.scene().model.bounds();
        let step_length = bounds.diagonal() / 50.0;
        let camera = session.settings().camera;
        let orbit = Orbit::new(&camera, bounds.center().into(), session.field_frame().height);
        let slice = Slice { steps: 0, shows: SliceView::Field, drawn: None, lattices: None };
        Ok(Self {
            session,
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
            help: None,
            slice,
        })
    }

    /// Carries out `action`; a move the frame's work cannot take (a node
    /// carried too far for the mesh lattice) is taken back and reported.
    pub fn act(&mut self, action: Action) -> anyhow::Result<()> {
        match action {
            Action::Move(axis, sign) => self.move_selected(axis, sign)?,
            Action::NextNode => self.selected = (self.selected + 1) % self.names.len().max(1),
            Action::NextView => {
                self.view = match self.view {
                    View::Field => View::Mesh,
                    View::Mesh => View::Difference,
                    View::Difference => View::NormalError,
                    View::NormalError => View::Cost,
                    View::Cost => View::Slice,
                    View::Slice => View::Field,
                }
            }
            Action::NextScriptFrame => {
                if let Some(edits) = self.script.frames.get(self.next_script_frame).cloned() {
                    self.apply(&edits).with_context(|| self.script.frame_label(self.next_script_frame))?;
                    self.next_script_frame += 1;
                }
            }
            Action::ToggleRectangles => self.dirty.1 = !self.dirty.1,
            Action::ToggleHelp => self.help = self.next_help_page(),
            Action::Snapshot => {
                self.settle();
                self.snapshots.1 += 1;
                let path = numbered(&self.snapshots.0, self.snapshots.1);
                self.image().save_png(&path)?;
                eprintln!("wrote {}", path.display());
            }
            Action::SelectAt(x, y) => self.select_at(x, y),
            Action::MoveSlice(steps) => self.move_slice(steps as i32),
            Action::NextSliceView => self.slice.shows = self.next_slice_view(),
            Action::Orbit(..) | Action::Zoom(_) | Action::Pan(..) => {
                let camera = self.orbit.moved(action.camera_move().expect("a camera action"));
                let start = Instant::now();
                self.session.begin_camera(camera);
                self.last = Some(EventTiming::new("camera", start, None));
                self.dirty.0.clear();
            }
        }
        self.note_refined();
        // Only what moves the plane, the camera or the model, or switches views, draws the slice again.
        if !matches!(
            action,
            Action::ToggleHelp | Action::ToggleRectangles | Action::Snapshot | Action::NextNode | Action::SelectAt(..)
        ) {
            self.draw_slice();
        }
        Ok(())
    }

    /// What the slice shows after what it shows now: error_C and the
    /// gradient error only where the model has caches to compare.
    fn next_slice_view(&self) -> SliceView {
        let caches = self.session.scene().model.counts().caches > 0;
        match self.slice.shows {
            SliceView::Field => SliceView::Sharp,
            SliceView::Sharp if caches => SliceView::Error,
            SliceView::Error => SliceView::Gradient,
            SliceView::Sharp | SliceView::Gradient => SliceView::Field,
        }
    }

    /// Moves the slice plane `steps` away from the viewer, but not to or past the eye.
    fn move_slice(&mut self, steps: i32) {
        self.slice.steps += steps;
        if self.slice_depth() <= 0.01 * self.step_length {
            self.slice.steps -= steps;
        }
    }

    /// The slice plane's distance in front of the eye: through the point
    /// the camera orbits, moved by its steps, and never behind the eye.
    fn slice_depth(&self) -> f32 {
        let camera = &self.session.settings().camera;
        let centre = glam::Vec3A::from(self.orbit.centre());
        let depth = (centre - camera.eye).dot(camera.forward()) + self.slice.steps as f32 * self.step_length;
        depth.max(0.01 * self.step_length)
    }

    /// Draws the slice view again, when it shows.
    fn draw_slice(&mut self) {
        if self.view != View::Slice {
            self.slice.drawn = None;
            return;
        }
        let s = self.session.settings();
        let plane = SlicePlane::facing(&s.camera, s.width, s.height, self.slice_depth());
        let model = &self.session.scene().model;
        let model = match self.slice.shows {
            SliceView::Error | SliceView::Gradient => {
                if self.slice.lattices.as_ref().is_none_or(|(frame, _)| *frame != self.frames) {
                    let mut forced = model.clone();
                    forced.use_lattices(false);
                    self.slice.lattices = Some((self.frames, forced));
                }
                &self.slice.lattices.as_ref().expect("just made").1
            }
            SliceView::Field | SliceView::Sharp => model,
        };
        self.slice.drawn = Some(plane_view(model, &plane, self.slice.shows));
    }

    /// Whether the viewer has work to do while idle: the refinement the
    /// last edits or camera moves left, the tidying that keeps a long
    /// session's cost a fresh one's, then samples to smooth the field view.
    #[must_use]
    pub fn is_refining(&self) -> bool {
        !self.session.is_refined() || !self.session.is_tidy() || self.samples_wanted()
    }

    /// Whether the field view still takes samples to smooth its edges.
    fn samples_wanted(&self) -> bool {
        self.view == View::Field && self.session.samples_taken() < IDLE_SAMPLES
    }

    /// Refines the images for about `budget` (see [`EditSession::refine`]),
    /// or once they are, tidies (see [`EditSession::tidy`]), then adds
    /// samples to the field view.
    pub fn refine(&mut self, budget: std::time::Duration) {
        if !self.session.is_refined() {
            self.session.refine(budget);
        } else if !self.session.is_tidy() {
            self.session.tidy(budget);
        } else if self.samples_wanted() {
            self.session.supersample(budget);
        }
        self.note_refined();
    }

    /// Whether the last edits' and camera moves' images are refined (the
    /// field view's samples aside).
    #[must_use]
    pub fn session_refined(&self) -> bool {
        self.session.is_refined()
    }

    /// The named node the arrow keys move.
    #[must_use]
    pub fn selected_node(&self) -> Option<&str> {
        self.names.get(self.selected).map(String::as_str)
    }

    /// How many edit frames the viewer has applied.
    #[must_use]
    pub fn frames_applied(&self) -> usize {
        self.frames
    }

    /// Finishes every refinement.
    pub fn settle(&mut self) {
        self.session.finish();
        self.note_refined();
    }

    /// Finishes every refinement, the tidying, and the samples of the field
    /// view: what the window shows once left alone.
    pub fn converge(&mut self) {
        self.settle();
        self.session.tidy_all();
        while self.samples_wanted() {
            self.session.supersample(std::time::Duration::from_secs(1));
        }
    }

    /// Records when the last event's images became up to date.
    fn note_refined(&mut self) {
        if let Some(last) = self.last.as_mut().filter(|l| l.refined_s.is_none())
            && self.session.is_refined()
        {
            let evaluations = self.session.field_frame().aov("evals.Y").unwrap_or(&[]);
            let per_ray = evaluations.iter().map(|&e| f64::from(e)).sum::<f64>() / evaluations.len().max(1) as f64;
            last.refined_s = Some((last.start.elapsed().as_secs_f64(), self.session.rays_per_second(), per_ray));
        }
    }

    /// Selects the named node strongest at the surface seen at pixel `x, y`
    /// (nothing changes where the ray missed or no named node reaches).
    fn select_at(&mut self, x: u32, y: u32) {
        let frame = self.session.field_preview();
        if x >= frame.width || y >= frame.height {
            return;
        }
        let depth = frame.depth[(y * frame.width + x) as usize];
        if !depth.is_finite() {
            return;
        }
        let ray = self.session.settings().camera.ray(x, y, frame.width, frame.height);
        let hit = ray.origin + ray.dir * depth;
        let model = &self.session.scene().model;
        if let Some(name) = model.strongest_named_at(hit, self.session.mode()) {
            self.selected = self.names.iter().position(|n| n == name).unwrap_or(self.selected);
        }
    }

    /// Moves the selected node one step along screen axis `axis` in direction
    /// `sign`; a move the frame's checks refuse is taken back and reported.
    fn move_selected(&mut self, axis: usize, sign: f32) -> anyhow::Result<()> {
        let Some(node) = self.names.get(self.selected).cloned() else {
            eprintln!("the scene names no node to move");
            return Ok(());
        };
        let by = Vec3::from(self.screen_axis(axis) * (sign * self.step_length));
        let bounds = |v: &Self| {
            let model = &v.session.scene().model;
            model.find(&node).map(|id| model.node(id).bounds)
        };
        let before = bounds(self);
        if let Err(e) = self.apply(&[Edit::Translate { node: node.clone(), by }]) {
            eprintln!("move refused: {e:#}");
            // Refused after the model moved (by the frame's checks): move it back.
            if bounds(self) != before {
                self.apply(&[Edit::Translate { node, by: -by }]).context("taking the refused move back")?;
            }
        }
        Ok(())
    }

    /// The camera's right (0), up (1) or forward (2) direction: a move is
    /// along the screen whichever way the camera has turned.
    fn screen_axis(&self, axis: usize) -> glam::Vec3A {
        let camera = &self.session.settings().camera;
        [camera.right(), camera.up(), camera.forward()][axis]
    }

    /// One incremental frame, up to its coarse pass.
    fn apply(&mut self, edits: &[Edit]) -> anyhow::Result<()> {
        let start = Instant::now();
        let update = self.session.begin_apply(edits)?;
        self.dirty.0 = update.dirty;
        self.frames += 1;
        let dirty = Some((update.row.dirty_fraction, self.dirty.0.len()));
        self.last = Some(EventTiming::new(&format!("frame {}", self.frames), start, dirty));
        Ok(())
    }

    /// The current view, as an image of the render's size.
    pub fn image(&self) -> Rgb8Image {
        self.outlined(self.view().0)
    }

    /// `image` with the last frame's dirty rectangles outlined, when asked for.
    fn outlined(&self, mut image: Rgb8Image) -> Rgb8Image {
        if self.dirty.1 {
            outline_dirty(&mut image, &self.dirty.0);
        }
        image
    }

    /// What the window shows: the view, and over it the overlay.
    pub fn screen(&self) -> Rgb8Image {
        let (image, key) = self.view();
        let mut image = self.outlined(image);
        for panel in self.overlay(key.as_ref()) {
            hud::draw(&mut image, &panel);
        }
        image
    }

    /// The overlay's panels as laid out for the window: the status band,
    /// then the help card when it shows, or else the colour bar of a
    /// heat-map view with `key`.
    fn overlay(&self, key: Option<&ColourKey>) -> Vec<hud::Panel> {
        let (w, h) = (self.session.settings().width, self.session.settings().height);
        let mut panels = vec![hud::status(w, &self.status_parts())];
        let top = hud::BAND_HEIGHT;
        if let Some(page) = self.help {
            panels.push(self.help_card().panel(page, w, h, top));
        } else if let Some(key) = key {
            panels.extend(hud::colour_bar(w, h, top, key));
        }
        panels
    }

    /// The help card, laid out for the window.
    fn help_card(&self) -> hud::HelpCard {
        let (w, h) = (self.session.settings().width, self.session.settings().height);
        hud::help(w, h, hud::BAND_HEIGHT, &Action::help())
    }

    /// The help card's page after the one showing: the first when hidden,
    /// none (hidden) after the last.
    fn next_help_page(&self) -> Option<usize> {
        match self.help {
            None => Some(0),
            Some(page) => (page + 1 < self.help_card().pages()).then_some(page + 1),
        }
    }

    /// The status line's parts: view, the node the keys move, what the
    /// slice shows, the last frame's or camera move's cost, the pass under
    /// way, the evaluation, and how to get help.
    pub fn status(&self) -> Vec<String> {
        self.status_parts().into_iter().map(|p| p.full).collect()
    }

    /// The status line's parts, most important first, each with its short form.
    fn status_parts(&self) -> Vec<StatusPart> {
        let view = match self.view {
            View::Field => "field",
            View::Mesh => "mesh",
            View::Difference => "depth difference",
            View::NormalError => "normal error",
            View::Cost => "cost",
            View::Slice => "slice",
        };
        let node = self.names.get(self.selected).map_or("no named node", String::as_str);
        let mut parts = vec![StatusPart::new(view), StatusPart::new(format!("moving {node}"))];
        if self.view == View::Slice {
            let (shows, short) = match self.slice.shows {
                SliceView::Field => ("f", "f"),
                SliceView::Sharp => ("sharp: sin(11 pi f), red at the iso-value", "sharp"),
                SliceView::Error => ("error_C", "error_C"),
                SliceView::Gradient => ("gradient error", "gradient error"),
            };
            let depth = self.slice_depth();
            let full = format!("{shows} at depth {depth:.3} (comma, period: move; n: next)");
            parts.push(StatusPart::shortened(full, format!("{short} at {depth:.3}")));
        }
        if let Some(last) = &self.last {
            parts.push(StatusPart::shortened(last.describe(), last.brief()));
        }
        if let Some(pending) = self.session.pending() {
            parts.push(StatusPart::new(pending.to_string()));
        } else if self.view == View::Field && self.session.samples_taken() > 1 {
            let n = self.session.samples_taken();
            parts.push(StatusPart::shortened(format!("{n} samples per pixel"), format!("{n} spp")));
        }
        parts.push(StatusPart::new(format!("{:?}", self.session.mode()).to_lowercase()));
        parts.push(StatusPart::new("H: help"));
        parts
    }

    /// The current view at the render's size, and the colour bar (scale,
    /// metric, unit, special colours) of a heat-map view.
    fn view(&self) -> (Rgb8Image, Option<ColourKey>) {
        let (w, h) = (self.session.settings().width, self.session.settings().height);
        // The special colours mean what they mean in `compare`'s maps:
        // missed by both renders, hit by one only.
        let heat_map = |values: &[f32], (scale, title, unit): (Scale, &'static str, &'static str)| {
            let key = ColourKey::of(values, scale, (title, unit), &SpecialLabels::default());
            (scale.paint(values, w, h), Some(key))
        };
        match self.view {
            View::NormalError => {
                let angles = differences(&self.session.mesh_preview(), &self.session.field_preview(), Metric::Normal);
                heat_map(&angles, (NORMAL_ERROR_SCALE, "angle between mesh and field normals", "deg"))
            }
            View::Cost => {
                let evaluations = self.session.field_frame().aov("evals.Y").unwrap_or(&[]);
                let evaluations = self.session.field_refinement().preview_values(evaluations);
                // The evaluations' 99th percentile, rounded up.
                let scale = Scale::from_data(&evaluations, false, 1.0);
                heat_map(&evaluations, (scale, "field evaluations per pixel", "evaluations"))
            }
            View::Slice => match &self.slice.drawn {
                Some(drawn) => (drawn.image.clone(), drawn.key.clone()),
                None => (Rgb8Image::filled(w, h, [0, 0, 0]), None),
            },
            // The colours alone: a preview of every channel would cost as much again.
            View::Field => (Rgb8Image { width: w, height: h, pixels: srgb8_of(&self.session.field_colors()) }, None),
            View::Mesh => {
                let colors = self.session.mesh_refinement().preview_values(&self.session.mesh_frame().color);
                (Rgb8Image { width: w, height: h, pixels: srgb8_of(&colors) }, None)
            }
            // A lattice cell either way is the strongest colour.
            View::Difference => heat_map(
                &self.session.depth_diff_preview(),
                (
                    Scale::Signed { max: self.session.lattice().cell },
                    "mesh depth - field depth, 1 cell full scale",
                    "scene units",
                ),
            ),
        }
    }

    /// The window's title: the status line's parts.
    pub fn title(&self) -> String {
        format!("blobtrace view · {}", self.status().join(" · "))
    }
}

impl EventTiming {
    /// An event that started at `start` and has just shown its coarse pass.
    fn new(what: &str, start: Instant, dirty: Option<(f64, usize)>) -> Self {
        let first_pass_s = start.elapsed().as_secs_f64();
        Self { what: what.into(), start, first_pass_s, refined_s: None, dirty }
    }

    /// As a narrow status line says it: the first pass and refined milliseconds.
    fn brief(&self) -> String {
        match self.refined_s {
            Some((s, ..)) => format!("{}: {:.0} / {:.0} ms", self.what, 1e3 * self.first_pass_s, 1e3 * s),
            None => format!("{}: {:.0} ms", self.what, 1e3 * self.first_pass_s),
        }
    }

    /// As the status line says it.
    fn describe(&self) -> String {
        let mut text = format!("{}: first pass {:.0} ms", self.what, 1e3 * self.first_pass_s);
        if let Some((s, rays_per_second, per_ray)) = self.refined_s {
            text += &format!(", refined {:.0} ms ({:.1} M rays/s", 1e3 * s, rays_per_second / 1e6);
            text += &format!(", {per_ray:.1} evaluations per ray)");
        }
        if let Some((dirty, rects)) = self.dirty {
            let s = if rects == 1 { "" } else { "s" };
            text += &format!(", {rects} dirty rectangle{s} ({:.1}%)", 100.0 * dirty);
        }
        text
    }
}

/// `dir/stem-NNNN.png` for `dir/stem.png` (checked to end in `.png`).
fn numbered(path: &std::path::Path, n: usize) -> PathBuf {
    let stem = path.file_stem().unwrap_or_default().to_string_lossy();
    path.with_file_name(format!("{stem}-{n:04}.png"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::EvalMode;
    use crate::frame::Size;
    use crate::mesh::canonical_triangles;
    use crate::pipeline::PolygonizeSettings;
    use crate::scene::Scene;
    use crate::trace::render_model;

    const SCENE: &str = "Scene(
        camera: Camera(eye: (0.0, 0.5, 5.0), target: (0.0, 0.0, 0.0), fov_y: 40.0),
        size: (48, 36),
        model: Blend([
            Named(\"left\", Point(center: (-0.6, 0.0, 0.0), radius: 1.0)),
            Named(\"right\", Cache(res: 32, child: Point(center: (0.6, 0.0, 0.0), radius: 1.0))),
        ]),
    )";

    fn viewer(mode: EvalMode) -> (Viewer, PolygonizeSettings) {
        let scene = Scene::parse(SCENE, "inline").unwrap();
        let polygonize = PolygonizeSettings { res: 24, ..Default::default() };
        let size = scene.size;
        let session = EditSession::new(scene, mode, size, &polygonize).unwrap();
        let snapshots = std::env::temp_dir().join(format!("blobtrace-view-test-{}.png", std::process::id()));
        (Viewer::new(session, Script::default(), None, snapshots).unwrap(), polygonize)
    }

    #[test]
    fn after_moves_by_key_the_views_equal_a_render_and_a_mesh_from_scratch() {
        for mode in [EvalMode::Indexed, EvalMode::Cached] {
            let (mut v, polygonize) = viewer(mode);
            let keys = [
                "right",
                "right",
                "a",
                "up",
                "tab",
                "w",
                "left",
                "z",
                "drag:12:-5",
                "pagedown",
                "pan:6:3",
                "tab",
                "wheel:1",
                "down",
            ];
            // Where each move should take its node: along the screen as the camera then was.
            let mut expected = [glam::Vec3A::ZERO; 2];
            for (k, key) in keys.into_iter().enumerate() {
                let action = Action::named(key).unwrap();
                if let Action::Move(axis, sign) = action {
                    expected[v.selected] += v.screen_axis(axis) * sign * v.step_length;
                }
                v.act(action).unwrap();
                // Events come as the last one's passes stand: coarse only, one pass further, or all.
                match k % 3 {
                    0 => {}
                    1 => v.refine(std::time::Duration::ZERO),
                    _ => v.settle(),
                }
            }
            v.settle();
            assert_eq!(v.frames, 6, "every move is a frame; tab is none");
            let s = &v.session;
            let full = render_model(&s.scene().model, mode, s.settings(), &|_| {}).0;
            assert!(full.same_image(s.field_frame()), "{mode:?}: the field view differs from a full render");
            // The model has grown: a lattice over its new bounds would differ, so polygonize on the session's.
            let fresh = crate::pipeline::polygonizer_on(&s.scene().model, mode, s.lattice(), polygonize.options());
            assert_eq!(fresh.mesh().triangle_set(), canonical_triangles(s.mesh().triangles()));
            // The moves went where the keys said.
            let centre =
                |model: &crate::field::Model, name: &str| model.node(model.find(name).unwrap()).bounds.center();
            let start = Scene::parse(SCENE, "inline").unwrap();
            for (name, expected) in ["left", "right"].iter().zip(expected) {
                let moved = centre(&v.session.scene().model, name) - centre(&start.model, name);
                assert!((moved - expected).length() < 1e-5, "{name}: {moved} against {expected}");
                assert!(expected.length() > 0.5 * v.step_length, "{name} moved");
            }
        }
    }

    #[test]
    fn a_move_too_far_is_refused_and_leaves_the_views_consistent() {
        let (mut v, _) = viewer(EvalMode::Cached);
        let model = |v: &Viewer| v.session.scene().model.clone();
        let start = model(&v).node(model(&v).find("left").unwrap()).bounds;
        // Far past where a model may reach (a thousand times its size).
        v.step_length = 1.0e5;
        v.act(Action::Move(0, 1.0)).unwrap();
        v.settle();
        let now = model(&v).node(model(&v).find("left").unwrap()).bounds;
        assert!((now.center() - start.center()).length() < 0.02, "{start:?} -> {now:?}");
        let s = &v.session;
        let full = render_model(&s.scene().model, EvalMode::Cached, s.settings(), &|_| {}).0;
        assert!(full.same_image(s.field_frame()));
    }

    #[test]
    fn the_overlay_fits_every_window_and_overlaps_nothing_in_every_view_and_help_page() {
        for (w, h) in [(160, 120), (320, 240), (640, 480), (1920, 1080)] {
            let scene = Scene::parse(SCENE, "inline").unwrap();
            let polygonize = PolygonizeSettings { res: 16, ..Default::default() };
            let session = EditSession::begin(scene, EvalMode::Indexed, Size(w, h), &polygonize).unwrap();
            let mut v = Viewer::new(session, Script::default(), None, PathBuf::from("unused.png")).unwrap();
            v.act(Action::Move(0, 1.0)).unwrap();
            let mut checked = 0;
            for view in 0..6 {
                let slice_views = if v.view == View::Slice { 4 } else { 1 };
                for _ in 0..slice_views {
                    let (_, key) = v.view();
                    let what = format!("{w}x{h} {:?} {:?}", v.view, v.slice.shows);
                    hud::tests::assert_fits(&v.overlay(key.as_ref()), w, h, &what);
                    assert_eq!(
                        v.overlay(key.as_ref()).len(),
                        1 + usize::from(key.is_some()),
                        "{what}: a bar when a key"
                    );
                    v.act(Action::NextSliceView).unwrap();
                    checked += 1;
                }
                if view == 0 {
                    // Every page of the help card, then hidden again.
                    let pages = v.help_card().pages();
                    for page in 0..pages {
                        v.act(Action::ToggleHelp).unwrap();
                        assert_eq!(v.help, Some(page));
                        hud::tests::assert_fits(&v.overlay(None), w, h, &format!("{w}x{h} help page {page}"));
                    }
                    v.act(Action::ToggleHelp).unwrap();
                    assert_eq!(v.help, None, "{w}x{h}: H after the last page hides the card");
                    assert!(w > 320 || pages > 1, "{w}x{h}: a small window pages the card");
                }
                v.act(Action::NextView).unwrap();
            }
            assert_eq!(checked, 9);
        }
    }

    #[test]
    fn the_help_card_names_every_key_and_the_screen_draws_over_the_view() {
        let listed: Vec<String> =
            Action::help().iter().flat_map(|(names, _)| names.split(", ").map(String::from)).collect();
        for (name, ..) in KEYS {
            assert!(listed.iter().any(|l| l == name), "{name} is on the help card");
        }
        let (mut v, _) = viewer(EvalMode::Indexed);
        let (plain, screen) = (v.image(), v.screen());
        assert_eq!((plain.width, plain.height), (screen.width, screen.height));
        let row = |img: &Rgb8Image, y: u32| {
            img.pixels[(3 * y * img.width) as usize..(3 * (y + 1) * img.width) as usize].to_vec()
        };
        assert_ne!(row(&plain, 2), row(&screen, 2), "the status line");
        assert!(v.status().iter().any(|p| p.contains("moving left")), "{:?}", v.status());
        v.act(Action::named("h").unwrap()).unwrap();
        let with_help = v.screen();
        assert_ne!(row(&with_help, screen.height / 2), row(&screen, screen.height / 2), "the card");
        // F1 turns the pages as H does, and after the last hides the card.
        for _ in 1..v.help_card().pages() {
            v.act(Action::named("f1").unwrap()).unwrap();
            assert!(v.screen().pixels != screen.pixels, "the next page");
        }
        v.act(Action::named("f1").unwrap()).unwrap();
        assert!(v.screen().pixels == screen.pixels, "f1 hides it again");
        v.act(Action::named("a").unwrap()).unwrap();
        assert!(v.status().iter().any(|p| p.starts_with("camera: first pass")), "{:?}", v.status());
        v.settle();
        assert!(v.status().iter().any(|p| p.contains("refined")), "{:?}", v.status());
    }

    #[test]
    fn the_slice_view_moves_its_plane_and_shows_f_sharp_error_and_gradient() {
        let (mut v, _) = viewer(EvalMode::Indexed);
        for _ in 0..5 {
            v.act(Action::NextView).unwrap();
        }
        let shows = |v: &Viewer| v.status().iter().any(|p| p.contains(" at depth "));
        assert!(shows(&v), "{:?}", v.status());
        // Through the blobs' centres, f reaches its peak and the contour is drawn in white.
        let through = v.image();
        let white = |img: &Rgb8Image| img.pixels.chunks(3).filter(|p| p == &[255, 255, 255]).count();
        assert!(white(&through) > 10, "the iso-contour");
        // Far behind the model the plane shows nothing; back again, the same picture.
        for _ in 0..60 {
            v.act(Action::named("period").unwrap()).unwrap();
        }
        assert_eq!(white(&v.image()), 0, "no contour beyond the model");
        for _ in 0..60 {
            v.act(Action::named("comma").unwrap()).unwrap();
        }
        assert!(v.image().pixels == through.pixels, "the plane comes back");
        // n: the sharp view, then (the model has a cache) error_C and the gradient error, then f.
        let mut seen = vec![through.pixels.clone()];
        for expected in ["sharp:", "error_C", "gradient error", "f at"] {
            v.act(Action::named("n").unwrap()).unwrap();
            assert!(v.status().iter().any(|p| p.starts_with(expected)), "{expected}: {:?}", v.status());
            seen.push(v.image().pixels);
        }
        assert!(seen[1] != seen[0] && seen[2] != seen[1] && seen[3] != seen[2]);
        assert!(seen[4] == seen[0], "n comes back to f");
        // The heat maps carry a colour bar on screen.
        assert!(v.screen().pixels != v.image().pixels);
    }

    #[test]
    fn mouse_gestures_orbit_zoom_pan_and_select() {
        assert_eq!(Action::named("drag:10:-5").unwrap(), Action::Orbit(-4.0, -2.0));
        assert_eq!(Action::named("wheel:1").unwrap(), Action::Zoom(ZOOM_FACTOR));
        for bad in ["drag:1", "wheel:x", "click:-1:2", "drag:nan:0", "pan:1:2:3", "spin:1"] {
            assert!(Action::named(bad).is_err(), "{bad} is refused");
        }
        // A wheel notch in is the zoom key.
        let (mut by_wheel, _) = viewer(EvalMode::Indexed);
        let (mut by_key, _) = viewer(EvalMode::Indexed);
        by_wheel.act(Action::named("wheel:1").unwrap()).unwrap();
        by_key.act(Action::named("z").unwrap()).unwrap();
        assert_eq!(by_wheel.image().pixels, by_key.image().pixels);
        // However far the wheel turns, the camera stays usable.
        let (mut far, _) = viewer(EvalMode::Indexed);
        for gesture in ["wheel:-1000", "wheel:1000", "wheel:1000"] {
            far.act(Action::named(gesture).unwrap()).unwrap();
            assert!(far.session.settings().camera.eye.is_finite(), "after {gesture}");
        }
        // A pan and its opposite bring the camera back.
        let (mut v, _) = viewer(EvalMode::Indexed);
        let before = v.session.settings().camera;
        v.act(Action::Pan(15.0, -4.0)).unwrap();
        assert!((v.session.settings().camera.eye - before.eye).length() > 1e-3, "the pan moved the camera");
        v.act(Action::Pan(-15.0, 4.0)).unwrap();
        v.settle();
        assert!((v.session.settings().camera.eye - before.eye).length() < 1e-4);
        // A click on either blob selects it; a click on the background keeps the selection.
        let frame = v.session.field_frame();
        let (w, h) = (frame.width, frame.height);
        let hit_in =
            |xs: std::ops::Range<u32>| xs.into_iter().find(|&x| frame.depth[(h / 2 * w + x) as usize].is_finite());
        let (left_x, right_x) = (hit_in(0..w / 2 - 4).unwrap(), hit_in(w / 2 + 4..w).map(|x| x + 2).unwrap());
        v.act(Action::SelectAt(right_x, h / 2)).unwrap();
        assert_eq!(v.names[v.selected], "right");
        v.act(Action::SelectAt(0, 0)).unwrap();
        assert_eq!(v.names[v.selected], "right", "the background selects nothing");
        v.act(Action::named(&format!("click:{left_x}:{}", h / 2)).unwrap()).unwrap();
        assert_eq!(v.names[v.selected], "left");
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
        let normals = v.image();
        v.act(Action::NextView).unwrap();
        let cost = v.image();
        assert!(v.status()[0] == "cost", "{:?}", v.status());
        v.act(Action::NextView).unwrap();
        let slice = v.image();
        assert!(v.status()[0] == "slice", "{:?}", v.status());
        v.act(Action::NextView).unwrap();
        assert!(v.image().pixels == field.pixels, "six presses come back to the field");
        assert!(normals.pixels != cost.pixels && slice.pixels != cost.pixels);
        for other in [&mesh, &difference, &cost, &slice] {
            assert!(other.pixels != field.pixels);
        }
        for image in [&field, &mesh, &difference, &normals, &cost, &slice] {
            assert_eq!((image.width, image.height), (48, 36));
        }
        v.act(Action::Move(0, 1.0)).unwrap();
        v.settle();
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
