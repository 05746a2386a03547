//! PVD collection: the list of frames with their times, which ParaView opens as one time series.

use super::atomic::write_atomically;
use std::fmt::Write;
use std::path::Path;

/// Writes the collection at `path` listing `(time, relative file)` frames.
pub fn write_pvd(path: &Path, frames: &[(f64, String)]) -> std::io::Result<()> {
    let mut xml = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\" \
         byte_order=\"LittleEndian\">\n  <Collection>\n",
    );
    for (time, file) in frames {
        let _ = writeln!(
            xml,
            "    <DataSet timestep=\"{time:e}\" group=\"\" part=\"0\" file=\"{file}\"/>"
        );
    }
    xml.push_str("  </Collection>\n</VTKFile>\n");
    write_atomically(path, xml.as_bytes())
}
