//! The previewer in a real window: under a virtual X server (Xvfb), a click
//! with xdotool selects Medusa's tail, keys switch the view and open the
//! help card, and a screenshot of the window (ImageMagick's `import`)
//! equals, pixel for pixel, what `view --headless --hud` writes after the
//! same input. `scripts/test` installs the three tools.

mod common;

use std::path::Path;
use std::process::Command;

use common::{blobtrace, scratch};

/// Opens the viewer, waits for its window, clicks the tail and types `v`
/// then `h` (each held long enough for a frame to see it: the window polls
/// the mouse and keys once a frame), and screenshots the window into
/// `$SHOT` once it matches `$EXPECTED` (or after ten tries, as it is).
const DRIVE_THE_WINDOW: &str = r#"
set -u
"$BIN" view scenes/medusa.ron --size 320x240 &
viewer=$!
window=$(timeout 60 xdotool search --sync --name "blobtrace view" | head -1)
xdotool windowfocus --sync "$window"
xdotool mousemove --window "$window" 170 150
sleep 0.3; xdotool mousedown 1; sleep 0.2; xdotool mouseup 1; sleep 0.3
for key in v h; do
  xdotool keydown "$key"; sleep 0.2; xdotool keyup "$key"; sleep 0.3
done
for try in $(seq 10); do
  import -window "$window" "$SHOT"
  [ "$(compare -metric AE "$SHOT" "$EXPECTED" null: 2>&1)" = "0" ] && break
  sleep 0.5
done
kill "$viewer"
"#;

fn require(tool: &str) {
    let found = Command::new("sh").args(["-c", &format!("command -v {tool}")]).output().unwrap();
    assert!(found.status.success(), "{tool} is missing: run the tests with scripts/test, which installs it");
}

fn rgb(path: &Path) -> image::RgbImage {
    image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgb8()
}

#[test]
fn the_window_shows_what_the_headless_viewer_draws_after_the_same_keys() {
    for tool in ["xvfb-run", "xdotool", "import", "compare"] {
        require(tool);
    }
    let dir = scratch("window");
    let (expected, shot) = (dir.join("expected.png"), dir.join("shot.png"));
    let out = blobtrace(&[
        "view",
        "scenes/medusa.ron",
        "--size",
        "320x240",
        "--headless",
        "--keys",
        "click:170:150,v,h",
        "--hud",
        "-o",
        expected.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("moving tail"), "the click selects the tail");
    let drawn = rgb(&expected);
    let hud_text = drawn.pixels().filter(|p| p.0 == [240, 240, 240]).count();
    assert!(hud_text > 500, "the status line and the help card are drawn ({hud_text} text pixels)");

    let status = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 640x480x24", "bash", "-c", DRIVE_THE_WINDOW])
        .env("BIN", env!("CARGO_BIN_EXE_blobtrace"))
        .env("SHOT", &shot)
        .env("EXPECTED", &expected)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("xvfb-run runs");
    let log = String::from_utf8_lossy(&status.stderr);
    let seen = rgb(&shot);
    assert_eq!(seen.dimensions(), drawn.dimensions(), "the window is the view's size: {log}");
    let differing = seen.pixels().zip(drawn.pixels()).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "pixels of the window unlike the headless view (kept in {}): {log}", dir.display());
    std::fs::remove_dir_all(dir).unwrap();
}
