//! Edit scripts: frames of edits, each frame applied at once, with repeats.
//!
//! ```ron
//! EditScript(frames: [
//!     (repeat: 25, edits: [Translate(node: "head", by: (0.0, -0.12, 0.0))]),
//!     (repeat: 25, edits: [Translate(node: "head", by: (0.0, 0.12, 0.0))]),
//! ])
//! ```

use std::path::Path;

use serde::Deserialize;

use super::SceneError;
use crate::field::Edit;

/// A script as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct EditScript {
    frames: Vec<ScriptFrame>,
}

/// One frame of a script, possibly repeated.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ScriptFrame {
    /// How many consecutive frames apply these edits (default 1).
    #[serde(default = "one")]
    repeat: u32,
    /// The edits of the frame, applied in order.
    edits: Vec<Edit>,
}

fn one() -> u32 {
    1
}

/// Most frames a script may expand to.
const MAX_FRAMES: usize = 100_000;

/// Reads a script; returns one list of edits per frame, repeats expanded.
pub fn load_script(path: &Path) -> Result<Vec<Vec<Edit>>, SceneError> {
    let label = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|cause| SceneError::Io { path: label.clone(), cause })?;
    parse_script(&text, &label)
}

/// Parses script text; `label` names the source in errors.
pub fn parse_script(text: &str, label: &str) -> Result<Vec<Vec<Edit>>, SceneError> {
    let script: EditScript =
        super::ron_options().from_str(super::without_bom(text)).map_err(|e| super::syntax_error(label, &e))?;
    let total: usize = script.frames.iter().map(|f| f.repeat as usize).sum();
    if total == 0 || total > MAX_FRAMES {
        return Err(SceneError::Syntax {
            path: label.to_string(),
            line: 1,
            column: 1,
            message: format!("a script must expand to 1..={MAX_FRAMES} frames, this one to {total}"),
        });
    }
    Ok(script.frames.iter().flat_map(|f| std::iter::repeat_n(f.edits.clone(), f.repeat as usize)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repeats_expand_and_errors_have_positions() {
        let frames = parse_script(
            "EditScript(frames: [(repeat: 3, edits: [Translate(node: \"a\", by: (0.0, 1.0, 0.0))]), (edits: [Radius(node: \"b\", radius: 0.5)])])",
            "s",
        )
        .unwrap();
        assert_eq!(frames.len(), 4);
        assert_eq!(frames[3], vec![Edit::Radius { node: "b".into(), radius: 0.5 }]);
        // A byte-order mark some editors write first is no syntax error.
        let marked = parse_script("\u{feff}EditScript(frames: [(edits: [Remove(node: \"a\")])])", "s").unwrap();
        assert_eq!(marked, vec![vec![Edit::Remove { node: "a".into() }]]);
        let err = parse_script("EditScript(frames: [\n  (edits: [Spin(node: \"a\")])])", "s").unwrap_err().to_string();
        assert!(err.starts_with("s:2:"), "{err}");
        assert!(parse_script("EditScript(frames: [])", "s").is_err());
    }
}
