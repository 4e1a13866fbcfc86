//! The keys and mouse gestures and what they do: one table of every key
//! (its name for `--keys`, the window's key, its action), the gestures
//! `--keys` spells, and the help card's lines, made from the same table.

use anyhow::Context;

use crate::camera::CameraMove;

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

/// Degrees of orbit per pixel a mouse drag moves.
pub const DRAG_DEGREES_PER_PIXEL: f32 = 0.4;

/// Degrees an orbit key turns the camera.
const ORBIT_DEGREES: f32 = 10.0;
/// The factor a zoom key moves the camera in by (its inverse, out).
pub(super) const ZOOM_FACTOR: f32 = 0.9;

/// How the help card says held keys repeat (see [`super::input::REPEAT_DELAY`]).
pub(super) const REPEAT_HELP: &str = "moves, orbits, zooms and slice steps repeat after 0.3 s, 20 a second";

/// Every key: its name for `--keys`, the window's key, and what it does.
pub(super) const KEYS: [(&str, minifb::Key, Action); 22] = {
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
    pub(super) fn camera_move(self) -> Option<CameraMove> {
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
