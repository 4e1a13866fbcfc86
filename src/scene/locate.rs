//! Where in a scene file a model error lies: errors the model finds only
//! once it is built (a name used twice, a model placed too far from the
//! origin) are pointed back to the text that caused them.

use crate::field::ModelError;

/// The 1-based line and column of `cause` in `text`, where it can be told.
#[must_use]
pub fn locate(text: &str, cause: &ModelError) -> Option<(usize, usize)> {
    let offset = match cause {
        ModelError::DuplicateName(name) => named_occurrences(text, name).nth(1)?,
        ModelError::TooFar { .. } => field_offset(text, "model")?,
        ModelError::BadWarp { kind, occurrence, .. } => node_occurrences(text, kind).nth(*occurrence)?,
        _ => return None,
    };
    Some(line_column(text, offset))
}

/// Byte offsets of each `Named("name"` in `text`, at the `N`.
fn named_occurrences<'a>(text: &'a str, name: &'a str) -> impl Iterator<Item = usize> + 'a {
    let quoted = format!("\"{name}\"");
    text.match_indices("Named").filter_map(move |(at, _)| {
        let rest = text[at + "Named".len()..].trim_start().strip_prefix('(')?.trim_start();
        rest.starts_with(&quoted).then_some(at)
    })
}

/// Byte offsets of each `Kind(` in `text` (a whole word), at the kind's first letter.
fn node_occurrences<'a>(text: &'a str, kind: &'a str) -> impl Iterator<Item = usize> + 'a {
    text.match_indices(kind).map(|(at, _)| at).filter(move |&at| {
        let before = text[..at].chars().next_back();
        let boundary = before.is_none_or(|c| !(c.is_alphanumeric() || c == '_'));
        boundary && text[at + kind.len()..].trim_start().starts_with('(')
    })
}

/// Byte offset of the scene's `field:` entry.
fn field_offset(text: &str, field: &str) -> Option<usize> {
    text.match_indices(field).map(|(at, _)| at).find(|&at| {
        let before = text[..at].chars().next_back();
        let boundary = before.is_none_or(|c| !(c.is_alphanumeric() || c == '_'));
        boundary && text[at + field.len()..].trim_start().starts_with(':')
    })
}

/// The 1-based line and column (in characters) of byte `offset`.
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_second_use_of_a_name_and_the_model_field_are_found() {
        let text = "Scene(\n  model: Blend([Named(\"a\", P), Named( \"a\", Q), Named(\"ab\", R)]),\n)";
        assert_eq!(locate(text, &ModelError::DuplicateName("a".into())), Some((2, 32)));
        assert_eq!(locate(text, &ModelError::TooFar { far: 1e9, size: 1.0 }), Some((2, 3)));
        assert_eq!(locate(text, &ModelError::Empty), None);
        let warps = "Blend([Bend(rate: 0.1, child: P),\n  Bend(rate: 9.0, child: Q)])";
        let bad = ModelError::BadWarp { kind: "Bend", occurrence: 1, message: String::new() };
        assert_eq!(locate(warps, &bad), Some((2, 3)));
    }
}
