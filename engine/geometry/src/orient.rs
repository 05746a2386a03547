//! A triangle surface checked closed and manifold, and its facets oriented consistently.
//!
//! Exporters do not all keep the facets of a closed surface turning the same way (Gmsh's STL
//! export of a meshed volume is one that does not), and the inside test (ray parity) does not
//! need them to: orientation is repaired here rather than refused. Every edge must belong to
//! exactly two facets (closed and manifold); facets connected across edges are then turned to
//! run along each shared edge in opposite directions, breadth first from the first facet of
//! each connected piece, and each piece is finally turned to face outwards (positive enclosed
//! volume). What cannot be repaired is refused with the first bad facet or edge: a facet of no
//! area, an edge of one facet (a hole), an edge of three or more (not manifold).

use crate::file_error::{FileError, fail};
use glam::DVec3;
use std::collections::{HashMap, VecDeque};

/// A corner as the file wrote it: `(x, y, z)`, single-precision values (STL's) shown as such.
fn point(v: DVec3) -> String {
    let shown = |c: f64| {
        let single = c as f32;
        if f64::from(single) == c {
            format!("{single}")
        } else {
            format!("{c}")
        }
    };
    format!("({}, {}, {})", shown(v.x), shown(v.y), shown(v.z))
}

/// Checks `triangles` closed and manifold and turns facets so that every piece is consistently
/// oriented and faces outwards; returns how many facets were turned.
pub(crate) fn orient_closed_surface(triangles: &mut [[DVec3; 3]]) -> Result<usize, FileError> {
    let faces = vertex_ids(triangles)?;
    let edges = edge_facets(&faces, triangles)?;
    let mut turned = vec![false; faces.len()];
    let mut seen = vec![false; faces.len()];
    let mut count = 0;
    for start in 0..faces.len() {
        if seen[start] {
            continue;
        }
        let piece = orient_piece(start, &faces, &edges, &mut turned, &mut seen, triangles)?;
        // A piece turned inside out as a whole (all its facets one way, the wrong way) faces
        // outwards after this.
        let volume: f64 = piece
            .iter()
            .map(|&k| signed_volume(&triangles[k], turned[k]))
            .sum();
        if volume < 0.0 {
            for &k in &piece {
                turned[k] = !turned[k];
            }
        }
    }
    for (t, turn) in triangles.iter_mut().zip(&turned) {
        if *turn {
            t.swap(1, 2);
            count += 1;
        }
    }
    Ok(count)
}

/// Each facet's corners as vertex ids (equal coordinates, equal id); a facet of no area is
/// refused.
fn vertex_ids(triangles: &[[DVec3; 3]]) -> Result<Vec<[u32; 3]>, FileError> {
    let key = |v: DVec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
    let mut ids: HashMap<[u64; 3], u32> = HashMap::new();
    let mut faces = Vec::with_capacity(triangles.len());
    for (k, t) in triangles.iter().enumerate() {
        if (t[1] - t[0]).cross(t[2] - t[0]).length_squared() == 0.0 {
            return Err(fail(
                format!("facet {}", k + 1),
                format!(
                    "has no area (corners {}, {}, {}); remove degenerate facets",
                    point(t[0]),
                    point(t[1]),
                    point(t[2])
                ),
            ));
        }
        let mut f = [0u32; 3];
        for (corner, v) in t.iter().enumerate() {
            let next = ids.len() as u32;
            f[corner] = *ids.entry(key(*v)).or_insert(next);
        }
        faces.push(f);
    }
    Ok(faces)
}

/// The facets along each undirected edge, with whether each runs along it from its lower id;
/// an edge of one facet or of more than two is refused.
type EdgeFacets = HashMap<(u32, u32), Vec<(usize, bool)>>;

fn edge_facets(faces: &[[u32; 3]], triangles: &[[DVec3; 3]]) -> Result<EdgeFacets, FileError> {
    let mut edges: EdgeFacets = HashMap::new();
    for (k, f) in faces.iter().enumerate() {
        for (a, b) in sides(f) {
            edges
                .entry((a.min(b), a.max(b)))
                .or_default()
                .push((k, a < b));
        }
    }
    // In facet order, so the facet named is the first bad one.
    for (k, f) in faces.iter().enumerate() {
        for (corner, (a, b)) in sides(f).into_iter().enumerate() {
            let along = &edges[&(a.min(b), a.max(b))];
            let (va, vb) = (triangles[k][corner], triangles[k][(corner + 1) % 3]);
            if along.len() == 1 {
                return Err(fail(
                    format!("facet {}", k + 1),
                    format!(
                        "its edge from {} to {} belongs to no other facet: the surface is not \
                         closed",
                        point(va),
                        point(vb)
                    ),
                ));
            }
            if along.len() > 2 {
                return Err(fail(
                    format!("facet {}", k + 1),
                    format!(
                        "its edge from {} to {} belongs to {} facets: the surface is not \
                         manifold (each edge of a closed surface bounds exactly two)",
                        point(va),
                        point(vb),
                        along.len()
                    ),
                ));
            }
        }
    }
    Ok(edges)
}

fn sides(f: &[u32; 3]) -> [(u32, u32); 3] {
    [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])]
}

/// Turns the facets connected to `start` to agree with it (breadth first); the piece's facets.
fn orient_piece(
    start: usize,
    faces: &[[u32; 3]],
    edges: &EdgeFacets,
    turned: &mut [bool],
    seen: &mut [bool],
    triangles: &[[DVec3; 3]],
) -> Result<Vec<usize>, FileError> {
    let mut piece = vec![start];
    let mut queue = VecDeque::from([start]);
    seen[start] = true;
    while let Some(k) = queue.pop_front() {
        for (corner, (a, b)) in sides(&faces[k]).into_iter().enumerate() {
            // The direction facet k runs along the edge once turned as decided.
            let forward = (a < b) != turned[k];
            for &(j, j_forward) in &edges[&(a.min(b), a.max(b))] {
                if j == k {
                    continue;
                }
                // Neighbours must run along the shared edge the other way.
                let turn_j = j_forward == forward;
                if !seen[j] {
                    seen[j] = true;
                    turned[j] = turn_j;
                    piece.push(j);
                    queue.push_back(j);
                } else if turned[j] != turn_j {
                    return Err(fail(
                        format!("facet {}", j + 1),
                        format!(
                            "cannot be oriented consistently with its neighbours (the surface \
                             is not orientable, or it touches itself at the edge from {} to {})",
                            point(triangles[k][corner]),
                            point(triangles[k][(corner + 1) % 3])
                        ),
                    ));
                }
            }
        }
    }
    Ok(piece)
}

/// The facet's share of the enclosed volume (divergence theorem), turned if `turned`.
fn signed_volume(t: &[DVec3; 3], turned: bool) -> f64 {
    let v = t[0].dot(t[1].cross(t[2])) / 6.0;
    if turned { -v } else { v }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit cube's 12 facets, facing outwards.
    fn cube() -> Vec<[DVec3; 3]> {
        let c = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let quads = [
            [c(0., 0., 0.), c(0., 1., 0.), c(1., 1., 0.), c(1., 0., 0.)],
            [c(0., 0., 1.), c(1., 0., 1.), c(1., 1., 1.), c(0., 1., 1.)],
            [c(0., 0., 0.), c(1., 0., 0.), c(1., 0., 1.), c(0., 0., 1.)],
            [c(0., 1., 0.), c(0., 1., 1.), c(1., 1., 1.), c(1., 1., 0.)],
            [c(0., 0., 0.), c(0., 0., 1.), c(0., 1., 1.), c(0., 1., 0.)],
            [c(1., 0., 0.), c(1., 1., 0.), c(1., 1., 1.), c(1., 0., 1.)],
        ];
        quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .collect()
    }

    fn volume(triangles: &[[DVec3; 3]]) -> f64 {
        triangles.iter().map(|t| signed_volume(t, false)).sum()
    }

    #[test]
    fn an_outward_cube_is_left_as_it_is() {
        let mut triangles = cube();
        assert_eq!(orient_closed_surface(&mut triangles), Ok(0));
        assert_eq!(triangles, cube());
        assert!((volume(&triangles) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn facets_turned_the_wrong_way_are_turned_back() {
        let mut triangles = cube();
        for k in [0, 3, 7, 11] {
            triangles[k].swap(1, 2);
        }
        assert_eq!(orient_closed_surface(&mut triangles), Ok(4));
        assert_eq!(triangles, cube());
    }

    #[test]
    fn a_cube_inside_out_is_turned_to_face_outwards() {
        let mut triangles = cube();
        for t in &mut triangles {
            t.swap(0, 1);
        }
        assert_eq!(orient_closed_surface(&mut triangles), Ok(12));
        assert!((volume(&triangles) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn holes_and_shared_edges_are_refused() {
        let mut open = cube();
        open.pop();
        let e = orient_closed_surface(&mut open).unwrap_err();
        assert!(e.message.contains("not closed"), "{e}");
    }
}
