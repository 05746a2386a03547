//! The solver digest `fractum verify` keys its results by: an FNV-1a hash of the engine's crates'
//! and the stock systems' sources and of `Cargo.lock`, so that a change to the physics re-runs the
//! verification cases while a change to the command line's own code does not. Built outside
//! this workspace (the sources not beside it), the digest is the crate's version alone.

use std::path::{Path, PathBuf};

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default());
    let root = manifest.parent().map(Path::to_path_buf).unwrap_or_default();
    let inputs = [
        root.join("engine/core/src"),
        root.join("engine/geometry/src"),
        root.join("engine/io/src"),
        root.join("engine/scene/src"),
        root.join("systems/src"),
        root.join("Cargo.lock"),
    ];
    let mut files = Vec::new();
    for input in &inputs {
        println!("cargo:rerun-if-changed={}", input.display());
        collect(input, &mut files);
    }
    files.sort();
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    for file in &files {
        let relative = file.strip_prefix(&root).unwrap_or(file);
        let bytes = std::fs::read(file).unwrap_or_default();
        for byte in relative.to_string_lossy().bytes().chain(bytes) {
            hash ^= u64::from(byte);
            hash = hash.wrapping_mul(0x0100_0000_01b3);
        }
    }
    let digest = if files.is_empty() {
        format!(
            "version-{}",
            std::env::var("CARGO_PKG_VERSION").unwrap_or_default()
        )
    } else {
        format!("{hash:016x}")
    };
    println!("cargo:rustc-env=FRACTUM_SOLVER_DIGEST={digest}");
}

fn collect(path: &Path, files: &mut Vec<PathBuf>) {
    if path.is_file() {
        files.push(path.to_path_buf());
    } else if let Ok(entries) = std::fs::read_dir(path) {
        for entry in entries.flatten() {
            collect(&entry.path(), files);
        }
    }
}
