//! `fractum snapshot`: a PNG of one frame's particles coloured by a field.

use crate::cli::SnapshotArgs;
use crate::overlay::Overlay;
use crate::snapshot::{SnapshotOptions, snapshot};
use crate::{EXIT_BAD_SCENE, EXIT_IO};
use fractum_io::output::read_particle_frame;

/// `fractum snapshot` with `args`; the exit code.
pub(crate) fn snapshot_command(args: &SnapshotArgs) -> i32 {
    let overlay = match args.overlay.as_deref().map(Overlay::read).transpose() {
        Ok(overlay) => overlay,
        Err(e) => {
            eprintln!("error: --overlay: {e}");
            return EXIT_BAD_SCENE;
        }
    };
    let options = &SnapshotOptions {
        field: args.field.clone(),
        view: args.view,
        width: args.width,
        range: (args.range.len() == 2).then(|| (args.range[0], args.range[1])),
        overlay,
        when: crate::snapshot::frame_when(&args.frame),
    };
    let frame = args.frame.as_path();
    let output = args.output.clone().unwrap_or_else(|| {
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
