//! The checked, typed scene ([`Spec`]) and its builder, for scenes made in code.
//!
//! A spec says everything a simulation is built from, in the types of its dimension `D`:
//! grid, materials, bodies, boundary regions, loads, output, safety and the pipeline. Specs come
//! from a scene file (`Spec::from_file`, in `validate.rs`) or from code:
//!
//! ```
//! use fractum_engine::prelude::*;
//! use fractum_engine::scene::{Body, InitialVelocity, Shape, Spec};
//! use fractum_engine::simulation::{End, TimeStep};
//!
//! let spec = Spec::<Three>::new(Grid { min: DVec3::ZERO, spacing: 0.1, cells: [10, 10, 10] })
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
//! `Spec::build` (in `spawn.rs`) checks every value, spawns the world and installs the pipeline.
//! Errors name the same field paths as for a file (`bodies[0].shape`); a spec from a file points
//! them at the text.

use super::Source;
use super::format::{Placement, Probe};
use super::shape::Shape;
use crate::boundary::{MAX_COMPONENTS, PiecewiseLinear};
use crate::dim::{Dim, MatrixOps, VectorOps};
use crate::health::LeaveGrid;
use crate::output::OutputPlan;
use crate::resources::{Grid, Material};
use crate::simulation::{End, Simulation, TimeStep};
use crate::stage::Stage;

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
        }
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
    /// `series.csv` row every this many steps (0: first and last only).
    pub csv_every: u64,
    /// Extra columns.
    pub probes: Vec<Probe>,
    /// Keep the state at the start of each step to write it if the step blows up.
    pub last_good_frame: bool,
}

impl Default for Output {
    fn default() -> Self {
        Self {
            vtu_every: 0,
            csv_every: 1,
            probes: Vec::new(),
            last_good_frame: true,
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
            in_source: false,
        }
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

/// Checks on a spec that need no world: every value in range, every name resolved.
impl<D: Dim> Spec<D> {
    /// Checks every value of the spec; the first problem is the error.
    pub fn check(&self) -> Result<(), super::SceneError> {
        self.check_grid()?;
        self.check_materials()?;
        self.check_thickness()?;
        self.check_bodies()?;
        self.check_boundaries()?;
        self.check_probes()?;
        if !self.body_force.is_finite() {
            return Err(self.source.error("body_force", "expected finite numbers"));
        }
        self.check_time()
    }

    fn check_grid(&self) -> Result<(), super::SceneError> {
        let g = &self.grid;
        if !(g.spacing.is_finite() && g.spacing > 0.0) {
            return Err(self
                .source
                .error("grid.spacing", "expected a positive spacing"));
        }
        if !g.min.is_finite() {
            return Err(self.source.error("grid.min", "expected finite coordinates"));
        }
        if (0..D::N).any(|a| g.cells[a] == 0) {
            return Err(self
                .source
                .error("grid.max", "expected at least one cell along each axis"));
        }
        if g.cells
            .as_ref()
            .iter()
            .try_fold(1usize, |n, c| n.checked_mul(*c))
            .is_none_or(|n| n > 100_000_000)
        {
            return Err(self
                .source
                .error("grid.spacing", "the grid would have more than 10^8 cells"));
        }
        Ok(())
    }

    fn check_materials(&self) -> Result<(), super::SceneError> {
        for m in &self.materials {
            let field = |f: &str| format!("materials.{}.{f}", m.name);
            if !(m.density.is_finite() && m.density > 0.0) {
                return Err(self
                    .source
                    .error(&field("density"), "expected a positive density (kg/m³)"));
            }
            if !(m.youngs_modulus.is_finite() && m.youngs_modulus > 0.0) {
                return Err(self
                    .source
                    .error(&field("youngs_modulus"), "expected a positive modulus (Pa)"));
            }
            if !(m.poisson_ratio > -1.0 && m.poisson_ratio < 0.5) {
                return Err(self
                    .source
                    .error(&field("poisson_ratio"), "expected a value in (-1, 0.5)"));
            }
            if self
                .materials
                .iter()
                .filter(|other| other.name == m.name)
                .count()
                > 1
            {
                return Err(self.source.error(
                    "materials",
                    format!("material \"{}\" is defined twice", m.name),
                ));
            }
        }
        if self.materials.len() > u16::MAX as usize {
            return Err(self.source.error("materials", "too many materials"));
        }
        Ok(())
    }

    fn check_thickness(&self) -> Result<(), super::SceneError> {
        if D::N == 2 && !(self.thickness.is_finite() && self.thickness > 0.0) {
            return Err(self
                .source
                .error("thickness", "expected a positive thickness (m)"));
        }
        if D::N == 3 && self.thickness != 1.0 {
            return Err(self.source.error(
                "thickness",
                "a thickness is for 2D scenes; a 3D body has its own depth",
            ));
        }
        Ok(())
    }

    /// Index of the material named `name`, or an error at `field` listing the known ones.
    pub(crate) fn material_index(
        &self,
        name: &str,
        field: &str,
    ) -> Result<usize, super::SceneError> {
        self.materials
            .iter()
            .position(|m| m.name == name)
            .ok_or_else(|| {
                let known = quoted(self.materials.iter().map(|m| m.name.as_str()));
                self.source.error(
                    field,
                    format!("unknown material \"{name}\"; the scene defines: {known}"),
                )
            })
    }

    fn check_shape(&self, field: &str, shape: &Shape) -> Result<(), super::SceneError> {
        if shape.dimension() != D::DIMENSION {
            let allowed = match D::N {
                2 => "Rectangle, Disk, Polygon",
                _ => "Box, Sphere, Cylinder, Prism",
            };
            return Err(self.source.error(
                field,
                format!(
                    "{} is a {} shape and the scene is {}; its shapes are {allowed}",
                    shape.kind(),
                    shape.dimension().describe(),
                    D::NAME
                ),
            ));
        }
        if let Some(expected) = shape.problem() {
            return Err(self.source.error(field, format!("expected {expected}")));
        }
        Ok(())
    }

    fn check_bodies(&self) -> Result<(), super::SceneError> {
        if self.bodies.is_empty() {
            return Err(self.source.error("bodies", "expected at least one body"));
        }
        if self.bodies.len() > u16::MAX as usize {
            return Err(self.source.error("bodies", "too many bodies"));
        }
        for (b, body) in self.bodies.iter().enumerate() {
            let field = |f: &str| format!("bodies[{b}].{f}");
            self.material_index(&body.material, &field("material"))?;
            if body.particles_per_cell == 0 || body.particles_per_cell > 16 {
                return Err(self
                    .source
                    .error(&field("particles_per_cell"), "expected 1 to 16"));
            }
            if super::seed::cell_points(body.placement, body.particles_per_cell).is_none() {
                return Err(self.source.error(
                    &field("particles_per_cell"),
                    "Gauss placement supports 1, 2 or 3 particles per cell per direction",
                ));
            }
            self.check_shape(&field("shape"), &body.shape)?;
            self.check_inside_grid(&field("shape"), &body.shape)?;
            for (k, crack) in body.cracks.iter().enumerate() {
                self.check_shape(&field(&format!("cracks[{k}]")), crack)?;
            }
            if let Some(expected) = body.velocity.problem() {
                return Err(self
                    .source
                    .error(&field("velocity"), format!("expected {expected}")));
            }
        }
        Ok(())
    }

    fn check_inside_grid(&self, field: &str, shape: &Shape) -> Result<(), super::SceneError> {
        let (lo, hi) = shape.bounds();
        let (glo, ghi) = (self.grid.min.to_3d(), self.grid.max().to_3d());
        if (0..D::N).any(|a| lo[a] < glo[a] || hi[a] > ghi[a]) {
            let show = |v: [f64; 3]| {
                format!(
                    "({})",
                    v[..D::N]
                        .iter()
                        .map(|c| c.to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            };
            return Err(self.source.error(
                field,
                format!(
                    "the body extends outside the grid: it spans {} to {}, the grid {} to {}",
                    show(lo.to_array()),
                    show(hi.to_array()),
                    show(glo),
                    show(ghi)
                ),
            ));
        }
        Ok(())
    }

    fn check_boundaries(&self) -> Result<(), super::SceneError> {
        for (r, region) in self.boundaries.iter().enumerate() {
            let field = |f: &str| format!("boundaries[{r}].{f}");
            if !valid_region_name(&region.name) {
                return Err(self
                    .source
                    .error(&field("name"), "expected letters, digits, `_` or `-` only"));
            }
            if self.boundaries[..r].iter().any(|x| x.name == region.name) {
                return Err(self.source.error(
                    &field("name"),
                    format!("region \"{}\" is defined twice", region.name),
                ));
            }
            if !(region.min.is_finite() && region.max.is_finite()) {
                return Err(self
                    .source
                    .error(&field("nodes"), "expected finite coordinates"));
            }
            match &region.condition {
                Condition::Fixed => {}
                Condition::Roller { normal } => {
                    if *normal >= D::N {
                        return Err(self
                            .source
                            .error(&field("condition.normal"), axis_message::<D>()));
                    }
                }
                Condition::Velocity(components) => {
                    let axes = ["x", "y", "z"];
                    if components.iter().all(Option::is_none) {
                        return Err(self.source.error(
                            &field("condition"),
                            format!("expected at least one of {}", D::AXES.join(", ")),
                        ));
                    }
                    for (a, points) in components.iter().enumerate() {
                        let Some(points) = points else { continue };
                        let at = field(&format!("condition.{}", axes[a]));
                        if a >= D::N {
                            return Err(self.source.error(&at, axis_message::<D>()));
                        }
                        PiecewiseLinear::new(points.clone())
                            .map_err(|e| self.source.error(&at, format!("expected {e}")))?;
                    }
                }
            }
        }
        Ok(())
    }

    /// Index of the boundary region named `name`, or an error at probe `probe`.
    pub(crate) fn region_index(
        &self,
        name: &str,
        probe: usize,
    ) -> Result<usize, super::SceneError> {
        self.boundaries
            .iter()
            .position(|r| r.name == name)
            .ok_or_else(|| {
                let known = quoted(self.boundaries.iter().map(|r| r.name.as_str()));
                self.source.error(
                    &format!("output.probes[{probe}]"),
                    format!("no boundary region named \"{name}\"; the scene defines: {known}"),
                )
            })
    }

    /// Index of the body named `name`, or an error at probe `probe`.
    pub(crate) fn body_index(&self, name: &str, probe: usize) -> Result<usize, super::SceneError> {
        self.bodies
            .iter()
            .position(|b| b.name.as_deref() == Some(name))
            .ok_or_else(|| {
                let known = quoted(self.bodies.iter().filter_map(|b| b.name.as_deref()));
                self.source.error(
                    &format!("output.probes[{probe}]"),
                    format!("no body named \"{name}\"; the named bodies are: {known}"),
                )
            })
    }

    fn check_probes(&self) -> Result<(), super::SceneError> {
        for (k, probe) in self.output.probes.iter().enumerate() {
            match probe {
                Probe::Reaction(name) | Probe::Displacement(name) => {
                    self.region_index(name, k)?;
                }
                Probe::Force(name) => {
                    self.body_index(name, k)?;
                }
                Probe::CentreOfMassVelocity => {}
            }
        }
        Ok(())
    }

    fn check_time(&self) -> Result<(), super::SceneError> {
        match self.end {
            End::Time(t) if !(t.is_finite() && t > 0.0) => {
                return Err(self
                    .source
                    .error("time.end", "expected a positive end time"));
            }
            End::Steps(0) => {
                return Err(self.source.error("time.end", "expected at least one step"));
            }
            _ => {}
        }
        match self.time_step {
            TimeStep::Fixed(dt) if !(dt.is_finite() && dt > 0.0) => Err(self
                .source
                .error("time.step", "expected a positive time step")),
            TimeStep::Cfl(f) if !(f > 0.0 && f <= 1.0) => Err(self
                .source
                .error("time.step", "expected a CFL factor in (0, 1]")),
            _ => Ok(()),
        }
    }
}

fn axis_message<D: Dim>() -> String {
    format!(
        "the scene is {}: its axes are {}",
        D::NAME,
        D::AXES.join(", ").to_uppercase()
    )
}

fn valid_region_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// `"a", "b"`, or `none`.
pub(crate) fn quoted<'a>(names: impl Iterator<Item = &'a str>) -> String {
    let names: Vec<String> = names.map(|n| format!("\"{n}\"")).collect();
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}

impl<D: Dim> Boundary<D> {
    /// A region `name` over the nodes in the box `[min, max]` holding `condition`.
    pub fn new(name: &str, min: D::Vector, max: D::Vector, condition: Condition) -> Self {
        Self {
            name: name.to_string(),
            min,
            max,
            condition,
        }
    }
}

impl<D: Dim> InitialVelocity<D> {
    /// The zero field.
    pub fn rest() -> Self {
        Self::Uniform(D::Vector::ZERO)
    }
}
