//! Shared helpers for the integration tests in `tests/`.

use fractum_engine::dim::Dim;
use fractum_scene::{Built, SceneError, SceneFile, Spec, build_simulation};
use std::path::{Path, PathBuf};

/// The workspace root.
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Every `*.ron` file in `dir` (relative to the workspace root), sorted.
pub fn ron_files(dir: &str) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(repo_root().join(dir))
        .unwrap_or_else(|e| panic!("cannot list {dir}: {e}"))
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "ron"))
        .collect();
    files.sort();
    files
}

/// Reads and builds a scene with the stock systems.
pub fn load(path: &Path) -> Result<Built, SceneError> {
    let file = SceneFile::read(path)?;
    build_simulation(&file, &fractum_systems::stock_registry())
}

/// Builds the shipped scene `scenes/{name}` and steps it `steps` times; gives what `look` sees
/// of its world before the first step and after the last. Twin scenes (a shape and its
/// imported copy) are compared this way.
pub fn seeded_and_stepped<T>(
    name: &str,
    steps: usize,
    look: impl Fn(&mut bevy_ecs::world::World) -> T,
) -> (T, T) {
    let mut built =
        load(&repo_root().join("scenes").join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    let seeded = look(&mut built.simulation.world);
    for _ in 0..steps {
        built
            .simulation
            .step()
            .unwrap_or_else(|e| panic!("{name}: {e}"));
    }
    (seeded, look(&mut built.simulation.world))
}

/// A fresh, empty temporary folder for one test, of its own however many tests of the process
/// give the same name.
pub fn temp_dir(name: &str) -> PathBuf {
    static MADE: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let k = MADE.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("fractum-test-{}-{k}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)
        .unwrap_or_else(|e| panic!("cannot create {}: {e}", dir.display()));
    dir
}

/// Builds `spec` with the plainest pipeline, linear basis, USL and linear elasticity, for tests
/// about what a scene seeds rather than how it moves.
pub fn build_elastic<D: Dim>(spec: Spec<D>) -> Built {
    spec.system("basis/linear")
        .system("predictor/usl")
        .system("stress/linear_elastic")
        .system("advection/usl")
        .build(&fractum_systems::stock_registry())
        .unwrap_or_else(|e| panic!("{e}"))
}
