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
use base64::Engine as _;
use base64::engine::general_purpose::STANDARD as BASE64;
use glam::DVec3;
use std::io::Read;

/// The value of `name="..."` in the text of a tag.
fn attribute<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let start = tag.find(&format!(" {name}=\""))? + name.len() + 3;
    let end = tag[start..].find('"')? + start;
    Some(&tag[start..end])
}

/// The line of byte offset `at` in `text`.
fn line_of(text: &str, at: usize) -> String {
    format!("line {}", text[..at].matches('\n').count() + 1)
}

/// How the file encodes its binary arrays.
struct Encoding {
    header_bytes: usize,
    compressed: bool,
}

/// One `DataArray`: where it starts, its attributes' text and its content.
struct Array<'a> {
    at: usize,
    tag: &'a str,
    body: &'a str,
}

/// Every `DataArray` between `from` and `to` in `text`.
fn arrays(text: &str, from: usize, to: usize) -> Result<Vec<Array<'_>>, FileError> {
    let mut out = Vec::new();
    let mut at = from;
    while let Some(offset) = text[at..to].find("<DataArray") {
        let start = at + offset;
        let close = text[start..to]
            .find('>')
            .ok_or_else(|| fail(line_of(text, start), "a DataArray tag that does not close"))?
            + start;
        let tag = &text[start..close];
        if tag.ends_with('/') {
            out.push(Array {
                at: start,
                tag,
                body: "",
            });
            at = close + 1;
            continue;
        }
        let end = text[close..to]
            .find("</DataArray>")
            .ok_or_else(|| fail(line_of(text, start), "a DataArray without its end tag"))?
            + close;
        out.push(Array {
            at: start,
            tag,
            body: text[close + 1..end].trim(),
        });
        at = end;
    }
    Ok(out)
}

impl Array<'_> {
    fn name(&self) -> &str {
        attribute(self.tag, "Name").unwrap_or("")
    }

    fn components(&self) -> usize {
        attribute(self.tag, "NumberOfComponents")
            .and_then(|c| c.parse().ok())
            .unwrap_or(1)
    }

    /// The array's values as doubles, `count` tuples of its components expected.
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

/// Little-endian values of VTK type `ty` as doubles; `None` for an unknown type.
fn numbers(bytes: &[u8], ty: &str) -> Option<Vec<f64>> {
    macro_rules! read {
        ($t:ty) => {
            bytes
                .chunks_exact(std::mem::size_of::<$t>())
                .map(|c| <$t>::from_le_bytes(c.try_into().expect("sized chunk")) as f64)
                .collect()
        };
    }
    Some(match ty {
        "Float64" => read!(f64),
        "Float32" => read!(f32),
        "Int8" => read!(i8),
        "UInt8" => read!(u8),
        "Int16" => read!(i16),
        "UInt16" => read!(u16),
        "Int32" => read!(i32),
        "UInt32" => read!(u32),
        "Int64" => read!(i64),
        "UInt64" => read!(u64),
        _ => return None,
    })
}

/// The header word `index` (4 or 8 bytes).
fn word(bytes: &[u8], index: usize, size: usize) -> Option<usize> {
    let chunk = bytes.get(size * index..size * (index + 1))?;
    Some(match size {
        4 => u32::from_le_bytes(chunk.try_into().ok()?) as usize,
        _ => u64::from_le_bytes(chunk.try_into().ok()?) as usize,
    })
}

/// The bytes of an inline binary array: a byte count and the data encoded together, or with
/// VTK's zlib compression, a header `[blocks, block size, last block size, compressed
/// sizes...]` encoded apart from the compressed blocks.
fn decode(body: &str, encoding: &Encoding) -> Result<Vec<u8>, String> {
    let base64 = |s: &str| BASE64.decode(s).map_err(|e| format!("not base64: {e}"));
    let size = encoding.header_bytes;
    let short = || "its header is cut short".to_string();
    if !encoding.compressed {
        let block = base64(body)?;
        let count = word(&block, 0, size).ok_or_else(short)?;
        let data = &block[size..];
        if count != data.len() {
            return Err(format!(
                "{} bytes where its header says {count}",
                data.len()
            ));
        }
        return Ok(data.to_vec());
    }
    let encoded = |bytes: usize| bytes.div_ceil(3) * 4;
    let first = base64(body.get(..encoded(size)).ok_or_else(short)?)?;
    let blocks = word(&first, 0, size).ok_or_else(short)?;
    if blocks > body.len() {
        return Err(format!(
            "{blocks} compressed blocks, more than it could hold"
        ));
    }
    let header_len = encoded(size * (3 + blocks));
    let header = base64(body.get(..header_len).ok_or_else(short)?)?;
    let at = |i: usize| word(&header, i, size).ok_or_else(short);
    let (block_size, last) = (at(1)?, at(2)?);
    let total = match (blocks, last) {
        (0, _) => 0,
        (b, 0) => b * block_size,
        (b, l) => (b - 1) * block_size + l,
    };
    let data = base64(body[header_len..].trim())?;
    let mut out = Vec::with_capacity(total.min(data.len().saturating_mul(1032)));
    let mut offset = 0;
    for i in 0..blocks {
        let size = at(3 + i)?;
        let block = data
            .get(offset..offset + size)
            .ok_or("fewer compressed bytes than its header says")?;
        flate2::read::ZlibDecoder::new(block)
            .take(total.saturating_sub(out.len()) as u64 + 1)
            .read_to_end(&mut out)
            .map_err(|e| format!("its data do not inflate: {e}"))?;
        offset += size;
    }
    if out.len() != total {
        return Err(format!("{} bytes where its header says {total}", out.len()));
    }
    Ok(out)
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
            .values(text, &encoding, count)?;
        let data = match section("PointData") {
            Some((a, b)) => arrays(text, a, b)?,
            None => Vec::new(),
        };
        let named = |name: &str| data.iter().find(|a| a.name() == name);
        let Some(volume) = named("volume") else {
            let names: Vec<&str> = data.iter().map(Array::name).collect();
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
        let volumes = volume.values(text, &encoding, count)?;
        let optional = |name: &str| -> Result<Option<Vec<f64>>, FileError> {
            named(name)
                .map(|a| a.values(text, &encoding, count))
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
        let damage = optional("damage")?;
        let strength_scale = optional("strength_scale")?;
        let materials = optional("material")?;
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
