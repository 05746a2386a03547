//! VTU (VTK XML unstructured grid) frames of the particles, one vertex cell per particle.
//!
//! Arrays are written inline as base64, so the file stays well-formed XML that generic XML
//! tools and every VTK reader accept (unlike raw appended data). Two encodings, chosen by the
//! scene's `output.compression` ([`FrameCompression`]):
//!
//! - `Zlib` (the default): each array is one zlib block, preceded by VTK's compression header
//!   `[blocks = 1, block size, last partial block = 0, compressed size]` (`header_type="UInt64"`);
//!   the header and the compressed bytes are base64-encoded separately, as VTK's own writer
//!   does, and the file names `compressor="vtkZLibDataCompressor"`. ParaView and VTK read it.
//! - `None`: each array's bytes preceded by their byte count, encoded together (VTK's
//!   uncompressed form).
//!
//! The scene's `output.fields` chooses the arrays a particle frame carries; positions are always
//! written. An array left out is an empty column of [`ParticleFrame`].

use super::atomic::write_atomically;
pub use super::pvtu::PieceArrays;
use base64::Engine as _;
use base64::engine::general_purpose::STANDARD as BASE64;
use std::fmt::Write;
use std::path::Path;

/// How the arrays of a frame are encoded (the scene's `output.compression`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FrameCompression {
    /// Raw little-endian bytes, base64-encoded.
    None,
    /// zlib at its fastest level (float data gains almost nothing from slower ones), then
    /// base64.
    #[default]
    Zlib,
}

/// The names of the arrays a particle frame of the engine itself can carry, beside positions
/// (which every frame has) and the columns systems register.
pub const ENGINE_FRAME_FIELDS: [&str; 9] = [
    "id",
    "body",
    "material",
    "velocity",
    "mass",
    "volume",
    "stress",
    "damage",
    "strain_energy_density",
];

/// Particle data of one frame, in particle-table order. Vectors have three components (z = 0
/// in 2D) and stresses nine (plane strain: `xz = yz = 0`, `zz` kept), as VTK expects. A column
/// the scene's `output.fields` leaves out is empty.
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

impl ParticleFrame {
    /// Empties every column not named in `fields` (positions and the thickness stay), so the
    /// frame carries only the arrays the scene chose.
    pub fn keep_only(&mut self, fields: &[String]) {
        let keep = |name: &str| fields.iter().any(|f| f == name);
        macro_rules! drop_unless {
            ($($column:ident),*) => {$(
                if !keep(stringify!($column)) {
                    self.$column = Vec::new();
                }
            )*};
        }
        drop_unless!(
            id,
            body,
            material,
            velocity,
            mass,
            volume,
            stress,
            damage,
            strain_energy_density
        );
        self.scalars.retain(|(name, _)| keep(name));
        self.vectors.retain(|(name, _)| keep(name));
    }

    /// Keeps the particles whose entry of `keep` is true, in order (a rank's piece of a frame:
    /// the particles it owns). Columns left empty by [`Self::keep_only`] stay empty.
    pub fn retain_rows(&mut self, keep: &[bool]) {
        fn retain<T>(column: &mut Vec<T>, keep: &[bool]) {
            if column.len() == keep.len() {
                let mut row = 0;
                column.retain(|_| {
                    row += 1;
                    keep[row - 1]
                });
            }
        }
        debug_assert_eq!(keep.len(), self.position.len());
        retain(&mut self.id, keep);
        retain(&mut self.body, keep);
        retain(&mut self.material, keep);
        retain(&mut self.velocity, keep);
        retain(&mut self.mass, keep);
        retain(&mut self.volume, keep);
        retain(&mut self.stress, keep);
        retain(&mut self.damage, keep);
        retain(&mut self.strain_energy_density, keep);
        self.scalars.iter_mut().for_each(|(_, v)| retain(v, keep));
        self.vectors.iter_mut().for_each(|(_, v)| retain(v, keep));
        retain(&mut self.position, keep);
    }

    /// Appends the particles of `other`, a frame of the same arrays (another rank's piece).
    pub fn append(&mut self, other: ParticleFrame) {
        self.id.extend(other.id);
        self.body.extend(other.body);
        self.material.extend(other.material);
        self.position.extend(other.position);
        self.velocity.extend(other.velocity);
        self.mass.extend(other.mass);
        self.volume.extend(other.volume);
        self.stress.extend(other.stress);
        self.damage.extend(other.damage);
        self.strain_energy_density
            .extend(other.strain_energy_density);
        for (name, values) in other.scalars {
            match self.scalars.iter_mut().find(|(n, _)| *n == name) {
                Some((_, mine)) => mine.extend(values),
                None => self.scalars.push((name, values)),
            }
        }
        for (name, values) in other.vectors {
            match self.vectors.iter_mut().find(|(n, _)| *n == name) {
                Some((_, mine)) => mine.extend(values),
                None => self.vectors.push((name, values)),
            }
        }
        self.thickness = self.thickness.or(other.thickness);
    }

    /// The engine columns among `fields` that this frame lacks (its file was written with a
    /// narrower `output.fields`), as an error that says how to get them; `Ok` when it has all.
    pub fn require(&self, fields: &[&str]) -> Result<(), String> {
        let n = self.position.len();
        let len = |name: &str| match name {
            "id" => self.id.len(),
            "body" => self.body.len(),
            "material" => self.material.len(),
            "velocity" => self.velocity.len(),
            "mass" => self.mass.len(),
            "volume" => self.volume.len(),
            "stress" => self.stress.len(),
            "damage" => self.damage.len(),
            "strain_energy_density" => self.strain_energy_density.len(),
            other => self
                .scalars
                .iter()
                .find(|(s, _)| s == other)
                .map(|(_, v)| v.len())
                .or_else(|| {
                    self.vectors
                        .iter()
                        .find(|(s, _)| s == other)
                        .map(|(_, v)| v.len())
                })
                .unwrap_or(usize::MAX),
        };
        let missing: Vec<&str> = fields.iter().copied().filter(|&f| len(f) != n).collect();
        if missing.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "the frame lacks {}: add {} to the scene's output.fields and run it again",
                missing.join(", "),
                if missing.len() == 1 { "it" } else { "them" }
            ))
        }
    }
}

struct Inline {
    xml: String,
    compression: FrameCompression,
    /// Arrays must have this many tuples; an empty one is left out (`output.fields`).
    tuples: usize,
    /// The point-data arrays written, for the `.pvtu` index of a distributed run's pieces.
    declared: PieceArrays,
}

impl Inline {
    /// Starts a file of `n` VTK vertices, with `field_data` (name, value) as the grid's field
    /// data, opening the vertices' point data.
    fn vertices(
        n: usize,
        compression: FrameCompression,
        field_data: &[(&str, f64)],
        scalars: &str,
        vectors: &str,
    ) -> Self {
        let mut out = Inline {
            xml: String::new(),
            compression,
            tuples: n,
            declared: PieceArrays {
                scalars: scalars.to_string(),
                vectors: vectors.to_string(),
                arrays: Vec::new(),
            },
        };
        let compressor = match compression {
            FrameCompression::None => "",
            FrameCompression::Zlib => " compressor=\"vtkZLibDataCompressor\"",
        };
        let _ = writeln!(
            out.xml,
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" \
             byte_order=\"LittleEndian\" header_type=\"UInt64\"{compressor}>\n  <UnstructuredGrid>"
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
    fn finish(mut self, path: &Path, position: &[[f64; 3]]) -> std::io::Result<PieceArrays> {
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
        write_atomically(path, self.xml.as_bytes())?;
        Ok(self.declared)
    }

    /// A point-data array of `tuples` × `components` values, left out when the scene's
    /// `output.fields` emptied it.
    fn column(&mut self, name: &str, ty: &str, components: usize, tuples: usize, bytes: Vec<u8>) {
        if tuples == self.tuples {
            self.array(Some(name), ty, components, bytes);
            (self.declared.arrays).push((name.to_string(), ty.to_string(), components));
        }
    }

    fn array(&mut self, name: Option<&str>, ty: &str, components: usize, bytes: Vec<u8>) {
        let name_attr = name.map(|n| format!(" Name=\"{n}\"")).unwrap_or_default();
        let _ = write!(
            self.xml,
            "        <DataArray type=\"{ty}\"{name_attr} NumberOfComponents=\"{components}\" \
             format=\"binary\">"
        );
        match self.compression {
            FrameCompression::None => {
                let mut block = (bytes.len() as u64).to_le_bytes().to_vec();
                block.extend_from_slice(&bytes);
                BASE64.encode_string(&block, &mut self.xml);
            }
            FrameCompression::Zlib => {
                let compressed = zlib(&bytes);
                let header: Vec<u8> = [1, bytes.len() as u64, 0, compressed.len() as u64]
                    .into_iter()
                    .flat_map(u64::to_le_bytes)
                    .collect();
                BASE64.encode_string(&header, &mut self.xml);
                BASE64.encode_string(&compressed, &mut self.xml);
            }
        }
        self.xml.push_str("</DataArray>\n");
    }
}

/// `bytes` as one zlib stream at the fastest level.
fn zlib(bytes: &[u8]) -> Vec<u8> {
    use std::io::Write as _;
    let mut encoder = flate2::write::ZlibEncoder::new(
        Vec::with_capacity(bytes.len() / 2),
        flate2::Compression::fast(),
    );
    encoder
        .write_all(bytes)
        .and_then(|()| encoder.finish())
        .expect("compressing into memory cannot fail")
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

/// The grid nodes that carry mass, with their velocity fields (see [`fractum_engine::components`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GridFrame {
    /// Node indices.
    pub index: Vec<u32>,
    /// Node positions.
    pub position: Vec<[f64; 3]>,
    /// Number of velocity fields at each node.
    pub fields: Vec<u8>,
    /// Per field slot: the field's key `2 × group + side`, or −1 for an unused slot.
    pub key: Vec<[i32; fractum_engine::components::MAX_FIELDS]>,
    /// Per field slot: mass.
    pub mass: Vec<[f64; fractum_engine::components::MAX_FIELDS]>,
    /// Per field slot: velocity.
    pub velocity: Vec<[[f64; 3]; fractum_engine::components::MAX_FIELDS]>,
    /// Per field slot: the contact normal (zero where the node has one field).
    pub normal: Vec<[[f64; 3]; fractum_engine::components::MAX_FIELDS]>,
}

/// Writes the grid `frame` to `path` atomically: one VTK vertex per node, with `index`,
/// `fields`, and `key_k`, `mass_k`, `velocity_k`, `normal_k` for each field slot `k`.
pub fn write_grid_frame(
    path: &Path,
    frame: &GridFrame,
    compression: FrameCompression,
) -> std::io::Result<()> {
    grid_frame_file(path, frame, compression).map(drop)
}

/// [`write_grid_frame`], returning the arrays written.
pub(crate) fn grid_frame_file(
    path: &Path,
    frame: &GridFrame,
    compression: FrameCompression,
) -> std::io::Result<PieceArrays> {
    let n = frame.position.len();
    let mut out = Inline::vertices(n, compression, &[], "fields", "velocity_0");
    let index = i32_bytes(frame.index.iter().map(|&v| v as i32));
    out.column("index", "Int32", 1, n, index);
    let fields = i32_bytes(frame.fields.iter().map(|&v| i32::from(v)));
    out.column("fields", "Int32", 1, n, fields);
    for k in 0..fractum_engine::components::MAX_FIELDS {
        let key = i32_bytes(frame.key.iter().map(|v| v[k]));
        out.column(&format!("key_{k}"), "Int32", 1, n, key);
        let mass = f64_bytes(frame.mass.iter().map(|v| v[k]));
        out.column(&format!("mass_{k}"), "Float64", 1, n, mass);
        let velocity = f64_bytes(frame.velocity.iter().flat_map(|v| v[k]));
        out.column(&format!("velocity_{k}"), "Float64", 3, n, velocity);
        let normal = f64_bytes(frame.normal.iter().flat_map(|v| v[k]));
        out.column(&format!("normal_{k}"), "Float64", 3, n, normal);
    }
    out.finish(path, &frame.position)
}

/// Writes `frame` to `path` atomically, each non-empty column as one array.
pub fn write_particle_frame(
    path: &Path,
    frame: &ParticleFrame,
    compression: FrameCompression,
) -> std::io::Result<()> {
    particle_frame_file(path, frame, compression).map(drop)
}

/// [`write_particle_frame`], returning the arrays written.
pub(crate) fn particle_frame_file(
    path: &Path,
    frame: &ParticleFrame,
    compression: FrameCompression,
) -> std::io::Result<PieceArrays> {
    let field_data: Vec<(&str, f64)> = frame
        .thickness
        .map(|t| ("thickness", t))
        .into_iter()
        .collect();
    let f = frame;
    let mut out = Inline::vertices(
        f.position.len(),
        compression,
        &field_data,
        "damage",
        "velocity",
    );
    let ints = |v: &[u16]| i32_bytes(v.iter().map(|&v| i32::from(v)));
    out.column(
        "id",
        "Int32",
        1,
        f.id.len(),
        i32_bytes(f.id.iter().map(|&v| v as i32)),
    );
    out.column("body", "Int32", 1, f.body.len(), ints(&f.body));
    out.column("material", "Int32", 1, f.material.len(), ints(&f.material));
    let velocity = f64_bytes(f.velocity.iter().flatten().copied());
    out.column("velocity", "Float64", 3, f.velocity.len(), velocity);
    let scalar = |v: &[f64]| f64_bytes(v.iter().copied());
    out.column("mass", "Float64", 1, f.mass.len(), scalar(&f.mass));
    out.column("volume", "Float64", 1, f.volume.len(), scalar(&f.volume));
    let stress = f64_bytes(f.stress.iter().flatten().copied());
    out.column("stress", "Float64", 9, f.stress.len(), stress);
    out.column("damage", "Float64", 1, f.damage.len(), scalar(&f.damage));
    let energy = scalar(&f.strain_energy_density);
    let energy_len = f.strain_energy_density.len();
    out.column("strain_energy_density", "Float64", 1, energy_len, energy);
    for (name, values) in &f.scalars {
        out.column(name, "Float64", 1, values.len(), scalar(values));
    }
    for (name, values) in &f.vectors {
        let bytes = f64_bytes(values.iter().flatten().copied());
        out.column(name, "Float64", 3, values.len(), bytes);
    }
    out.finish(path, &f.position)
}

#[cfg(test)]
mod tests {
    use super::super::read_particle_frame;
    use super::*;
    use fractum_geometry::vtk::{self, Encoding};

    fn sample() -> ParticleFrame {
        ParticleFrame {
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
        }
    }

    fn scratch(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("fractum-vtu-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn assert_same(read: &ParticleFrame, frame: &ParticleFrame) {
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
    }

    #[test]
    fn a_particle_frame_reads_back_as_written_in_either_encoding() {
        let dir = scratch("read");
        for compression in [FrameCompression::None, FrameCompression::Zlib] {
            let path = dir.join(format!("{compression:?}.vtu"));
            write_particle_frame(&path, &sample(), compression).unwrap();
            let text = std::fs::read_to_string(&path).unwrap();
            let named = text.contains("compressor=\"vtkZLibDataCompressor\"");
            assert_eq!(named, compression == FrameCompression::Zlib);
            assert_same(&read_particle_frame(&path).unwrap(), &sample());
        }
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn compression_shrinks_a_frame_of_repetitive_columns() {
        let n = 2000;
        let frame = ParticleFrame {
            id: (0..n).collect(),
            body: vec![0; n as usize],
            position: (0..n).map(|i| [f64::from(i) * 1e-3, 0.5, 0.0]).collect(),
            damage: vec![0.0; n as usize],
            ..Default::default()
        };
        let dir = scratch("shrink");
        let size = |compression| {
            let path = dir.join("frame.vtu");
            write_particle_frame(&path, &frame, compression).unwrap();
            std::fs::metadata(&path).unwrap().len()
        };
        let (plain, zlib) = (size(FrameCompression::None), size(FrameCompression::Zlib));
        assert!(zlib * 3 < plain, "zlib {zlib} B against {plain} B");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_narrowed_frame_carries_only_the_chosen_fields() {
        let mut frame = sample();
        frame.keep_only(&["damage".into(), "strength".into()]);
        assert!(frame.id.is_empty() && frame.stress.is_empty() && frame.vectors.is_empty());
        assert_eq!(frame.scalars.len(), 1);
        let dir = scratch("narrow");
        let path = dir.join("frame.vtu");
        write_particle_frame(&path, &frame, FrameCompression::Zlib).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(!text.contains("Name=\"stress\"") && text.contains("Name=\"damage\""));
        let read = read_particle_frame(&path).unwrap();
        assert_same(&read, &frame);
        assert!(read.require(&["damage", "strength"]).is_ok());
        let missing = read.require(&["damage", "volume", "mass"]).unwrap_err();
        assert!(missing.contains("volume, mass"), "{missing}");
        assert!(missing.contains("output.fields"), "{missing}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// VTK's own writer splits an array into 32 KiB blocks; the shared codec reads the frame
    /// writer's zlib blocks in any number.
    #[test]
    fn an_array_in_several_zlib_blocks_decodes() {
        let bytes: Vec<u8> = (0..10_000u32)
            .flat_map(|i| (i % 251).to_le_bytes())
            .collect();
        let (block, last) = (16_384, bytes.len() % 16_384);
        let blocks: Vec<Vec<u8>> = bytes.chunks(block).map(zlib).collect();
        let mut header = vec![blocks.len() as u64, block as u64, last as u64];
        header.extend(blocks.iter().map(|b| b.len() as u64));
        let header: Vec<u8> = header.into_iter().flat_map(u64::to_le_bytes).collect();
        let body = BASE64.encode(header) + &BASE64.encode(blocks.concat());
        let encoding = Encoding {
            header_bytes: 8,
            compressed: true,
        };
        let decode_compressed = |body: &str| vtk::decode(body, &encoding);
        assert_eq!(decode_compressed(&body).unwrap(), bytes);
        // Cut short, or with a corrupt block: an error, not a panic.
        assert!(decode_compressed(&body[..body.len() / 2]).is_err());
        assert!(decode_compressed(&body[..20]).is_err());
        let mut corrupt = body.into_bytes();
        let end = corrupt.len() - 10;
        corrupt[end] = if corrupt[end] == b'A' { b'B' } else { b'A' };
        assert!(decode_compressed(std::str::from_utf8(&corrupt).unwrap()).is_err());
    }
}
