//! The previewer in a real window: under a virtual X server (Xvfb), a click
//! with xdotool selects Medusa's tail, keys switch the view and open the
//! help card, and a screenshot of the window (ImageMagick's `import`)
//! equals, pixel for pixel, what `view --headless --hud` writes after the
//! same input; taps and clicks as quick as a person's (or quicker) all
//! count, idle or while a refinement runs, as the events log shows.
//! `scripts/test` installs the three tools.

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

/// One window at a time: two viewers of Medusa at once would share two
/// cores, and each test's timings assume a machine to itself.
static ONE_WINDOW: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn require(tool: &str) {
    let found = Command::new("sh").args(["-c", &format!("command -v {tool}")]).output().unwrap();
    assert!(found.status.success(), "{tool} is missing: run the tests with scripts/test, which installs it");
}

fn rgb(path: &Path) -> image::RgbImage {
    image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgb8()
}

#[test]
fn the_window_shows_what_the_headless_viewer_draws_after_the_same_keys() {
    let _alone = ONE_WINDOW.lock().unwrap_or_else(|e| e.into_inner());
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

/// Opens the viewer with an events log, then: 20 taps of the right arrow,
/// 15 ms each and 120 ms apart; 10 clicks with no hold (xdotool's own
/// press and release), turn about between the head and the tail; a drag
/// with no pause and three wheel notches (two in, one out); an orbit key,
/// and at once 10 taps of the left arrow while its refinement runs.
/// Escape closes the window.
const QUICK_INPUT: &str = r#"
set -u
"$BIN" view scenes/medusa.ron --size 320x240 --events-log "$LOG" &
viewer=$!
window=$(timeout 60 xdotool search --sync --name "blobtrace view" | head -1)
xdotool windowfocus --sync "$window"
sleep 1
for i in $(seq 20); do xdotool keydown Right; sleep 0.015; xdotool keyup Right; sleep 0.12; done
for i in $(seq 5); do
  xdotool mousemove --window "$window" 160 60 click 1; sleep 0.12
  xdotool mousemove --window "$window" 170 150 click 1; sleep 0.12
done
xdotool mousemove --window "$window" 100 100 mousedown 1 mousemove --window "$window" 140 110 mouseup 1
sleep 0.3
xdotool click 4 click 4 click 5
sleep 0.3
xdotool key a
for i in $(seq 10); do xdotool keydown Left; sleep 0.015; xdotool keyup Left; sleep 0.02; done
sleep 1
xdotool key Escape
# The viewer applies every event still queued before it exits: on a loaded
# machine that may take a while.
for try in $(seq 600); do kill -0 "$viewer" 2>/dev/null || exit 0; sleep 0.1; done
kill "$viewer"
"#;

/// The events log's lines: input, action, when it came, and the state after it.
fn logged(log: &str) -> Vec<[String; 4]> {
    log.lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            assert_eq!(f.len(), 6, "a line of six fields: {l:?}");
            [f[2], f[3], f[4], f[5]].map(String::from)
        })
        .collect()
}

#[test]
fn every_quick_tap_and_click_counts_idle_or_while_refining() {
    let _alone = ONE_WINDOW.lock().unwrap_or_else(|e| e.into_inner());
    for tool in ["xvfb-run", "xdotool"] {
        require(tool);
    }
    let dir = scratch("quick-input");
    let log_path = dir.join("events.log");
    let status = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 640x480x24", "bash", "-c", QUICK_INPUT])
        .env("BIN", env!("CARGO_BIN_EXE_blobtrace"))
        .env("LOG", &log_path)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("xvfb-run runs");
    let stderr = String::from_utf8_lossy(&status.stderr);
    let log = std::fs::read_to_string(&log_path).unwrap_or_else(|e| panic!("no events log ({e}): {stderr}"));
    let lines = logged(&log);
    let rights: Vec<_> = lines.iter().filter(|l| l[0] == "key right").collect();
    assert_eq!(rights.len(), 20, "20 taps, 20 moves:\n{log}");
    assert!(rights.iter().all(|l| l[1] == "Move(0, 1.0)"), "{log}");
    let clicks: Vec<_> = lines.iter().filter(|l| l[0].starts_with("click ")).collect();
    assert_eq!(clicks.len(), 10, "10 clicks, 10 selections:\n{log}");
    for (k, click) in clicks.iter().enumerate() {
        let node = if k % 2 == 0 { "moving head" } else { "moving tail" };
        assert!(click[3].starts_with(node), "click {k} selects what is under the pointer: {click:?}\n{log}");
    }
    // The drag's steps add up to the 40 by 10 pixels it went, whatever the loop saw of it.
    let (dx, dy) = lines.iter().filter_map(|l| l[0].strip_prefix("drag ")).fold((0.0, 0.0), |(x, y), d| {
        let (a, b) = d.split_once(',').expect("drag DX,DY");
        (x + a.parse::<f32>().unwrap(), y + b.parse::<f32>().unwrap())
    });
    assert_eq!((dx, dy), (40.0, 10.0), "the whole drag:\n{log}");
    let notches: f32 =
        lines.iter().filter_map(|l| l[0].strip_prefix("wheel ")).map(|n| n.parse::<f32>().unwrap()).sum();
    let turns = lines.iter().filter(|l| l[0].starts_with("wheel ")).count();
    assert!(notches == 1.0 && (1..=3).contains(&turns), "two notches in and one out:\n{log}");
    let lefts: Vec<_> = lines.iter().filter(|l| l[0] == "key left").collect();
    assert_eq!(lefts.len(), 10, "10 taps during the orbit's refinement, 10 moves:\n{log}");
    assert!(lefts.iter().any(|l| l[2] == "refining"), "some came while the orbit refined:\n{log}");
    let last = lines.last().expect("a line");
    assert!(last[3].ends_with(", 30 frames"), "every move is a frame: {last:?}");
    assert!(!lines.iter().any(|l| l[0].starts_with("repeat")), "taps this short never repeat:\n{log}");
    let loop_line = log.lines().last().unwrap_or_default();
    assert!(loop_line.starts_with("# window loop: ") && loop_line.contains(" turns, at most "), "{loop_line}");
    eprintln!("{loop_line}");
    std::fs::remove_dir_all(dir).unwrap();
}
