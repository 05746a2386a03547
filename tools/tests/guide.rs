//! Runs every command of the guide (the lines of `sh` blocks in docs/guide/*.md) from the
//! repository's root, with `fractum` the binary under test and `cargo` the toolchain's, so the
//! guide cannot drift from the code. Outputs go under `out/guide/`.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// The commands of a page's `sh` blocks.
fn commands(page: &str) -> Vec<String> {
    let mut inside = false;
    let mut found = Vec::new();
    for line in page.lines() {
        match line.trim() {
            "```sh" => inside = true,
            "```" => inside = false,
            command if inside && !command.is_empty() => found.push(command.to_string()),
            _ => {}
        }
    }
    found
}

fn run_page(name: &str) {
    let page = std::fs::read_to_string(root().join("docs/guide").join(name)).unwrap();
    let found = commands(&page);
    assert!(!found.is_empty(), "{name} has no commands");
    for command in found {
        let words: Vec<&str> = command.split_whitespace().collect();
        let program = match words[0] {
            "fractum" => PathBuf::from(env!("CARGO_BIN_EXE_fractum")),
            "cargo" => PathBuf::from(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into())),
            other => panic!("{name}: `{other}` is not a command the guide may use"),
        };
        let output = Command::new(program)
            .args(&words[1..])
            .current_dir(root())
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "{name}: `{command}` failed:\n{}{}",
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        );
    }
}

#[test]
fn first_scene_commands_run() {
    run_page("first-scene.md");
}

#[test]
fn output_commands_run() {
    run_page("outputs.md");
}

#[test]
fn convergence_commands_run() {
    run_page("convergence.md");
}
