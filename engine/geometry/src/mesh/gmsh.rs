//! Gmsh MSH 4.1 reader, ASCII and binary: `$MeshFormat`, `$PhysicalNames`, `$Entities`,
//! `$Nodes` and `$Elements`; other sections are skipped. Errors name the line (ASCII) or the
//! byte offset (binary) where the file goes wrong.
//!
//! Binary files hold the same sections with integers as 4-byte `int` or 8-byte `size_t` and
//! coordinates as 8-byte doubles, in the writer's byte order, which the `int` 1 after the
//! format line gives.

use super::{ElementKind, Place, RawElement, RawMesh};
use crate::file_error::{FileError, fail};
use glam::DVec3;
use std::collections::HashMap;

/// A position in the file, read as text tokens or binary values.
struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
    line: usize,
    binary: bool,
}

impl<'a> Cursor<'a> {
    fn place(&self) -> Place {
        if self.binary {
            Place::Byte(self.at)
        } else {
            Place::Line(self.line)
        }
    }

    fn error(&self, message: impl Into<String>) -> FileError {
        fail(self.place().to_string(), message)
    }

    fn skip_space(&mut self) {
        while let Some(&b) = self.bytes.get(self.at) {
            if !b.is_ascii_whitespace() {
                break;
            }
            if b == b'\n' {
                self.line += 1;
            }
            self.at += 1;
        }
    }

    /// The next whitespace-separated word.
    fn word(&mut self, what: &str) -> Result<&'a str, FileError> {
        self.skip_space();
        let start = self.at;
        while self
            .bytes
            .get(self.at)
            .is_some_and(|b| !b.is_ascii_whitespace())
        {
            self.at += 1;
        }
        if start == self.at {
            return Err(self.error(format!("the file ends where {what} was expected")));
        }
        std::str::from_utf8(&self.bytes[start..self.at])
            .map_err(|_| self.error(format!("expected {what}, found bytes that are not text")))
    }

    /// The rest of the current line, without its end.
    fn rest_of_line(&mut self) -> &'a str {
        let start = self.at;
        while self.bytes.get(self.at).is_some_and(|&b| b != b'\n') {
            self.at += 1;
        }
        std::str::from_utf8(&self.bytes[start..self.at])
            .unwrap_or("")
            .trim()
    }

    fn text<T: std::str::FromStr>(&mut self, what: &str) -> Result<T, FileError> {
        let word = self.word(what)?;
        word.parse()
            .map_err(|_| self.error(format!("expected {what}, found `{word}`")))
    }

    fn raw<const N: usize>(&mut self, what: &str) -> Result<[u8; N], FileError> {
        let bytes = self
            .bytes
            .get(self.at..self.at + N)
            .ok_or_else(|| self.error(format!("the file ends where {what} was expected")))?;
        self.at += N;
        Ok(bytes.try_into().expect("slice of N bytes"))
    }

    /// An `int` (4 bytes binary).
    fn int(&mut self, what: &str) -> Result<i64, FileError> {
        if self.binary {
            Ok(i64::from(i32::from_le_bytes(self.raw::<4>(what)?)))
        } else {
            self.text(what)
        }
    }

    /// A `size_t` (8 bytes binary).
    fn size(&mut self, what: &str) -> Result<u64, FileError> {
        if self.binary {
            Ok(u64::from_le_bytes(self.raw::<8>(what)?))
        } else {
            self.text(what)
        }
    }

    fn double(&mut self, what: &str) -> Result<f64, FileError> {
        if self.binary {
            Ok(f64::from_le_bytes(self.raw::<8>(what)?))
        } else {
            self.text(what)
        }
    }

    /// Expects the text `token` (a section's end).
    fn expect(&mut self, token: &str) -> Result<(), FileError> {
        let word = self.word(token)?;
        if word == token {
            Ok(())
        } else {
            Err(self.error(format!("expected `{token}`, found `{word}`")))
        }
    }

    /// A count no larger than the bytes left could hold (`least` bytes or more each), so that
    /// a corrupt count is reported instead of allocated.
    fn count(&mut self, what: &str, least: usize) -> Result<usize, FileError> {
        let place = self.place();
        let n = self.size(what)?;
        let left = (self.bytes.len() - self.at) as u64;
        if n > left / least.max(1) as u64 + 1 {
            return Err(fail(
                place.to_string(),
                format!(
                    "{what} is {n}, more than the rest of the file could hold: the file is \
                     cut short or the count is wrong"
                ),
            ));
        }
        Ok(n as usize)
    }
}

/// Entities by `(dimension, tag)`, and the physical tags of each.
#[derive(Default)]
struct Entities {
    index: HashMap<(i64, i64), u32>,
    physicals: Vec<Vec<i32>>,
}

impl Entities {
    fn get_or_add(&mut self, dim: i64, tag: i64) -> u32 {
        let next = self.physicals.len() as u32;
        *self.index.entry((dim, tag)).or_insert_with(|| {
            self.physicals.push(Vec::new());
            next
        })
    }
}

/// Parses a whole MSH 4.1 file.
pub(super) fn parse(bytes: &[u8]) -> Result<RawMesh, FileError> {
    let mut c = Cursor {
        bytes,
        at: 0,
        line: 1,
        binary: false,
    };
    let mut mesh = RawMesh::default();
    let mut entities = Entities::default();
    let mut node_index = NodeIndex::default();
    let (mut has_nodes, mut has_elements) = (false, false);
    loop {
        c.skip_space();
        if c.at >= bytes.len() {
            break;
        }
        let section = c.word("a section such as `$Nodes`")?;
        if c.binary {
            // A binary section's data start right after its name's line.
            c.rest_of_line();
            if c.at < bytes.len() {
                c.at += 1;
                c.line += 1;
            }
        }
        match section {
            "$MeshFormat" => format(&mut c)?,
            "$PhysicalNames" => physical_names(&mut c, &mut mesh)?,
            "$Entities" => read_entities(&mut c, &mut entities)?,
            "$Nodes" => {
                read_nodes(&mut c, &mut mesh, &mut node_index)?;
                has_nodes = true;
            }
            "$Elements" => {
                if !has_nodes {
                    return Err(c.error("`$Elements` before `$Nodes`"));
                }
                read_elements(&mut c, &mut mesh, &mut entities, &node_index)?;
                has_elements = true;
            }
            other if other.starts_with('$') && !other.starts_with("$End") => {
                skip_section(&mut c, &other[1..])?;
            }
            other => {
                return Err(c.error(format!(
                    "expected a section such as `$Nodes`, found `{other}`"
                )));
            }
        }
    }
    if !has_elements {
        return Err(fail("", "the file has no `$Elements` section"));
    }
    mesh.entities = entities.physicals;
    Ok(mesh)
}

fn format(c: &mut Cursor) -> Result<(), FileError> {
    let version = c.word("the format version")?;
    if version != "4.1" {
        return Err(c.error(format!(
            "Gmsh format version {version} is not read; save the mesh as version 4.1 \
             (`Mesh.MshFileVersion = 4.1;` or `gmsh -format msh41`)"
        )));
    }
    let kind: u32 = c.text("the file type (0 for ASCII, 1 for binary)")?;
    let size: u32 = c.text("the data size")?;
    if kind > 1 || size != 8 {
        return Err(c.error(format!(
            "expected file type 0 or 1 and data size 8, found {kind} and {size}"
        )));
    }
    if kind == 1 {
        // The int 1, right after the line's end, tells the byte order.
        c.rest_of_line();
        c.at += 1;
        c.line += 1;
        c.binary = true;
        let one = c.raw::<4>("the byte-order mark (the int 1)")?;
        if i32::from_le_bytes(one) != 1 {
            return Err(c.error(
                "the binary mesh was written in big-endian byte order; save it on a \
                 little-endian machine or as ASCII",
            ));
        }
        c.binary = false;
    }
    c.expect("$EndMeshFormat")?;
    c.binary = kind == 1;
    Ok(())
}

fn physical_names(c: &mut Cursor, mesh: &mut RawMesh) -> Result<(), FileError> {
    let binary = std::mem::replace(&mut c.binary, false);
    let n: usize = c.text("the number of physical names")?;
    for _ in 0..n {
        let dim: usize = c.text("a physical group's dimension")?;
        let tag: i32 = c.text("a physical group's tag")?;
        let name = c.rest_of_line().trim_matches('"').to_string();
        if dim > 3 {
            return Err(c.error(format!("expected a dimension 0 to 3, found {dim}")));
        }
        mesh.physical_names.push((dim, tag, name));
    }
    c.expect("$EndPhysicalNames")?;
    c.binary = binary;
    Ok(())
}

fn read_entities(c: &mut Cursor, entities: &mut Entities) -> Result<(), FileError> {
    let counts = [
        c.count("the number of point entities", 20)?,
        c.count("the number of curve entities", 20)?,
        c.count("the number of surface entities", 20)?,
        c.count("the number of volume entities", 20)?,
    ];
    for (dim, &count) in counts.iter().enumerate() {
        for _ in 0..count {
            let tag = c.int("an entity tag")?;
            // A point's coordinates; a curve's, surface's or volume's bounding box.
            for _ in 0..if dim == 0 { 3 } else { 6 } {
                c.double("an entity's coordinate")?;
            }
            let n = c.count("the number of physical tags", 4)?;
            let mut tags = Vec::with_capacity(n);
            for _ in 0..n {
                tags.push(c.int("a physical tag")? as i32);
            }
            let e = entities.get_or_add(dim as i64, tag);
            entities.physicals[e as usize] = tags;
            if dim > 0 {
                let bounding = c.count("the number of bounding entities", 4)?;
                for _ in 0..bounding {
                    c.int("a bounding entity's tag")?;
                }
            }
        }
    }
    end_binary_section(c, "$EndEntities")
}

/// After a section's data: its end marker, as text.
fn end_binary_section(c: &mut Cursor, end: &str) -> Result<(), FileError> {
    let binary = std::mem::replace(&mut c.binary, false);
    let result = c.expect(end);
    c.binary = binary;
    result
}

/// Node tags to indices: a table when the tags are dense, a map otherwise.
#[derive(Default)]
struct NodeIndex {
    min: u64,
    table: Vec<u32>,
    map: HashMap<u64, u32>,
}

impl NodeIndex {
    /// Gives node tag `tag` the index `k`; an error when the tag lies outside the table's range
    /// (up to `max`, the header's largest tag) or was given before.
    fn insert(&mut self, tag: u64, k: u32, max: u64) -> Result<(), String> {
        let fresh = if self.table.is_empty() {
            self.map.insert(tag, k).is_none()
        } else {
            match tag
                .checked_sub(self.min)
                .and_then(|i| self.table.get_mut(i as usize))
            {
                Some(slot) if *slot == u32::MAX => {
                    *slot = k;
                    true
                }
                Some(_) => false,
                None => {
                    let min = self.min;
                    return Err(format!(
                        "node tag {tag} is outside the header's range {min} to {max}"
                    ));
                }
            }
        };
        if fresh {
            Ok(())
        } else {
            Err(format!("node tag {tag} is given twice"))
        }
    }

    fn get(&self, tag: u64) -> Option<u32> {
        if self.table.is_empty() {
            self.map.get(&tag).copied()
        } else {
            let i = tag.checked_sub(self.min)? as usize;
            self.table.get(i).copied().filter(|&n| n != u32::MAX)
        }
    }
}

fn read_nodes(c: &mut Cursor, mesh: &mut RawMesh, index: &mut NodeIndex) -> Result<(), FileError> {
    let blocks = c.count("the number of node blocks", 16)?;
    let total = c.count("the number of nodes", 8)?;
    let min = c.size("the smallest node tag")?;
    let max = c.size("the largest node tag")?;
    index.min = min;
    if max >= min && max - min < 4 * total as u64 + 16 {
        index.table = vec![u32::MAX; (max - min + 1) as usize];
    }
    mesh.nodes.reserve(total);
    let mut read = 0usize;
    for _ in 0..blocks {
        let dim = c.int("a node block's entity dimension")?;
        c.int("a node block's entity tag")?;
        let parametric = c.int("whether the block is parametric")?;
        let n = c.count("the number of nodes in the block", 8)?;
        if read + n > total {
            return Err(c.error(format!(
                "the node blocks hold more nodes than the {total} the section's header gives"
            )));
        }
        let first = mesh.nodes.len();
        let mut tags = Vec::with_capacity(n);
        for _ in 0..n {
            tags.push(c.size("a node tag")?);
        }
        let extra = if parametric == 1 {
            dim.max(0) as usize
        } else {
            0
        };
        for &tag in &tags {
            let place = c.place();
            let mut x = DVec3::ZERO;
            for a in 0..3 {
                x[a] = c.double("a node coordinate")?;
            }
            for _ in 0..extra {
                c.double("a node's parametric coordinate")?;
            }
            if !x.is_finite() {
                return Err(fail(
                    place.to_string(),
                    format!(
                        "node {tag} has coordinates ({}, {}, {}); expected finite numbers",
                        x.x, x.y, x.z
                    ),
                ));
            }
            let k = mesh.nodes.len() as u32;
            mesh.nodes.push(x);
            index
                .insert(tag, k, max)
                .map_err(|e| fail(place.to_string(), e))?;
        }
        read += mesh.nodes.len() - first;
    }
    if read != total {
        return Err(c.error(format!(
            "the node blocks hold {read} nodes; the section's header gives {total}"
        )));
    }
    end_binary_section(c, "$EndNodes")
}

/// The kind and node count of a Gmsh element type; `Ok(None)` for lines and points, read and
/// set aside; an error for every other type.
fn element_type(code: i64) -> Result<(Option<ElementKind>, usize), String> {
    Ok(match code {
        1 => (None, 2),
        15 => (None, 1),
        2 => (Some(ElementKind::Triangle), 3),
        3 => (Some(ElementKind::Quadrilateral), 4),
        4 => (Some(ElementKind::Tetrahedron), 4),
        5 => (Some(ElementKind::Hexahedron), 8),
        _ => {
            let name = match code {
                6 => "6-node prism",
                7 => "5-node pyramid",
                8 | 26 | 27 | 28 => "higher-order line",
                9 | 20 | 21 | 22 | 23 | 24 | 25 => "higher-order triangle",
                10 | 16 | 36 | 37 | 38 => "higher-order quadrilateral",
                11 | 29 | 30 | 31 => "higher-order tetrahedron",
                12 | 17 | 92 | 93 => "higher-order hexahedron",
                13 | 18 => "higher-order prism",
                14 | 19 => "higher-order pyramid",
                _ => "an element type this reader does not know",
            };
            return Err(format!(
                "element type {code} ({name}) is not read; bodies are made of 3-node \
                 triangles (2), 4-node quadrilaterals (3), 4-node tetrahedra (4) and 8-node \
                 hexahedra (5), with lines (1) and points (15) as boundaries; mesh with \
                 `Mesh.ElementOrder = 1` and without prisms or pyramids"
            ));
        }
    })
}

fn read_elements(
    c: &mut Cursor,
    mesh: &mut RawMesh,
    entities: &mut Entities,
    nodes: &NodeIndex,
) -> Result<(), FileError> {
    let blocks = c.count("the number of element blocks", 16)?;
    let total = c.count("the number of elements", 8)?;
    c.size("the smallest element tag")?;
    c.size("the largest element tag")?;
    let mut read = 0usize;
    for _ in 0..blocks {
        let dim = c.int("an element block's entity dimension")?;
        let tag = c.int("an element block's entity tag")?;
        let place = c.place();
        let code = c.int("an element type")?;
        let (kind, count) = element_type(code).map_err(|m| fail(place.to_string(), m))?;
        // Each element is at least its tag and nodes: 8 bytes each binary, 2 as text.
        let least = if c.binary { 8 } else { 2 } * (count + 1);
        let n = c.count("the number of elements in the block", least)?;
        if read + n > total {
            return Err(c.error(format!(
                "the element blocks hold more elements than the {total} the section's header \
                 gives"
            )));
        }
        read += n;
        let entity = entities.get_or_add(dim, tag);
        for _ in 0..n {
            if !c.binary {
                c.skip_space();
            }
            let place = c.place();
            let element = c.size("an element tag")?;
            let mut refs = [0u32; 8];
            for slot in refs.iter_mut().take(count) {
                let node = c.size("a node tag of an element")?;
                *slot = nodes.get(node).ok_or_else(|| {
                    fail(
                        place.to_string(),
                        format!(
                            "element {element} refers to node {node}, which `$Nodes` does not hold"
                        ),
                    )
                })?;
            }
            match kind {
                Some(kind) => mesh.elements.push(RawElement {
                    kind,
                    nodes: refs,
                    entity,
                    tag: element,
                    place,
                }),
                None => {
                    if count == 2 {
                        mesh.lines.push(([refs[0], refs[1]], entity));
                    }
                    mesh.lower += 1;
                }
            }
        }
    }
    if read != total {
        return Err(c.error(format!(
            "the element blocks hold {read} elements; the section's header gives {total}"
        )));
    }
    end_binary_section(c, "$EndElements")
}

/// Skips a section this reader does not use, to its `$End...` line.
fn skip_section(c: &mut Cursor, name: &str) -> Result<(), FileError> {
    let end = format!("\n$End{name}");
    let start = c.place();
    let rest = &c.bytes[c.at..];
    let Some(offset) = rest.windows(end.len()).position(|w| w == end.as_bytes()) else {
        return Err(fail(
            start.to_string(),
            format!("the section `${name}` has no `$End{name}`"),
        ));
    };
    c.line += rest[..offset].iter().filter(|&&b| b == b'\n').count();
    c.at += offset;
    c.skip_space();
    c.word("the section's end")?;
    Ok(())
}
