//! From the file format to a [`Spec`]: coordinates, shapes, axes and components that fit the
//! scene's dimension, each error at its place in the file.
//!
//! Value checks that do not depend on the file (positive spacing, known materials, bodies
//! inside the grid, …) are `Spec::check`'s, so scenes built in code get them too.

use super::format::*;
use super::spec::{Body, Boundary, Condition, InitialVelocity, Load, Output, PipelineEntry, Spec};
use super::{SceneError, Source};
use fractum_engine::dim::{Dim, MatrixOps, VectorOps};
use fractum_engine::health::LeaveGrid;
use fractum_engine::quasi_static::{DEFAULT_KINETIC_LIMIT, QuasiStatic};
use fractum_engine::resources::Material;
use fractum_engine::simulation::{End, TimeStep};
use glam::{DVec2, DVec3};

mod grid;
mod shapes;

/// Turns the file format into a [`Spec`] of dimension `D`, each error at the place in the file
/// of the field it is about.
pub(crate) struct Validator<D: Dim> {
    source: Source,
    dimension: std::marker::PhantomData<D>,
}

impl<D: Dim> Validator<D> {
    /// The validator of a scene from `source`.
    pub(crate) fn new(source: Source) -> Self {
        Self {
            source,
            dimension: std::marker::PhantomData,
        }
    }

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

    /// The spec of `scene`, whose grid must be `D`-dimensional.
    pub(crate) fn spec(&self, scene: &Scene) -> Result<Spec<D>, SceneError> {
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
            quasi_static: scene.time.quasi_static.map(|q| QuasiStatic {
                mass_scaling: q.mass_scaling.unwrap_or(1.0),
                kinetic_limit: q.kinetic_limit.unwrap_or(DEFAULT_KINETIC_LIMIT),
            }),
            grid,
            thickness,
            materials,
            bodies,
            boundaries,
            body_force,
            output: output(&scene.output),
            on_leave_grid: match scene.safety.on_leave_grid {
                LeaveGridSpec::Stop => LeaveGrid::Stop,
                LeaveGridSpec::Remove => LeaveGrid::Remove,
            },
            pipeline,
        })
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

/// The output settings of the file's `output`.
fn output(output: &OutputSpec) -> Output {
    Output {
        vtu_every: output.vtu_every,
        grid_every: output.grid_every,
        csv_every: output.csv_every,
        probes: output.probes.clone(),
        last_good_frame: output.last_good_frame,
        compression: match output.compression {
            CompressionSpec::None => fractum_io::output::FrameCompression::None,
            CompressionSpec::Zlib => fractum_io::output::FrameCompression::Zlib,
        },
        fields: output.fields.clone(),
    }
}
