//! The VTU form of a particle file: a VTK XML `UnstructuredGrid` (or `PolyData`) whose points
//! are the particles, as meshio, ParaView and Fractum's own frames write it. The point data
//! named `volume` are required; `velocity` (3 components), `damage`, `strength_scale` and
//! `material` (an index into the scene's materials, as Fractum writes it) are optional. Arrays may be ASCII or
//! inline base64 (`format="binary"`), with `UInt32` or `UInt64` headers and, optionally, VTK's
//! zlib compression; every piece of the file is read. Data appended after the XML (raw or
//! base64) are refused with how to re-save the file. The file is scanned tag by tag for these
//! elements only: no XML crate is needed for a format this regular.

use super::{OptionalColumns, PlaceKind, PointAttributes, PointSet};
use crate::file_error::{FileError, fail};
use crate::vtk::{DataArray, Encoding, attribute, data_arrays, decode, numbers};
use glam::DVec3;

/// The line of byte offset `at` in `text`.
fn line_of(text: &str, at: usize) -> String {
    format!("line {}", text[..at].matches('\n').count() + 1)
}

/// Every `DataArray` between `from` and `to` in `text`, a malformed one as an error at its line.
fn arrays(text: &str, from: usize, to: usize) -> Result<Vec<DataArray<'_>>, FileError> {
    data_arrays(text, from, to).map_err(|(at, what)| fail(line_of(text, at), what))
}

/// What a particle file needs of an array beyond the codec's.
trait Values {
    /// The array's values as doubles, `count` tuples of its components expected.
    fn values(&self, text: &str, encoding: &Encoding, count: usize) -> Result<Vec<f64>, FileError>;
}

impl Values for DataArray<'_> {
    fn values(&self, text: &str, encoding: &Encoding, count: usize) -> Result<Vec<f64>, FileError> {
        let place = || line_of(text, self.at);
        let name = self.name();
        let format = attribute(self.tag, "format").unwrap_or("ascii");
        let ty = attribute(self.tag, "type").unwrap_or("");
        let values = match format {
            "ascii" => self
                .body
                .split_ascii_whitespace()
                .map(|w| {
                    w.parse::<f64>().map_err(|_| {
                        fail(
                            place(),
                            format!("DataArray `{name}` holds `{w}`, not a number"),
                        )
                    })
                })
                .collect::<Result<Vec<f64>, _>>()?,
            "binary" => {
                let bytes = decode(self.body, encoding)
                    .map_err(|e| fail(place(), format!("DataArray `{name}`: {e}")))?;
                numbers(&bytes, ty)
                    .ok_or_else(|| fail(place(), format!("DataArray `{name}` of type `{ty}`")))?
            }
            other => {
                return Err(fail(
                    place(),
                    format!("DataArray `{name}` in format `{other}`; expected ascii or binary"),
                ));
            }
        };
        let expected = count * self.components();
        if values.len() != expected {
            return Err(fail(
                place(),
                format!(
                    "DataArray `{name}` holds {} values; expected {expected} ({count} points × {} \
                     components)",
                    values.len(),
                    self.components()
                ),
            ));
        }
        Ok(values)
    }
}

/// The `<VTKFile ...>` tag's encoding of binary arrays, or why the file cannot be read.
fn encoding(text: &str) -> Result<Encoding, FileError> {
    let start = text
        .find("<VTKFile")
        .ok_or_else(|| fail("line 1", "expected a VTK XML file (`<VTKFile ...>`)"))?;
    let tag = &text[start..start + text[start..].find('>').unwrap_or(0)];
    let place = || line_of(text, start);
    match attribute(tag, "type") {
        Some("UnstructuredGrid" | "PolyData") => {}
        other => {
            return Err(fail(
                place(),
                format!(
                    "a VTK file of type {}; expected the points of an UnstructuredGrid or PolyData",
                    other.unwrap_or("(none)")
                ),
            ));
        }
    }
    if attribute(tag, "byte_order").is_some_and(|o| o != "LittleEndian") {
        return Err(fail(
            place(),
            "big-endian data; save the file as little-endian",
        ));
    }
    let header_bytes = match attribute(tag, "header_type").unwrap_or("UInt32") {
        "UInt32" => 4,
        "UInt64" => 8,
        other => {
            return Err(fail(
                place(),
                format!("header_type {other}; expected UInt32 or UInt64"),
            ));
        }
    };
    let compressed = match attribute(tag, "compressor") {
        None => false,
        Some("vtkZLibDataCompressor") => true,
        Some(other) => {
            return Err(fail(
                place(),
                format!("data compressed by {other}; save without compression or with zlib"),
            ));
        }
    };
    if let Some(appended) = text.find("<AppendedData") {
        return Err(fail(
            line_of(text, appended),
            "the data are appended after the XML (raw or base64), which is not read; save the \
             file with its arrays inline: in ParaView, File > Save Data with Data Mode `Binary` \
             or `Ascii`; with meshio, `meshio.write(path, mesh)` (its default)",
        ));
    }
    Ok(Encoding {
        header_bytes,
        compressed,
    })
}

/// The columns of one piece of a particle file: each point's coordinates (x, y, z), its
/// volume, and the velocities, damage, strength scales and materials the piece gives.
struct PieceColumns {
    coordinates: Vec<f64>,
    volumes: Vec<f64>,
    velocities: Option<Vec<f64>>,
    damage: Option<Vec<f64>>,
    strength_scale: Option<Vec<f64>>,
    materials: Option<Vec<f64>>,
}

/// The columns of the piece of `count` points between `start` and `end` in `text`; a piece
/// without points or volumes, or with velocities of other than 3 components, is an error at
/// its line.
fn piece_columns(
    text: &str,
    encoding: &Encoding,
    (start, end): (usize, usize),
    count: usize,
) -> Result<PieceColumns, FileError> {
    let section = |name: &str| -> Option<(usize, usize)> {
        let a = text[start..end].find(&format!("<{name}"))? + start;
        let b = text[a..end].find(&format!("</{name}>"))? + a;
        Some((a, b))
    };
    let (points_from, points_to) = section("Points")
        .ok_or_else(|| fail(line_of(text, start), "a Piece without its Points"))?;
    let points = arrays(text, points_from, points_to)?;
    let coordinates = points
        .first()
        .ok_or_else(|| fail(line_of(text, points_from), "Points without a DataArray"))?
        .values(text, encoding, count)?;
    let data = match section("PointData") {
        Some((a, b)) => arrays(text, a, b)?,
        None => Vec::new(),
    };
    let named = |name: &str| data.iter().find(|a| a.name() == name);
    let Some(volume) = named("volume") else {
        let names: Vec<&str> = data.iter().map(DataArray::name).collect();
        return Err(fail(
            line_of(text, start),
            format!(
                "no point data named `volume` (the piece has {}); a particle's volume is \
                 never guessed: add a `volume` array (m³; in 2D the area times the scene's \
                 thickness)",
                if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                }
            ),
        ));
    };
    let volumes = volume.values(text, encoding, count)?;
    let optional = |name: &str| -> Result<Option<Vec<f64>>, FileError> {
        named(name)
            .map(|a| a.values(text, encoding, count))
            .transpose()
    };
    let velocities = optional("velocity")?;
    if let Some(v) = named("velocity")
        && v.components() != 3
    {
        return Err(fail(
            line_of(text, v.at),
            "DataArray `velocity` needs 3 components",
        ));
    }
    Ok(PieceColumns {
        coordinates,
        volumes,
        velocities,
        damage: optional("damage")?,
        strength_scale: optional("strength_scale")?,
        materials: optional("material")?,
    })
}

/// Parses a VTU (or VTP) particle file.
pub fn parse_vtu(text: &str, file: &str) -> Result<PointSet, FileError> {
    let encoding = encoding(text)?;
    let mut set: Option<PointSet> = None;
    let mut from = 0;
    let mut first_point = 0u32;
    while let Some(offset) = text[from..].find("<Piece") {
        let start = from + offset;
        let end = text[start..]
            .find("</Piece>")
            .ok_or_else(|| fail(line_of(text, start), "a Piece without its end tag"))?
            + start;
        let tag = &text[start..start + text[start..].find('>').unwrap_or(0)];
        let count: usize = attribute(tag, "NumberOfPoints")
            .and_then(|n| n.parse().ok())
            .ok_or_else(|| fail(line_of(text, start), "a Piece without NumberOfPoints"))?;
        let PieceColumns {
            coordinates,
            volumes,
            velocities,
            damage,
            strength_scale,
            materials,
        } = piece_columns(text, &encoding, (start, end), count)?;
        let three_d = coordinates.chunks_exact(3).any(|c| c[2] != 0.0);
        let set = set.get_or_insert_with(|| {
            let columns = OptionalColumns {
                velocity: velocities.is_some(),
                damage: damage.is_some(),
                strength_scale: strength_scale.is_some(),
                material: materials.is_some(),
            };
            PointSet::empty(file, three_d, columns, PlaceKind::Point)
        });
        set.three_d |= three_d;
        for k in 0..count {
            let c = &coordinates[3 * k..3 * k + 3];
            let velocity = velocities
                .as_ref()
                .map(|v| DVec3::new(v[3 * k], v[3 * k + 1], v[3 * k + 2]));
            let material = materials.as_ref().map(|m| format!("{}", m[k]));
            let given = PointAttributes {
                velocity,
                damage: damage.as_ref().map(|d| d[k]),
                strength_scale: strength_scale.as_ref().map(|s| s[k]),
                material: material.as_deref(),
            };
            set.push(
                first_point + k as u32,
                DVec3::new(c[0], c[1], c[2]),
                volumes[k],
                given,
            )?;
        }
        first_point += count as u32;
        from = end;
    }
    match set {
        Some(set) if !set.is_empty() => Ok(set),
        _ => Err(fail("", "the file holds no point")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ASCII: &str = r#"<?xml version="1.0"?>
<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">
<UnstructuredGrid>
<Piece NumberOfPoints="2" NumberOfCells="0">
<Points>
<DataArray type="Float64" Name="Points" NumberOfComponents="3" format="ascii">
0.1 0.2 0 0.3 0.4 0
</DataArray>
</Points>
<PointData>
<DataArray type="Float64" Name="volume" format="ascii">1e-3 2e-3</DataArray>
<DataArray type="Int32" Name="material" format="ascii">0 1</DataArray>
</PointData>
</Piece>
</UnstructuredGrid>
</VTKFile>
"#;

    #[test]
    fn ascii_points_volumes_and_material_indices_are_read() {
        let set = parse_vtu(ASCII, "p.vtu").unwrap();
        assert_eq!(set.dimension(), 2);
        assert_eq!(
            set.particles(),
            vec![
                (DVec3::new(0.1, 0.2, 0.0), 1e-3),
                (DVec3::new(0.3, 0.4, 0.0), 2e-3)
            ]
        );
        assert!(set.materials_by_index());
        let a = set.attributes(DVec3::new(0.3, 0.4, 0.0)).unwrap();
        assert_eq!(a.material, Some("1"));
    }

    #[test]
    fn a_missing_volume_wrong_counts_and_appended_data_are_refused() {
        let e = parse_vtu(&ASCII.replace("\"volume\"", "\"mass\""), "p.vtu").unwrap_err();
        assert!(e.message.contains("never guessed"), "{e}");
        let e = parse_vtu(&ASCII.replace("1e-3 2e-3", "1e-3"), "p.vtu").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("line 11: DataArray `volume` holds 1 values"),
            "{e}"
        );
        let appended = ASCII.replace(
            "</UnstructuredGrid>",
            "</UnstructuredGrid>\n<AppendedData encoding=\"raw\">_</AppendedData>",
        );
        let e = parse_vtu(&appended, "p.vtu").unwrap_err();
        assert!(e.message.contains("Data Mode"), "{e}");
    }
}
