//! Closed triangle surfaces read from STL (ASCII and binary) and Wavefront OBJ files, as a 3D
//! shape (`Surface("part.stl")`). The readers are small and in-house: both formats are a page
//! of specification, and reading them here adds no crate to the default build.
//!
//! A surface is checked when it is read: every edge must belong to exactly two facets (closed
//! and manifold), or the first bad edge or facet is named; facets that run the wrong way round
//! (as some exporters write them, Gmsh's STL among them) are turned to agree with their
//! neighbours (`orient.rs`). Membership is ray parity: a point is inside when a ray
//! from it along +z crosses the surface an odd number of times. The facets are binned by their
//! extent across z, so a point meets only the facets above and below its own bin (a column
//! sweep's cost, point by point). Crossings on a shared edge or vertex are counted once by a
//! tie rule on exact, direction-independent edge tests (the rasterisers' top-left rule), so a
//! ray through an edge neither misses the surface nor crosses it twice.

use glam::{DVec2, DVec3};
use std::path::Path;

use super::file_error::{FileError, fail};

/// A closed triangle surface, consistently oriented, and its index for inside tests.
#[derive(Clone, Debug)]
pub struct Surface {
    /// The file it was read from, as the scene names it.
    pub file: String,
    triangles: Vec<[DVec3; 3]>,
    lo: DVec3,
    hi: DVec3,
    bins: Bins,
}

impl PartialEq for Surface {
    fn eq(&self, other: &Self) -> bool {
        self.triangles == other.triangles
    }
}

/// Facets binned by their extent across z: a square grid over the surface's x-y box.
#[derive(Clone, Debug, Default)]
struct Bins {
    origin: DVec2,
    width: DVec2,
    count: [usize; 2],
    start: Vec<usize>,
    facets: Vec<u32>,
}

impl Bins {
    fn new(triangles: &[[DVec3; 3]], lo: DVec3, hi: DVec3) -> Self {
        let side = ((triangles.len() as f64).sqrt().ceil() as usize).clamp(1, 1024);
        let span = (hi - lo).truncate().max(DVec2::splat(f64::MIN_POSITIVE));
        let count = [side, side];
        let width = span / side as f64;
        let mut bins = Bins {
            origin: lo.truncate(),
            width,
            count,
            ..Bins::default()
        };
        let mut members: Vec<Vec<u32>> = vec![Vec::new(); side * side];
        for (k, t) in triangles.iter().enumerate() {
            let a = t[0].truncate().min(t[1].truncate()).min(t[2].truncate());
            let b = t[0].truncate().max(t[1].truncate()).max(t[2].truncate());
            let (i0, j0) = bins.cell(a);
            let (i1, j1) = bins.cell(b);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    members[j * side + i].push(k as u32);
                }
            }
        }
        bins.start.push(0);
        for m in members {
            bins.facets.extend(m);
            bins.start.push(bins.facets.len());
        }
        bins
    }

    fn cell(&self, p: DVec2) -> (usize, usize) {
        let at = |a: usize| {
            let f = ((p[a] - self.origin[a]) / self.width[a]).floor();
            (f.max(0.0) as usize).min(self.count[a] - 1)
        };
        (at(0), at(1))
    }

    fn facets_at(&self, p: DVec2) -> &[u32] {
        let (i, j) = self.cell(p);
        let k = j * self.count[0] + i;
        &self.facets[self.start[k]..self.start[k + 1]]
    }
}

/// Reads and checks the surface at `path` (`.stl` or `.obj`); `file` is how the scene names it.
pub fn read_surface(path: &Path, file: &str) -> Result<Surface, FileError> {
    let bytes = std::fs::read(path).map_err(|e| fail("", format!("cannot read it: {e}")))?;
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    let triangles = match extension.as_deref() {
        Some("stl") => parse_stl(&bytes)?,
        Some("obj") => parse_obj(&bytes)?,
        _ => {
            return Err(fail(
                "",
                "expected a .stl (ASCII or binary) or .obj file, by its extension",
            ));
        }
    };
    Surface::new(file, triangles)
}

impl Surface {
    /// A surface of `triangles`, checked closed and manifold, its facets turned where they
    /// disagree with their neighbours' orientation (`orient.rs`).
    pub fn new(file: &str, mut triangles: Vec<[DVec3; 3]>) -> Result<Self, FileError> {
        if triangles.len() < 4 {
            return Err(fail(
                "",
                format!(
                    "{} facets; a closed surface has at least 4",
                    triangles.len()
                ),
            ));
        }
        crate::orient::orient_closed_surface(&mut triangles)?;
        let (lo, hi) = triangles.iter().flatten().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), v| (lo.min(*v), hi.max(*v)),
        );
        let bins = Bins::new(&triangles, lo, hi);
        Ok(Self {
            file: file.to_string(),
            triangles,
            lo,
            hi,
            bins,
        })
    }

    /// The bounding box.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        (self.lo, self.hi)
    }

    /// The enclosed volume (divergence theorem over the facets).
    pub fn volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|[a, b, c]| a.dot(b.cross(*c)) / 6.0)
            .sum::<f64>()
            .abs()
    }

    /// Number of facets.
    pub fn facet_count(&self) -> usize {
        self.triangles.len()
    }

    /// Whether `x` is inside or on the surface.
    pub fn contains(&self, x: DVec3) -> bool {
        if x.cmplt(self.lo).any() || x.cmpgt(self.hi).any() {
            return false;
        }
        let mut above = 0usize;
        for &k in self.bins.facets_at(x.truncate()) {
            match crossing(&self.triangles[k as usize], x) {
                Crossing::Above => above += 1,
                Crossing::On => return true,
                Crossing::Miss => {}
            }
        }
        above % 2 == 1
    }
}

enum Crossing {
    Above,
    On,
    Miss,
}

/// `(b − a) × (p − a)` across z, computed with the endpoints in one fixed order so that the two
/// facets sharing an edge get exactly opposite values.
fn edge_test(a: DVec2, b: DVec2, p: DVec2) -> f64 {
    let (first, second, sign) = if (a.x, a.y) <= (b.x, b.y) {
        (a, b, 1.0)
    } else {
        (b, a, -1.0)
    };
    let d = second - first;
    sign * (d.x * (p.y - first.y) - d.y * (p.x - first.x))
}

/// Whether a point on the edge from `a` to `b` (of a counter-clockwise triangle) belongs to
/// this triangle: of the two directions of an edge exactly one owns it.
fn owns(a: DVec2, b: DVec2) -> bool {
    let d = b - a;
    d.y < 0.0 || (d.y == 0.0 && d.x < 0.0)
}

/// Where the vertical line through `x` meets the facet, relative to `x`.
fn crossing(t: &[DVec3; 3], x: DVec3) -> Crossing {
    let p = x.truncate();
    let (mut a, mut b, c) = (t[0], t[1], t[2]);
    let mut area = edge_test(a.truncate(), b.truncate(), c.truncate());
    if area == 0.0 {
        return Crossing::Miss;
    }
    if area < 0.0 {
        std::mem::swap(&mut a, &mut b);
        area = -area;
    }
    let (a2, b2, c2) = (a.truncate(), b.truncate(), c.truncate());
    let w = [
        (edge_test(b2, c2, p), b2, c2),
        (edge_test(c2, a2, p), c2, a2),
        (edge_test(a2, b2, p), a2, b2),
    ];
    for &(e, from, to) in &w {
        if e < 0.0 || (e == 0.0 && !owns(from, to)) {
            return Crossing::Miss;
        }
    }
    let z = (w[0].0 * a.z + w[1].0 * b.z + w[2].0 * c.z) / area;
    if z > x.z {
        Crossing::Above
    } else if z == x.z {
        Crossing::On
    } else {
        Crossing::Miss
    }
}

/// The facets of an STL file: binary when its length is that of its facet count, else ASCII.
fn parse_stl(bytes: &[u8]) -> Result<Vec<[DVec3; 3]>, FileError> {
    if bytes.len() >= 84 {
        let count = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        if bytes.len() == 84 + 50 * count {
            return parse_binary_stl(bytes, count);
        }
    }
    if !bytes.trim_ascii_start().starts_with(b"solid") {
        return Err(fail(
            "",
            format!(
                "neither a binary STL ({} bytes, not 84 + 50 per facet as its header counts) \
                 nor an ASCII one (starting with `solid`); a binary file may be truncated",
                bytes.len()
            ),
        ));
    }
    let text = std::str::from_utf8(bytes).map_err(|e| {
        fail(
            format!("byte {}", e.valid_up_to()),
            "an ASCII STL must be text",
        )
    })?;
    parse_ascii_stl(text)
}

fn parse_binary_stl(bytes: &[u8], count: usize) -> Result<Vec<[DVec3; 3]>, FileError> {
    let mut triangles = Vec::with_capacity(count);
    for k in 0..count {
        let at = 84 + 50 * k + 12;
        let corner = |c: usize| {
            let base = at + 12 * c;
            let f = |i: usize| {
                let o = base + 4 * i;
                f64::from(f32::from_le_bytes([
                    bytes[o],
                    bytes[o + 1],
                    bytes[o + 2],
                    bytes[o + 3],
                ]))
            };
            DVec3::new(f(0), f(1), f(2))
        };
        let t = [corner(0), corner(1), corner(2)];
        if !t.iter().all(|v| v.is_finite()) {
            return Err(fail(
                format!("byte {at}"),
                format!("facet {} has a coordinate that is not finite", k + 1),
            ));
        }
        triangles.push(t);
    }
    Ok(triangles)
}

fn parse_ascii_stl(text: &str) -> Result<Vec<[DVec3; 3]>, FileError> {
    let mut triangles = Vec::new();
    let mut corners: Vec<DVec3> = Vec::new();
    let mut ended = false;
    for (n, line) in text.lines().enumerate() {
        let place = || format!("line {}", n + 1);
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.first().copied() {
            Some("vertex") => {
                if words.len() != 4 {
                    return Err(fail(place(), "expected `vertex x y z`"));
                }
                let mut v = [0.0; 3];
                // STL holds single precision: ASCII values are read as such, so the ASCII and
                // binary forms of one mesh give the same facets.
                for (a, w) in words[1..].iter().enumerate() {
                    let value = w
                        .parse::<f32>()
                        .map_err(|_| fail(place(), format!("expected a number, found `{w}`")))?;
                    v[a] = f64::from(value);
                }
                if !v.iter().all(|c| c.is_finite()) {
                    return Err(fail(place(), "a vertex coordinate is not finite"));
                }
                corners.push(DVec3::from_array(v));
            }
            Some("endloop") => {
                if corners.len() != 3 {
                    return Err(fail(
                        place(),
                        format!(
                            "a facet has {} vertices; expected 3 (triangles only)",
                            corners.len()
                        ),
                    ));
                }
                triangles.push([corners[0], corners[1], corners[2]]);
                corners.clear();
            }
            Some("endsolid") => ended = true,
            Some("solid" | "facet" | "outer" | "endfacet") | None => {}
            Some(other) => {
                return Err(fail(
                    place(),
                    format!(
                        "unexpected `{other}`; expected solid, facet, outer loop, vertex, \
                         endloop, endfacet or endsolid"
                    ),
                ));
            }
        }
    }
    if !ended || !corners.is_empty() {
        return Err(fail(
            format!("line {}", text.lines().count()),
            "the file ends before `endsolid`: truncated?",
        ));
    }
    Ok(triangles)
}

/// The facets of an OBJ file: `v x y z` vertices and `f` faces (1-based or negative indices,
/// `i/t/n` forms); faces of more than three corners are fanned into triangles.
fn parse_obj(bytes: &[u8]) -> Result<Vec<[DVec3; 3]>, FileError> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        fail(
            format!("byte {}", e.valid_up_to()),
            "an OBJ file must be text",
        )
    })?;
    let mut vertices: Vec<DVec3> = Vec::new();
    let mut triangles = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let place = || format!("line {}", n + 1);
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.first().copied() {
            Some("v") => {
                if words.len() < 4 {
                    return Err(fail(place(), "expected `v x y z`"));
                }
                let mut v = [0.0; 3];
                for (a, w) in words[1..4].iter().enumerate() {
                    v[a] = w
                        .parse::<f64>()
                        .map_err(|_| fail(place(), format!("expected a number, found `{w}`")))?;
                }
                if !v.iter().all(|c| c.is_finite()) {
                    return Err(fail(place(), "a vertex coordinate is not finite"));
                }
                vertices.push(DVec3::from_array(v));
            }
            Some("f") => {
                if words.len() < 4 {
                    return Err(fail(place(), "a face needs at least 3 vertices"));
                }
                let mut corners = Vec::with_capacity(words.len() - 1);
                for w in &words[1..] {
                    let index = w.split('/').next().unwrap_or("");
                    let i: i64 = index.parse().map_err(|_| {
                        fail(place(), format!("expected a vertex index, found `{w}`"))
                    })?;
                    let resolved = if i > 0 {
                        i - 1
                    } else {
                        vertices.len() as i64 + i
                    };
                    let v = usize::try_from(resolved)
                        .ok()
                        .and_then(|r| vertices.get(r))
                        .ok_or_else(|| {
                            fail(
                                place(),
                                format!(
                                    "vertex {i} does not exist ({} vertices so far)",
                                    vertices.len()
                                ),
                            )
                        })?;
                    corners.push(*v);
                }
                for k in 1..corners.len() - 1 {
                    triangles.push([corners[0], corners[k], corners[k + 1]]);
                }
            }
            _ => {}
        }
    }
    Ok(triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit cube's 12 facets, outward.
    fn cube(lo: DVec3, hi: DVec3) -> Vec<[DVec3; 3]> {
        let v = |i: usize| {
            DVec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            )
        };
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        quads
            .iter()
            .flat_map(|q| [[v(q[0]), v(q[1]), v(q[2])], [v(q[0]), v(q[2]), v(q[3])]])
            .collect()
    }

    #[test]
    fn a_cube_holds_its_inside_and_its_volume() {
        let s = Surface::new("cube", cube(DVec3::ZERO, DVec3::ONE)).unwrap();
        assert!((s.volume() - 1.0).abs() < 1e-15);
        assert!(s.contains(DVec3::splat(0.5)));
        assert!(!s.contains(DVec3::new(0.5, 0.5, 1.5)));
        assert!(!s.contains(DVec3::new(1.5, 0.5, 0.5)));
        // On the diagonal of the top and bottom faces, where two facets meet: counted once.
        assert!(s.contains(DVec3::new(0.25, 0.25, 0.5)));
        assert!(s.contains(DVec3::new(0.7, 0.7, 0.5)));
    }

    #[test]
    fn a_lattice_in_a_cube_is_counted_exactly() {
        let s = Surface::new("cube", cube(DVec3::splat(0.1), DVec3::splat(0.9))).unwrap();
        // A lattice whose diagonal points lie on the edges shared by the top facets and by
        // the bottom ones: each ray is counted once at the top and once at the bottom.
        let mut inside = 0;
        for i in 0..20 {
            for j in 0..20 {
                let p = DVec3::new(0.025 + i as f64 * 0.05, 0.025 + j as f64 * 0.05, 0.5);
                if s.contains(p) {
                    inside += 1;
                }
            }
        }
        // 0.125 to 0.875: 16 × 16.
        assert_eq!(inside, 16 * 16);
    }

    #[test]
    fn an_open_or_flipped_surface_is_refused_naming_the_facet() {
        let mut open = cube(DVec3::ZERO, DVec3::ONE);
        open.pop();
        let e = Surface::new("open", open).unwrap_err();
        assert!(e.message.contains("not closed"), "{e}");
        let mut three = cube(DVec3::ZERO, DVec3::ONE);
        let extra = [three[0][0], three[0][1], DVec3::new(0.5, 0.5, 2.0)];
        three.push(extra);
        let e = Surface::new("three", three).unwrap_err();
        assert!(e.message.contains("not manifold"), "{e}");
        let mut flat = cube(DVec3::ZERO, DVec3::ONE);
        flat[0][2] = flat[0][1];
        assert!(
            Surface::new("flat", flat)
                .unwrap_err()
                .message
                .contains("no area")
        );
    }

    #[test]
    fn stl_and_obj_text_give_the_same_facets() {
        let ascii = "solid t\nfacet normal 0 0 -1\n outer loop\n  vertex 0 0 0\n  vertex 0 1 0\n  \
                     vertex 1 0 0\n endloop\nendfacet\nendsolid t\n";
        let stl = parse_stl(ascii.as_bytes()).unwrap();
        let obj = parse_obj(b"v 0 0 0\nv 0 1 0\nv 1 0 0\nf 1 2 3\n").unwrap();
        assert_eq!(stl, obj);
        let mut binary = vec![0u8; 80];
        binary.extend(1u32.to_le_bytes());
        binary.extend([0u8; 12]);
        for v in [[0f32, 0., 0.], [0., 1., 0.], [1., 0., 0.]] {
            for c in v {
                binary.extend(c.to_le_bytes());
            }
        }
        binary.extend([0u8; 2]);
        assert_eq!(parse_stl(&binary).unwrap(), stl);
        let cut = &ascii[..ascii.len() - 12];
        assert!(
            parse_stl(cut.as_bytes())
                .unwrap_err()
                .message
                .contains("truncated")
        );
        let e = parse_obj(b"v 0 0 0\nf 1 2 3\n").unwrap_err();
        assert_eq!(e.place, "line 2");
        let e = parse_stl(b"solid t\n vertex 0 nan 0\n").unwrap_err();
        assert_eq!(e.place, "line 2");
    }
}
