//! `blobtrace view`: options of the interactive previewer, which the
//! [`crate::viewer`] runs over an edit session.

use std::path::PathBuf;

use clap::Args;

use super::args::{LatticeArgs, LoadedScene, SceneArgs, check_output_file, worker_pool};
use super::exit::UsageError;
use crate::field::Model;
use crate::pipeline::{EditSession, check_names};
use crate::scene::{Script, load_script};
use crate::viewer::{Action, Viewer, background_pool, show};

/// Options of `blobtrace view`.
#[derive(Debug, Args)]
pub struct ViewArgs {
    /// The scene, its image size, camera and field evaluation.
    #[command(flatten)]
    pub input: SceneArgs,
    /// Edit script (RON) whose frames Space steps through.
    #[arg(long)]
    pub script: Option<PathBuf>,
    /// The named node the arrow keys move first (default: the first name).
    #[arg(long)]
    pub node: Option<String>,
    /// Run without a window: apply `--keys` in order, then write the view to
    /// `--output` as the window shows it once left alone (refined, and the
    /// field view smoothed by 16 samples per pixel).
    #[arg(long)]
    pub headless: bool,
    /// Keys for `--headless`, comma-separated: left, right, up, down, pageup,
    /// pagedown (move the node), tab (next node), v (next view), space (next
    /// script frame), r (outline the dirty rectangles), a, d, w, s (orbit),
    /// z, x (zoom in, out), p (snapshot), h or f1 (help card, its next page, hide it), comma and
    /// period (move the slice plane nearer, away), n (what the slice shows); and mouse
    /// gestures drag:DX:DY (orbit), pan:DX:DY, wheel:N (zoom), click:X:Y
    /// (select the named node under that pixel).
    #[arg(long, value_delimiter = ',', requires = "headless")]
    pub keys: Vec<String>,
    /// With `--headless`, draw the status line, the colour bar and the help
    /// card (when its key was pressed) into `--output`, as the window shows them.
    #[arg(long, requires = "headless")]
    pub hud: bool,
    /// Write a line for every event the window applies to FILE, as it is
    /// applied: when the input came and was applied, the key, click, drag
    /// or wheel step, the action, whether a refinement was under way, and
    /// the node selected and frames applied after it.
    #[arg(long, value_name = "FILE", conflicts_with = "headless")]
    pub events_log: Option<PathBuf>,
    /// The PNG `--headless` writes at the end; P writes snapshots beside it
    /// (`view-0001.png`, …).
    #[arg(short, long, default_value = "view.png")]
    pub output: PathBuf,
    /// Polygonizer options.
    #[command(flatten)]
    pub polygonize: LatticeArgs,
}

/// Runs `blobtrace view`.
pub fn run(a: &ViewArgs) -> anyhow::Result<()> {
    let actions = parse_keys(&a.keys, a.script.is_some())?;
    check_output_file(&a.output, "png")?;
    let LoadedScene { scene, mode, size } = a.input.load()?;
    check_node(&scene.model, a.node.as_deref())?;
    let script = match &a.script {
        Some(path) => load_script(path)?,
        None => Script::default(),
    };
    check_names(&scene.model, &script)?;
    // The window stays on this thread (some systems draw windows from the
    // main thread alone); the frames' work runs on the pool.
    // Below the window's thread, which must turn every few milliseconds.
    let pool = if a.headless { worker_pool(None)? } else { background_pool()? };
    // The window opens on the coarse pass and refines the rest while idle.
    let session = pool.install(|| EditSession::begin(scene, mode, size, &a.polygonize.settings()))?;
    let mut viewer = Viewer::new(session, script, a.node.as_deref(), a.output.clone())?;
    if !a.headless {
        return show(&mut viewer, &pool, a.events_log.as_deref());
    }
    for action in actions {
        pool.install(|| {
            viewer.act(action)?;
            viewer.settle();
            anyhow::Ok(())
        })?;
    }
    pool.install(|| viewer.converge());
    eprintln!("{}", viewer.title());
    let image = if a.hud { viewer.screen() } else { viewer.image() };
    Ok(image.save_png(&a.output)?)
}

/// The actions of `--keys`; Space steps a script, so it needs `--script`.
fn parse_keys(keys: &[String], scripted: bool) -> Result<Vec<Action>, UsageError> {
    let gestures = "drag:DX:DY (orbit), pan:DX:DY, wheel:N (zoom), click:X:Y (select)";
    let actions = keys.iter().map(|k| Action::named(k)).collect::<anyhow::Result<Vec<_>>>().map_err(|e| {
        let message = format!("{e:#}");
        // The viewer's list names the keys; a person typing a gesture needs those too.
        match message.contains("drag:DX:DY") {
            true => UsageError(message),
            false => UsageError(format!("{message}; or a mouse gesture: {gestures}")),
        }
    })?;
    if !scripted && actions.contains(&Action::NextScriptFrame) {
        return Err(UsageError("--keys space steps an edit script's frames, and no --script is given".into()));
    }
    Ok(actions)
}

/// Checks before any work that `--node` names a node of the scene.
fn check_node(model: &Model, node: Option<&str>) -> Result<(), UsageError> {
    let names = model.names();
    match node {
        Some(n) if !names.contains(&n) => Err(UsageError(match names.is_empty() {
            true => format!("--node: no node is named {n:?} (the scene names none)"),
            false => format!("--node: no node is named {n:?} (names: {})", names.join(", ")),
        })),
        _ => Ok(()),
    }
}
