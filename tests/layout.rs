//! The README's Layout table, enforced: every top-level module of `src/` has
//! a row, and its files import (`use crate::x`, a `crate::x::` path in code,
//! or a `super::super` escape out of the module) only the modules its row's
//! "may import" cell names. A row's cell lists modules in backticks;
//! "nothing of ours" allows none, "everything above" every module of the rows
//! above it, and words in parentheses (such as the feature a module sits
//! behind) are not read. Test code (an item under `#[cfg(test)]`, or a
//! `tests.rs` file) may import what it needs to build its cases, and is not
//! checked.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// One row of the table: the module and what it may import.
#[derive(Debug)]
struct Row {
    module: String,
    allowed: BTreeSet<String>,
}

/// A source file: its path from the crate root (such as `src/mesh/export.rs`)
/// and its text.
struct Source {
    path: String,
    text: String,
}

/// Reads the rows of the table under the `## Layout` heading of `readme`.
fn layout_rows(readme: &str) -> Result<Vec<Row>, String> {
    let section = readme.split("\n## Layout").nth(1).ok_or("README.md has no \"## Layout\" section")?;
    let section = section.split("\n## ").next().unwrap_or(section);
    let mut rows: Vec<Row> = Vec::new();
    for line in section.lines().filter(|l| l.starts_with('|')) {
        let cells: Vec<&str> = line.trim().trim_matches('|').split('|').map(str::trim).collect();
        let [module, _holds, may_import] = cells[..] else {
            return Err(format!("a Layout row without three cells: {line}"));
        };
        if module == "module" || module.starts_with("---") {
            continue;
        }
        let module = module.trim_matches('`').to_string();
        let mut allowed = backticked(&without_parentheses(may_import));
        if may_import.contains("everything above") {
            allowed.extend(rows.iter().map(|r| r.module.clone()));
        }
        let nothing = may_import.contains("nothing of ours");
        if allowed.is_empty() && !nothing {
            return Err(format!("the Layout row of `{module}` names no module (write \"nothing of ours\" for none)"));
        }
        rows.push(Row { module, allowed });
    }
    if rows.is_empty() {
        return Err("the Layout section holds no table rows".into());
    }
    Ok(rows)
}

/// `text` with every parenthesized part removed.
fn without_parentheses(text: &str) -> String {
    let mut depth = 0usize;
    text.chars()
        .filter(|&c| {
            match c {
                '(' => depth += 1,
                ')' => depth = depth.saturating_sub(1),
                _ => return depth == 0,
            }
            false
        })
        .collect()
}

/// The names in backticks in `text`.
fn backticked(text: &str) -> BTreeSet<String> {
    text.split('`').skip(1).step_by(2).map(str::to_string).collect()
}

/// The top-level module a file under `src/` belongs to, and its module path
/// below the crate (`src/pipeline/regress/run.rs` → `[pipeline, regress, run]`).
/// `None` for the crate root files.
fn module_path(path: &str) -> Option<Vec<String>> {
    let rest = path.strip_prefix("src/")?;
    let mut parts: Vec<String> = rest.split('/').map(str::to_string).collect();
    let last = parts.pop()?;
    let stem = last.strip_suffix(".rs")?;
    if parts.is_empty() && (stem == "lib" || stem == "main") {
        return None;
    }
    if stem != "mod" {
        parts.push(stem.to_string());
    }
    Some(parts)
}

/// Each line of `text` with its number, code only: line comments cut off
/// and items under `#[cfg(test)]` left out.
fn code_lines(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut skipping = false;
    let mut depth = 0i64;
    let mut opened = false;
    for (k, line) in text.lines().enumerate() {
        let code = line.split("//").next().unwrap_or("");
        if !skipping && code.trim() == "#[cfg(test)]" {
            (skipping, depth, opened) = (true, 0, false);
            continue;
        }
        if skipping {
            for c in code.chars() {
                match c {
                    '{' => (depth, opened) = (depth + 1, true),
                    '}' => depth -= 1,
                    _ => {}
                }
            }
            // The item ends at its closing brace, or at a `;` if it has no body.
            if (opened && depth <= 0) || (!opened && code.trim_end().ends_with(';')) {
                skipping = false;
            }
            continue;
        }
        out.push((k + 1, code.to_string()));
    }
    out
}

/// The top-level modules a line of code in the file at `module` names:
/// `crate::x`, each name of `crate::{x, y}`, and `super::super…::x` where
/// the supers climb out of the file's top-level module.
fn imported_modules(code: &str, module: &[String]) -> Vec<String> {
    let mut found = Vec::new();
    for (at, _) in code.match_indices("crate::") {
        if code[..at].ends_with(|c: char| c.is_alphanumeric() || c == '_' || c == '$') {
            continue;
        }
        let rest = &code[at + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let group = group.split('}').next().unwrap_or("");
            found.extend(group.split(',').filter_map(|item| first_name(item.trim())));
        } else {
            found.extend(first_name(rest));
        }
    }
    for (at, _) in code.match_indices("super::") {
        let before = &code[..at];
        if before.ends_with("super::") || before.ends_with(|c: char| c.is_alphanumeric() || c == '_') {
            continue;
        }
        let mut rest = &code[at..];
        let mut supers = 0;
        while let Some(r) = rest.strip_prefix("super::") {
            supers += 1;
            rest = r;
        }
        // A file's own module path ends in itself; each `super` drops one name.
        if supers >= module.len() {
            found.extend(first_name(rest));
        }
    }
    found
}

/// The identifier `text` starts with.
fn first_name(text: &str) -> Option<String> {
    let name: String = text.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
    (!name.is_empty() && name != "self").then_some(name)
}

/// Every import that the table does not allow, as `file:line: ...`, and every
/// module without a row.
fn violations(rows: &[Row], sources: &[Source]) -> Vec<String> {
    let table: BTreeMap<&str, &Row> = rows.iter().map(|r| (r.module.as_str(), r)).collect();
    let mut found = Vec::new();
    let mut missing = BTreeSet::new();
    for source in sources {
        let Some(module) = module_path(&source.path) else { continue };
        if source.path.ends_with("/tests.rs") {
            continue;
        }
        let top = module[0].as_str();
        let Some(row) = table.get(top) else {
            missing.insert(top.to_string());
            continue;
        };
        for (line, code) in code_lines(&source.text) {
            for imported in imported_modules(&code, &module) {
                if imported != top && table.contains_key(imported.as_str()) && !row.allowed.contains(&imported) {
                    found.push(format!(
                        "{}:{line}: `{top}` imports `{imported}`, which its Layout row in README.md does not allow: {}",
                        source.path,
                        code.trim()
                    ));
                }
            }
        }
    }
    found.extend(
        missing.into_iter().map(|m| format!("src/{m}: the module `{m}` has no row in README.md's Layout table")),
    );
    found
}

/// Every `.rs` file under `dir`, its path relative to `root`.
fn rust_files(root: &Path, dir: &Path, out: &mut Vec<Source>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            rust_files(root, &path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            let relative = path.strip_prefix(root).unwrap().to_string_lossy().replace('\\', "/");
            out.push(Source { path: relative, text: std::fs::read_to_string(&path).unwrap() });
        }
    }
}

#[test]
fn every_module_imports_only_what_its_layout_row_allows() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).unwrap();
    let rows = layout_rows(&readme).unwrap();
    let mut sources = Vec::new();
    rust_files(root, &root.join("src"), &mut sources);
    assert!(sources.len() > 100, "read {} source files", sources.len());
    let found = violations(&rows, &sources);
    assert!(found.is_empty(), "{} imports against the Layout table:\n{}", found.len(), found.join("\n"));
}

#[test]
fn the_check_names_the_file_and_line_of_a_bad_import() {
    let readme = "# x\n\n## Layout\n\n| module | holds | may import |\n| --- | --- | --- |\n\
        | `geom` | boxes | nothing of ours |\n| `field` | the arena | `geom` |\n\
        | `pipeline` | jobs | everything above |\n| `cli` | clap | `pipeline` (feature `field`) |\n\n## Next\n";
    let rows = layout_rows(readme).unwrap();
    let file = |path: &str, text: &str| Source { path: path.into(), text: text.into() };
    let sources = [
        file("src/lib.rs", "pub mod geom;\n"),
        file("src/geom/mod.rs", "//! use crate::field::Model; (a comment)\nuse crate::field::Model;\n"),
        file("src/field/mod.rs", "use crate::geom::Aabb;\n#[cfg(test)]\nmod tests {\n    use crate::pipeline::x;\n}\n"),
        file(
            "src/field/node/kind.rs",
            "fn f() { super::super::super::pipeline::run(); super::super::Model::new(); }\n",
        ),
        file("src/pipeline/mod.rs", "use crate::{field::Model, geom::Aabb};\n"),
        file("src/cli/mod.rs", "use crate::{pipeline, field};\n"),
        file("src/viewer.rs", "use crate::pipeline;\n"),
    ];
    let found = violations(&rows, &sources);
    assert_eq!(found.len(), 4, "{found:#?}");
    assert!(found[0].starts_with("src/geom/mod.rs:2: `geom` imports `field`"), "{}", found[0]);
    assert!(found[1].starts_with("src/field/node/kind.rs:1: `field` imports `pipeline`"), "{}", found[1]);
    assert!(
        found[2].starts_with("src/cli/mod.rs:1: `cli` imports `field`"),
        "a feature in parentheses allows nothing: {}",
        found[2]
    );
    assert!(found[3].contains("`viewer` has no row"), "{}", found[3]);
}
