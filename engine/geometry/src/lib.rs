//! # fractum-geometry
//!
//! The geometry a Fractum scene fills its bodies from, as plain values with no ECS: analytic
//! shapes and their booleans ([`shape`]), closed triangulated surfaces from STL and OBJ files
//! ([`surface`]), finite-element meshes from Gmsh and GiD files ([`mesh`]), point sets from CSV
//! and VTU files ([`points`]) and voxel images from PNG and TIFF files ([`image`]). Every
//! reader reports what is wrong with a file and where in it ([`FileError`]); the scene crate
//! turns that into an error at the scene's field.

mod file_error;
pub mod image;
pub mod mesh;
mod orient;
pub mod points;
pub mod shape;
pub mod surface;
pub mod vtk;

pub use file_error::FileError;
pub use shape::Shape;
