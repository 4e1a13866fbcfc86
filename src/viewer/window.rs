//! The previewer's window (minifb): keys in, the current view out, the
//! frames' work on the worker pool while the window stays on its thread.

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
    let mut buffer = to_window_pixels(&image);
    while window.is_open() && !window.is_key_down(Key::Escape) {
        let actions: Vec<Action> =
            window.get_keys_pressed(KeyRepeat::Yes).into_iter().filter_map(Action::of_key).collect();
        if !actions.is_empty() {
            for action in actions {
                pool.install(|| viewer.act(action))?;
            }
            buffer = to_window_pixels(&viewer.screen());
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
