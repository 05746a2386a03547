//! VTU (VTK XML unstructured grid) frames of the particles, one vertex cell per particle.
//!
//! Arrays are written inline as base64 of their little-endian bytes, each preceded by its byte
//! count (`header_type="UInt64"`, header and data encoded together as VTK does for uncompressed
//! data). Unlike raw appended data this keeps the file well-formed XML, so generic XML tools and
//! every VTK reader accept it.

use super::atomic::write_atomically;
use base64::Engine as _;
use base64::engine::general_purpose::STANDARD as BASE64;
use std::fmt::Write;
use std::path::Path;

/// Particle data of one frame, in particle-table order. Vectors have three components (z = 0
/// in 2D) and stresses nine (plane strain: `xz = yz = 0`, `zz` kept), as VTK expects.
#[derive(Clone, Debug, Default)]
pub struct ParticleFrame {
    /// Particle ids.
    pub id: Vec<u32>,
    /// Body index.
    pub body: Vec<u16>,
    /// Material index.
    pub material: Vec<u16>,
    /// Positions.
    pub position: Vec<[f64; 3]>,
    /// Velocities.
    pub velocity: Vec<[f64; 3]>,
    /// Masses.
    pub mass: Vec<f64>,
    /// Current volumes.
    pub volume: Vec<f64>,
    /// Cauchy stresses, row-major 3×3.
    pub stress: Vec<[f64; 9]>,
    /// Damage.
    pub damage: Vec<f64>,
    /// Stored energy per unit reference volume.
    pub strain_energy_density: Vec<f64>,
    /// Further per-particle scalars that only some pipelines have (the surface flag, the
    /// velocity field at the nearest node), by name.
    pub scalars: Vec<(String, Vec<f64>)>,
    /// Further per-particle vectors (the damage-field gradient), by name.
    pub vectors: Vec<(String, Vec<[f64; 3]>)>,
    /// The scene's thickness (m) of a 2D frame, whose masses and volumes are per this thickness;
    /// `None` in 3D. Written as the file's field data, so analysis tools need not be told it.
    pub thickness: Option<f64>,
}

struct Inline {
    xml: String,
}

impl Inline {
    /// Starts a file of `n` VTK vertices, with `field_data` (name, value) as the grid's field
    /// data, opening the vertices' point data.
    fn vertices(n: usize, field_data: &[(&str, f64)], scalars: &str, vectors: &str) -> Self {
        let mut out = Inline { xml: String::new() };
        out.xml.push_str(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" \
             byte_order=\"LittleEndian\" header_type=\"UInt64\">\n  <UnstructuredGrid>\n",
        );
        if !field_data.is_empty() {
            out.xml.push_str("    <FieldData>\n");
            for &(name, value) in field_data {
                out.array(Some(name), "Float64", 1, value.to_le_bytes().to_vec());
            }
            out.xml.push_str("    </FieldData>\n");
        }
        let _ = write!(
            out.xml,
            "    <Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{n}\">\n      <PointData \
             Scalars=\"{scalars}\" Vectors=\"{vectors}\">\n"
        );
        out
    }

    /// Closes the point data, writes the points and one vertex cell per point, and writes the
    /// file to `path` atomically.
    fn finish(mut self, path: &Path, position: &[[f64; 3]]) -> std::io::Result<()> {
        let n = position.len();
        self.xml.push_str("      </PointData>\n      <Points>\n");
        self.array(
            None,
            "Float64",
            3,
            f64_bytes(position.iter().flatten().copied()),
        );
        self.xml.push_str("      </Points>\n      <Cells>\n");
        self.array(Some("connectivity"), "Int64", 1, i64_bytes(0..n as i64));
        self.array(Some("offsets"), "Int64", 1, i64_bytes(1..=n as i64));
        // VTK_VERTEX = 1.
        self.array(Some("types"), "UInt8", 1, vec![1u8; n]);
        self.xml
            .push_str("      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n");
        write_atomically(path, self.xml.as_bytes())
    }

    fn array(&mut self, name: Option<&str>, ty: &str, components: usize, bytes: Vec<u8>) {
        let name_attr = name.map(|n| format!(" Name=\"{n}\"")).unwrap_or_default();
        let mut block = (bytes.len() as u64).to_le_bytes().to_vec();
        block.extend_from_slice(&bytes);
        let _ = writeln!(
            self.xml,
            "        <DataArray type=\"{ty}\"{name_attr} NumberOfComponents=\"{components}\" \
             format=\"binary\">{}</DataArray>",
            BASE64.encode(&block)
        );
    }
}

fn f64_bytes(values: impl Iterator<Item = f64>) -> Vec<u8> {
    values.flat_map(f64::to_le_bytes).collect()
}

fn i32_bytes(values: impl Iterator<Item = i32>) -> Vec<u8> {
    values.flat_map(i32::to_le_bytes).collect()
}

fn i64_bytes(values: impl Iterator<Item = i64>) -> Vec<u8> {
    values.flat_map(i64::to_le_bytes).collect()
}

/// One named array of a frame file: its type, components and little-endian bytes.
struct ReadArray {
    name: Option<String>,
    ty: String,
    components: usize,
    bytes: Vec<u8>,
}

/// The `DataArray`s of a file written by this module, in file order.
fn read_arrays(xml: &str) -> Result<Vec<ReadArray>, String> {
    let mut arrays = Vec::new();
    for piece in xml.split("<DataArray").skip(1) {
        let (tag, rest) = piece
            .split_once('>')
            .ok_or("a DataArray tag that does not close")?;
        let body = rest
            .split_once("</DataArray>")
            .ok_or("a DataArray without its end tag")?
            .0;
        let block = BASE64
            .decode(body.trim())
            .map_err(|e| format!("a DataArray that is not base64: {e}"))?;
        if block.len() < 8 {
            return Err("a DataArray without its byte count".into());
        }
        let (count, data) = block.split_at(8);
        let count = u64::from_le_bytes(count.try_into().expect("8 bytes")) as usize;
        if count != data.len() {
            return Err(format!(
                "a DataArray of {} bytes that says {count}",
                data.len()
            ));
        }
        arrays.push(ReadArray {
            name: super::pvd::attribute(tag, "Name").map(str::to_string),
            ty: super::pvd::attribute(tag, "type")
                .unwrap_or_default()
                .to_string(),
            components: super::pvd::attribute(tag, "NumberOfComponents")
                .and_then(|c| c.parse().ok())
                .unwrap_or(1),
            bytes: data.to_vec(),
        });
    }
    Ok(arrays)
}

impl ReadArray {
    fn f64s(&self) -> Result<Vec<f64>, String> {
        match self.ty.as_str() {
            "Float64" => Ok(self
                .bytes
                .chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
                .collect()),
            "Int32" => Ok(self
                .bytes
                .chunks_exact(4)
                .map(|c| f64::from(i32::from_le_bytes(c.try_into().expect("4 bytes"))))
                .collect()),
            other => Err(format!("array {:?} of type {other}", self.name)),
        }
    }

    fn triples(&self) -> Result<Vec<[f64; 3]>, String> {
        Ok(self
            .f64s()?
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect())
    }
}

/// Reads a particle frame written by [`write_particle_frame`] (the arrays it writes, extra
/// scalars and vectors by name; a frame from elsewhere is refused with the reason).
pub fn read_particle_frame(path: &Path) -> Result<ParticleFrame, String> {
    let xml = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let at = |e: String| format!("{}: {e}", path.display());
    let (field_data, piece) = match xml.split_once("<Piece") {
        Some((head, piece)) => (read_arrays(head).map_err(at)?, piece),
        None => (Vec::new(), xml.as_str()),
    };
    let arrays = read_arrays(piece).map_err(at)?;
    let mut f = ParticleFrame::default();
    for a in &field_data {
        if a.name.as_deref() == Some("thickness") {
            f.thickness = a.f64s().map_err(at)?.first().copied();
        }
    }
    let mut seen_points = false;
    for a in &arrays {
        match (a.name.as_deref(), a.components) {
            (None, 3) => {
                f.position = a.triples().map_err(at)?;
                seen_points = true;
            }
            (Some("id"), 1) => f.id = a.f64s().map_err(at)?.iter().map(|&v| v as u32).collect(),
            (Some("body"), 1) => f.body = a.f64s().map_err(at)?.iter().map(|&v| v as u16).collect(),
            (Some("material"), 1) => {
                f.material = a.f64s().map_err(at)?.iter().map(|&v| v as u16).collect();
            }
            (Some("velocity"), 3) => f.velocity = a.triples().map_err(at)?,
            (Some("mass"), 1) => f.mass = a.f64s().map_err(at)?,
            (Some("volume"), 1) => f.volume = a.f64s().map_err(at)?,
            (Some("stress"), 9) => {
                f.stress = a
                    .f64s()
                    .map_err(at)?
                    .chunks_exact(9)
                    .map(|c| c.try_into().expect("9 values"))
                    .collect();
            }
            (Some("damage"), 1) => f.damage = a.f64s().map_err(at)?,
            (Some("strain_energy_density"), 1) => f.strain_energy_density = a.f64s().map_err(at)?,
            (Some("connectivity" | "offsets" | "types"), _) => {}
            (Some(name), 1) => f.scalars.push((name.to_string(), a.f64s().map_err(at)?)),
            (Some(name), 3) => f.vectors.push((name.to_string(), a.triples().map_err(at)?)),
            (name, n) => return Err(at(format!("an array {name:?} of {n} components"))),
        }
    }
    let n = f.position.len();
    let complete = seen_points
        && [
            f.id.len(),
            f.mass.len(),
            f.volume.len(),
            f.damage.len(),
            f.velocity.len(),
        ]
        .iter()
        .all(|&len| len == n);
    if !complete {
        return Err(at(
            "not a particle frame of fractum (missing or short arrays)".into(),
        ));
    }
    Ok(f)
}

/// The grid nodes that carry mass, with their velocity fields (see [`crate::components`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GridFrame {
    /// Node indices.
    pub index: Vec<u32>,
    /// Node positions.
    pub position: Vec<[f64; 3]>,
    /// Number of velocity fields at each node.
    pub fields: Vec<u8>,
    /// Per field slot: the field's key `2 × group + side`, or −1 for an unused slot.
    pub key: Vec<[i32; crate::components::MAX_FIELDS]>,
    /// Per field slot: mass.
    pub mass: Vec<[f64; crate::components::MAX_FIELDS]>,
    /// Per field slot: velocity.
    pub velocity: Vec<[[f64; 3]; crate::components::MAX_FIELDS]>,
    /// Per field slot: the contact normal (zero where the node has one field).
    pub normal: Vec<[[f64; 3]; crate::components::MAX_FIELDS]>,
}

/// Writes the grid `frame` to `path` atomically: one VTK vertex per node, with `index`,
/// `fields`, and `key_k`, `mass_k`, `velocity_k`, `normal_k` for each field slot `k`.
pub fn write_grid_frame(path: &Path, frame: &GridFrame) -> std::io::Result<()> {
    let mut out = Inline::vertices(frame.position.len(), &[], "fields", "velocity_0");
    out.array(
        Some("index"),
        "Int32",
        1,
        i32_bytes(frame.index.iter().map(|&v| v as i32)),
    );
    out.array(
        Some("fields"),
        "Int32",
        1,
        i32_bytes(frame.fields.iter().map(|&v| i32::from(v))),
    );
    for k in 0..crate::components::MAX_FIELDS {
        out.array(
            Some(&format!("key_{k}")),
            "Int32",
            1,
            i32_bytes(frame.key.iter().map(|v| v[k])),
        );
        out.array(
            Some(&format!("mass_{k}")),
            "Float64",
            1,
            f64_bytes(frame.mass.iter().map(|v| v[k])),
        );
        out.array(
            Some(&format!("velocity_{k}")),
            "Float64",
            3,
            f64_bytes(frame.velocity.iter().flat_map(|v| v[k])),
        );
        out.array(
            Some(&format!("normal_{k}")),
            "Float64",
            3,
            f64_bytes(frame.normal.iter().flat_map(|v| v[k])),
        );
    }
    out.finish(path, &frame.position)
}

/// Writes `frame` to `path` atomically.
pub fn write_particle_frame(path: &Path, frame: &ParticleFrame) -> std::io::Result<()> {
    let field_data: Vec<(&str, f64)> = frame
        .thickness
        .map(|t| ("thickness", t))
        .into_iter()
        .collect();
    let mut out = Inline::vertices(frame.position.len(), &field_data, "damage", "velocity");
    out.array(
        Some("id"),
        "Int32",
        1,
        i32_bytes(frame.id.iter().map(|&v| v as i32)),
    );
    out.array(
        Some("body"),
        "Int32",
        1,
        i32_bytes(frame.body.iter().map(|&v| v as i32)),
    );
    out.array(
        Some("material"),
        "Int32",
        1,
        i32_bytes(frame.material.iter().map(|&v| v as i32)),
    );
    out.array(
        Some("velocity"),
        "Float64",
        3,
        f64_bytes(frame.velocity.iter().flatten().copied()),
    );
    out.array(
        Some("mass"),
        "Float64",
        1,
        f64_bytes(frame.mass.iter().copied()),
    );
    out.array(
        Some("volume"),
        "Float64",
        1,
        f64_bytes(frame.volume.iter().copied()),
    );
    out.array(
        Some("stress"),
        "Float64",
        9,
        f64_bytes(frame.stress.iter().flatten().copied()),
    );
    out.array(
        Some("damage"),
        "Float64",
        1,
        f64_bytes(frame.damage.iter().copied()),
    );
    out.array(
        Some("strain_energy_density"),
        "Float64",
        1,
        f64_bytes(frame.strain_energy_density.iter().copied()),
    );
    for (name, values) in &frame.scalars {
        out.array(Some(name), "Float64", 1, f64_bytes(values.iter().copied()));
    }
    for (name, values) in &frame.vectors {
        out.array(
            Some(name),
            "Float64",
            3,
            f64_bytes(values.iter().flatten().copied()),
        );
    }
    out.finish(path, &frame.position)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_particle_frame_reads_back_as_written() {
        let frame = ParticleFrame {
            id: vec![3, 1],
            body: vec![0, 2],
            material: vec![1, 0],
            position: vec![[0.1, 0.2, 0.0], [0.3, -0.4, 0.5]],
            velocity: vec![[1.0, 2.0, 3.0], [-1.0, 0.0, 0.5]],
            mass: vec![2.0, 3.0],
            volume: vec![0.01, 0.02],
            stress: vec![[1.0; 9], [2.0; 9]],
            damage: vec![0.0, 1.0],
            strain_energy_density: vec![5.0, 6.0],
            scalars: vec![("strength".into(), vec![7.0, 8.0])],
            vectors: vec![("damage_gradient".into(), vec![[0.0; 3], [1.0, 0.0, 0.0]])],
            thickness: Some(2.0e-3),
        };
        let dir = std::env::temp_dir().join(format!("fractum-vtu-read-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("frame.vtu");
        write_particle_frame(&path, &frame).unwrap();
        let read = read_particle_frame(&path).unwrap();
        assert_eq!(read.id, frame.id);
        assert_eq!(read.body, frame.body);
        assert_eq!(read.material, frame.material);
        assert_eq!(read.position, frame.position);
        assert_eq!(read.velocity, frame.velocity);
        assert_eq!(read.mass, frame.mass);
        assert_eq!(read.volume, frame.volume);
        assert_eq!(read.stress, frame.stress);
        assert_eq!(read.damage, frame.damage);
        assert_eq!(read.strain_energy_density, frame.strain_energy_density);
        assert_eq!(read.scalars, frame.scalars);
        assert_eq!(read.vectors, frame.vectors);
        assert_eq!(read.thickness, frame.thickness);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
