//! Parallel VTU (`.pvtu`) indexes: a distributed run writes each frame as one VTU piece per rank
//! (the particles or nodes the rank owns) and one index that lists the pieces, which ParaView
//! opens as one data set. The index declares the pieces' point-data arrays, as the piece of the
//! rank that writes it has them ([`PieceArrays`]).

use super::atomic::write_atomically;
use fractum_geometry::vtk::attribute;
use std::fmt::Write;
use std::path::Path;

/// The point-data arrays of a frame file as a `.pvtu` index declares them: the scalars' and
/// vectors' default arrays, then each array's name, VTK type and components, in file order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PieceArrays {
    /// The array ParaView colours by at first.
    pub scalars: String,
    /// The array ParaView shows as vectors at first.
    pub vectors: String,
    /// Name, type and components of each array.
    pub arrays: Vec<(String, String, usize)>,
}

/// The file of rank `rank`'s piece of the frame whose index is `index` (`frames/x.pvtu` →
/// `frames/x_3.vtu`), relative to the same folder as `index`.
pub fn piece_name(index: &str, rank: usize) -> String {
    let stem = index.strip_suffix(".pvtu").unwrap_or(index);
    format!("{stem}_{rank}.vtu")
}

/// Writes the index at `path` of the pieces `pieces` (file names relative to the index's
/// folder), each holding the point-data arrays `arrays`.
pub fn write_pvtu(path: &Path, arrays: &PieceArrays, pieces: &[String]) -> std::io::Result<()> {
    let mut xml = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" \
         byte_order=\"LittleEndian\" header_type=\"UInt64\">\n  <PUnstructuredGrid \
         GhostLevel=\"0\">\n",
    );
    let _ = writeln!(
        xml,
        "    <PPointData Scalars=\"{}\" Vectors=\"{}\">",
        arrays.scalars, arrays.vectors
    );
    for (name, ty, components) in &arrays.arrays {
        let _ = writeln!(
            xml,
            "      <PDataArray type=\"{ty}\" Name=\"{name}\" NumberOfComponents=\"{components}\"/>"
        );
    }
    xml.push_str(
        "    </PPointData>\n    <PPoints>\n      <PDataArray type=\"Float64\" \
         NumberOfComponents=\"3\"/>\n    </PPoints>\n",
    );
    for piece in pieces {
        let _ = writeln!(xml, "    <Piece Source=\"{piece}\"/>");
    }
    xml.push_str("  </PUnstructuredGrid>\n</VTKFile>\n");
    write_atomically(path, xml.as_bytes())
}

/// The pieces an index written by [`write_pvtu`] lists, relative to its folder, in order.
pub fn read_pvtu_pieces(path: &Path) -> Result<Vec<String>, String> {
    let xml = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    xml.split("<Piece")
        .skip(1)
        .map(|tag| {
            attribute(tag, "Source")
                .map(str::to_string)
                .ok_or_else(|| format!("{}: a Piece without a Source", path.display()))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_index_lists_its_pieces_and_declares_their_arrays() {
        let dir = std::env::temp_dir().join(format!("fractum-pvtu-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("particles_00000010.pvtu");
        let arrays = PieceArrays {
            scalars: "damage".into(),
            vectors: "velocity".into(),
            arrays: vec![
                ("id".into(), "Int32".into(), 1),
                ("velocity".into(), "Float64".into(), 3),
            ],
        };
        let pieces: Vec<String> = (0..3)
            .map(|r| piece_name("particles_00000010.pvtu", r))
            .collect();
        assert_eq!(pieces[2], "particles_00000010_2.vtu");
        write_pvtu(&path, &arrays, &pieces).unwrap();
        assert_eq!(read_pvtu_pieces(&path).unwrap(), pieces);
        let xml = std::fs::read_to_string(&path).unwrap();
        assert!(
            xml.contains(
                "<PDataArray type=\"Float64\" Name=\"velocity\" NumberOfComponents=\"3\"/>"
            )
        );
        assert!(xml.contains("<PPointData Scalars=\"damage\" Vectors=\"velocity\">"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
