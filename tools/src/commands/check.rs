//! `fractum check SCENE`: the one-screen summary of a built scene, with the run's length and
//! warnings for magnitudes no solid has; beside a refused scene, those magnitudes as notes.

use crate::{report_scene_error, reports};
use fractum_engine::registry::Registry;
use fractum_scene::{SceneFile, build_simulation, implausible_magnitudes};
use std::path::Path;

/// `fractum check` of the scene at `path`; the exit code.
pub(crate) fn check_command(path: &Path, registry: &Registry) -> i32 {
    let file = match SceneFile::read(path) {
        Ok(file) => file,
        Err(e) => return report_scene_error(&e),
    };
    // A valid scene with a magnitude no solid has is a warning; an invalid one that also has
    // one gets it as a note: the unit slip is often the cause.
    let implausible = implausible_magnitudes(&file);
    match build_simulation(&file, registry) {
        Ok(mut built) => {
            out!("{}", reports::check_report(&mut built, &implausible).0);
            0
        }
        Err(e) => {
            let code = report_scene_error(&e);
            for slip in &implausible {
                eprintln!("note: {slip}");
            }
            code
        }
    }
}
