//! GiD ASCII mesh reader (`.msh`, the format NL-PartSol reads): one or more blocks, each a
//! `MESH dimension 2 ElemType Triangle Nnode 3` header, a `Coordinates` list (usually only in
//! the first block) and an `Elements` list of `number node node ... [material]` lines. Errors
//! name the line.

use super::{ElementKind, Place, RawElement, RawMesh};
use crate::file_error::{FileError, fail, text_of};
use glam::DVec3;
use std::collections::HashMap;

/// The kind of a GiD element type, `None` for lines and points (set aside), with its node
/// count.
fn element_type(name: &str) -> Option<(Option<ElementKind>, usize)> {
    Some(match name.to_ascii_lowercase().as_str() {
        "triangle" => (Some(ElementKind::Triangle), 3),
        "quadrilateral" => (Some(ElementKind::Quadrilateral), 4),
        "tetrahedra" | "tetrahedron" => (Some(ElementKind::Tetrahedron), 4),
        "hexahedra" | "hexahedron" => (Some(ElementKind::Hexahedron), 8),
        "linear" => (None, 2),
        "point" => (None, 1),
        _ => return None,
    })
}

/// What a block's header gives.
struct Header {
    dimension: usize,
    kind: Option<ElementKind>,
    nodes: usize,
}

fn header(line: &str, at: usize) -> Result<Header, FileError> {
    let place = format!("line {at}");
    let words: Vec<&str> = line.split_whitespace().collect();
    let after = |key: &str| {
        words
            .iter()
            .position(|w| w.eq_ignore_ascii_case(key))
            .and_then(|k| words.get(k + 1).copied())
    };
    let dimension = match after("dimension").map(str::parse::<usize>) {
        Some(Ok(d @ (2 | 3))) => d,
        _ => {
            return Err(fail(
                place,
                "expected `dimension 2` or `dimension 3` in the MESH header",
            ));
        }
    };
    let Some(type_name) = after("ElemType") else {
        return Err(fail(place, "expected `ElemType <type>` in the MESH header"));
    };
    let Some((kind, count)) = element_type(type_name) else {
        return Err(fail(
            place,
            format!(
                "element type `{type_name}` is not read; bodies are made of Triangle, \
                 Quadrilateral, Tetrahedra and Hexahedra, with Linear and Point as boundaries"
            ),
        ));
    };
    let nodes = match after("Nnode").map(str::parse::<usize>) {
        Some(Ok(n)) => n,
        _ => return Err(fail(place, "expected `Nnode <count>` in the MESH header")),
    };
    if nodes != count {
        return Err(fail(
            place,
            format!(
                "`{type_name}` with {nodes} nodes is not read; expected the first-order element \
                 of {count} nodes"
            ),
        ));
    }
    Ok(Header {
        dimension,
        kind,
        nodes,
    })
}

/// Parses a whole GiD ASCII mesh.
pub(super) fn parse(bytes: &[u8]) -> Result<RawMesh, FileError> {
    let text = text_of(bytes)?;
    let mut mesh = RawMesh::default();
    let mut ids: HashMap<u64, u32> = HashMap::new();
    let mut lines = text.lines().enumerate().map(|(k, l)| (k + 1, l.trim()));
    let mut current: Option<Header> = None;
    let mut pending: Vec<(usize, Vec<u64>, u64)> = Vec::new();
    while let Some((at, line)) = lines.next() {
        let lower = line.to_ascii_lowercase();
        if line.is_empty() || line.starts_with('#') {
            continue;
        } else if lower.starts_with("mesh") {
            current = Some(header(line, at)?);
            mesh.entities.push(Vec::new());
        } else if lower == "coordinates" {
            let Some(h) = &current else {
                return Err(fail(
                    format!("line {at}"),
                    "`Coordinates` before a MESH header",
                ));
            };
            coordinates(&mut lines, h.dimension, &mut mesh, &mut ids, at)?;
        } else if lower == "elements" {
            let Some(h) = &current else {
                return Err(fail(
                    format!("line {at}"),
                    "`Elements` before a MESH header",
                ));
            };
            let entity = (mesh.entities.len() - 1) as u32;
            elements(&mut lines, h, entity, &mut mesh, &mut pending, at)?;
        } else {
            return Err(fail(
                format!("line {at}"),
                format!("expected `MESH`, `Coordinates` or `Elements`, found `{line}`"),
            ));
        }
    }
    // Elements may name nodes listed in a later block's coordinates: resolve at the end.
    for (e, (at, refs, tag)) in mesh.elements.iter_mut().zip(&pending) {
        for (slot, id) in e.nodes.iter_mut().zip(refs) {
            *slot = *ids.get(id).ok_or_else(|| {
                fail(
                    format!("line {at}"),
                    format!("element {tag} refers to node {id}, which no `Coordinates` list holds"),
                )
            })?;
        }
    }
    if mesh.elements.is_empty() && mesh.lower == 0 && current.is_none() {
        return Err(fail("", "the file has no MESH block"));
    }
    Ok(mesh)
}

fn coordinates<'a>(
    lines: &mut impl Iterator<Item = (usize, &'a str)>,
    dimension: usize,
    mesh: &mut RawMesh,
    ids: &mut HashMap<u64, u32>,
    start: usize,
) -> Result<(), FileError> {
    let mut last = start;
    for (at, line) in lines.by_ref() {
        last = at;
        if line.eq_ignore_ascii_case("end coordinates") {
            return Ok(());
        }
        if line.is_empty() {
            continue;
        }
        let place = || format!("line {at}");
        let words: Vec<&str> = line.split_whitespace().collect();
        if words.len() < 1 + dimension.min(2) {
            return Err(fail(
                place(),
                format!("expected a node number and {dimension} coordinates, found `{line}`"),
            ));
        }
        let id: u64 = words[0].parse().map_err(|_| {
            fail(
                place(),
                format!("expected a node number, found `{}`", words[0]),
            )
        })?;
        let mut x = DVec3::ZERO;
        for (a, w) in words[1..].iter().take(3).enumerate() {
            x[a] = w
                .parse()
                .map_err(|_| fail(place(), format!("expected a coordinate, found `{w}`")))?;
        }
        if !x.is_finite() {
            return Err(fail(
                place(),
                format!(
                    "node {id} has coordinates ({}, {}, {}); expected finite numbers",
                    x.x, x.y, x.z
                ),
            ));
        }
        if ids.insert(id, mesh.nodes.len() as u32).is_some() {
            return Err(fail(place(), format!("node {id} is given twice")));
        }
        mesh.nodes.push(x);
    }
    Err(fail(
        format!("line {}", last + 1),
        "the file ends inside `Coordinates`; expected `End Coordinates`",
    ))
}

fn elements<'a>(
    lines: &mut impl Iterator<Item = (usize, &'a str)>,
    h: &Header,
    entity: u32,
    mesh: &mut RawMesh,
    pending: &mut Vec<(usize, Vec<u64>, u64)>,
    start: usize,
) -> Result<(), FileError> {
    let mut last = start;
    for (at, line) in lines.by_ref() {
        last = at;
        if line.eq_ignore_ascii_case("end elements") {
            return Ok(());
        }
        if line.is_empty() {
            continue;
        }
        let place = || format!("line {at}");
        let words: Vec<&str> = line.split_whitespace().collect();
        // The element's number, its nodes and perhaps a material number.
        if words.len() != 1 + h.nodes && words.len() != 2 + h.nodes {
            return Err(fail(
                place(),
                format!(
                    "expected an element number and {} node numbers (and perhaps a material), \
                     found {} numbers",
                    h.nodes,
                    words.len()
                ),
            ));
        }
        let numbers: Vec<u64> = words
            .iter()
            .map(|w| {
                w.parse()
                    .map_err(|_| fail(place(), format!("expected a whole number, found `{w}`")))
            })
            .collect::<Result<_, _>>()?;
        match h.kind {
            Some(kind) => {
                mesh.elements.push(RawElement {
                    kind,
                    nodes: [0; 8],
                    entity,
                    tag: numbers[0],
                    place: Place::Line(at),
                });
                pending.push((at, numbers[1..=h.nodes].to_vec(), numbers[0]));
            }
            None => mesh.lower += 1,
        }
    }
    Err(fail(
        format!("line {}", last + 1),
        "the file ends inside `Elements`; expected `End Elements`",
    ))
}
