//! The previewer's window (minifb): keys and mouse in, the current view
//! out, the frames' work on the worker pool while the window stays on its
//! thread. Each event shows its coarse pass at once; while no input comes,
//! the passes refine about a frame's time at a time. A left drag orbits, a
//! right or shift drag pans, the wheel zooms, and a click (a press and
//! release without moving) selects the named node under the pointer.

use std::time::{Duration, Instant};

use anyhow::Context;

use super::{Action, Viewer};
use crate::compare::Rgb8Image;

/// The window loop: keys in, the current view out, until the window closes or Escape.
pub fn show(viewer: &mut Viewer, pool: &rayon::ThreadPool) -> anyhow::Result<()> {
    use minifb::{Key, KeyRepeat, Window, WindowOptions};
    let image = viewer.screen();
    let (w, h) = (image.width as usize, image.height as usize);
    let mut window = Window::new(&viewer.title(), w, h, WindowOptions::default()).map_err(|e| {
        anyhow::anyhow!("could not open a window ({e}); where there is no display, run with --headless --keys …")
    })?;
    window.set_target_fps(60);
    window.update_with_buffer(&to_window_pixels(&image), w, h).context("drawing the window")?;
    let mut mouse = Mouse::default();
    let (mut shown_at, mut shown_refining) = (Instant::now(), false);
    while window.is_open() && !window.is_key_down(Key::Escape) {
        let mut actions: Vec<Action> =
            window.get_keys_pressed(KeyRepeat::Yes).into_iter().filter_map(Action::of_key).collect();
        actions.extend(mouse.actions(&window));
        let acted = !actions.is_empty();
        if acted {
            for action in actions {
                pool.install(|| viewer.act(action))?;
            }
        } else if viewer.is_refining() {
            // No input: refine for about a frame's time, then look for input again.
            pool.install(|| viewer.refine(REFINE_BUDGET));
        }
        // Each event's coarse pass shows at once; the passes after it, every
        // so often and when done (each showing costs a few milliseconds).
        let refined = !viewer.is_refining() && shown_refining;
        if acted || refined || (viewer.is_refining() && shown_at.elapsed() >= SHOW_EVERY) {
            window.set_title(&viewer.title());
            (shown_at, shown_refining) = (Instant::now(), viewer.is_refining());
            window.update_with_buffer(&to_window_pixels(&viewer.screen()), w, h).context("drawing the window")?;
        } else {
            window.update();
        }
    }
    Ok(())
}

/// How long the window refines before it shows the passes so far and looks
/// for input again.
const REFINE_BUDGET: Duration = Duration::from_millis(25);

/// How often the window shows the passes while it refines.
const SHOW_EVERY: Duration = Duration::from_millis(100);

/// `0RGB` words, as the window takes them.
fn to_window_pixels(image: &Rgb8Image) -> Vec<u32> {
    image.pixels.chunks_exact(3).map(|p| u32::from_be_bytes([0, p[0], p[1], p[2]])).collect()
}

/// The mouse between frames: where the pointer was, where the buttons went
/// down, and whether it moved since.
#[derive(Default)]
struct Mouse {
    last: Option<(f32, f32)>,
    pressed_at: Option<(f32, f32)>,
    dragged: bool,
}

/// Pixels a press may move and still count as a click.
const CLICK_SLACK: f32 = 3.0;

impl Mouse {
    /// What the mouse did since the last frame.
    fn actions(&mut self, window: &minifb::Window) -> Vec<Action> {
        use minifb::{Key, MouseButton, MouseMode};
        let mut actions = vec![];
        if let Some((_, notches)) = window.get_scroll_wheel()
            && notches != 0.0
        {
            actions.push(Action::wheel(notches.signum()));
        }
        let Some(at) = window.get_mouse_pos(MouseMode::Discard) else { return actions };
        let (left, right) = (window.get_mouse_down(MouseButton::Left), window.get_mouse_down(MouseButton::Right));
        let shift = window.is_key_down(Key::LeftShift) || window.is_key_down(Key::RightShift);
        if left || right {
            let pressed = *self.pressed_at.get_or_insert(at);
            self.dragged |= (at.0 - pressed.0).abs() > CLICK_SLACK || (at.1 - pressed.1).abs() > CLICK_SLACK;
            if let Some(last) = self.last
                && self.dragged
                && last != at
            {
                let (dx, dy) = (at.0 - last.0, at.1 - last.1);
                actions.push(if right || shift { Action::Pan(dx, dy) } else { Action::drag(dx, dy) });
            }
            self.last = Some(at);
        } else {
            if let Some(pressed) = self.pressed_at.take()
                && !self.dragged
            {
                actions.push(Action::SelectAt(pressed.0 as u32, pressed.1 as u32));
            }
            (self.last, self.dragged) = (None, false);
        }
        actions
    }
}
