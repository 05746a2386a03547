//! The house rules of the source, held against the source itself (ARCHITECTURE.md, "House
//! rules"): no source file over 600 lines before its tests, no function over 80 lines, and no
//! two files of a crate that import each other (a file and the files of its own folder may:
//! that is one module split over files), and no mutable column of the stepping crates taken
//! with its change ticks (`single_table_mut`, not `single_table`, for `contiguous_iter_mut`).
//! Test code is exempt: a file's `#[cfg(test)]` module, and the integration tests under
//! `tests/` folders.
//!
//! The source is rustfmt's, so a function ends at the first line that is its opening line's
//! indentation followed by `}`.

use fractum_suite::repo_root;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Most lines a file may hold before its tests.
const MAX_FILE_LINES: usize = 600;
/// Most lines a function may span, its signature and closing brace included.
const MAX_FUNCTION_LINES: usize = 80;

/// The crates whose `src/` the rules hold for.
const CRATES: [&str; 8] = [
    "engine/core",
    "engine/geometry",
    "engine/io",
    "engine/scene",
    "systems",
    "tools",
    "tools/mpi",
    "tools/python",
];

/// Every `.rs` file under `dir`, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    let mut folders = vec![dir.to_path_buf()];
    while let Some(folder) = folders.pop() {
        for entry in std::fs::read_dir(&folder).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                folders.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                files.push(path);
            }
        }
    }
    files.sort();
    files
}

/// The lines of `text` before its test module.
fn before_tests(text: &str) -> Vec<&str> {
    text.lines()
        .take_while(|line| !line.starts_with("#[cfg(test)]"))
        .collect()
}

/// The name and line count of each function with a body among `lines`.
fn function_lengths(lines: &[&str]) -> Vec<(String, usize)> {
    let mut found = Vec::new();
    for (start, line) in lines.iter().enumerate() {
        let trimmed = line.trim_start();
        let indent = &line[..line.len() - trimmed.len()];
        let signature = [
            "pub fn ",
            "pub(crate) fn ",
            "pub(super) fn ",
            "fn ",
            "const fn ",
        ]
        .iter()
        .find_map(|prefix| trimmed.strip_prefix(prefix));
        let Some(signature) = signature else {
            continue;
        };
        let name: String = signature
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        // A declaration without a body (a trait's) ends at its `;` before any `{`.
        let closing = format!("{indent}}}");
        let mut end = None;
        let mut opened = false;
        for (k, later) in lines.iter().enumerate().skip(start) {
            opened |= later.contains('{');
            if !opened && later.trim_end().ends_with(';') {
                break;
            }
            let one_line = k == start && opened && later.trim_end().ends_with('}');
            if one_line || (k > start && *later == closing) {
                end = Some(k);
                break;
            }
        }
        if let Some(end) = end {
            found.push((name, end - start + 1));
        }
    }
    found
}

/// The crates whose systems run in the step: their mutable columns come without change ticks.
const STEPPING_CRATES: [&str; 2] = ["engine/core", "systems"];

/// Whether `text` hands a mutable contiguous query to `single_table`, whose `ContiguousMut`
/// columns mark every row changed when borrowed (`storage::single_table_mut` does not).
fn takes_mutable_columns_with_ticks(text: &str) -> bool {
    text.match_indices("single_table(").any(|(at, call)| {
        let argument: String = text[at + call.len()..]
            .chars()
            .filter(|c| !c.is_whitespace())
            .take(80)
            .collect();
        let first = argument.split(',').next().unwrap_or("");
        first.contains(".contiguous_iter_mut(")
    })
}

/// The source files of `crates` (paths from the repository's root) whose code before its tests
/// `breaks` a rule.
fn files_where(crates: &[&str], breaks: impl Fn(&str) -> bool) -> Vec<String> {
    let root = repo_root();
    let mut found = Vec::new();
    for krate in crates {
        for file in rust_files(&root.join(krate).join("src")) {
            let text = std::fs::read_to_string(&file).unwrap();
            if breaks(&before_tests(&text).join("\n")) {
                found.push(file.strip_prefix(&root).unwrap().display().to_string());
            }
        }
    }
    found
}

#[test]
fn stepping_code_takes_mutable_columns_without_change_ticks() {
    assert!(takes_mutable_columns_with_ticks(
        "single_table(\n        nodes.contiguous_iter_mut(), \"nodes\")"
    ));
    assert!(!takes_mutable_columns_with_ticks(
        "single_table_mut(nodes.contiguous_iter_mut(), \"nodes\"); single_table(q.contiguous_iter(), \"p\")"
    ));
    let found = files_where(&STEPPING_CRATES, takes_mutable_columns_with_ticks);
    assert!(
        found.is_empty(),
        "take mutable columns with `single_table_mut` (storage.rs says why): {found:?}"
    );
}

/// Whether `text` hands [`fractum_engine::vector_isa::vectorised`] a closure not marked
/// `#[inline(always)]`: the kernel would then be a call out of the wide code, compiled for the
/// baseline (vector_isa.rs says why).
fn vectorises_without_inlining(text: &str) -> bool {
    text.match_indices("vectorised(").any(|(at, call)| {
        let rest = text[at + call.len()..].trim_start();
        !rest.starts_with("#[inline(always)]")
    })
}

#[test]
fn vectorised_kernels_are_inlined_into_the_dispatch() {
    assert!(vectorises_without_inlining(
        "vectorised(|| { for x in y {} })"
    ));
    assert!(!vectorises_without_inlining(
        "vectorised(\n    #[inline(always)]\n    || {})"
    ));
    let found = files_where(&CRATES, vectorises_without_inlining);
    assert!(
        found.is_empty(),
        "mark the closure handed to `vectorised` `#[inline(always)]`: {found:?}"
    );
}

#[test]
fn no_file_is_over_600_lines_before_its_tests() {
    let root = repo_root();
    let mut over = Vec::new();
    for krate in CRATES {
        for file in rust_files(&root.join(krate).join("src")) {
            let text = std::fs::read_to_string(&file).unwrap();
            let lines = before_tests(&text).len();
            if lines > MAX_FILE_LINES {
                over.push(format!(
                    "{} ({lines})",
                    file.strip_prefix(&root).unwrap().display()
                ));
            }
        }
    }
    assert!(
        over.is_empty(),
        "over {MAX_FILE_LINES} lines before the tests; split by what the parts do: {over:?}"
    );
}

#[test]
fn no_function_is_over_80_lines() {
    let root = repo_root();
    let mut over = Vec::new();
    let mut seen = 0;
    for krate in CRATES {
        for file in rust_files(&root.join(krate).join("src")) {
            let text = std::fs::read_to_string(&file).unwrap();
            for (name, lines) in function_lengths(&before_tests(&text)) {
                seen += 1;
                if lines > MAX_FUNCTION_LINES {
                    let at = file.strip_prefix(&root).unwrap().display().to_string();
                    over.push(format!("{at}: {name} ({lines})"));
                }
            }
        }
    }
    // The scanner must see the functions: the source has thousands.
    assert!(seen > 1000, "the scanner found only {seen} functions");
    assert!(
        over.is_empty(),
        "functions over {MAX_FUNCTION_LINES} lines; give their parts names: {over:?}"
    );
}

/// The module path (`["build", "ranks"]`) of a file of a crate's `src/`.
fn module_of(src: &Path, file: &Path) -> Vec<String> {
    let relative = file.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = relative
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts
}

/// The module paths named by `crate::…`, `super::…` and `self::…` paths in `text`, resolved
/// from `module` to the longest prefix that is a module of `modules`.
fn imported_modules(
    text: &str,
    module: &[String],
    modules: &BTreeSet<Vec<String>>,
) -> BTreeSet<Vec<String>> {
    let mut imported = BTreeSet::new();
    for line in text.lines().filter(|l| !l.trim_start().starts_with("//")) {
        let starts = ["crate::", "super::", "self::"]
            .iter()
            .flat_map(|keyword| line.match_indices(keyword).map(|(at, _)| at));
        for start in starts {
            let before = line[..start].chars().next_back();
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
                continue;
            }
            let path: String = line[start..]
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_' || *c == ':')
                .collect();
            let mut segments = path.split("::");
            let mut base: Vec<String> = match segments.next() {
                Some("crate") => Vec::new(),
                Some("super") => module[..module.len().saturating_sub(1)].to_vec(),
                Some("self") => module.to_vec(),
                _ => continue,
            };
            let mut resolved = base.clone();
            for segment in segments {
                if segment == "super" {
                    base.pop();
                    resolved = base.clone();
                    continue;
                }
                base.push(segment.to_string());
                if modules.contains(&base) {
                    resolved = base.clone();
                } else {
                    break;
                }
            }
            imported.insert(resolved);
        }
    }
    imported
}

#[test]
fn no_two_files_of_a_crate_import_each_other() {
    let root = repo_root();
    let mut circles = Vec::new();
    let mut edges_seen = 0;
    for krate in CRATES {
        let src = root.join(krate).join("src");
        let files = rust_files(&src);
        let modules: BTreeSet<Vec<String>> = files.iter().map(|f| module_of(&src, f)).collect();
        let mut edges: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
        for file in &files {
            let module = module_of(&src, file);
            let text = std::fs::read_to_string(file).unwrap();
            let code = before_tests(&text).join("\n");
            let mut imported = imported_modules(&code, &module, &modules);
            imported.remove(&module);
            edges_seen += imported.len();
            edges.insert(module, imported);
        }
        for (a, targets) in &edges {
            for b in targets {
                // A module and the files of its own folder are one module split over files.
                let nested = a.starts_with(b) || b.starts_with(a);
                if a < b && !nested && edges.get(b).is_some_and(|back| back.contains(a)) {
                    circles.push(format!("{krate}: {} ⇄ {}", a.join("::"), b.join("::")));
                }
            }
        }
    }
    assert!(
        edges_seen > 100,
        "the scanner found only {edges_seen} imports"
    );
    assert!(
        circles.is_empty(),
        "files that import each other; move what both need below both: {circles:?}"
    );
}
