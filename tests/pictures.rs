//! The pictures README.md and docs/ show exist, and each is made by a line
//! of `scripts/pictures`, the command its caption gives where it gives one:
//! running the script makes every one of them again from the current build.

use std::path::Path;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// The images a Markdown file links, as paths from the repository's root.
fn pictures_in(doc: &str, from: &str) -> Vec<String> {
    let mut found = vec![];
    for (i, _) in doc.match_indices("](") {
        let rest = &doc[i + 2..];
        let link = &rest[..rest.find(')').unwrap_or(0)];
        if link.ends_with(".png") {
            found.push(Path::new(from).join(link).to_string_lossy().replace("docs/../", ""));
        }
    }
    found
}

/// The commands in a doc's captions: backquoted text starting `blobtrace`
/// and naming `picture`.
fn caption_commands<'a>(doc: &'a str, picture: &str) -> Vec<&'a str> {
    doc.split('`').skip(1).step_by(2).filter(|c| c.starts_with("blobtrace ") && c.contains(picture)).collect()
}

#[test]
fn every_picture_the_documents_show_exists_and_the_pictures_script_makes_it() {
    let script = std::fs::read_to_string(Path::new(ROOT).join("scripts/pictures")).unwrap();
    let lines: Vec<&str> = script.lines().map(str::trim).filter(|l| !l.starts_with('#')).collect();
    let mut checked = 0;
    for (doc_path, from) in [("README.md", ""), ("docs/ALGORITHMS.md", "docs"), ("docs/PERFORMANCE.md", "docs")] {
        let doc = std::fs::read_to_string(Path::new(ROOT).join(doc_path)).unwrap();
        for picture in pictures_in(&doc, from) {
            assert!(Path::new(ROOT).join(&picture).is_file(), "{doc_path} shows {picture}, which is missing");
            // Named by the line, or in the folder a command writes its set of pictures into.
            let folder = Path::new(&picture).parent().map(|f| format!("--out-dir {}", f.display())).unwrap_or_default();
            let makes =
                |l: &&&str| l.contains(picture.as_str()) || l.ends_with(&folder) || l.contains(&format!("{folder} "));
            let makers: Vec<&&str> = lines.iter().filter(makes).collect();
            assert!(!makers.is_empty(), "{doc_path} shows {picture}, which no line of scripts/pictures makes");
            for command in caption_commands(&doc, &picture) {
                assert!(lines.contains(&command), "{doc_path}'s caption command {command:?} is not the script's");
            }
            checked += 1;
        }
    }
    assert!(checked >= 10, "the documents show {checked} pictures");
}

#[test]
fn the_links_are_read_as_the_documents_write_them() {
    let doc = "![a](images/a.png) and ![b](../images/b.png) and [c](x.md)";
    assert_eq!(pictures_in(doc, ""), ["images/a.png", "../images/b.png"]);
    assert_eq!(pictures_in("![b](../images/b.png)", "docs"), ["images/b.png"]);
    assert_eq!(
        caption_commands("*`blobtrace render s -o images/a.png`: it*", "images/a.png"),
        ["blobtrace render s -o images/a.png"]
    );
}
