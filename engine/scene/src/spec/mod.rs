//! The checked, typed scene ([`Spec`]) and its builder, for scenes made in code.
//!
//! A spec says everything a simulation is built from, in the types of its dimension `D`:
//! grid, materials, bodies, boundary regions, loads, output, safety and the pipeline. Specs come
//! from a scene file (`Spec::from_file`, read by the validator in `validate/`) or from code:
//!
//! ```
//! use fractum_engine::prelude::*;
//! use fractum_scene::{Body, InitialVelocity, Shape, Spec};
//! use fractum_engine::simulation::{End, TimeStep};
//!
//! let spec = Spec::<Three>::new(Grid::uniform(DVec3::ZERO, 0.1, [10, 10, 10]))
//!     .time(TimeStep::Cfl(0.5), End::Steps(10))
//!     .material(Material::new("rubber", 1000.0, 1.0e6, 0.3))
//!     .body(
//!         Body::new(Shape::Sphere { center: DVec3::splat(0.5), radius: 0.3 }, "rubber")
//!             .velocity(InitialVelocity::Uniform(DVec3::new(0.1, 0.0, 0.0))),
//!     )
//!     .system("basis/linear")
//!     .system("predictor/usl")
//!     .system("stress/linear_elastic")
//!     .system("advection/usl");
//! # let _ = spec;
//! ```
//!
//! A spec is data; its verbs (`Spec::from_file`, `Spec::check`, `Spec::estimate`,
//! `Spec::build`) hand it to the phase that does the work: the validator (`validate/`), the
//! checks (`check.rs`), the estimator (`estimate.rs`), the world builder (`build/`).
//! Errors name the same field paths as for a file (`bodies[0].shape`); a spec from a file points
//! them at the text.

use super::format::{Placement, Probe};
use super::shape::Shape;

use super::Source;
use fractum_engine::boundary::MAX_COMPONENTS;
use fractum_engine::dim::{Dim, MatrixOps, VectorOps};
use fractum_engine::health::LeaveGrid;
use fractum_engine::quasi_static::QuasiStatic;
use fractum_engine::resources::{Grid, Material};
use fractum_engine::simulation::{End, Simulation, TimeStep};
use fractum_engine::stage::Stage;
use fractum_io::output::OutputPlan;

mod verbs;

/// A checked scene in dimension `D`, ready to build.
#[derive(Clone, Debug)]
pub struct Spec<D: Dim> {
    /// Where errors point.
    pub source: Source,
    /// Free text shown by `fractum check`.
    pub title: String,
    /// How the step size is chosen.
    pub time_step: TimeStep,
    /// When the run ends.
    pub end: End,
    /// Mass scaling and the kinetic-energy check of a quasi-static run (`None`: a dynamic run).
    pub quasi_static: Option<QuasiStatic>,
    /// Background grid.
    pub grid: Grid<D>,
    /// Out-of-plane thickness in 2D (m); 1 in 3D.
    pub thickness: f64,
    /// Materials, in the order of their indices.
    pub materials: Vec<Material>,
    /// Bodies, in the order of their indices.
    pub bodies: Vec<Body<D>>,
    /// Essential boundary conditions.
    pub boundaries: Vec<Boundary<D>>,
    /// Body force per unit mass.
    pub body_force: D::Vector,
    /// What to write.
    pub output: Output,
    /// What happens to a particle that leaves the grid.
    pub on_leave_grid: LeaveGrid,
    /// The systems of the step.
    pub pipeline: Vec<PipelineEntry>,
}

/// A body filled with particles.
#[derive(Clone, Debug)]
pub struct Body<D: Dim> {
    /// Name, for `fractum check` and `Force` probes.
    pub name: Option<String>,
    /// Region the particles fill.
    pub shape: Shape,
    /// Name of a material of the spec.
    pub material: String,
    /// Particles per cell along each direction.
    pub particles_per_cell: u32,
    /// Where particles sit in a cell.
    pub placement: Placement,
    /// Initial velocity.
    pub velocity: InitialVelocity<D>,
    /// Contact group.
    pub contact_group: u8,
    /// Particles inside any of these start failed (damage 1).
    pub cracks: Vec<Shape>,
    /// Loads on the body's particles.
    pub loads: Vec<Load<D>>,
    /// Names of the bodies whose particles inside this body's shape are not seeded (it keeps
    /// the overlap; `scene/overlap.rs`).
    pub wins_over: Vec<String>,
}

/// A ramped force on the particles of a body (or of a region of it), shared by volume.
#[derive(Clone, Debug)]
pub struct Load<D: Dim> {
    /// Only particles inside carry the load (`None`: the whole body).
    pub region: Option<Shape>,
    /// Total force at ramp factor 1 (N).
    pub total: D::Vector,
    /// `(time, factor)` points; empty means factor 1 throughout.
    pub ramp: Vec<(f64, f64)>,
}

impl<D: Dim> Load<D> {
    /// A constant total force on the whole body.
    pub fn force(total: D::Vector) -> Self {
        Self {
            region: None,
            total,
            ramp: Vec::new(),
        }
    }

    /// Restricts the load to the particles inside `region`.
    pub fn on(mut self, region: Shape) -> Self {
        self.region = Some(region);
        self
    }

    /// Scales the load in time by the piecewise-linear `(time, factor)` points.
    pub fn ramped(mut self, points: Vec<(f64, f64)>) -> Self {
        self.ramp = points;
        self
    }
}

impl<D: Dim> Body<D> {
    /// A body of `shape` made of `material`, at rest, 2 particles per cell per direction at
    /// the sub-cell centres.
    pub fn new(shape: Shape, material: &str) -> Self {
        Self {
            name: None,
            shape,
            material: material.to_string(),
            particles_per_cell: 2,
            placement: Placement::Uniform,
            velocity: InitialVelocity::Uniform(D::Vector::ZERO),
            contact_group: 0,
            cracks: Vec::new(),
            loads: Vec::new(),
            wins_over: Vec::new(),
        }
    }

    /// Lets this body keep its overlap with body `name`, whose particles inside this body's
    /// shape are then not seeded.
    pub fn wins_over(mut self, name: &str) -> Self {
        self.wins_over.push(name.to_string());
        self
    }

    /// Puts the body in a contact group.
    pub fn group(mut self, group: u8) -> Self {
        self.contact_group = group;
        self
    }

    /// Adds a load.
    pub fn load(mut self, load: Load<D>) -> Self {
        self.loads.push(load);
        self
    }

    /// Names the body.
    pub fn named(mut self, name: &str) -> Self {
        self.name = Some(name.to_string());
        self
    }

    /// Sets the initial velocity.
    pub fn velocity(mut self, velocity: InitialVelocity<D>) -> Self {
        self.velocity = velocity;
        self
    }

    /// Sets the particles per cell per direction and their placement.
    pub fn particles(mut self, per_direction: u32, placement: Placement) -> Self {
        self.particles_per_cell = per_direction;
        self.placement = placement;
        self
    }

    /// Adds an initial crack.
    pub fn crack(mut self, shape: Shape) -> Self {
        self.cracks.push(shape);
        self
    }
}

/// Initial velocity of a body.
#[derive(Clone, Debug, PartialEq)]
pub enum InitialVelocity<D: Dim> {
    /// The same everywhere.
    Uniform(D::Vector),
    /// `amplitude · sin(2π (x_axis − origin) / wavelength)`.
    Sine {
        /// Velocity at the crests.
        amplitude: D::Vector,
        /// Index of the axis the profile varies along.
        axis: usize,
        /// Wavelength (m).
        wavelength: f64,
        /// Coordinate where the profile is zero.
        origin: f64,
    },
    /// `gradient · (x − origin)`.
    Linear {
        /// Velocity gradient `∂v_i/∂x_j`.
        gradient: D::Matrix,
        /// Point where the velocity is zero.
        origin: D::Vector,
    },
}

impl<D: Dim> InitialVelocity<D> {
    /// The velocity at `x`.
    pub fn at(&self, x: D::Vector) -> D::Vector {
        match self {
            Self::Uniform(v) => *v,
            Self::Sine {
                amplitude,
                axis,
                wavelength,
                origin,
            } => {
                let factor = (2.0 * std::f64::consts::PI * (x[*axis] - origin) / wavelength).sin();
                *amplitude * factor
            }
            Self::Linear { gradient, origin } => *gradient * (x - *origin),
        }
    }

    /// The velocity gradient `∂v_i/∂x_j` at `x`: what an affine transfer's particle starts with
    /// as its `C_p`, so that its first particle-to-grid transfer hands the nodes the field
    /// itself rather than the particles' velocities averaged (a PIC step).
    pub fn gradient_at(&self, x: D::Vector) -> D::Matrix {
        match self {
            Self::Uniform(_) => D::Matrix::ZERO,
            Self::Sine {
                amplitude,
                axis,
                wavelength,
                origin,
            } => {
                let k = 2.0 * std::f64::consts::PI / wavelength;
                let slope = k * (k * (x[*axis] - origin)).cos();
                D::Matrix::from_fn(|i, j| {
                    if j == *axis {
                        amplitude[i] * slope
                    } else {
                        0.0
                    }
                })
            }
            Self::Linear { gradient, .. } => *gradient,
        }
    }

    /// `None` when every number is finite (a wavelength positive, an axis in range), else what
    /// was expected.
    pub fn problem(&self) -> Option<&'static str> {
        match self {
            Self::Uniform(v) => (!v.is_finite()).then_some("finite numbers"),
            Self::Sine {
                amplitude,
                axis,
                wavelength,
                origin,
            } => {
                if *axis >= D::N {
                    Some("an axis of the scene's dimension")
                } else if !(amplitude.is_finite()
                    && origin.is_finite()
                    && wavelength.is_finite()
                    && *wavelength > 0.0)
                {
                    Some("finite numbers and a positive wavelength")
                } else {
                    None
                }
            }
            Self::Linear { gradient, origin } => {
                (!(gradient.is_finite() && origin.is_finite())).then_some("finite numbers")
            }
        }
    }
}

/// A named essential boundary condition on the nodes inside a box (boundary included).
#[derive(Clone, Debug, PartialEq)]
pub struct Boundary<D: Dim> {
    /// Name, used in probe columns.
    pub name: String,
    /// Lower corner of the box.
    pub min: D::Vector,
    /// Upper corner of the box.
    pub max: D::Vector,
    /// When the region is a mesh's boundary group: its facets, and the region is the nodes
    /// within half a cell of them (inside the box, which is then the facets' bounding box).
    pub facets: Option<std::sync::Arc<super::mesh::BoundaryFacets>>,
    /// What is held.
    pub condition: Condition,
}

/// What a boundary region holds.
#[derive(Clone, Debug, PartialEq)]
pub enum Condition {
    /// Every velocity component zero.
    Fixed,
    /// The component along axis `normal` (0, 1, 2) zero.
    Roller {
        /// Axis index.
        normal: usize,
    },
    /// Prescribed components (x, y, z) as `(time, value)` points; `None` leaves one free.
    Velocity([Option<Vec<(f64, f64)>>; MAX_COMPONENTS]),
}

/// Output settings.
#[derive(Clone, Debug, PartialEq)]
pub struct Output {
    /// VTU frame every this many steps (0: none).
    pub vtu_every: u64,
    /// Grid-node VTU frame every this many steps (0: none).
    pub grid_every: u64,
    /// `series.csv` row every this many steps (0: first and last only).
    pub csv_every: u64,
    /// Extra columns.
    pub probes: Vec<Probe>,
    /// Keep the state at the start of each step to write it if the step blows up.
    pub last_good_frame: bool,
    /// How frame arrays are encoded.
    pub compression: fractum_io::output::FrameCompression,
    /// The arrays a particle frame carries beside positions; every one when `None`.
    pub fields: Option<Vec<String>>,
}

impl Default for Output {
    fn default() -> Self {
        Self {
            vtu_every: 0,
            grid_every: 0,
            csv_every: 1,
            probes: Vec::new(),
            last_good_frame: true,
            compression: fractum_io::output::FrameCompression::default(),
            fields: None,
        }
    }
}

/// One system of the pipeline and its parameters (RON text, parsed by its installer).
#[derive(Clone, Debug, PartialEq)]
pub struct PipelineEntry {
    /// Registered name, `stage/algorithm`.
    pub system: String,
    /// The `params` value as RON text.
    pub params: Option<String>,
    /// The materials the entry is limited to (stress and damage systems); all when `None`.
    pub materials: Option<Vec<String>>,
    /// True when the entry is the one written in the source file at its index, so errors can
    /// point at the text.
    pub(crate) in_source: bool,
}

impl PipelineEntry {
    /// `system` with no parameters.
    pub fn new(system: &str) -> Self {
        Self {
            system: system.to_string(),
            params: None,
            materials: None,
            in_source: false,
        }
    }

    /// Limits the entry to the particles of `materials` (stress and damage systems).
    pub fn for_materials(mut self, materials: &[&str]) -> Self {
        self.materials = Some(materials.iter().map(|m| m.to_string()).collect());
        self
    }

    /// `system` with `params`, RON text such as `"(gamma: 3.5)"`.
    pub fn with_params(system: &str, params: &str) -> Self {
        Self {
            params: Some(params.to_string()),
            ..Self::new(system)
        }
    }
}

/// The pipeline as installed: system names per stage, in stage order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PipelineSummary {
    /// `(stage, systems)` for every stage with at least one system.
    pub by_stage: Vec<(Stage, Vec<String>)>,
}

impl PipelineSummary {
    /// Every system's name, in stage order.
    pub fn system_names(&self) -> Vec<&str> {
        self.by_stage
            .iter()
            .flat_map(|(_, names)| names.iter().map(String::as_str))
            .collect()
    }
}

/// What `fractum check` reports about a built scene besides the world itself.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneSummary {
    /// Name of the source (file name or `<code>`).
    pub source: String,
    /// Title.
    pub title: String,
    /// Out-of-plane thickness (2D).
    pub thickness: f64,
    /// Name (or `body N`) and particle count of each body.
    pub bodies: Vec<(String, usize)>,
    /// Name and a description of each boundary region.
    pub boundaries: Vec<(String, String)>,
    /// How the step size is chosen.
    pub time_step: Option<TimeStep>,
}

/// Everything built from a spec.
pub struct Built {
    /// The simulation, ready to step.
    pub simulation: Simulation,
    /// The installed pipeline.
    pub pipeline: PipelineSummary,
    /// What to write during the run.
    pub output: OutputPlan,
    /// Particles per body, in scene order.
    pub body_particles: Vec<usize>,
    /// What `fractum check` shows.
    pub summary: SceneSummary,
}

impl<D: Dim> Spec<D> {
    /// A spec over `grid` with nothing in it yet: no materials, bodies or systems; a CFL step
    /// of 0.5 and one step; default output; built in code (errors name fields only).
    pub fn new(grid: Grid<D>) -> Self {
        Self {
            source: Source::code("<code>"),
            title: String::new(),
            time_step: TimeStep::Cfl(0.5),
            end: End::Steps(1),
            quasi_static: None,
            grid,
            thickness: 1.0,
            materials: Vec::new(),
            bodies: Vec::new(),
            boundaries: Vec::new(),
            body_force: D::Vector::ZERO,
            output: Output::default(),
            on_leave_grid: LeaveGrid::Stop,
            pipeline: Vec::new(),
        }
    }

    /// Names the source in messages (e.g. `<bench>`).
    pub fn named(mut self, name: &str) -> Self {
        self.source = Source::code(name);
        self
    }

    /// Sets the title.
    pub fn title(mut self, title: &str) -> Self {
        self.title = title.to_string();
        self
    }

    /// Sets the step rule and the end of the run.
    pub fn time(mut self, step: TimeStep, end: End) -> Self {
        self.time_step = step;
        self.end = end;
        self
    }

    /// Sets the out-of-plane thickness of a 2D scene.
    pub fn thickness(mut self, thickness: f64) -> Self {
        self.thickness = thickness;
        self
    }

    /// Adds a material.
    pub fn material(mut self, material: Material) -> Self {
        self.materials.push(material);
        self
    }

    /// Adds a body.
    pub fn body(mut self, body: Body<D>) -> Self {
        self.bodies.push(body);
        self
    }

    /// Adds a boundary region.
    pub fn boundary(mut self, boundary: Boundary<D>) -> Self {
        self.boundaries.push(boundary);
        self
    }

    /// Sets the body force per unit mass.
    pub fn body_force(mut self, acceleration: D::Vector) -> Self {
        self.body_force = acceleration;
        self
    }

    /// Makes the run quasi-static: mass scaling and the kinetic-energy check.
    pub fn quasi_static(mut self, settings: QuasiStatic) -> Self {
        self.quasi_static = Some(settings);
        self
    }

    /// The factor on every density: the quasi-static mass scaling, or 1.
    pub fn mass_scaling(&self) -> f64 {
        self.quasi_static.map_or(1.0, |q| q.mass_scaling)
    }

    /// The materials the world steps with: the scene's, each density times the mass scaling
    /// (its wave speed, and so the stable step, divided by the factor's square root).
    pub fn inertial_materials(&self) -> Vec<Material> {
        let scaling = self.mass_scaling();
        self.materials
            .iter()
            .map(|m| Material {
                density: m.density * scaling,
                ..m.clone()
            })
            .collect()
    }

    /// The body force per unit of the scaled mass: the scene's divided by the mass scaling, so
    /// that the weight of each particle is the scene's.
    pub fn inertial_body_force(&self) -> D::Vector {
        self.body_force * (1.0 / self.mass_scaling())
    }

    /// Sets the output settings.
    pub fn output(mut self, output: Output) -> Self {
        self.output = output;
        self
    }

    /// Sets the policy for particles that leave the grid.
    pub fn on_leave_grid(mut self, policy: LeaveGrid) -> Self {
        self.on_leave_grid = policy;
        self
    }

    /// Appends a system without parameters.
    pub fn system(mut self, name: &str) -> Self {
        self.pipeline.push(PipelineEntry::new(name));
        self
    }

    /// Appends a system with parameters (RON text such as `"(gamma: 3.5)"`).
    pub fn system_with(mut self, name: &str, params: &str) -> Self {
        self.pipeline.push(PipelineEntry::with_params(name, params));
        self
    }

    /// Replaces the pipeline.
    pub fn with_pipeline(mut self, entries: Vec<PipelineEntry>) -> Self {
        self.pipeline = entries;
        self
    }
}

impl<D: Dim> Boundary<D> {
    /// A region `name` over the nodes in the box `[min, max]` holding `condition`.
    pub fn new(name: &str, min: D::Vector, max: D::Vector, condition: Condition) -> Self {
        Self {
            name: name.to_string(),
            min,
            max,
            facets: None,
            condition,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fractum_engine::dim::{MatrixOps, Three, Two};
    use glam::{DMat2, DVec2, DVec3};

    /// The gradient against central differences of the velocity, for each kind of field.
    fn check<D: Dim>(velocity: &InitialVelocity<D>, x: D::Vector) {
        let gradient = velocity.gradient_at(x);
        let step = 1e-6;
        for j in 0..D::N {
            let offset = D::Vector::from_fn(|a| if a == j { step } else { 0.0 });
            let slope = (velocity.at(x + offset) - velocity.at(x - offset)) * (0.5 / step);
            for i in 0..D::N {
                let exact = gradient.get(i, j);
                assert!(
                    (exact - slope[i]).abs() < 1e-6,
                    "∂v_{i}/∂x_{j}: {exact} against {}",
                    slope[i]
                );
            }
        }
    }

    #[test]
    fn the_initial_velocity_gradient_is_the_fields_derivative() {
        check::<Two>(
            &InitialVelocity::Uniform(DVec2::new(1.0, -2.0)),
            DVec2::new(0.3, 0.7),
        );
        check::<Two>(
            &InitialVelocity::Sine {
                amplitude: DVec2::new(0.1, 0.05),
                axis: 0,
                wavelength: 0.8,
                origin: 0.04,
            },
            DVec2::new(0.31, 0.2),
        );
        check::<Three>(
            &InitialVelocity::Sine {
                amplitude: DVec3::new(0.0, 2.0, -1.0),
                axis: 2,
                wavelength: 3.0,
                origin: -0.5,
            },
            DVec3::new(0.1, 0.2, 0.9),
        );
        check::<Two>(
            &InitialVelocity::Linear {
                gradient: DMat2::from_cols(DVec2::new(0.0, 50.0), DVec2::new(-50.0, 0.0)),
                origin: DVec2::new(0.05, 0.05),
            },
            DVec2::new(0.07, 0.02),
        );
    }
}
