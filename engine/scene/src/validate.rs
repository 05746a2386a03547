//! From the file format to a [`Spec`]: coordinates, shapes, axes and components that fit the
//! scene's dimension, each error at its place in the file.
//!
//! Value checks that do not depend on the file (positive spacing, known materials, bodies
//! inside the grid, …) are `Spec::check`'s, so scenes built in code get them too.

use super::format::*;
use super::image::{Phase, VoxelFrame, VoxelImage, phase_problem, read_image};
use super::mesh::{
    BoundaryFacets, Facet, Mesh, MeshSeeding, RawMesh, boundary_facets, check_physical,
    read_raw_mesh,
};
use super::points::read_points;
use super::shape::Shape;
use super::spec::{Body, Boundary, Condition, InitialVelocity, Load, Output, PipelineEntry, Spec};
use super::surface::{Surface, read_surface};
use super::{SceneError, SceneFile, Source};
use fractum_engine::dim::{Dim, MatrixOps, VectorOps};
use fractum_engine::health::LeaveGrid;
use fractum_engine::resources::{Grid, Material};
use fractum_engine::simulation::{End, TimeStep};
use fractum_geometry::FileError;
use glam::{DVec2, DVec3};
use std::path::{Path, PathBuf};

impl<D: Dim> Spec<D> {
    /// Reads the spec of `file`, whose grid must be `D`-dimensional.
    pub fn from_file(file: &SceneFile) -> Result<Self, SceneError> {
        let reader = Reader::<D> {
            source: file.source(),
            dimension: std::marker::PhantomData,
        };
        reader.spec(&file.scene)
    }
}

struct Reader<D: Dim> {
    source: Source,
    dimension: std::marker::PhantomData<D>,
}

impl<D: Dim> Reader<D> {
    fn error(&self, field: &str, message: impl Into<String>) -> SceneError {
        self.source.error(field, message)
    }

    /// A vector of the scene's dimension.
    fn vector(&self, field: &str, coords: &Coords) -> Result<D::Vector, SceneError> {
        if coords.0.len() != D::N {
            return Err(self.error(field, self.count_message(coords.0.len())));
        }
        Ok(D::Vector::from_fn(|a| coords.0[a]))
    }

    fn count_message(&self, found: usize) -> String {
        format!(
            "expected {} coordinates ({}): the grid makes this a {} scene; found {found}",
            D::N,
            D::AXES.join(", "),
            D::NAME
        )
    }

    /// A point of a 2D shape (only in a 2D scene; the shape check reports a 3D scene).
    fn point2(&self, field: &str, coords: &Coords) -> Result<DVec2, SceneError> {
        match coords.0.as_slice() {
            [x, y] => Ok(DVec2::new(*x, *y)),
            _ => Err(self.error(
                field,
                format!("expected 2 coordinates (x, y), found {}", coords.0.len()),
            )),
        }
    }

    /// A point of a 3D shape.
    fn point3(&self, field: &str, coords: &Coords) -> Result<DVec3, SceneError> {
        match coords.0.as_slice() {
            [x, y, z] => Ok(DVec3::new(*x, *y, *z)),
            _ => Err(self.error(
                field,
                format!("expected 3 coordinates (x, y, z), found {}", coords.0.len()),
            )),
        }
    }

    fn axis(&self, field: &str, axis: Axis) -> Result<usize, SceneError> {
        let index = axis.index();
        if index >= D::N {
            return Err(self.error(
                field,
                format!(
                    "the scene is {}: its axes are {}",
                    D::NAME,
                    D::AXES.join(", ").to_uppercase()
                ),
            ));
        }
        Ok(index)
    }

    fn spec(&self, scene: &Scene) -> Result<Spec<D>, SceneError> {
        let grid = self.grid(&scene.grid)?;
        let thickness = match scene.thickness {
            Some(_) if D::N == 3 => {
                return Err(self.error(
                    "thickness",
                    "a thickness is for 2D scenes; a 3D body has its own depth",
                ));
            }
            Some(t) => t,
            None => 1.0,
        };
        let materials = scene
            .materials
            .iter()
            .map(|(name, m)| Material::new(name, m.density, m.youngs_modulus, m.poisson_ratio))
            .collect();
        let bodies = scene
            .bodies
            .iter()
            .enumerate()
            .map(|(b, body)| self.body(b, body))
            .collect::<Result<_, _>>()?;
        let boundaries = scene
            .boundaries
            .iter()
            .enumerate()
            .map(|(r, spec)| self.boundary(r, spec))
            .collect::<Result<_, _>>()?;
        let body_force = match &scene.body_force {
            Some(coords) => self.vector("body_force", coords)?,
            None => D::Vector::ZERO,
        };
        let pipeline = scene
            .pipeline
            .iter()
            .map(|entry| PipelineEntry {
                system: entry.system.clone(),
                params: entry
                    .params
                    .as_deref()
                    .map(|r| r.trim().get_ron().to_string()),
                materials: entry.materials.clone(),
                in_source: true,
            })
            .collect();
        Ok(Spec {
            source: self.source.clone(),
            title: scene.title.clone(),
            time_step: match scene.time.step {
                TimeStepSpec::Fixed(dt) => TimeStep::Fixed(dt),
                TimeStepSpec::Cfl(f) => TimeStep::Cfl(f),
            },
            end: match scene.time.end {
                EndSpec::Time(t) => End::Time(t),
                EndSpec::Steps(n) => End::Steps(n),
            },
            grid,
            thickness,
            materials,
            bodies,
            boundaries,
            body_force,
            output: Output {
                vtu_every: scene.output.vtu_every,
                grid_every: scene.output.grid_every,
                csv_every: scene.output.csv_every,
                probes: scene.output.probes.clone(),
                last_good_frame: scene.output.last_good_frame,
                compression: match scene.output.compression {
                    CompressionSpec::None => fractum_io::output::FrameCompression::None,
                    CompressionSpec::Zlib => fractum_io::output::FrameCompression::Zlib,
                },
                fields: scene.output.fields.clone(),
            },
            on_leave_grid: match scene.safety.on_leave_grid {
                LeaveGridSpec::Stop => LeaveGrid::Stop,
                LeaveGridSpec::Remove => LeaveGrid::Remove,
            },
            pipeline,
        })
    }

    fn grid(&self, g: &GridSpec) -> Result<Grid<D>, SceneError> {
        if !(g.spacing.is_finite() && g.spacing > 0.0) {
            return Err(self.error("grid.spacing", "expected a positive spacing"));
        }
        let min = self.vector("grid.min", &g.min)?;
        let max = self.vector("grid.max", &g.max)?;
        if !min.is_finite() {
            return Err(self.error("grid.min", "expected finite coordinates"));
        }
        if !(max.is_finite() && (0..D::N).all(|a| max[a] > min[a])) {
            return Err(self.error("grid.max", "expected a corner above `min` along every axis"));
        }
        let mut cells = D::Cell::default();
        for a in 0..D::N {
            let length = max[a] - min[a];
            let count = length / g.spacing;
            if (count - count.round()).abs() > 1e-6 * count.max(1.0) {
                return Err(self.error(
                    "grid.max",
                    format!(
                        "the box must hold a whole number of cells: {length} / {} = {count} along {}",
                        g.spacing,
                        D::AXES[a]
                    ),
                ));
            }
            if count.round() > MAX_CELLS {
                return Err(self.error("grid.spacing", too_many_cells(count.round())));
            }
            cells[a] = count.round() as usize;
        }
        // The cap is on the whole grid: 10^5 cells along each of two axes is 10^10 cells.
        let total: f64 = (0..D::N).map(|a| cells[a] as f64).product();
        if total > MAX_CELLS {
            return Err(self.error("grid.spacing", too_many_cells(total)));
        }
        if g.refine.is_empty() {
            return Ok(Grid {
                min,
                spacing: g.spacing,
                cells,
                graded: None,
                window: None,
            });
        }
        if let Some(k) = g.refine.iter().position(|r| r.axis.index() >= D::N) {
            return Err(self.error(
                &format!("grid.refine[{k}].axis"),
                "a 2D grid has only the axes X and Y",
            ));
        }
        let coordinates: Vec<Vec<f64>> = (0..D::N)
            .map(|a| self.graded_axis(g, a, min[a], max[a]))
            .collect::<Result<_, _>>()?;
        let total = coordinates
            .iter()
            .try_fold(1usize, |n, c| n.checked_mul(c.len() - 1));
        if total.is_none_or(|n| n as f64 > MAX_CELLS) {
            let cells: f64 = coordinates.iter().map(|c| (c.len() - 1) as f64).product();
            return Err(self.error("grid.refine", too_many_cells(cells)));
        }
        Grid::graded(coordinates)
            .ok_or_else(|| self.error("grid.refine", "the node coordinates must increase"))
    }

    /// Node coordinates along axis `a` of a grid with refinement intervals: uniform at the
    /// grid's spacing between intervals and at each interval's own spacing inside it.
    /// One `grid.refine` interval: a positive spacing and bounds inside the grid, in order.
    fn check_refine_interval(
        &self,
        k: usize,
        r: &RefineSpec,
        lo: f64,
        hi: f64,
    ) -> Result<(), SceneError> {
        let field = |f: &str| format!("grid.refine[{k}].{f}");
        if !(r.spacing.is_finite() && r.spacing > 0.0) {
            return Err(self.error(&field("spacing"), "expected a positive spacing"));
        }
        if !(r.min.is_finite() && r.min >= lo && r.min < hi) {
            return Err(self.error(
                &field("min"),
                format!("expected a coordinate inside the grid, from {lo} to {hi}"),
            ));
        }
        if !(r.max.is_finite() && r.max > r.min && r.max <= hi) {
            return Err(self.error(
                &field("max"),
                format!("expected a coordinate above `min` and at most {hi}"),
            ));
        }
        Ok(())
    }

    fn graded_axis(
        &self,
        g: &GridSpec,
        a: usize,
        lo: f64,
        hi: f64,
    ) -> Result<Vec<f64>, SceneError> {
        let mut intervals: Vec<(usize, &RefineSpec)> = g
            .refine
            .iter()
            .enumerate()
            .filter(|(_, r)| r.axis.index() == a)
            .collect();
        for &(k, r) in &intervals {
            self.check_refine_interval(k, r, lo, hi)?;
        }
        intervals.sort_by(|x, y| x.1.min.total_cmp(&y.1.min));
        let mut nodes = vec![lo];
        let mut cursor = lo;
        // Appends the nodes of a segment ending at `end`, `step` apart; the segment must hold a
        // whole number of them. The last node is `end` itself, so nothing drifts.
        let segment = |nodes: &mut Vec<f64>, start: f64, end: f64, step: f64, field: &str| {
            let count = (end - start) / step;
            if (count - count.round()).abs() > 1e-6 * count.max(1.0) {
                return Err(self.error(
                    field,
                    format!(
                        "the segment from {start} to {end} along {} must hold a whole number of \
                         cells of {step}: it holds {count}",
                        D::AXES[a]
                    ),
                ));
            }
            let count = count.round() as usize;
            if count as f64 > MAX_CELLS {
                return Err(self.error(field, too_many_cells(count as f64)));
            }
            for i in 1..count {
                nodes.push(start + i as f64 * step);
            }
            if count > 0 {
                nodes.push(end);
            }
            Ok(())
        };
        for &(k, r) in &intervals {
            if r.min < cursor {
                return Err(self.error(
                    &format!("grid.refine[{k}].min"),
                    format!("overlaps another interval along {}", D::AXES[a]),
                ));
            }
            segment(
                &mut nodes,
                cursor,
                r.min,
                g.spacing,
                &format!("grid.refine[{k}].min"),
            )?;
            segment(
                &mut nodes,
                r.min,
                r.max,
                r.spacing,
                &format!("grid.refine[{k}].max"),
            )?;
            cursor = r.max;
        }
        segment(&mut nodes, cursor, hi, g.spacing, "grid.max")?;
        Ok(nodes)
    }

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
    fn boundary_facets(
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
    fn shape_of_dimension(&self, field: &str, shape: &ShapeSpec) -> Result<Shape, SceneError> {
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

    fn velocity(&self, field: &str, v: &VelocitySpec) -> Result<InitialVelocity<D>, SceneError> {
        let at = |f: &str| format!("{field}.{f}");
        Ok(match v {
            VelocitySpec::Uniform(coords) => InitialVelocity::Uniform(self.vector(field, coords)?),
            VelocitySpec::Sine {
                amplitude,
                axis,
                wavelength,
                origin,
            } => InitialVelocity::Sine {
                amplitude: self.vector(&at("amplitude"), amplitude)?,
                axis: self.axis(&at("axis"), *axis)?,
                wavelength: *wavelength,
                origin: *origin,
            },
            VelocitySpec::Linear { gradient, origin } => {
                if gradient.0.len() != D::N {
                    return Err(self.error(
                        &at("gradient"),
                        format!(
                            "expected {} rows (one per velocity component): the scene is {}",
                            D::N,
                            D::NAME
                        ),
                    ));
                }
                let rows = gradient
                    .0
                    .iter()
                    .enumerate()
                    .map(|(i, row)| self.vector(&at(&format!("gradient.{i}")), row))
                    .collect::<Result<Vec<_>, _>>()?;
                InitialVelocity::Linear {
                    gradient: D::Matrix::from_fn(|i, j| rows[i][j]),
                    origin: match origin {
                        Some(o) => self.vector(&at("origin"), o)?,
                        None => D::Vector::ZERO,
                    },
                }
            }
        })
    }

    fn body(&self, b: usize, body: &BodySpec) -> Result<Body<D>, SceneError> {
        let field = |f: &str| format!("bodies[{b}].{f}");
        let cracks = body
            .cracks
            .iter()
            .enumerate()
            .map(|(k, c)| self.shape_of_dimension(&field(&format!("cracks[{k}]")), c))
            .collect::<Result<_, _>>()?;
        Ok(Body {
            name: body.name.clone(),
            shape: self.shape_of_dimension(&field("shape"), &body.shape)?,
            material: body.material.clone(),
            particles_per_cell: body.particles_per_cell,
            placement: body.placement,
            velocity: match &body.velocity {
                Some(v) => self.velocity(&field("velocity"), v)?,
                None => InitialVelocity::Uniform(D::Vector::ZERO),
            },
            contact_group: body.contact_group,
            cracks,
            loads: body
                .loads
                .iter()
                .enumerate()
                .map(|(k, load)| self.load(&field(&format!("loads[{k}]")), load))
                .collect::<Result<_, _>>()?,
            wins_over: body.wins_over.clone(),
        })
    }

    fn load(&self, field: &str, load: &LoadSpec) -> Result<Load<D>, SceneError> {
        let at = |f: &str| format!("{field}.{f}");
        let total = match (&load.force, &load.traction, load.area) {
            (Some(force), None, None) => self.vector(&at("force"), force)?,
            (None, Some(traction), Some(area)) => {
                if !(area.is_finite() && area > 0.0) {
                    return Err(self.error(&at("area"), "expected a positive area in m²"));
                }
                self.vector(&at("traction"), traction)? * area
            }
            (None, Some(_), None) => {
                return Err(self.error(
                    &at("traction"),
                    "a traction needs `area` (m²; in 2D the loaded length × thickness) to make a \
                     force",
                ));
            }
            (Some(_), Some(_), _) => {
                return Err(self.error(&at("traction"), "give `force` or `traction`, not both"));
            }
            (Some(_), None, Some(_)) => {
                return Err(self.error(&at("area"), "`area` goes with `traction`, not `force`"));
            }
            (None, None, _) => {
                return Err(self.error(field, "a load needs `force: (..)` or `traction: (..)`"));
            }
        };
        Ok(Load {
            region: match &load.region {
                Some(r) => Some(self.shape_of_dimension(&at("region"), r)?),
                None => None,
            },
            total,
            ramp: load.ramp.clone().unwrap_or_default(),
        })
    }

    fn boundary(&self, r: usize, spec: &BoundarySpec) -> Result<Boundary<D>, SceneError> {
        let field = |f: &str| format!("boundaries[{r}].{f}");
        let condition = match &spec.condition {
            ConditionSpec::Fixed => Condition::Fixed,
            ConditionSpec::Roller { normal } => Condition::Roller {
                normal: self.axis(&field("condition.normal"), *normal)?,
            },
            ConditionSpec::Velocity { x, y, z } => {
                if z.is_some() && D::N == 2 {
                    return Err(self.error(
                        &field("condition.z"),
                        format!("the scene is {}: its velocity components are x, y", D::NAME),
                    ));
                }
                Condition::Velocity([x.clone(), y.clone(), z.clone()])
            }
        };
        let (min, max, facets) = match &spec.nodes {
            RegionSpec::Box { min, max } => (
                self.vector(&field("nodes.min"), min)?,
                self.vector(&field("nodes.max"), max)?,
                None,
            ),
            RegionSpec::Mesh { file, physical } => {
                let facets = self.boundary_facets(&field("nodes"), file, physical)?;
                let (lo, hi) = facets.bounds();
                let corner = |x: DVec3| D::Vector::from_fn(|a| x[a]);
                (corner(lo), corner(hi), Some(std::sync::Arc::new(facets)))
            }
        };
        Ok(Boundary {
            name: spec.name.clone(),
            min,
            max,
            facets,
            condition,
        })
    }
}

/// The most cells a grid may have (all axes together).
pub const MAX_CELLS: f64 = 1e8;

fn too_many_cells(cells: f64) -> String {
    format!(
        "the grid would have {cells:.3e} cells, more than the 10^8 a scene may have; use a larger spacing or a smaller box"
    )
}
