//! PVD collection: the list of frames with their times, which ParaView opens as one time series.

use super::atomic::write_atomically;
use fractum_geometry::vtk::attribute;
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

/// Reads a collection written by [`write_pvd`]: `(time, file relative to the collection)` per
/// frame, in file order.
pub fn read_pvd(path: &Path) -> Result<Vec<(f64, String)>, String> {
    let xml = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut frames = Vec::new();
    for tag in xml.split("<DataSet").skip(1) {
        let time = attribute(tag, "timestep")
            .and_then(|t| t.parse::<f64>().ok())
            .ok_or_else(|| format!("{}: a DataSet without a readable timestep", path.display()))?;
        let file = attribute(tag, "file")
            .ok_or_else(|| format!("{}: a DataSet without a file", path.display()))?;
        frames.push((time, file.to_string()));
    }
    Ok(frames)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_collection_reads_back_as_written() {
        let dir = std::env::temp_dir().join(format!("fractum-pvd-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("particles.pvd");
        let frames = vec![
            (0.0, "frames/a.vtu".to_string()),
            (2.5e-6, "frames/b.vtu".into()),
        ];
        write_pvd(&path, &frames).unwrap();
        assert_eq!(read_pvd(&path).unwrap(), frames);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
