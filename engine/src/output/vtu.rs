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
}

struct Inline {
    xml: String,
}

impl Inline {
    /// Starts a file of `n` VTK vertices, opening their point data.
    fn vertices(n: usize, scalars: &str, vectors: &str) -> Self {
        let mut out = Inline { xml: String::new() };
        let _ = write!(
            out.xml,
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" \
             byte_order=\"LittleEndian\" header_type=\"UInt64\">\n  <UnstructuredGrid>\n    \
             <Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{n}\">\n      <PointData \
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
    let mut out = Inline::vertices(frame.position.len(), "fields", "velocity_0");
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
    let mut out = Inline::vertices(frame.position.len(), "damage", "velocity");
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
