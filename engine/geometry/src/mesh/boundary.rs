//! Boundary groups of a mesh: the Gmsh physical groups one dimension below the mesh's (lines
//! of a 2D mesh; triangles and quadrilaterals, each quadrilateral as two triangles, of a 3D
//! one), as named regions of grid nodes (`nodes: Mesh(file: "beam.msh", physical:
//! "support")`). A region holds the grid nodes within a distance of the group's facets; the
//! distance kernels are pure and tested here.

use super::{RawMesh, listed};
use crate::file_error::{FileError, fail};
use glam::DVec3;

/// A line segment (2D meshes) or a triangle (3D meshes) of a boundary group.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Facet {
    /// Two ends.
    Segment([DVec3; 2]),
    /// Three corners.
    Triangle([DVec3; 3]),
}

impl Facet {
    /// The facet's bounding box.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        let corners: &[DVec3] = match self {
            Facet::Segment(s) => s,
            Facet::Triangle(t) => t,
        };
        corners
            .iter()
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), &c| {
                (lo.min(c), hi.max(c))
            })
    }

    /// The distance from `p` to the facet's nearest point.
    pub fn distance(&self, p: DVec3) -> f64 {
        match self {
            Facet::Segment([a, b]) => (p - closest_on_segment(p, *a, *b)).length(),
            Facet::Triangle([a, b, c]) => (p - closest_on_triangle(p, *a, *b, *c)).length(),
        }
    }
}

/// The point of the segment from `a` to `b` nearest `p`.
fn closest_on_segment(p: DVec3, a: DVec3, b: DVec3) -> DVec3 {
    let d = b - a;
    let length2 = d.length_squared();
    if length2 == 0.0 {
        return a;
    }
    a + d * ((p - a).dot(d) / length2).clamp(0.0, 1.0)
}

/// The point of the triangle (a, b, c) nearest `p`: the vertex, edge or face region of `p`,
/// told by the signs of its projections on the edges (the Voronoi regions of the triangle).
fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let scale = 1.0 / (va + vb + vc);
    a + ab * (vb * scale) + ac * (vc * scale)
}

/// The facets of one boundary group.
#[derive(Clone, Debug, PartialEq)]
pub struct BoundaryFacets {
    /// The mesh file, as the scene names it.
    pub file: String,
    /// The group's name.
    pub physical: String,
    /// Its facets.
    pub facets: Vec<Facet>,
}

impl BoundaryFacets {
    /// The bounding box of all the facets.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.facets.iter().map(Facet::bounds).fold(
            (DVec3::INFINITY, DVec3::NEG_INFINITY),
            |(lo, hi), (a, b)| (lo.min(a), hi.max(b)),
        )
    }
}

/// The facets of the physical group `name` one dimension below the mesh's; an error that lists
/// the boundary groups the mesh has when there is none of that name.
pub fn boundary_facets(raw: &RawMesh, file: &str, name: &str) -> Result<BoundaryFacets, FileError> {
    let Some(dimension) = raw.elements.iter().map(|e| e.kind.dimension()).max() else {
        return Err(fail("", "the mesh has no elements of dimension 2 or 3"));
    };
    let below = dimension - 1;
    let tags: Vec<i32> = raw
        .physical_names
        .iter()
        .filter(|(d, _, n)| *d == below && n == name)
        .map(|(_, t, _)| *t)
        .collect();
    if tags.is_empty() {
        let boundaries: Vec<String> = raw
            .physical_names
            .iter()
            .filter(|(d, _, _)| *d == below)
            .map(|(_, _, n)| format!("\"{n}\""))
            .collect();
        let of_body = raw
            .physical_names
            .iter()
            .any(|(d, _, n)| *d == dimension && n == name);
        let what = if dimension == 2 { "lines" } else { "surfaces" };
        let message = if of_body {
            format!(
                "physical group \"{name}\" is of dimension {dimension}, a region of the body; a \
                 boundary region needs a group of {what} (dimension {below}){}",
                listed(&boundaries)
            )
        } else {
            let known = if boundaries.is_empty() {
                format!("; the mesh names no group of {what}")
            } else {
                listed(&boundaries)
            };
            format!("no physical group \"{name}\" of {what} (dimension {below}){known}")
        };
        return Err(fail("$PhysicalNames", message));
    }
    let tagged = |entity: u32| {
        raw.entities
            .get(entity as usize)
            .is_some_and(|p| p.iter().any(|t| tags.contains(t)))
    };
    let node = |n: u32| raw.nodes[n as usize];
    let mut facets = Vec::new();
    if dimension == 2 {
        for (ends, entity) in &raw.lines {
            if tagged(*entity) {
                facets.push(Facet::Segment([node(ends[0]), node(ends[1])]));
            }
        }
    } else {
        for e in raw.elements.iter().filter(|e| e.kind.dimension() == 2) {
            if tagged(e.entity) {
                let c = e.nodes.map(node);
                facets.push(Facet::Triangle([c[0], c[1], c[2]]));
                if e.kind.nodes() == 4 {
                    facets.push(Facet::Triangle([c[0], c[2], c[3]]));
                }
            }
        }
    }
    if facets.is_empty() {
        return Err(fail(
            "$Elements",
            format!("the physical group \"{name}\" holds no element; mesh it with the body"),
        ));
    }
    Ok(BoundaryFacets {
        file: file.to_string(),
        physical: name.to_string(),
        facets,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_to_segments_and_triangles() {
        let segment = Facet::Segment([DVec3::ZERO, DVec3::X]);
        assert_eq!(segment.distance(DVec3::new(0.5, 0.3, 0.0)), 0.3);
        assert_eq!(segment.distance(DVec3::new(2.0, 0.0, 0.0)), 1.0);
        let triangle = Facet::Triangle([DVec3::ZERO, DVec3::X, DVec3::Y]);
        // Above the face, beyond an edge, beyond a vertex.
        assert_eq!(triangle.distance(DVec3::new(0.2, 0.2, 0.5)), 0.5);
        assert!((triangle.distance(DVec3::new(1.0, 1.0, 0.0)) - 0.5f64.sqrt()).abs() < 1e-15);
        assert_eq!(triangle.distance(DVec3::new(-3.0, -4.0, 0.0)), 5.0);
        assert_eq!(triangle.distance(DVec3::new(0.5, -2.0, 0.0)), 2.0);
        assert_eq!(triangle.bounds(), (DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0)));
    }
}
