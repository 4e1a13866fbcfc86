//! The interactive previewer. A window shows the field render, the mesh
//! render or their depth difference; keys move a named node along the
//! screen or play an edit script, and each move updates only what it
//! changed (an [`EditSession`] frame: dirty rectangles, local mesh cells,
//! BVH2 triangles, the difference in those rectangles). Other keys and the
//! mouse orbit, pan and zoom the camera about the model, which renders the
//! images again whole (the empty space and the mesh stay); a click selects
//! the named node strongest at the surface under the pointer. Headless, the
//! same [`Viewer`] runs on a list of keys instead of a window, so the
//! previewer runs where there is no display (and under `cargo test`).
//!
//! Its parts: `keys` (every key and gesture and what it does, the help
//! card's lines), `views` (every view, its name and how it draws), `slice`
//! (the slice view's plane), `hud` (the status band, colour bars and help
//! card laid out over the view), `timing` (each event's cost), `input` (the
//! window's key and button edges as actions), `worker` (the work off the
//! window's thread) and `window` (the window loop). To add a view: a
//! variant and a row in `views`; to add a key: a row of `keys::KEYS`.

mod hud;
mod input;
mod keys;
mod slice;
#[cfg(test)]
mod tests;
mod timing;
mod views;
mod window;
mod worker;

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use glam::Vec3;

use crate::camera::Orbit;
use crate::draw::{ColourKey, Rgb8Image};
use crate::field::Edit;
use crate::pipeline::{EditSession, IDLE_SAMPLES, SliceView, outline_dirty};
use crate::scene::Script;
use crate::trace::PixelRect;
use hud::StatusPart;
pub use keys::{Action, DRAG_DEGREES_PER_PIXEL};
use slice::Slice;
use timing::EventTiming;
use views::View;
pub use window::show;
pub use worker::background_pool;

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
            Action::NextView => self.view = self.view.next(),
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
        let view = self.view.name();
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
        let mode = format!("{:?}", self.session.mode()).to_lowercase();
        parts.push(StatusPart::shortened(format!("{mode}, {} tracer", self.session.tracer()), mode));
        parts.push(StatusPart::new("H: help"));
        parts
    }

    /// The window's title: the status line's parts.
    pub fn title(&self) -> String {
        format!("blobtrace view · {}", self.status().join(" · "))
    }
}

/// `dir/stem-NNNN.png` for `dir/stem.png` (checked to end in `.png`).
fn numbered(path: &std::path::Path, n: usize) -> PathBuf {
    let stem = path.file_stem().unwrap_or_default().to_string_lossy();
    path.with_file_name(format!("{stem}-{n:04}.png"))
}
