//! Parse errors in the scene format's own words. The RON library reports a
//! bad value in terms of the grammar's Rust types (`enum AxisDesc`, `u32`,
//! "a tuple of size 3") and gives its own advice ("try the raw identifier");
//! a person editing a scene, a script or a manifest needs to hear what the
//! file may write at that place instead, with the valid words listed.

use ron::Error;

/// The message for `code`, raised where `rest` (the text from the error's
/// position on) begins.
#[must_use]
pub fn explain(code: &Error, rest: &str) -> String {
    let found = found(rest);
    let rest = rest.trim_start();
    match code {
        Error::NoSuchEnumVariant { expected, found: word, outer } => {
            let (what, kind) = role(outer.as_deref());
            format!("expected {what} here, found `{word}`; {kind} is {}", one_of(expected))
        }
        Error::NoSuchStructField { expected, found: field, outer } => {
            let of = outer.as_deref().map_or(String::new(), |o| format!(" {o}"));
            format!("`{field}` is no field of{of}; its fields are {}", all_of(expected))
        }
        Error::MissingStructField { field, outer } => {
            let of = outer.as_deref().map_or("this value".to_string(), |o| o.to_string());
            format!("{of} needs its `{field}` field")
        }
        Error::DuplicateStructField { field, outer } => {
            let of = outer.as_deref().map_or(String::new(), |o| format!(" of {o}"));
            format!("the field `{field}`{of} is written twice")
        }
        Error::SuggestRawIdentifier(word) | Error::InvalidIdentifier(word) => {
            format!("expected a field name and a colon here (such as `radius: 1.0`), found `{word}`")
        }
        Error::ExpectedIdentifier if rest.starts_with('"') => {
            "expected a bare word here, found a quoted string: write Y, not \"Y\"".to_string()
        }
        Error::ExpectedIdentifier => {
            format!("expected a word here (a field name and a colon, or a kind such as Point), found {found}")
        }
        Error::InvalidValueForType { expected, found: value } => {
            format!("expected {} here, found {value}", in_scene_words(expected))
        }
        Error::ExpectedDifferentLength { expected, found: n } => {
            format!("expected {} here, found {n}", in_scene_words(expected))
        }
        Error::ExpectedComma if rest.starts_with('.') => "expected a whole number here, found a fraction".to_string(),
        Error::IntegerOutOfBounds => "expected a whole number of at least 0 that fits here".to_string(),
        Error::ExceededRecursionLimit => {
            format!("the file nests brackets deeper than {} levels", super::RECURSION_LIMIT)
        }
        Error::ExpectedDifferentStructName { expected, found } => {
            format!("expected {expected}( … ) here, not {found}( … )")
        }
        Error::UnclosedBlockComment => "a /* comment is never closed with */".to_string(),
        Error::Message(message) => message.clone(),
        other => format!("{}, found {found}", expected_token(other).unwrap_or_else(|| other.to_string())),
    }
}

/// What the grammar's enum `outer` is called in a file: the thing expected,
/// and how the sentence listing its words begins.
fn role(outer: Option<&str>) -> (&'static str, &'static str) {
    match outer.unwrap_or("") {
        "node" => ("a node", "a node"),
        "AxisDesc" => ("an axis", "an axis"),
        "Kernel" => ("a kernel", "the kernel"),
        "Filter" => ("a reconstruction filter", "a filter"),
        "Storage" => ("a sample storage", "the storage"),
        "CacheUse" => ("a cache's `use`", "`use`"),
        "EditDesc" => ("an edit", "an edit"),
        "OperatorDesc" => ("an operator", "an operator"),
        "Kind" => ("an entry's kind", "a kind"),
        _ => ("a word", "the word"),
    }
}

/// `A`, `A or B`, `A, B or C`.
fn one_of(words: &[&str]) -> String {
    match words {
        [] => "nothing".to_string(),
        [only] => only.to_string(),
        [init @ .., last] => format!("{} or {last}", init.join(", ")),
    }
}

/// `A`, `A and B`, `A, B and C`.
fn all_of(words: &[&str]) -> String {
    match words {
        [init @ .., last] if !init.is_empty() => format!("{} and {last}", init.join(", ")),
        _ => one_of(words),
    }
}

/// serde's description of a Rust type, as a scene file writes the value.
fn in_scene_words(expected: &str) -> String {
    if let Some(n) = expected.strip_prefix("a tuple of size ").or_else(|| expected.strip_prefix("tuple of size ")) {
        return format!("{n} values in parentheses");
    }
    // serde names a tuple variant by its Rust path: `tuple variant NodeDesc::Named with 2 elements`.
    if let Some(variant) = expected.strip_prefix("tuple variant ") {
        let (path, count) = variant.split_once(" with ").unwrap_or((variant, "its elements"));
        let name = path.rsplit("::").next().unwrap_or(path);
        return format!("{name}( … ) with {}", count.replace("elements", "values"));
    }
    let word = match expected {
        "u8" | "u16" | "u32" | "u64" | "usize" | "i32" | "i64" => "a whole number",
        "f32" | "f64" => "a number",
        "a string" | "string" => "a name in double quotes",
        "a sequence" => "a list in square brackets",
        "a boolean" => "true or false",
        other => other,
    };
    word.to_string()
}

/// The bracket or token a syntax error expected.
fn expected_token(code: &Error) -> Option<String> {
    let what = match code {
        Error::Eof => "the file ends early: a bracket is left open",
        Error::ExpectedArray => "expected a list in square brackets, [ … ]",
        Error::ExpectedArrayEnd => "expected a comma or the list's closing `]`",
        Error::ExpectedComma => "expected a comma",
        Error::ExpectedFloat => "expected a number",
        Error::ExpectedInteger => "expected a whole number",
        Error::ExpectedBoolean => "expected true or false",
        Error::ExpectedString | Error::ExpectedStringEnd => "expected a name in double quotes, such as \"head\"",
        Error::ExpectedStructLike => "expected `(` and the values inside",
        Error::ExpectedStructLikeEnd => "expected a comma or the closing `)` (or one value too many)",
        Error::ExpectedNamedStructLike(name) => return Some(format!("expected {name}( … )")),
        Error::ExpectedMapColon => "expected a colon after the field name",
        Error::TrailingCharacters => "expected the end of the file after the outermost `)`",
        Error::UnexpectedChar(_) => "unexpected character",
        _ => return None,
    };
    Some(what.to_string())
}

/// What the text holds at the error's position, for "found …".
fn found(rest: &str) -> String {
    let rest = rest.trim_start();
    let token: String = match rest.chars().next() {
        None => return "the end of the file".to_string(),
        Some(c) if c.is_alphanumeric() || c == '_' || c == '-' || c == '.' => {
            rest.chars().take_while(|c| c.is_alphanumeric() || matches!(c, '_' | '-' | '.')).take(40).collect()
        }
        Some(c) => c.to_string(),
    };
    format!("`{token}`")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_are_listed_as_a_person_reads_them() {
        assert_eq!(one_of(&["X", "Y", "Z"]), "X, Y or Z");
        assert_eq!(one_of(&["Wyvill"]), "Wyvill");
        assert_eq!(all_of(&["a", "b"]), "a and b");
        let axis =
            Error::NoSuchEnumVariant { expected: &["X", "Y", "Z"], found: "W".into(), outer: Some("AxisDesc".into()) };
        assert_eq!(explain(&axis, "W, rate: 1.0"), "expected an axis here, found `W`; an axis is X, Y or Z");
        let tuple = Error::ExpectedDifferentLength { expected: "a tuple of size 3".into(), found: 2 };
        assert_eq!(explain(&tuple, ")"), "expected 3 values in parentheses here, found 2");
        assert_eq!(
            explain(&Error::ExpectedArray, "Point("),
            "expected a list in square brackets, [ … ], found `Point`"
        );
        let named = Error::ExpectedDifferentLength {
            expected: "tuple variant NodeDesc::Named with 2 elements".into(),
            found: 1,
        };
        assert_eq!(explain(&named, ")"), "expected Named( … ) with 2 values here, found 1");
    }
}
