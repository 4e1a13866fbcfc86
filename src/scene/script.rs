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
use super::edit_desc::EditDesc;
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
    edits: Vec<EditDesc>,
}

fn one() -> u32 {
    1
}

/// Most frames a script may expand to.
const MAX_FRAMES: usize = 100_000;

/// A script's frames, repeats expanded, each with where it is written.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Script {
    /// The edits of each frame, applied in order.
    pub frames: Vec<Vec<Edit>>,
    /// Per frame, `file:line:column` of its entry in the script, for errors
    /// found when the frame is applied.
    origins: Vec<String>,
}

impl Script {
    /// Where frame `i` is written, as `file:line:column`.
    #[must_use]
    pub fn origin(&self, i: usize) -> &str {
        self.origins.get(i).map_or("", String::as_str)
    }

    /// Frame `i` (from 0) named for an error: where it is written, and its
    /// number as a person counts the frames the script expands to, from 1.
    #[must_use]
    pub fn frame_label(&self, i: usize) -> String {
        format!("{}: frame {}", self.origin(i), i + 1)
    }
}

/// Reads a script; returns one list of edits per frame, repeats expanded.
pub fn load_script(path: &Path) -> Result<Script, SceneError> {
    let label = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|cause| SceneError::Io { path: label.clone(), cause })?;
    parse_script(&text, &label)
}

/// Parses script text; `label` names the source in errors.
pub fn parse_script(text: &str, label: &str) -> Result<Script, SceneError> {
    let text = super::without_bom(text);
    let script: EditScript = super::on_a_deep_stack(|| super::ron_options().from_str(text))
        .map_err(|e| super::syntax_error(label, text, &e))?;
    let total: usize = script.frames.iter().map(|f| f.repeat as usize).sum();
    if total == 0 || total > MAX_FRAMES {
        return Err(SceneError::Syntax {
            path: label.to_string(),
            line: 1,
            column: 1,
            message: format!("a script must expand to 1..={MAX_FRAMES} frames, this one to {total}"),
        });
    }
    let entries = entry_positions(text);
    let mut out = Script::default();
    for (k, frame) in script.frames.iter().enumerate() {
        let (line, column) = entries.get(k).copied().unwrap_or((1, 1));
        let edits: Vec<Edit> = frame.edits.iter().cloned().map(Edit::from).collect();
        for _ in 0..frame.repeat {
            out.frames.push(edits.clone());
            out.origins.push(format!("{label}:{line}:{column}"));
        }
    }
    Ok(out)
}

/// The line and column (from 1) where each entry of a parsed script's
/// `frames` list is written: each parenthesis opened directly inside the list
/// that the outermost parentheses hold (or the name before it), skipping
/// strings and comments. (The `#![enable(…)]` lines RON allows first open
/// their brackets the other way round.)
pub fn entry_positions(text: &str) -> Vec<(usize, usize)> {
    let mut text = Cursor { chars: text.chars().peekable(), line: 1, column: 0 };
    let mut open: Vec<char> = vec![];
    let mut entries = vec![];
    // Where the name before an opening parenthesis starts (`ScriptFrame(…)`).
    let mut name_start = None;
    while let Some(c) = text.next() {
        if c.is_alphanumeric() || c == '_' {
            name_start.get_or_insert((text.line, text.column));
        } else if !c.is_whitespace() && c != '(' {
            name_start = None;
        }
        match c {
            '/' if text.chars.peek() == Some(&'/') => text.skip_past("\n"),
            '/' if text.chars.peek() == Some(&'*') => {
                text.next();
                text.skip_past("*/");
            }
            '"' => text.skip_string(),
            '(' | '[' => {
                if c == '(' && open == ['(', '['] {
                    entries.push(name_start.unwrap_or((text.line, text.column)));
                }
                name_start = None;
                open.push(c);
            }
            ')' | ']' => {
                open.pop();
            }
            _ => {}
        }
    }
    entries
}

/// Characters of a text with the line and column of the last one taken.
struct Cursor<'a> {
    chars: std::iter::Peekable<std::str::Chars<'a>>,
    line: usize,
    column: usize,
}

impl Cursor<'_> {
    fn next(&mut self) -> Option<char> {
        let c = self.chars.next()?;
        (self.line, self.column) = if c == '\n' { (self.line + 1, 0) } else { (self.line, self.column + 1) };
        Some(c)
    }

    /// Takes characters up to and including the first `end` (or all).
    fn skip_past(&mut self, end: &str) {
        let mut last = String::new();
        while let Some(c) = self.next() {
            last.push(c);
            if last.ends_with(end) {
                return;
            }
        }
    }

    /// Takes the rest of a string, escapes included, up to its closing quote.
    fn skip_string(&mut self) {
        while let Some(c) = self.next() {
            match c {
                '\\' => {
                    self.next();
                }
                '"' => return,
                _ => {}
            }
        }
    }
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
        .unwrap()
        .frames;
        assert_eq!(frames.len(), 4);
        assert_eq!(frames[3], vec![Edit::Radius { node: "b".into(), radius: 0.5 }]);
        // A byte-order mark some editors write first is no syntax error.
        let marked = parse_script("\u{feff}EditScript(frames: [(edits: [Remove(node: \"a\")])])", "s").unwrap().frames;
        assert_eq!(marked, vec![vec![Edit::Remove { node: "a".into() }]]);
        let err = parse_script("EditScript(frames: [\n  (edits: [Spin(node: \"a\")])])", "s").unwrap_err().to_string();
        assert!(err.starts_with("s:2:"), "{err}");
        assert!(parse_script("EditScript(frames: [])", "s").is_err());
    }

    #[test]
    fn each_frame_knows_where_its_entry_is_written() {
        let text = concat!(
            "#![enable(implicit_some)]\n",
            "// frames: [(not, one)]\n",
            "EditScript(frames: [\n",
            "    (repeat: 2, edits: [Translate(node: \"a (b\", by: (0.0, 1.0, 0.0))]), /* (no) */\n",
            "  ScriptFrame(edits: [Remove(node: \"x\\\"(\")]),\n",
            "    (edits: [Radius(node: \"b\", radius: 0.5)])])",
        );
        let script = parse_script(text, "s.ron").unwrap();
        assert_eq!(script.frames.len(), 4);
        let origins: Vec<&str> = (0..4).map(|i| script.origin(i)).collect();
        assert_eq!(origins, ["s.ron:4:5", "s.ron:4:5", "s.ron:5:3", "s.ron:6:5"]);
        assert_eq!(script.frame_label(0), "s.ron:4:5: frame 1");
        assert_eq!(script.frame_label(3), "s.ron:6:5: frame 4");
    }
}
