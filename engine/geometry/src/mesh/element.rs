//! The finite elements a mesh file may hold, as pure geometric kernels: shape functions,
//! quadrature points with their exact volumes, inside tests and orientation.
//!
//! Node orders are Gmsh's, which GiD shares: a quadrilateral's corners counter-clockwise from
//! (−1, −1); a hexahedron's bottom face (ζ = −1) then its top face, each like a quadrilateral.
//! Triangles and tetrahedra use area (volume) coordinates, the first node at the origin of the
//! reference element.

use glam::DVec3;

/// The kinds of element a body can be made of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ElementKind {
    /// 3-node triangle.
    Triangle,
    /// 4-node quadrilateral.
    Quadrilateral,
    /// 4-node tetrahedron.
    Tetrahedron,
    /// 8-node hexahedron.
    Hexahedron,
}

impl ElementKind {
    /// Number of nodes.
    pub fn nodes(self) -> usize {
        match self {
            ElementKind::Triangle => 3,
            ElementKind::Quadrilateral | ElementKind::Tetrahedron => 4,
            ElementKind::Hexahedron => 8,
        }
    }

    /// Dimension of the element: 2 or 3.
    pub fn dimension(self) -> usize {
        match self {
            ElementKind::Triangle | ElementKind::Quadrilateral => 2,
            ElementKind::Tetrahedron | ElementKind::Hexahedron => 3,
        }
    }

    /// The name used in messages.
    pub fn name(self) -> &'static str {
        match self {
            ElementKind::Triangle => "triangle",
            ElementKind::Quadrilateral => "quadrilateral",
            ElementKind::Tetrahedron => "tetrahedron",
            ElementKind::Hexahedron => "hexahedron",
        }
    }

    /// Points of the quadrature rule of `order` (1: one point; 2: three points in a triangle,
    /// four in a quadrilateral or tetrahedron, eight in a hexahedron) as reference
    /// coordinates and weights that sum to one. `None` for other orders.
    pub fn rule(self, order: u32) -> Option<Vec<(DVec3, f64)>> {
        let third = 1.0 / 3.0;
        Some(match (self, order) {
            (ElementKind::Triangle, 1) => vec![(DVec3::new(third, third, 0.0), 1.0)],
            (ElementKind::Triangle, 2) => [(1.0, 1.0), (4.0, 1.0), (1.0, 4.0)]
                .iter()
                .map(|&(a, b)| (DVec3::new(a / 6.0, b / 6.0, 0.0), third))
                .collect(),
            (ElementKind::Quadrilateral, 1) => vec![(DVec3::ZERO, 1.0)],
            (ElementKind::Hexahedron, 1) => vec![(DVec3::ZERO, 1.0)],
            (ElementKind::Quadrilateral, 2) => gauss_points(2, 0.25),
            (ElementKind::Hexahedron, 2) => gauss_points(3, 0.125),
            (ElementKind::Tetrahedron, 1) => vec![(DVec3::splat(0.25), 1.0)],
            (ElementKind::Tetrahedron, 2) => {
                let (a, b) = (0.585_410_196_624_968_5, 0.138_196_601_125_010_5);
                [
                    DVec3::new(b, b, b),
                    DVec3::new(a, b, b),
                    DVec3::new(b, a, b),
                    DVec3::new(b, b, a),
                ]
                .into_iter()
                .map(|x| (x, 0.25))
                .collect()
            }
            _ => return None,
        })
    }

    /// Shape functions at reference point `xi`, in node order (the first [`Self::nodes`]).
    pub fn shape_functions(self, xi: DVec3) -> [f64; 8] {
        let mut n = [0.0; 8];
        match self {
            ElementKind::Triangle => {
                n[0] = 1.0 - xi.x - xi.y;
                n[1] = xi.x;
                n[2] = xi.y;
            }
            ElementKind::Tetrahedron => {
                n[0] = 1.0 - xi.x - xi.y - xi.z;
                n[1] = xi.x;
                n[2] = xi.y;
                n[3] = xi.z;
            }
            ElementKind::Quadrilateral => {
                for (k, c) in QUAD_CORNERS.iter().enumerate() {
                    n[k] = 0.25 * (1.0 + c[0] * xi.x) * (1.0 + c[1] * xi.y);
                }
            }
            ElementKind::Hexahedron => {
                for (k, c) in HEX_CORNERS.iter().enumerate() {
                    n[k] = 0.125 * (1.0 + c[0] * xi.x) * (1.0 + c[1] * xi.y) * (1.0 + c[2] * xi.z);
                }
            }
        }
        n
    }
}

/// Reference corners of the quadrilateral, counter-clockwise.
const QUAD_CORNERS: [[f64; 2]; 4] = [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]];

/// Reference corners of the hexahedron: the bottom face, then the top.
const HEX_CORNERS: [[f64; 3]; 8] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
];

/// The hexahedron as six tetrahedra about its 0–6 diagonal.
const HEX_TETRAHEDRA: [[usize; 4]; 6] = [
    [0, 1, 2, 6],
    [0, 2, 3, 6],
    [0, 3, 7, 6],
    [0, 7, 4, 6],
    [0, 4, 5, 6],
    [0, 5, 1, 6],
];

/// The tensor-product two-point Gauss rule in `dimensions` directions, each weight `weight`.
fn gauss_points(dimensions: usize, weight: f64) -> Vec<(DVec3, f64)> {
    let g = 1.0 / 3f64.sqrt();
    let mut points = Vec::new();
    for k in 0..(1usize << dimensions) {
        let coordinate = |a: usize| {
            if a < dimensions && (k >> a) & 1 == 1 {
                g
            } else if a < dimensions {
                -g
            } else {
                0.0
            }
        };
        points.push((
            DVec3::new(coordinate(0), coordinate(1), coordinate(2)),
            weight,
        ));
    }
    points
}

/// Twice the signed area of the triangle (a, b, c) in the x-y plane, by the shoelace formula.
fn shoelace(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    a.y * (c.x - b.x) + b.y * (a.x - c.x) + c.y * (b.x - a.x)
}

/// Six times the signed volume of the tetrahedron (a, b, c, d).
fn tetrahedron_volume6(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    (b - a).dot((c - a).cross(d - a))
}

/// Jacobian determinant of the bilinear map at reference point `xi` (2D, in the x-y plane).
fn quad_jacobian(x: &[DVec3], xi: DVec3) -> f64 {
    let (mut dx, mut dy) = (DVec3::ZERO, DVec3::ZERO);
    for (k, c) in QUAD_CORNERS.iter().enumerate() {
        dx += x[k] * (0.25 * c[0] * (1.0 + c[1] * xi.y));
        dy += x[k] * (0.25 * c[1] * (1.0 + c[0] * xi.x));
    }
    dx.x * dy.y - dx.y * dy.x
}

/// Jacobian determinant of the trilinear map at reference point `xi`.
fn hex_jacobian(x: &[DVec3], xi: DVec3) -> f64 {
    let mut d = [DVec3::ZERO; 3];
    for (k, c) in HEX_CORNERS.iter().enumerate() {
        let f = [1.0 + c[0] * xi.x, 1.0 + c[1] * xi.y, 1.0 + c[2] * xi.z];
        d[0] += x[k] * (0.125 * c[0] * f[1] * f[2]);
        d[1] += x[k] * (0.125 * c[1] * f[0] * f[2]);
        d[2] += x[k] * (0.125 * c[2] * f[0] * f[1]);
    }
    d[0].dot(d[1].cross(d[2]))
}

/// The element's signed measure at reference point `xi`: twice the triangle's area, six times
/// the tetrahedron's volume, or the Jacobian determinant of a quadrilateral or hexahedron.
fn jacobian(kind: ElementKind, x: &[DVec3], xi: DVec3) -> f64 {
    match kind {
        ElementKind::Triangle => shoelace(x[0], x[1], x[2]),
        ElementKind::Tetrahedron => tetrahedron_volume6(x[0], x[1], x[2], x[3]),
        ElementKind::Quadrilateral => quad_jacobian(x, xi),
        ElementKind::Hexahedron => hex_jacobian(x, xi),
    }
}

/// The element's area (2D) or volume (3D), exact for straight-sided elements: the shoelace
/// formula for a triangle, the determinant for a tetrahedron, the two-point Gauss rule (exact
/// for the bilinear and trilinear maps' determinants) for quadrilaterals and hexahedra.
pub fn measure(kind: ElementKind, x: &[DVec3]) -> f64 {
    match kind {
        ElementKind::Triangle => 0.5 * shoelace(x[0], x[1], x[2]).abs(),
        ElementKind::Tetrahedron => tetrahedron_volume6(x[0], x[1], x[2], x[3]).abs() / 6.0,
        ElementKind::Quadrilateral => gauss_points(2, 1.0)
            .iter()
            .map(|&(xi, w)| w * quad_jacobian(x, xi))
            .sum::<f64>()
            .abs(),
        ElementKind::Hexahedron => gauss_points(3, 1.0)
            .iter()
            .map(|&(xi, w)| w * hex_jacobian(x, xi))
            .sum::<f64>()
            .abs(),
    }
}

/// The sign of the element's orientation (+1 or −1), or `None` when it is degenerate or
/// folded: a zero measure, or corners whose Jacobians disagree in sign (a bow-tie
/// quadrilateral, a hexahedron turned inside out at one corner).
pub fn orientation(kind: ElementKind, x: &[DVec3]) -> Option<f64> {
    let corners: Vec<DVec3> = match kind {
        ElementKind::Triangle | ElementKind::Tetrahedron => vec![DVec3::ZERO],
        ElementKind::Quadrilateral => QUAD_CORNERS
            .iter()
            .map(|c| DVec3::new(c[0], c[1], 0.0))
            .collect(),
        ElementKind::Hexahedron => HEX_CORNERS.iter().map(|c| DVec3::from(*c)).collect(),
    };
    let signs: Vec<f64> = corners.iter().map(|&xi| jacobian(kind, x, xi)).collect();
    if signs.iter().all(|&j| j > 0.0) {
        Some(1.0)
    } else if signs.iter().all(|&j| j < 0.0) {
        Some(-1.0)
    } else {
        None
    }
}

/// The quadrature points of the element with corners `x`: positions `Σ N_k(ξ) x_k`, summed
/// in node order, and volumes that add up to the element's [`measure`].
pub fn quadrature_points(
    kind: ElementKind,
    x: &[DVec3],
    rule: &[(DVec3, f64)],
) -> Vec<(DVec3, f64)> {
    let total = measure(kind, x);
    let exact_by_point =
        rule.len() > 1 && matches!(kind, ElementKind::Quadrilateral | ElementKind::Hexahedron);
    let reference = match kind {
        ElementKind::Quadrilateral => 4.0,
        ElementKind::Hexahedron => 8.0,
        _ => 1.0,
    };
    rule.iter()
        .map(|&(xi, w)| {
            let n = kind.shape_functions(xi);
            let position = (0..kind.nodes()).fold(DVec3::ZERO, |p, k| p + x[k] * n[k]);
            // A quadrilateral's or hexahedron's points carry their own Jacobian: a distorted
            // element's points differ in volume. Simplices have one Jacobian throughout.
            let volume = if exact_by_point {
                (w * reference * jacobian(kind, x, xi)).abs()
            } else {
                w * total
            };
            (position, volume)
        })
        .collect()
}

/// Whether `p` lies inside or on the element with corners `x` (2D elements in the x-y plane).
/// Quadrilaterals are their two triangles (exact: a plane quadrilateral's bilinear image is
/// its polygon); hexahedra are six tetrahedra, exact when their faces are plane.
pub fn contains(kind: ElementKind, x: &[DVec3], p: DVec3) -> bool {
    match kind {
        ElementKind::Triangle => in_triangle(x[0], x[1], x[2], p),
        ElementKind::Quadrilateral => {
            in_triangle(x[0], x[1], x[2], p) || in_triangle(x[0], x[2], x[3], p)
        }
        ElementKind::Tetrahedron => in_tetrahedron(x[0], x[1], x[2], x[3], p),
        ElementKind::Hexahedron => HEX_TETRAHEDRA
            .iter()
            .any(|t| in_tetrahedron(x[t[0]], x[t[1]], x[t[2]], x[t[3]], p)),
    }
}

/// Inside or on the triangle, whichever its orientation.
fn in_triangle(a: DVec3, b: DVec3, c: DVec3, p: DVec3) -> bool {
    let s = [shoelace(p, b, c), shoelace(a, p, c), shoelace(a, b, p)];
    s.iter().all(|&v| v >= 0.0) || s.iter().all(|&v| v <= 0.0)
}

/// Inside or on the tetrahedron, whichever its orientation.
fn in_tetrahedron(a: DVec3, b: DVec3, c: DVec3, d: DVec3, p: DVec3) -> bool {
    let s = [
        tetrahedron_volume6(p, b, c, d),
        tetrahedron_volume6(a, p, c, d),
        tetrahedron_volume6(a, b, p, d),
        tetrahedron_volume6(a, b, c, p),
    ];
    s.iter().all(|&v| v >= 0.0) || s.iter().all(|&v| v <= 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit(kind: ElementKind) -> Vec<DVec3> {
        match kind {
            ElementKind::Triangle => vec![DVec3::ZERO, DVec3::X, DVec3::Y],
            ElementKind::Tetrahedron => vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
            ElementKind::Quadrilateral => QUAD_CORNERS
                .iter()
                .map(|c| DVec3::new(c[0], c[1], 0.0))
                .collect(),
            ElementKind::Hexahedron => HEX_CORNERS.iter().map(|c| DVec3::from(*c)).collect(),
        }
    }

    #[test]
    fn rules_integrate_the_reference_measures() {
        let kinds = [
            (ElementKind::Triangle, 0.5),
            (ElementKind::Tetrahedron, 1.0 / 6.0),
            (ElementKind::Quadrilateral, 4.0),
            (ElementKind::Hexahedron, 8.0),
        ];
        for (kind, expected) in kinds {
            let x = unit(kind);
            // Round-off only: a few ulps from the Jacobians' sums of products.
            assert!(
                (measure(kind, &x) / expected - 1.0).abs() < 1e-14,
                "{kind:?}"
            );
            for order in [1, 2] {
                let rule = kind.rule(order).unwrap();
                let points = quadrature_points(kind, &x, &rule);
                let sum: f64 = points.iter().map(|p| p.1).sum();
                assert!(
                    (sum / expected - 1.0).abs() < 1e-14,
                    "{kind:?} order {order}"
                );
                // First moments: the centroid of the points is the element's.
                let centroid = points.iter().fold(DVec3::ZERO, |c, p| c + p.0 * p.1) / sum;
                let mean = x.iter().copied().sum::<DVec3>() / x.len() as f64;
                assert!((centroid - mean).length() < 1e-14, "{kind:?} order {order}");
            }
            assert!(kind.rule(3).is_none());
        }
    }

    #[test]
    fn distorted_quadrilateral_volumes_follow_their_jacobians() {
        let x = vec![
            DVec3::ZERO,
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(1.5, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
        ];
        // A trapezoid of area (2 + 1.5) / 2.
        assert!((measure(ElementKind::Quadrilateral, &x) - 1.75).abs() < 1e-15);
        let rule = ElementKind::Quadrilateral.rule(2).unwrap();
        let points = quadrature_points(ElementKind::Quadrilateral, &x, &rule);
        let (low, high) = (points[0].1, points[2].1);
        assert!(
            low > high,
            "the wide bottom's points weigh more: {low} vs {high}"
        );
    }

    #[test]
    fn inside_tests_include_the_boundary() {
        let tri = unit(ElementKind::Triangle);
        assert!(contains(
            ElementKind::Triangle,
            &tri,
            DVec3::new(0.5, 0.5, 0.0)
        ));
        assert!(!contains(
            ElementKind::Triangle,
            &tri,
            DVec3::new(0.6, 0.5, 0.0)
        ));
        let hex = unit(ElementKind::Hexahedron);
        assert!(contains(
            ElementKind::Hexahedron,
            &hex,
            DVec3::new(0.9, -0.9, 0.99)
        ));
        assert!(contains(ElementKind::Hexahedron, &hex, DVec3::ONE));
        assert!(!contains(
            ElementKind::Hexahedron,
            &hex,
            DVec3::new(1.01, 0.0, 0.0)
        ));
        let tet = unit(ElementKind::Tetrahedron);
        assert!(contains(ElementKind::Tetrahedron, &tet, DVec3::splat(0.3)));
        assert!(!contains(
            ElementKind::Tetrahedron,
            &tet,
            DVec3::splat(0.34)
        ));
    }

    #[test]
    fn orientation_finds_swapped_and_folded_elements() {
        let mut tri = unit(ElementKind::Triangle);
        assert_eq!(orientation(ElementKind::Triangle, &tri), Some(1.0));
        tri.swap(1, 2);
        assert_eq!(orientation(ElementKind::Triangle, &tri), Some(-1.0));
        let mut bow_tie = unit(ElementKind::Quadrilateral);
        bow_tie.swap(2, 3);
        assert_eq!(orientation(ElementKind::Quadrilateral, &bow_tie), None);
        let mut tet = unit(ElementKind::Tetrahedron);
        tet[3] = DVec3::new(0.5, 0.5, 0.0);
        assert_eq!(orientation(ElementKind::Tetrahedron, &tet), None);
    }
}
