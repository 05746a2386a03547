//! The validator's shapes: primitives of the scene's dimension, and shapes read from files
//! (surfaces, meshes, point sets, images) or made of other shapes, each checked against the
//! dimension with errors at the shape's field.

use super::Validator;
use crate::SceneError;
use crate::format::*;
use crate::image::{Phase, VoxelFrame, VoxelImage, phase_problem, read_image};
use crate::mesh::{
    BoundaryFacets, Facet, Mesh, MeshSeeding, RawMesh, boundary_facets, check_physical,
    read_raw_mesh,
};
use crate::points::read_points;
use crate::shape::Shape;
use crate::surface::{Surface, read_surface};
use fractum_engine::dim::{Dim, VectorOps};
use fractum_geometry::FileError;
use glam::{DVec2, DVec3};
use std::path::{Path, PathBuf};

impl<D: Dim> Validator<D> {
    fn shape(&self, field: &str, shape: &ShapeSpec) -> Result<Shape, SceneError> {
        let at = |f: &str| format!("{field}.{f}");
        let points2 = |vertices: &[Coords]| -> Result<Vec<DVec2>, SceneError> {
            vertices
                .iter()
                .enumerate()
                .map(|(k, v)| self.point2(&at(&format!("vertices[{k}]")), v))
                .collect()
        };
        Ok(match shape {
            ShapeSpec::Rectangle { min, max } => Shape::Rectangle {
                min: self.point2(&at("min"), min)?,
                max: self.point2(&at("max"), max)?,
            },
            ShapeSpec::Disk { center, radius } => Shape::Disk {
                center: self.point2(&at("center"), center)?,
                radius: *radius,
            },
            ShapeSpec::Polygon { vertices } => Shape::Polygon {
                vertices: points2(vertices)?,
            },
            ShapeSpec::Box { min, max } => Shape::Box {
                min: self.point3(&at("min"), min)?,
                max: self.point3(&at("max"), max)?,
            },
            ShapeSpec::Sphere { center, radius } => Shape::Sphere {
                center: self.point3(&at("center"), center)?,
                radius: *radius,
            },
            ShapeSpec::Cylinder {
                center,
                axis,
                radius,
                length,
            } => Shape::Cylinder {
                center: self.point3(&at("center"), center)?,
                axis: axis.index(),
                radius: *radius,
                length: *length,
            },
            ShapeSpec::Prism {
                vertices,
                axis,
                min,
                max,
            } => Shape::Prism {
                vertices: points2(vertices)?,
                axis: axis.index(),
                min: *min,
                max: *max,
            },
            // Read from files or made of other shapes.
            composed => self.composed(field, composed)?,
        })
    }

    /// A shape read from a file (a surface, a mesh, points, an image) or made of other shapes.
    fn composed(&self, field: &str, shape: &ShapeSpec) -> Result<Shape, SceneError> {
        let at = |f: &str| format!("{field}.{f}");
        Ok(match shape {
            ShapeSpec::Surface(file) => {
                Shape::Surface(std::sync::Arc::new(self.surface(field, file)?))
            }
            ShapeSpec::Mesh {
                file,
                physical,
                seeding,
            } => Shape::Mesh(std::sync::Arc::new(self.mesh(
                field,
                file,
                physical.as_deref(),
                *seeding,
            )?)),
            ShapeSpec::Points(file) => {
                let path = self.geometry_path(file);
                Shape::Points(std::sync::Arc::new(read_points(&path, file).map_err(
                    |e| {
                        self.error(
                            &format!("{field}.0"),
                            format!("points `{}`: {e}", path.display()),
                        )
                    },
                )?))
            }
            ShapeSpec::Image {
                file,
                voxel_size,
                slice_spacing,
                origin,
                phases,
            } => Shape::Image(std::sync::Arc::new(self.image(
                field,
                file,
                *voxel_size,
                *slice_spacing,
                origin.as_ref(),
                phases,
            )?)),
            ShapeSpec::Union(shapes) => Shape::Union(self.operands(field, shapes)?),
            ShapeSpec::Intersection(shapes) => Shape::Intersection(self.operands(field, shapes)?),
            ShapeSpec::Difference(base, removed) => Shape::Difference(
                Box::new(self.shape_of_dimension(&at("0"), base)?),
                Box::new(self.shape_of_dimension(&at("1"), removed)?),
            ),
            // `shape` reads the others, and hands only these here.
            primitive => self.shape(field, primitive)?,
        })
    }

    /// The image in `file`, read after its frame and phases are checked: errors about those
    /// point at their fields, errors in the file at `file`.
    fn image(
        &self,
        field: &str,
        file: &str,
        voxel_size: f64,
        slice_spacing: Option<f64>,
        origin: Option<&Coords>,
        phases: &[PhaseSpec],
    ) -> Result<VoxelImage, SceneError> {
        let at = |f: &str| format!("{field}.{f}");
        let positive = |value: f64, name: &str| {
            if value.is_finite() && value > 0.0 {
                Ok(value)
            } else {
                Err(self.error(
                    &at(name),
                    format!("`{name}` is {value}; expected a positive length"),
                ))
            }
        };
        let size = positive(voxel_size, "voxel_size")?;
        let depth = match slice_spacing {
            Some(s) => positive(s, "slice_spacing")?,
            None => size,
        };
        let origin = match origin {
            Some(coords) => {
                let v = self.vector(&at("origin"), coords)?.to_3d();
                if !v.iter().all(|c| c.is_finite()) {
                    return Err(self.error(&at("origin"), "expected finite coordinates"));
                }
                DVec3::from(v)
            }
            None => DVec3::ZERO,
        };
        let phases: Vec<Phase> = phases
            .iter()
            .map(|p| Phase {
                grey_min: p.grey_min,
                grey_max: p.grey_max,
                material: p.material.clone(),
            })
            .collect();
        if let Some((k, message)) = phase_problem(&phases) {
            return Err(self.error(&format!("{field}.phases[{k}]"), message));
        }
        let path = self.geometry_path(file);
        let frame = VoxelFrame {
            origin,
            spacing: DVec3::new(size, size, depth),
        };
        let image = read_image(&path, file, frame, &phases)
            .map_err(|e| self.error(&at("file"), format!("image `{}`: {e}", path.display())))?;
        if slice_spacing.is_some() && image.dimension() == 2 {
            return Err(self.error(
                &at("slice_spacing"),
                "a slice spacing is for stacks; this image is a single picture",
            ));
        }
        Ok(image)
    }

    /// Where a geometry file the scene names lies: relative paths from the scene file's folder.
    fn geometry_path(&self, file: &str) -> PathBuf {
        match Path::new(self.source.name()).parent() {
            Some(folder) if Path::new(file).is_relative() => folder.join(file),
            _ => PathBuf::from(file),
        }
    }

    /// The mesh in `file` as read, and how to word an error about its field `f` (below
    /// `field`): `mesh `path`: place: what`.
    fn raw_mesh(
        &self,
        field: &str,
        file: &str,
    ) -> Result<(RawMesh, impl Fn(&str, FileError) -> SceneError + '_), SceneError> {
        let path = self.geometry_path(file);
        let field = field.to_string();
        let at = move |f: &str, e: FileError| {
            self.error(
                &format!("{field}.{f}"),
                format!("mesh `{}`: {e}", path.display()),
            )
        };
        let raw = read_raw_mesh(&self.geometry_path(file)).map_err(|e| at("file", e))?;
        Ok((raw, at))
    }

    /// The region `physical` of the mesh in `file`, read and checked; errors about the group's
    /// name point at `physical`, others at `file`.
    fn mesh(
        &self,
        field: &str,
        file: &str,
        physical: Option<&str>,
        seeding: MeshSeeding,
    ) -> Result<Mesh, SceneError> {
        let (raw, at) = self.raw_mesh(field, file)?;
        if let Some(name) = physical {
            check_physical(&raw, name).map_err(|e| at("physical", e))?;
        }
        Mesh::from_raw(raw, file, physical, seeding).map_err(|e| at("file", e))
    }

    /// The boundary group `physical` of the mesh in `file`, for the region at `field`.
    pub(super) fn boundary_facets(
        &self,
        field: &str,
        file: &str,
        physical: &str,
    ) -> Result<BoundaryFacets, SceneError> {
        let (raw, at) = self.raw_mesh(field, file)?;
        let facets = boundary_facets(&raw, file, physical).map_err(|e| at("physical", e))?;
        let of_2d_mesh = matches!(facets.facets[0], Facet::Segment(_));
        if of_2d_mesh != (D::N == 2) {
            let mesh = if of_2d_mesh { "2D" } else { "3D" };
            return Err(self.error(
                &format!("{field}.file"),
                format!(
                    "a boundary of a {mesh} mesh in a {} scene; the mesh must be of the scene's \
                     dimension",
                    D::NAME
                ),
            ));
        }
        Ok(facets)
    }

    /// The surface in `file` (relative to the scene file's folder), read and checked.
    fn surface(&self, field: &str, file: &str) -> Result<Surface, SceneError> {
        let path = self.geometry_path(file);
        read_surface(&path, file).map_err(|e| {
            self.error(
                &format!("{field}.0"),
                format!("surface `{}`: {e}", path.display()),
            )
        })
    }

    /// The shapes a union or intersection at `field` combines (`field.0[k]`).
    fn operands(&self, field: &str, shapes: &[ShapeSpec]) -> Result<Vec<Shape>, SceneError> {
        shapes
            .iter()
            .enumerate()
            .map(|(k, shape)| self.shape_of_dimension(&format!("{field}.0[{k}]"), shape))
            .collect()
    }

    /// A shape of the scene's dimension; a shape of the other dimension is reported before its
    /// coordinates are looked at, since that is the real mistake.
    pub(super) fn shape_of_dimension(
        &self,
        field: &str,
        shape: &ShapeSpec,
    ) -> Result<Shape, SceneError> {
        // A boolean's dimension is its operands', each checked where it is written.
        let two = match shape {
            ShapeSpec::Rectangle { .. } | ShapeSpec::Disk { .. } | ShapeSpec::Polygon { .. } => {
                Some(true)
            }
            // A mesh's dimension is its elements', known once it is read.
            ShapeSpec::Union(_)
            | ShapeSpec::Intersection(_)
            | ShapeSpec::Difference(..)
            | ShapeSpec::Mesh { .. }
            | ShapeSpec::Points(_)
            | ShapeSpec::Image { .. } => None,
            _ => Some(false),
        };
        if two.is_some_and(|two| two != (D::N == 2)) {
            let (kind, allowed) = match D::N {
                2 => (
                    "a 3D shape",
                    "Rectangle, Disk, Polygon, Mesh (of triangles and quadrilaterals), Points, Image (a picture) and their Union, \
                     Intersection, Difference",
                ),
                _ => (
                    "a 2D shape",
                    "Box, Sphere, Cylinder, Prism, Surface, Mesh (of tetrahedra and hexahedra), Points, Image (a stack) and their \
                     Union, Intersection, Difference",
                ),
            };
            return Err(self.error(
                field,
                format!(
                    "{kind} in a {} scene; the scene's shapes are {allowed}",
                    D::NAME
                ),
            ));
        }
        self.shape(field, shape)
    }
}
