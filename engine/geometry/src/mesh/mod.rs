//! Bodies from finite-element meshes: Gmsh MSH 4.1 (ASCII and binary) and GiD ASCII `.msh`
//! files, as a shape (`Mesh(file: "specimen.msh", physical: "rock", seeding: Grid)`).
//!
//! A mesh is read once, checked (finite coordinates, known element types, node references
//! that exist, no degenerate, folded or inverted element) and reduced to the elements of its
//! highest dimension that belong to the chosen physical group. It then answers inside tests
//! (a point is inside when it lies in or on one of the elements; the elements are binned on a
//! uniform grid over the mesh's box) and gives the quadrature points of its elements for
//! `Elements` seeding. The readers are in-house: both formats are short, line- or
//! block-structured text (and Gmsh's binary twin of it), and no maintained Rust crate reads
//! Gmsh 4.1's binary form.

mod boundary;
mod element;
mod gid;
mod gmsh;

pub use boundary::{BoundaryFacets, Facet, boundary_facets};
pub use element::ElementKind;

use super::file_error::{FileError, fail};
use glam::DVec3;
use std::path::Path;

/// How a mesh body is filled with particles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub enum MeshSeeding {
    /// The per-cell rule every shape uses: lattice points inside the mesh's elements.
    #[default]
    Grid,
    /// Each element's quadrature points with their exact volumes: one point per element
    /// (`particles_per_cell: 1`), or three per triangle and four per quadrilateral or
    /// tetrahedron and eight per hexahedron (`particles_per_cell: 2`).
    Elements,
}

/// Where in the file an element was written: a line (ASCII) or a byte offset (binary).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Place {
    /// 1-based line.
    Line(usize),
    /// 0-based byte offset.
    Byte(usize),
}

impl std::fmt::Display for Place {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Place::Line(n) => write!(f, "line {n}"),
            Place::Byte(n) => write!(f, "byte {n}"),
        }
    }
}

/// An element as a reader found it.
#[derive(Clone, Debug)]
pub(crate) struct RawElement {
    kind: ElementKind,
    /// Indices into the mesh's nodes; the first `kind.nodes()` are used.
    nodes: [u32; 8],
    /// Index into the reader's entities (the physical groups it belongs to).
    entity: u32,
    /// The element's number in the file.
    tag: u64,
    place: Place,
}

/// A mesh file as read: nodes, elements of every dimension, and its named groups; reduced to
/// one region by [`Mesh::from_raw`].
#[derive(Clone, Debug, Default)]
pub struct RawMesh {
    nodes: Vec<DVec3>,
    elements: Vec<RawElement>,
    /// For each entity, the physical tags it belongs to.
    entities: Vec<Vec<i32>>,
    /// `(dimension, tag, name)` of each named physical group.
    physical_names: Vec<(usize, i32, String)>,
    /// Two-node lines (the boundaries of 2D meshes) and the entity of each.
    lines: Vec<([u32; 2], u32)>,
    /// Lines and points the file held, which bodies do not use; counted so that a file of only
    /// those is reported as such.
    lower: usize,
}

/// The elements of one region of a mesh, ready for inside tests and seeding.
#[derive(Clone, Debug)]
pub struct Mesh {
    /// The file it was read from, as the scene names it.
    pub file: String,
    /// The physical group it was reduced to, if any.
    pub physical: Option<String>,
    /// How bodies made of it are filled.
    pub seeding: MeshSeeding,
    dimension: usize,
    nodes: Vec<DVec3>,
    kinds: Vec<ElementKind>,
    connectivity: Vec<[u32; 8]>,
    lo: DVec3,
    hi: DVec3,
    bins: Bins,
}

impl PartialEq for Mesh {
    fn eq(&self, other: &Self) -> bool {
        self.file == other.file
            && self.physical == other.physical
            && self.seeding == other.seeding
            && self.kinds == other.kinds
            && self.connectivity == other.connectivity
            && self.nodes == other.nodes
    }
}

/// Reads the mesh at `path` (`file` is how the scene names it) and reduces it to `physical`.
pub fn read_mesh(
    path: &Path,
    file: &str,
    physical: Option<&str>,
    seeding: MeshSeeding,
) -> Result<Mesh, FileError> {
    let raw = read_raw_mesh(path)?;
    Mesh::from_raw(raw, file, physical, seeding)
}

/// Reads and parses the mesh file at `path`, every element of every dimension.
pub fn read_raw_mesh(path: &Path) -> Result<RawMesh, FileError> {
    let bytes = std::fs::read(path).map_err(|e| fail("", format!("cannot read it: {e}")))?;
    parse_mesh(&bytes)
}

/// Whether the mesh has a physical group `name` of its highest dimension; an error that lists
/// those it has when not.
pub fn check_physical(raw: &RawMesh, name: &str) -> Result<(), FileError> {
    let dimension = raw
        .elements
        .iter()
        .map(|e| e.kind.dimension())
        .max()
        .unwrap_or(2);
    physical_tags(raw, name, dimension).map(|_| ())
}

/// Parses Gmsh MSH 4.1 (ASCII or binary, told by its `$MeshFormat`) or GiD ASCII (`MESH ...`
/// headers), told apart by the first line.
pub(crate) fn parse_mesh(bytes: &[u8]) -> Result<RawMesh, FileError> {
    let start = bytes
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .unwrap_or(bytes.len());
    let head = &bytes[start..bytes.len().min(start + 16)];
    if head.starts_with(b"$MeshFormat") {
        gmsh::parse(bytes)
    } else if head.len() >= 4 && head[..4].eq_ignore_ascii_case(b"MESH") {
        gid::parse(bytes)
    } else {
        Err(fail(
            "line 1",
            "expected a Gmsh mesh (`$MeshFormat`, version 4.1) or a GiD mesh (`MESH dimension \
             ...`)",
        ))
    }
}

impl Mesh {
    /// The region `physical` (every element of the highest dimension when `None`) of a mesh
    /// as read, checked element by element.
    pub fn from_raw(
        raw: RawMesh,
        file: &str,
        physical: Option<&str>,
        seeding: MeshSeeding,
    ) -> Result<Self, FileError> {
        let Some(dimension) = raw.elements.iter().map(|e| e.kind.dimension()).max() else {
            let lower = if raw.lower > 0 {
                format!(" ({} lines or points only)", raw.lower)
            } else {
                String::new()
            };
            return Err(fail(
                "",
                format!(
                    "the mesh has no triangle, quadrilateral, tetrahedron or hexahedron{lower}; \
                     a body needs elements that fill an area or a volume"
                ),
            ));
        };
        let tags = match physical {
            Some(name) => Some(physical_tags(&raw, name, dimension)?),
            None => None,
        };
        let in_region = |e: &RawElement| {
            e.kind.dimension() == dimension
                && tags.as_ref().is_none_or(|tags| {
                    raw.entities[e.entity as usize]
                        .iter()
                        .any(|t| tags.contains(t))
                })
        };
        let mut kinds = Vec::new();
        let mut connectivity = Vec::new();
        let mut reference: Vec<Option<f64>> = vec![None; raw.entities.len().max(1)];
        for e in raw.elements.iter().filter(|e| in_region(e)) {
            let corners: Vec<DVec3> = e.nodes[..e.kind.nodes()]
                .iter()
                .map(|&n| raw.nodes[n as usize])
                .collect();
            check_element(e, &corners, dimension, &mut reference)?;
            kinds.push(e.kind);
            connectivity.push(e.nodes);
        }
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for (c, kind) in connectivity.iter().zip(&kinds) {
            for &n in &c[..kind.nodes()] {
                let x = raw.nodes[n as usize];
                lo = lo.min(x);
                hi = hi.max(x);
            }
        }
        let mut mesh = Mesh {
            file: file.to_string(),
            physical: physical.map(str::to_string),
            seeding,
            dimension,
            nodes: raw.nodes,
            kinds,
            connectivity,
            lo,
            hi,
            bins: Bins::default(),
        };
        mesh.bins = Bins::new(&mesh);
        Ok(mesh)
    }

    /// 2 for a mesh of triangles and quadrilaterals, 3 for tetrahedra and hexahedra.
    pub fn dimension(&self) -> usize {
        self.dimension
    }

    /// Number of elements in the region.
    pub fn element_count(&self) -> usize {
        self.kinds.len()
    }

    /// The bounding box of the region's elements.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        (self.lo, self.hi)
    }

    /// The corners of element `k`.
    fn corners(&self, k: usize) -> Vec<DVec3> {
        self.connectivity[k][..self.kinds[k].nodes()]
            .iter()
            .map(|&n| self.nodes[n as usize])
            .collect()
    }

    /// The region's area (2D) or volume (3D): the sum of its elements'.
    pub fn measure(&self) -> f64 {
        (0..self.kinds.len())
            .map(|k| element::measure(self.kinds[k], &self.corners(k)))
            .sum()
    }

    /// Whether `x` (z ignored for a 2D mesh) lies in or on one of the region's elements.
    pub fn contains(&self, x: DVec3) -> bool {
        let x = if self.dimension == 2 {
            DVec3::new(x.x, x.y, 0.0)
        } else {
            x
        };
        let d = self.dimension;
        if (0..d).any(|a| x[a] < self.lo[a] || x[a] > self.hi[a]) {
            return false;
        }
        self.bins.elements_at(x).iter().any(|&k| {
            let k = k as usize;
            let corners = self.connectivity[k];
            let mut c = [DVec3::ZERO; 8];
            for (i, &n) in corners[..self.kinds[k].nodes()].iter().enumerate() {
                c[i] = self.nodes[n as usize];
            }
            element::contains(self.kinds[k], &c, x)
        })
    }

    /// The quadrature points of every element (in file order, each element's points in the
    /// rule's order) with their volumes, for `Elements` seeding; `None` when `order` is not a
    /// rule of the region's elements.
    pub fn quadrature_points(&self, order: u32) -> Option<Vec<(DVec3, f64)>> {
        let mut rules: Vec<(ElementKind, Vec<(DVec3, f64)>)> = Vec::new();
        let mut out = Vec::new();
        for k in 0..self.kinds.len() {
            let kind = self.kinds[k];
            if !rules.iter().any(|(r, _)| *r == kind) {
                rules.push((kind, kind.rule(order)?));
            }
            let rule = &rules.iter().find(|(r, _)| *r == kind)?.1;
            out.extend(element::quadrature_points(kind, &self.corners(k), rule));
        }
        Some(out)
    }
}

/// The tags of the physical groups named `name` of the region's `dimension`; an error that
/// lists the names there are when none is.
fn physical_tags(raw: &RawMesh, name: &str, dimension: usize) -> Result<Vec<i32>, FileError> {
    let tags: Vec<i32> = raw
        .physical_names
        .iter()
        .filter(|(d, _, n)| *d == dimension && n == name)
        .map(|(_, t, _)| *t)
        .collect();
    if !tags.is_empty() {
        return Ok(tags);
    }
    let of_dimension: Vec<String> = raw
        .physical_names
        .iter()
        .filter(|(d, _, _)| *d == dimension)
        .map(|(_, _, n)| format!("\"{n}\""))
        .collect();
    let lower = raw
        .physical_names
        .iter()
        .find(|(d, _, n)| *d < dimension && n == name);
    let message = match (lower, of_dimension.is_empty()) {
        (Some((d, _, _)), _) => format!(
            "physical group \"{name}\" is of dimension {d}, a boundary; a body needs a group of \
             dimension {dimension}{}",
            listed(&of_dimension)
        ),
        (None, true) => format!(
            "the mesh names no physical group of dimension {dimension}, so it has no \
             \"{name}\"; leave `physical` out to use every element"
        ),
        (None, false) => format!(
            "no physical group \"{name}\" of dimension {dimension}{}",
            listed(&of_dimension)
        ),
    };
    Err(fail("$PhysicalNames", message))
}

fn listed(names: &[String]) -> String {
    if names.is_empty() {
        String::new()
    } else {
        format!("; the mesh has {}", names.join(", "))
    }
}

/// Refuses a degenerate, folded or inverted element (one turned against the first element of
/// its entity), and a 2D element off the plane z = 0.
fn check_element(
    e: &RawElement,
    corners: &[DVec3],
    dimension: usize,
    reference: &mut [Option<f64>],
) -> Result<(), FileError> {
    let at = format!("{} (element {})", e.place, e.tag);
    if dimension == 2
        && let Some(z) = corners.iter().map(|c| c.z).find(|&z| z != 0.0)
    {
        return Err(fail(
            at,
            format!(
                "a node of this {} has z = {z}; a 2D mesh must lie in the plane z = 0",
                e.kind.name()
            ),
        ));
    }
    let Some(sign) = element::orientation(e.kind, corners) else {
        return Err(fail(
            at,
            format!(
                "this {} is degenerate or folded (its Jacobian is zero or changes sign); \
                 remesh or fix its node order",
                e.kind.name()
            ),
        ));
    };
    let slot = &mut reference[(e.entity as usize).min(reference.len() - 1)];
    match *slot {
        None => *slot = Some(sign),
        Some(first) if first != sign => {
            return Err(fail(
                at,
                format!(
                    "this {} is inverted: its nodes run {} where the first element of its \
                     region runs {}; fix its node order",
                    e.kind.name(),
                    turn(sign, dimension),
                    turn(first, dimension)
                ),
            ));
        }
        Some(_) => {}
    }
    Ok(())
}

fn turn(sign: f64, dimension: usize) -> &'static str {
    match (dimension, sign > 0.0) {
        (2, true) => "counter-clockwise",
        (2, false) => "clockwise",
        (_, true) => "with a positive volume",
        (_, false) => "with a negative volume",
    }
}

/// Elements binned on a uniform grid over the mesh's box, about one element per bin.
#[derive(Clone, Debug, Default)]
struct Bins {
    origin: DVec3,
    width: DVec3,
    count: [usize; 3],
    start: Vec<usize>,
    elements: Vec<u32>,
}

impl Bins {
    fn new(mesh: &Mesh) -> Self {
        let d = mesh.dimension;
        let n = mesh.kinds.len().max(1) as f64;
        let side =
            (n.powf(1.0 / d as f64).ceil() as usize).clamp(1, if d == 2 { 2048 } else { 256 });
        let count = [side, side, if d == 2 { 1 } else { side }];
        let span = (mesh.hi - mesh.lo).max(DVec3::splat(f64::MIN_POSITIVE));
        let width = DVec3::new(
            span.x / count[0] as f64,
            span.y / count[1] as f64,
            span.z / count[2] as f64,
        );
        let mut bins = Bins {
            origin: mesh.lo,
            width,
            count,
            ..Bins::default()
        };
        let total = count[0] * count[1] * count[2];
        let mut members: Vec<u32> = vec![0; total + 1];
        let ranges: Vec<([usize; 3], [usize; 3])> = (0..mesh.kinds.len())
            .map(|k| {
                let corners = mesh.corners(k);
                let lo = corners.iter().copied().fold(DVec3::INFINITY, DVec3::min);
                let hi = corners
                    .iter()
                    .copied()
                    .fold(DVec3::NEG_INFINITY, DVec3::max);
                (bins.cell(lo), bins.cell(hi))
            })
            .collect();
        let each = |(a, b): &([usize; 3], [usize; 3]), f: &mut dyn FnMut(usize)| {
            for k in a[2]..=b[2] {
                for j in a[1]..=b[1] {
                    for i in a[0]..=b[0] {
                        f((k * count[1] + j) * count[0] + i);
                    }
                }
            }
        };
        for r in &ranges {
            each(r, &mut |b| members[b + 1] += 1);
        }
        for b in 0..total {
            members[b + 1] += members[b];
        }
        bins.start = members.iter().map(|&m| m as usize).collect();
        let mut fill = bins.start.clone();
        bins.elements = vec![0; *bins.start.last().unwrap_or(&0)];
        for (e, r) in ranges.iter().enumerate() {
            each(r, &mut |b| {
                bins.elements[fill[b]] = e as u32;
                fill[b] += 1;
            });
        }
        bins
    }

    fn cell(&self, p: DVec3) -> [usize; 3] {
        std::array::from_fn(|a| {
            let f = ((p[a] - self.origin[a]) / self.width[a]).floor();
            (f.max(0.0) as usize).min(self.count[a] - 1)
        })
    }

    fn elements_at(&self, p: DVec3) -> &[u32] {
        let [i, j, k] = self.cell(p);
        let b = (k * self.count[1] + j) * self.count[0] + i;
        &self.elements[self.start[b]..self.start[b + 1]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SQUARE: &str = "MESH dimension 2 ElemType Quadrilateral Nnode 4\nCoordinates\n\
        1 0 0\n2 1 0\n3 2 0\n4 0 1\n5 1 1\n6 2 1\nEnd Coordinates\n\
        Elements\n1 1 2 5 4\n2 2 3 6 5\nEnd Elements\n";

    #[test]
    fn a_two_quadrilateral_strip_answers_inside_tests_and_seeds_its_elements() {
        let raw = parse_mesh(SQUARE.as_bytes()).unwrap();
        let mesh = Mesh::from_raw(raw, "strip", None, MeshSeeding::Elements).unwrap();
        assert_eq!(mesh.dimension(), 2);
        assert_eq!(mesh.element_count(), 2);
        assert!((mesh.measure() - 2.0).abs() < 1e-15);
        assert!(mesh.contains(DVec3::new(1.5, 0.5, 0.0)));
        assert!(mesh.contains(DVec3::new(2.0, 1.0, 0.0)));
        assert!(!mesh.contains(DVec3::new(2.0001, 0.5, 0.0)));
        let one = mesh.quadrature_points(1).unwrap();
        let centres = [DVec3::new(0.5, 0.5, 0.0), DVec3::new(1.5, 0.5, 0.0)];
        assert_eq!(one.len(), 2);
        for ((x, v), centre) in one.iter().zip(centres) {
            assert_eq!(*x, centre);
            assert!((v - 1.0).abs() < 1e-15, "{v}");
        }
        let four = mesh.quadrature_points(2).unwrap();
        assert_eq!(four.len(), 8);
        assert!((four.iter().map(|p| p.1).sum::<f64>() - 2.0).abs() < 1e-15);
        assert!(mesh.quadrature_points(3).is_none());
    }

    #[test]
    fn an_inverted_element_is_named_with_its_line() {
        let flipped = SQUARE.replace("2 2 3 6 5", "2 2 5 6 3");
        let raw = parse_mesh(flipped.as_bytes()).unwrap();
        let e = Mesh::from_raw(raw, "strip", None, MeshSeeding::Grid).unwrap_err();
        assert_eq!(e.place, "line 12 (element 2)");
        assert!(e.message.contains("inverted"), "{e}");
    }

    #[test]
    fn an_unknown_file_kind_is_refused() {
        let e = parse_mesh(b"solid cube\n").unwrap_err();
        assert!(e.message.contains("Gmsh"), "{e}");
    }
}
