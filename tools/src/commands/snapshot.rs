//! `fractum snapshot`: a PNG of one frame's particles coloured by a field.

use crate::EXIT_IO;
use crate::snapshot::{SnapshotOptions, snapshot};
use fractum_io::output::read_particle_frame;
use std::path::{Path, PathBuf};

pub(crate) fn snapshot_command(
    frame: &Path,
    options: &SnapshotOptions,
    output: Option<PathBuf>,
) -> i32 {
    let output = output.unwrap_or_else(|| {
        let stem = frame
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        frame.with_file_name(format!("{stem}_{}.png", options.field))
    });
    match read_particle_frame(frame).and_then(|f| snapshot(&f, options, &output)) {
        Ok(()) => {
            outln!("wrote {}", output.display());
            0
        }
        Err(e) => {
            eprintln!("error: {e}");
            EXIT_IO
        }
    }
}
