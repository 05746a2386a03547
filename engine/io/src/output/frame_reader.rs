//! Reading particle frames back (`fractum crack`, `fragments`, `snapshot`, the tests): the
//! frames [`write_particle_frame`](super::write_particle_frame) writes, compressed or not, and a
//! distributed run's `.pvtu` index of pieces, through the VTK codec that Fractum's readers share
//! ([`fractum_geometry::vtk`]).

use super::ParticleFrame;
use fractum_geometry::vtk::{self, Encoding};
use std::path::Path;

/// One named array of a frame file: its components and values.
struct ReadArray {
    name: Option<String>,
    components: usize,
    values: Vec<f64>,
}

/// The `DataArray`s of `xml` between byte offsets `from` and `to`, in file order, decoded with
/// the shared VTK codec.
fn read_arrays(
    xml: &str,
    (from, to): (usize, usize),
    encoding: &Encoding,
) -> Result<Vec<ReadArray>, String> {
    let arrays = vtk::data_arrays(xml, from, to).map_err(|(_, what)| what.to_string())?;
    arrays
        .iter()
        .map(|array| {
            let name = vtk::attribute(array.tag, "Name").map(str::to_string);
            let ty = vtk::attribute(array.tag, "type").unwrap_or_default();
            let bytes = vtk::decode(array.body, encoding)
                .map_err(|e| format!("DataArray {name:?}: {e}"))?;
            let values =
                vtk::numbers(&bytes, ty).ok_or_else(|| format!("array {name:?} of type {ty}"))?;
            Ok(ReadArray {
                name,
                components: array.components(),
                values,
            })
        })
        .collect()
}

impl ReadArray {
    fn triples(&self) -> Vec<[f64; 3]> {
        self.values
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect()
    }
}

/// How a frame file encodes its arrays, from its `<VTKFile ...>` tag.
fn frame_encoding(xml: &str) -> Result<Encoding, String> {
    let tag = xml
        .split_once("<VTKFile")
        .and_then(|(_, tag)| tag.split_once('>'))
        .map_or("", |(tag, _)| tag);
    let compressed = match vtk::attribute(tag, "compressor") {
        None => false,
        Some("vtkZLibDataCompressor") => true,
        Some(other) => return Err(format!("a frame compressed by {other}, not zlib")),
    };
    let header_bytes = match vtk::attribute(tag, "header_type") {
        Some("UInt64") => 8,
        _ => 4,
    };
    Ok(Encoding {
        header_bytes,
        compressed,
    })
}

/// Reads a particle frame written by [`write_particle_frame`](super::write_particle_frame), compressed or not (the arrays it
/// writes, extra scalars and vectors by name; a column the scene's `output.fields` left out is
/// empty, see [`ParticleFrame::require`]; a frame from elsewhere is refused with the reason).
pub fn read_particle_frame(path: &Path) -> Result<ParticleFrame, String> {
    if path.extension().is_some_and(|e| e == "pvtu") {
        // A distributed run's frame: the ranks' pieces, one after another.
        let folder = path.parent().unwrap_or(Path::new("."));
        let mut whole = ParticleFrame::default();
        for piece in super::pvtu::read_pvtu_pieces(path)? {
            whole.append(read_particle_frame(&folder.join(piece))?);
        }
        return Ok(whole);
    }
    let xml = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let at = |e: String| format!("{}: {e}", path.display());
    let encoding = frame_encoding(&xml).map_err(at)?;
    let (field_data, arrays) = match xml.find("<Piece") {
        Some(piece) => (
            read_arrays(&xml, (0, piece), &encoding).map_err(at)?,
            read_arrays(&xml, (piece, xml.len()), &encoding).map_err(at)?,
        ),
        None => (
            Vec::new(),
            read_arrays(&xml, (0, xml.len()), &encoding).map_err(at)?,
        ),
    };
    let mut f = ParticleFrame::default();
    for a in &field_data {
        if a.name.as_deref() == Some("thickness") {
            f.thickness = a.values.first().copied();
        }
    }
    let mut seen_points = false;
    for a in arrays {
        seen_points |= place_array(&mut f, a).map_err(at)?;
    }
    let consistent = lengths_agree(&f);
    if !seen_points || !consistent {
        return Err(at(
            "not a particle frame of fractum (no points, or arrays of the wrong length)".into(),
        ));
    }
    Ok(f)
}

/// Puts array `a` of a frame file where it belongs in `f`; whether it was the points.
fn place_array(f: &mut ParticleFrame, a: ReadArray) -> Result<bool, String> {
    match (a.name.as_deref(), a.components) {
        (None, 3) => {
            f.position = a.triples();
            return Ok(true);
        }
        (Some("id"), 1) => f.id = a.values.iter().map(|&v| v as u32).collect(),
        (Some("body"), 1) => f.body = a.values.iter().map(|&v| v as u16).collect(),
        (Some("material"), 1) => {
            f.material = a.values.iter().map(|&v| v as u16).collect();
        }
        (Some("velocity"), 3) => f.velocity = a.triples(),
        (Some("mass"), 1) => f.mass = a.values,
        (Some("volume"), 1) => f.volume = a.values,
        (Some("stress"), 9) => {
            f.stress = a
                .values
                .chunks_exact(9)
                .map(|c| c.try_into().expect("9 values"))
                .collect();
        }
        (Some("damage"), 1) => f.damage = a.values,
        (Some("strain_energy_density"), 1) => f.strain_energy_density = a.values,
        (Some("connectivity" | "offsets" | "types"), _) => {}
        (Some(name), 1) => f.scalars.push((name.to_string(), a.values)),
        (Some(name), 3) => f.vectors.push((name.to_string(), a.triples())),
        (name, n) => return Err(format!("an array {name:?} of {n} components")),
    }
    Ok(false)
}

/// Whether every array of `f` has a value per point, or none.
fn lengths_agree(f: &ParticleFrame) -> bool {
    let n = f.position.len();
    let lengths = [
        f.id.len(),
        f.body.len(),
        f.material.len(),
        f.velocity.len(),
        f.mass.len(),
        f.volume.len(),
        f.stress.len(),
        f.damage.len(),
        f.strain_energy_density.len(),
    ];
    let extra = f.scalars.iter().map(|(_, v)| v.len());
    let extra = extra.chain(f.vectors.iter().map(|(_, v)| v.len()));
    lengths
        .into_iter()
        .chain(extra)
        .all(|len| len == n || len == 0)
}
