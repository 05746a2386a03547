//! SCENES.md documents every field and variant of the scene format: each name declared in
//! `engine/scene/src/format/` (struct fields, enum variants and their fields) must appear in
//! it in backticks, so adding a field without documenting it fails here.

use fractum_suite::repo_root;

/// Field and variant names declared in the format module, read from the source of each of its
/// files.
fn format_names() -> Vec<String> {
    let folder = repo_root().join("engine/scene/src/format");
    let mut files: Vec<_> = std::fs::read_dir(&folder)
        .unwrap()
        .map(|entry| entry.unwrap().path())
        .filter(|path| path.extension().is_some_and(|e| e == "rs"))
        .collect();
    files.sort();
    assert!(files.len() >= 2, "the format module's files: {files:?}");
    files
        .iter()
        .flat_map(|path| names_in(&std::fs::read_to_string(path).unwrap()))
        .collect()
}

/// Field and variant names declared in one file of the format module.
fn names_in(source: &str) -> Vec<String> {
    let mut names = Vec::new();
    let mut inside: Option<&str> = None;
    for line in source.lines() {
        let trimmed = line.trim_start();
        if trimmed.starts_with("//") || trimmed.starts_with("#[") {
            continue;
        }
        if line.starts_with("pub struct ") && line.ends_with('{') {
            inside = Some("struct");
            continue;
        }
        if line.starts_with("pub enum ") && line.ends_with('{') {
            inside = Some("enum");
            continue;
        }
        if line.starts_with('}') {
            inside = None;
            continue;
        }
        let indent = line.len() - trimmed.len();
        let word: String = trimmed
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        let rest = &trimmed[word.len()..];
        match inside {
            Some("struct") if indent == 4 => {
                if let Some(field) = trimmed.strip_prefix("pub ") {
                    let field: String = field.chars().take_while(|c| *c != ':').collect();
                    names.push(field);
                }
            }
            Some("enum")
                if indent == 4
                    && !word.is_empty()
                    && (rest.starts_with(',')
                        || rest.starts_with('(')
                        || rest.starts_with(" {")) =>
            {
                names.push(word)
            }
            Some("enum") if indent == 8 && rest.starts_with(':') => names.push(word),
            _ => {}
        }
    }
    names
}

#[test]
fn every_field_and_variant_of_the_format_is_documented() {
    let names = format_names();
    // The scanner must see the format; these are a sample of each kind of name.
    for expected in [
        "thickness",
        "spacing",
        "Sphere",
        "Prism",
        "axis",
        "on_leave_grid",
        "z",
    ] {
        assert!(
            names.iter().any(|n| n == expected),
            "scanner missed {expected}: {names:?}"
        );
    }
    let reference = std::fs::read_to_string(repo_root().join("SCENES.md")).unwrap();
    // `name` opening a code span and followed by something that ends the name: `name`,
    // `name: …`, `name(…)`.
    let documented = |name: &str| {
        reference.match_indices(&format!("`{name}")).any(|(at, m)| {
            let next = reference[at + m.len()..].chars().next();
            next.is_some_and(|c| !(c.is_ascii_alphanumeric() || c == '_'))
        })
    };
    let missing: Vec<&String> = names.iter().filter(|n| !documented(n)).collect();
    assert!(
        missing.is_empty(),
        "SCENES.md does not document: {missing:?}"
    );
}
