//! Helpers the command-line test crates share: the workspace root and the `fractum` binary
//! run from it. Each test crate uses some of them, so the others are dead code there.
#![allow(dead_code)]

pub mod mpirun;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The workspace root (scene paths in the tests are relative to it).
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The `fractum` binary with `args`, run from the workspace root.
pub fn command(args: &[&str]) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_fractum"));
    command.args(args).current_dir(root());
    command
}

/// Runs `fractum` with `args` to its end.
pub fn fractum(args: &[&str]) -> Output {
    command(args).output().expect("the fractum binary runs")
}

/// Process output as text.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}
