//! The scene format's shapes: primitives of either dimension, shapes read from files
//! (surfaces, meshes, point sets, images with their phases), and booleans of shapes.

use super::{Axis, Coords};
use crate::mesh::MeshSeeding;
use serde::Deserialize;

/// Geometric shapes a body (or an initial crack) can take: Rectangle, Disk and Polygon in 2D
/// scenes, Box, Sphere, Cylinder and Prism in 3D scenes, and their unions, intersections and
/// differences in either.
#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum ShapeSpec {
    /// 2D: axis-aligned rectangle.
    Rectangle {
        /// Lower corner.
        min: Coords,
        /// Upper corner.
        max: Coords,
    },
    /// 2D: disk.
    Disk {
        /// Centre.
        center: Coords,
        /// Radius.
        radius: f64,
    },
    /// 2D: simple polygon (vertices in order, either orientation).
    Polygon {
        /// Vertices.
        vertices: Vec<Coords>,
    },
    /// 3D: axis-aligned box.
    Box {
        /// Lower corner.
        min: Coords,
        /// Upper corner.
        max: Coords,
    },
    /// 3D: sphere.
    Sphere {
        /// Centre.
        center: Coords,
        /// Radius.
        radius: f64,
    },
    /// 3D: circular cylinder along a coordinate axis.
    Cylinder {
        /// Centre (the midpoint of the axis).
        center: Coords,
        /// Direction of the axis.
        axis: Axis,
        /// Radius.
        radius: f64,
        /// Length along the axis.
        length: f64,
    },
    /// 3D: a polygon extruded along a coordinate axis.
    Prism {
        /// Vertices in the plane across the axis, as the two other coordinates in x, y, z
        /// order: `(y, z)` for axis X, `(x, z)` for Y, `(x, y)` for Z.
        vertices: Vec<Coords>,
        /// Direction of extrusion.
        axis: Axis,
        /// Coordinate along the axis where the prism starts.
        min: f64,
        /// Coordinate along the axis where it ends.
        max: f64,
    },
    /// 3D: the inside of a closed triangle surface in an STL (ASCII or binary) or OBJ file,
    /// its path relative to the scene file: `Surface("parts/anvil.stl")`.
    Surface(String),
    /// 2D or 3D: the elements of a Gmsh MSH 4.1 (ASCII or binary) or GiD ASCII mesh, its path
    /// relative to the scene file: `Mesh(file: "geometry/rock.msh", physical: "rock", seeding:
    /// Elements)`.
    Mesh {
        /// The mesh file.
        file: String,
        /// The physical group (Gmsh `$PhysicalNames`) whose elements make the shape; all the
        /// elements of the mesh's highest dimension when left out.
        #[serde(default)]
        physical: Option<String>,
        /// `Grid` (default): the per-cell rule every shape uses. `Elements`: each element's
        /// quadrature points with their exact volumes.
        #[serde(default)]
        seeding: MeshSeeding,
    },
    /// 2D or 3D: the particles of a CSV file, one per row with its position and volume (and
    /// optionally its velocity, damage and material), its path relative to the scene file:
    /// `Points("geometry/rock.csv")`.
    Points(String),
    /// 2D or 3D: the voxels of a greyscale image whose grey values fall in the phases'
    /// windows: a PNG or TIFF picture (2D), or a stack (3D) as a multi-page TIFF or numbered
    /// slices (`"ct/rock_###.png"`, a run of `#` for the zero-padded slice number), its path
    /// relative to the scene file. Columns run along x, rows along y (the top row highest),
    /// slices along z, from `origin`.
    Image {
        /// The picture, the multi-page TIFF, or the numbered slices' pattern.
        file: String,
        /// The width of a voxel along x and y (and z, unless `slice_spacing` says otherwise).
        voxel_size: f64,
        /// The distance between slices of a stack, when it differs from `voxel_size`.
        #[serde(default)]
        slice_spacing: Option<f64>,
        /// The outer corner of the bottom-left voxel of the first slice (the origin when left
        /// out).
        #[serde(default)]
        origin: Option<Coords>,
        /// Grey windows, each a phase of the body: `[(grey_min: 0, grey_max: 90), ..]`.
        phases: Vec<PhaseSpec>,
    },
    /// Every point of any of the shapes (at least two, of the scene's dimension):
    /// `Union([Rectangle(..), Disk(..)])`.
    Union(Vec<ShapeSpec>),
    /// The points common to all the shapes (at least two): `Intersection([Box(..), Sphere(..)])`.
    Intersection(Vec<ShapeSpec>),
    /// The points of the first shape outside the second: `Difference(Rectangle(..), Disk(..))`,
    /// a plate with a hole.
    Difference(Box<ShapeSpec>, Box<ShapeSpec>),
}

/// A phase of an image: the voxels whose grey value lies in `[grey_min, grey_max]` (the file's
/// raw sample values, 0 to 255 for an 8-bit image).
#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PhaseSpec {
    /// The lowest grey value of the phase.
    pub grey_min: f64,
    /// The highest grey value of the phase (included).
    pub grey_max: f64,
    /// The material of the phase's particles (the body's when left out).
    #[serde(default)]
    pub material: Option<String>,
}
