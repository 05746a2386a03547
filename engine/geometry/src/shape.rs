//! Shapes of bodies and initial cracks, as checked values: membership and bounding boxes.
//!
//! 2D shapes (rectangle, disk, polygon) look at x and y; 3D shapes (box, sphere, cylinder,
//! prism) at x, y and z; unions, intersections and differences combine shapes of one dimension. Points are given with three coordinates (z = 0 in 2D); which shapes a
//! scene may use is checked against its dimension when the scene is built.

use glam::{DVec2, DVec3};

/// A region of space a body fills.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// 2D: axis-aligned rectangle (boundary included).
    Rectangle {
        /// Lower corner.
        min: DVec2,
        /// Upper corner.
        max: DVec2,
    },
    /// 2D: disk (boundary included).
    Disk {
        /// Centre.
        center: DVec2,
        /// Radius.
        radius: f64,
    },
    /// 2D: simple polygon (even-odd rule).
    Polygon {
        /// Vertices in order.
        vertices: Vec<DVec2>,
    },
    /// 3D: axis-aligned box (boundary included).
    Box {
        /// Lower corner.
        min: DVec3,
        /// Upper corner.
        max: DVec3,
    },
    /// 3D: sphere (boundary included).
    Sphere {
        /// Centre.
        center: DVec3,
        /// Radius.
        radius: f64,
    },
    /// 3D: circular cylinder along a coordinate axis (boundary included).
    Cylinder {
        /// Midpoint of the axis.
        center: DVec3,
        /// Axis index (0, 1, 2).
        axis: usize,
        /// Radius.
        radius: f64,
        /// Length along the axis.
        length: f64,
    },
    /// 3D: polygon across a coordinate axis, extruded from `min` to `max` along it.
    Prism {
        /// Vertices, as the two other coordinates in x, y, z order.
        vertices: Vec<DVec2>,
        /// Axis index (0, 1, 2).
        axis: usize,
        /// Start along the axis.
        min: f64,
        /// End along the axis.
        max: f64,
    },
    /// 3D: the inside of a closed triangle surface read from an STL or OBJ file.
    Surface(std::sync::Arc<super::surface::Surface>),
    /// 2D or 3D: the elements of a mesh read from a Gmsh or GiD file, with how a body made of
    /// it is seeded.
    Mesh(std::sync::Arc<super::mesh::Mesh>),
    /// 2D or 3D: particles read from a file, each with its own volume. A point set bounds no
    /// region: no point is inside it.
    Points(std::sync::Arc<super::points::PointSet>),
    /// 2D or 3D: the voxels of a picture or a stack whose grey values fall in the phases'
    /// windows, each voxel with its phase.
    Image(std::sync::Arc<super::image::VoxelImage>),
    /// Every point of any of the shapes.
    Union(Vec<Shape>),
    /// The points common to all the shapes.
    Intersection(Vec<Shape>),
    /// The points of the first shape outside the second (the second's boundary removed too).
    Difference(Box<Shape>, Box<Shape>),
}

/// The two coordinates across `axis`, in x, y, z order.
fn across(x: DVec3, axis: usize) -> DVec2 {
    match axis {
        0 => DVec2::new(x.y, x.z),
        1 => DVec2::new(x.x, x.z),
        _ => DVec2::new(x.x, x.y),
    }
}

/// The point with `along` on `axis` and `plane` on the two others.
fn compose(axis: usize, along: f64, plane: DVec2) -> DVec3 {
    match axis {
        0 => DVec3::new(along, plane.x, plane.y),
        1 => DVec3::new(plane.x, along, plane.y),
        _ => DVec3::new(plane.x, plane.y, along),
    }
}

/// Even-odd rule.
fn in_polygon(vertices: &[DVec2], x: DVec2) -> bool {
    let mut inside = false;
    let n = vertices.len();
    for k in 0..n {
        let (a, b) = (vertices[k], vertices[(k + 1) % n]);
        if (a.y > x.y) != (b.y > x.y) {
            let crossing = a.x + (x.y - a.y) * (b.x - a.x) / (b.y - a.y);
            if x.x < crossing {
                inside = !inside;
            }
        }
    }
    inside
}

/// Whether the closed polygon through `vertices` is simple: no two edges that are not
/// neighbours meet, and no two neighbours fold back onto each other. The even-odd rule of
/// [`in_polygon`] would fill a figure eight or a bow tie in a way no one drew.
fn is_simple(vertices: &[DVec2]) -> bool {
    let n = vertices.len();
    let edge = |i: usize| (vertices[i], vertices[(i + 1) % n]);
    let orient = |a: DVec2, b: DVec2, c: DVec2| (b - a).perp_dot(c - a);
    let on_segment = |a: DVec2, b: DVec2, c: DVec2| {
        c.x >= a.x.min(b.x) && c.x <= a.x.max(b.x) && c.y >= a.y.min(b.y) && c.y <= a.y.max(b.y)
    };
    let meet = |(a, b): (DVec2, DVec2), (c, d): (DVec2, DVec2)| {
        let (o1, o2, o3, o4) = (
            orient(a, b, c),
            orient(a, b, d),
            orient(c, d, a),
            orient(c, d, b),
        );
        if o1 * o2 < 0.0 && o3 * o4 < 0.0 {
            return true;
        }
        (o1 == 0.0 && on_segment(a, b, c))
            || (o2 == 0.0 && on_segment(a, b, d))
            || (o3 == 0.0 && on_segment(c, d, a))
            || (o4 == 0.0 && on_segment(c, d, b))
    };
    for i in 0..n {
        let (a, b) = edge(i);
        if a == b {
            return false;
        }
        // The next edge shares vertex b: it may only meet this one there, so it must not turn
        // straight back along it.
        let (_, c) = edge((i + 1) % n);
        if orient(a, b, c) == 0.0 && (c - b).dot(a - b) > 0.0 {
            return false;
        }
        for j in i + 2..n {
            if i == 0 && j == n - 1 {
                continue;
            }
            if meet(edge(i), edge(j)) {
                return false;
            }
        }
    }
    true
}

fn polygon_bounds(vertices: &[DVec2]) -> (DVec2, DVec2) {
    vertices.iter().fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(lo, hi), v| (lo.min(*v), hi.max(*v)),
    )
}

impl Shape {
    /// The number of space dimensions of the scene the shape belongs to: 2 or 3.
    pub fn dimension(&self) -> usize {
        match self {
            Shape::Rectangle { .. } | Shape::Disk { .. } | Shape::Polygon { .. } => 2,
            Shape::Union(shapes) | Shape::Intersection(shapes) => {
                shapes.first().map_or(2, |first| first.dimension())
            }
            Shape::Difference(base, _) => base.dimension(),
            Shape::Mesh(mesh) if mesh.dimension() == 2 => 2,
            Shape::Points(points) if points.dimension() == 2 => 2,
            Shape::Image(image) if image.dimension() == 2 => 2,
            _ => 3,
        }
    }

    /// Whether the shape places its own particles instead of the grid's lattice: a mesh seeded
    /// by `Elements`, alone or as the first operand of an intersection or difference (whose
    /// other operands then only remove particles).
    pub fn seeds_itself(&self) -> bool {
        match self {
            Shape::Mesh(mesh) => mesh.seeding == super::mesh::MeshSeeding::Elements,
            Shape::Points(_) | Shape::Image(_) => true,
            Shape::Intersection(shapes) => shapes.first().is_some_and(Shape::seeds_itself),
            Shape::Difference(base, _) => base.seeds_itself(),
            _ => false,
        }
    }

    /// The path below the shape's own field of a point set, or of a mesh's `seeding:
    /// Elements`, that is not where [`Self::seeds_itself`] looks for one (inside a union, or
    /// as a later operand), if any: its particles would be silently ignored. An image inside a
    /// union counts too (its voxels would give way to the grid's lattice); as a later operand
    /// of an intersection or difference it only crops, by its voxels.
    pub fn misplaced_element_seeding(&self) -> Option<String> {
        let elements = |s: &Shape| match s {
            Shape::Mesh(mesh) if mesh.seeding == super::mesh::MeshSeeding::Elements => {
                Some(".seeding")
            }
            Shape::Points(_) => Some(""),
            _ => None,
        };
        fn find(s: &Shape, elements: &dyn Fn(&Shape) -> Option<&'static str>) -> Option<String> {
            if let Some(field) = elements(s) {
                return Some(field.to_string());
            }
            s.operands()
                .into_iter()
                .enumerate()
                .find_map(|(k, o)| find(o, elements).map(|p| format!("{}{p}", s.operand_path(k))))
        }
        match self {
            Shape::Intersection(_) | Shape::Difference(..) => {
                let operands = self.operands();
                if let Some(p) = operands[0].misplaced_element_seeding() {
                    return Some(format!("{}{p}", self.operand_path(0)));
                }
                operands[1..].iter().enumerate().find_map(|(k, o)| {
                    find(o, &elements).map(|p| format!("{}{p}", self.operand_path(k + 1)))
                })
            }
            Shape::Union(_) => find(self, &|s: &Shape| match s {
                Shape::Image(_) => Some(""),
                _ => elements(s),
            }),
            _ => None,
        }
    }

    /// The particles of a shape that [seeds itself](Self::seeds_itself): the mesh's
    /// quadrature points of `order`, a point file's particles, or an image's voxels each
    /// seeded by the tensor-product rule `voxel_rule` (see [`VoxelImage::particles`]), less
    /// those outside the intersection's other operands or inside the difference's removed
    /// shape. Empty for other shapes or orders.
    ///
    /// [`VoxelImage::particles`]: super::image::VoxelImage::particles
    pub fn own_particles(&self, order: u32, voxel_rule: &[(f64, f64)]) -> Vec<(DVec3, f64)> {
        match self {
            Shape::Mesh(mesh) if self.seeds_itself() => {
                mesh.quadrature_points(order).unwrap_or_default()
            }
            Shape::Points(points) => points.particles(),
            Shape::Image(image) => image.particles(voxel_rule),
            Shape::Intersection(shapes) if self.seeds_itself() => {
                let mut points = shapes[0].own_particles(order, voxel_rule);
                points.retain(|p| shapes[1..].iter().all(|s| s.contains(p.0)));
                points
            }
            Shape::Difference(base, removed) if self.seeds_itself() => {
                let mut points = base.own_particles(order, voxel_rule);
                points.retain(|p| !removed.contains(p.0));
                points
            }
            _ => Vec::new(),
        }
    }

    /// At most how many particles a shape that places its own seeds with `per_direction`
    /// points per direction, where its own particles are not bounded by its box's cells: a
    /// point file's rows, an image's voxels in a phase times the points of each. `None` for
    /// other shapes.
    pub fn own_particle_bound(&self, per_direction: u32) -> Option<f64> {
        if let Some(set) = self.point_set() {
            return Some(set.len() as f64);
        }
        let image = self.image()?;
        let voxels = image.voxel_counts().iter().sum::<usize>() as f64;
        Some(voxels * f64::from(per_direction).powi(image.dimension() as i32))
    }

    /// The point set whose particles the shape places, if it places a file's: alone, or as
    /// the first operand of an intersection or difference.
    pub fn point_set(&self) -> Option<&super::points::PointSet> {
        match self {
            Shape::Points(points) => Some(points),
            Shape::Intersection(shapes) => shapes.first().and_then(Shape::point_set),
            Shape::Difference(base, _) => base.point_set(),
            _ => None,
        }
    }

    /// The image whose voxels the shape seeds, if it seeds an image's: alone, or as the first
    /// operand of an intersection or difference.
    pub fn image(&self) -> Option<&super::image::VoxelImage> {
        match self {
            Shape::Image(image) => Some(image),
            Shape::Intersection(shapes) => shapes.first().and_then(Shape::image),
            Shape::Difference(base, _) => base.image(),
            _ => None,
        }
    }

    /// Where [`Self::image`]'s image sits below the shape's own field: empty for the shape
    /// itself, `.0[0].0` for an intersection's first operand that is a difference, …
    pub fn image_path(&self) -> String {
        match self {
            Shape::Intersection(shapes) => format!(".0[0]{}", shapes[0].image_path()),
            Shape::Difference(base, _) => format!(".0{}", base.image_path()),
            _ => String::new(),
        }
    }

    /// Whether a point set is anywhere in the shape.
    pub fn holds_points(&self) -> bool {
        matches!(self, Shape::Points(_)) || self.operands().iter().any(|s| s.holds_points())
    }

    /// Whether the shape is a union, intersection or difference of others.
    pub fn is_boolean(&self) -> bool {
        matches!(
            self,
            Shape::Union(_) | Shape::Intersection(_) | Shape::Difference(..)
        )
    }

    /// The shapes a boolean combines, in order; none for a primitive shape.
    pub fn operands(&self) -> Vec<&Shape> {
        match self {
            Shape::Union(shapes) | Shape::Intersection(shapes) => shapes.iter().collect(),
            Shape::Difference(base, removed) => vec![base, removed],
            _ => Vec::new(),
        }
    }

    /// Where operand `k` of a boolean sits below the shape's own field path, as errors name
    /// it: `.0[k]` for a union or intersection's list, `.k` for a difference's pair.
    pub fn operand_path(&self, k: usize) -> String {
        match self {
            Shape::Difference(..) => format!(".{k}"),
            _ => format!(".0[{k}]"),
        }
    }

    /// The variant's name, as a scene writes it.
    pub fn kind(&self) -> &'static str {
        match self {
            Shape::Rectangle { .. } => "Rectangle",
            Shape::Disk { .. } => "Disk",
            Shape::Polygon { .. } => "Polygon",
            Shape::Box { .. } => "Box",
            Shape::Sphere { .. } => "Sphere",
            Shape::Cylinder { .. } => "Cylinder",
            Shape::Prism { .. } => "Prism",
            Shape::Surface(_) => "Surface",
            Shape::Mesh(_) => "Mesh",
            Shape::Points(_) => "Points",
            Shape::Image(_) => "Image",
            Shape::Union(_) => "Union",
            Shape::Intersection(_) => "Intersection",
            Shape::Difference(..) => "Difference",
        }
    }

    /// `None` when the shape is well formed, else what was expected.
    pub fn problem(&self) -> Option<&'static str> {
        let positive = |r: f64| r.is_finite() && r > 0.0;
        let valid = match self {
            Shape::Rectangle { min, max } => {
                min.is_finite() && max.is_finite() && max.cmpgt(*min).all()
            }
            Shape::Box { min, max } => min.is_finite() && max.is_finite() && max.cmpgt(*min).all(),
            Shape::Disk { center, radius } => center.is_finite() && positive(*radius),
            Shape::Sphere { center, radius } => center.is_finite() && positive(*radius),
            Shape::Cylinder {
                center,
                axis,
                radius,
                length,
            } => center.is_finite() && *axis < 3 && positive(*radius) && positive(*length),
            Shape::Polygon { vertices } => {
                vertices.len() >= 3 && vertices.iter().all(|v| v.is_finite()) && is_simple(vertices)
            }
            Shape::Prism {
                vertices,
                axis,
                min,
                max,
            } => {
                vertices.len() >= 3
                    && vertices.iter().all(|v| v.is_finite())
                    && is_simple(vertices)
                    && *axis < 3
                    && min.is_finite()
                    && max.is_finite()
                    && max > min
            }
            // Checked closed and consistently oriented when read.
            Shape::Surface(_) => true,
            // Checked element by element when read.
            Shape::Mesh(_) => true,
            // Checked row by row when read.
            Shape::Points(_) => true,
            // Its phases are checked before it is read, and it is read only if it holds a
            // voxel of some phase.
            Shape::Image(_) => true,
            // Operands are checked one by one, each at its own field path.
            Shape::Union(shapes) | Shape::Intersection(shapes) => shapes.len() >= 2,
            Shape::Difference(..) => true,
        };
        (!valid).then_some(match self {
            Shape::Rectangle { .. } => "a rectangle with `max` above and to the right of `min`",
            Shape::Box { .. } => "a box with `max` above `min` along every axis",
            Shape::Disk { .. } => "a disk with a positive radius",
            Shape::Sphere { .. } => "a sphere with a positive radius",
            Shape::Cylinder { .. } => "a cylinder with a positive radius and length",
            Shape::Polygon { .. } => {
                "a polygon with at least 3 finite vertices whose edges do not cross or touch"
            }
            Shape::Prism { .. } => {
                "a prism with at least 3 finite vertices, edges that do not cross, and `max` \
                 above `min`"
            }
            Shape::Surface(_) => "a closed triangle surface",
            Shape::Mesh(_) => "a mesh of valid elements",
            Shape::Points(_) => "a set of particles",
            Shape::Image(_) => "an image with voxels in its phases",
            Shape::Union(_) => "a union of at least two shapes: `Union([shape, shape, ...])`",
            Shape::Intersection(_) => {
                "an intersection of at least two shapes: `Intersection([shape, shape, ...])`"
            }
            Shape::Difference(..) => "a difference of two shapes: `Difference(shape, shape)`",
        })
    }

    /// True when `x` (z = 0 for a 2D shape) lies inside the shape.
    pub fn contains(&self, x: DVec3) -> bool {
        match self {
            Shape::Rectangle { min, max } => {
                x.x >= min.x && x.x <= max.x && x.y >= min.y && x.y <= max.y
            }
            Shape::Disk { center, radius } => {
                (x.truncate() - *center).length_squared() <= radius * radius
            }
            Shape::Polygon { vertices } => in_polygon(vertices, x.truncate()),
            Shape::Box { min, max } => x.cmpge(*min).all() && x.cmple(*max).all(),
            Shape::Sphere { center, radius } => (x - *center).length_squared() <= radius * radius,
            Shape::Cylinder {
                center,
                axis,
                radius,
                length,
            } => {
                let along = (x[*axis] - center[*axis]).abs();
                let radial = across(x, *axis) - across(*center, *axis);
                along <= 0.5 * length && radial.length_squared() <= radius * radius
            }
            Shape::Prism {
                vertices,
                axis,
                min,
                max,
            } => x[*axis] >= *min && x[*axis] <= *max && in_polygon(vertices, across(x, *axis)),
            Shape::Surface(surface) => surface.contains(x),
            Shape::Mesh(mesh) => mesh.contains(x),
            Shape::Points(_) => false,
            Shape::Image(image) => image.contains(x),
            Shape::Union(shapes) => shapes.iter().any(|s| s.contains(x)),
            Shape::Intersection(shapes) => shapes.iter().all(|s| s.contains(x)),
            Shape::Difference(base, removed) => base.contains(x) && !removed.contains(x),
        }
    }

    /// Axis-aligned bounding box (z = 0 for 2D shapes).
    pub fn bounds(&self) -> (DVec3, DVec3) {
        match self {
            Shape::Rectangle { min, max } => (min.extend(0.0), max.extend(0.0)),
            Shape::Disk { center, radius } => (
                (*center - DVec2::splat(*radius)).extend(0.0),
                (*center + DVec2::splat(*radius)).extend(0.0),
            ),
            Shape::Polygon { vertices } => {
                let (lo, hi) = polygon_bounds(vertices);
                (lo.extend(0.0), hi.extend(0.0))
            }
            Shape::Box { min, max } => (*min, *max),
            Shape::Sphere { center, radius } => (
                *center - DVec3::splat(*radius),
                *center + DVec3::splat(*radius),
            ),
            Shape::Cylinder {
                center,
                axis,
                radius,
                length,
            } => {
                let half = compose(*axis, 0.5 * length, DVec2::splat(*radius));
                (*center - half, *center + half)
            }
            Shape::Prism {
                vertices,
                axis,
                min,
                max,
            } => {
                let (lo, hi) = polygon_bounds(vertices);
                (compose(*axis, *min, lo), compose(*axis, *max, hi))
            }
            Shape::Surface(surface) => surface.bounds(),
            Shape::Mesh(mesh) => mesh.bounds(),
            Shape::Points(points) => points.bounds(),
            Shape::Image(image) => image.bounds(),
            Shape::Union(shapes) => shapes.iter().map(Shape::bounds).fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo, hi), (a, b)| (lo.min(a), hi.max(b)),
            ),
            Shape::Intersection(shapes) => {
                let (lo, hi) = shapes.iter().map(Shape::bounds).fold(
                    (DVec3::splat(f64::NEG_INFINITY), DVec3::splat(f64::INFINITY)),
                    |(lo, hi), (a, b)| (lo.max(a), hi.min(b)),
                );
                // Shapes whose boxes do not meet share no point: an empty box at the corner.
                (lo, hi.max(lo))
            }
            Shape::Difference(base, _) => base.bounds(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polygon_and_disk_membership() {
        let triangle = Shape::Polygon {
            vertices: vec![DVec2::ZERO, DVec2::X, DVec2::Y],
        };
        assert!(triangle.contains(DVec3::new(0.2, 0.2, 0.0)));
        assert!(!triangle.contains(DVec3::new(0.6, 0.6, 0.0)));
        let disk = Shape::Disk {
            center: DVec2::splat(0.5),
            radius: 0.25,
        };
        assert!(disk.contains(DVec3::new(0.5, 0.74, 0.0)));
        assert!(!disk.contains(DVec3::new(0.3, 0.3, 0.0)));
        assert_eq!(disk.bounds().1, DVec3::new(0.75, 0.75, 0.0));
        assert_eq!(disk.dimension(), 2);
    }

    #[test]
    fn crossing_and_folded_polygons_are_not_simple() {
        let v = |p: &[(f64, f64)]| p.iter().map(|&(x, y)| DVec2::new(x, y)).collect::<Vec<_>>();
        assert!(is_simple(&v(&[
            (0.0, 0.0),
            (1.0, 0.0),
            (1.0, 1.0),
            (0.0, 1.0)
        ])));
        assert!(is_simple(&v(&[
            (0.0, 0.0),
            (2.0, 0.0),
            (1.0, 0.5),
            (2.0, 1.0),
            (0.0, 1.0)
        ])));
        // A bow tie, a vertex touching a far edge, a spike back along its edge, a repeated vertex.
        assert!(!is_simple(&v(&[
            (0.0, 0.0),
            (1.0, 1.0),
            (1.0, 0.0),
            (0.0, 1.0)
        ])));
        assert!(!is_simple(&v(&[
            (0.0, 0.0),
            (2.0, 0.0),
            (1.0, 0.0),
            (1.0, 1.0)
        ])));
        assert!(!is_simple(&v(&[
            (0.0, 0.0),
            (2.0, 0.0),
            (1.0, 0.0),
            (0.0, 1.0)
        ])));
        assert!(!is_simple(&v(&[
            (0.0, 0.0),
            (0.0, 0.0),
            (1.0, 0.0),
            (0.0, 1.0)
        ])));
    }

    #[test]
    fn three_dimensional_shapes() {
        let cylinder = Shape::Cylinder {
            center: DVec3::new(1.0, 1.0, 1.0),
            axis: 1,
            radius: 0.5,
            length: 2.0,
        };
        assert!(cylinder.contains(DVec3::new(1.4, 1.9, 1.2)));
        assert!(!cylinder.contains(DVec3::new(1.4, 2.1, 1.2)));
        assert!(!cylinder.contains(DVec3::new(1.4, 1.0, 1.4)));
        assert_eq!(
            cylinder.bounds(),
            (DVec3::new(0.5, 0.0, 0.5), DVec3::new(1.5, 2.0, 1.5))
        );
        // A notched beam section across z, 0.1 deep.
        let prism = Shape::Prism {
            vertices: vec![
                DVec2::new(0.0, 0.0),
                DVec2::new(0.4, 0.0),
                DVec2::new(0.4, 0.1),
                DVec2::new(0.0, 0.1),
            ],
            axis: 2,
            min: 0.0,
            max: 0.1,
        };
        assert!(prism.contains(DVec3::new(0.2, 0.05, 0.05)));
        assert!(!prism.contains(DVec3::new(0.2, 0.05, 0.15)));
        assert_eq!(prism.bounds().1, DVec3::new(0.4, 0.1, 0.1));
        // Across x the plane coordinates are (y, z).
        let across_x = Shape::Prism {
            vertices: vec![DVec2::ZERO, DVec2::new(1.0, 0.0), DVec2::new(0.0, 2.0)],
            axis: 0,
            min: -1.0,
            max: 1.0,
        };
        assert!(across_x.contains(DVec3::new(0.5, 0.2, 0.2)));
        assert!(!across_x.contains(DVec3::new(0.5, 0.2, 1.8)));
        let sphere = Shape::Sphere {
            center: DVec3::ZERO,
            radius: 1.0,
        };
        assert!(sphere.contains(DVec3::new(0.5, 0.5, 0.5)));
        assert!(!sphere.contains(DVec3::new(0.6, 0.6, 0.6)));
        assert_eq!(sphere.dimension(), 3);
        assert!(
            Shape::Box {
                min: DVec3::ONE,
                max: DVec3::ZERO
            }
            .problem()
            .is_some()
        );
    }
}
