//! The scene file format: plain serde structs, every one rejecting unknown fields.
//!
//! A scene is one RON value of type [`Scene`]. See `scenes/` for examples and ARCHITECTURE.md
//! for the meaning of each section. Units are SI throughout.

use ron::value::RawValue;
use serde::Deserialize;
use std::collections::BTreeMap;

/// A 2D point or vector written as `(x, y)`.
pub type Pair = (f64, f64);

/// The whole scene.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Free text shown by `fractum check`.
    #[serde(default)]
    pub title: String,
    /// Unit system; only SI is supported, and it is the default.
    #[serde(default)]
    pub units: Units,
    /// Time stepping and end of the run.
    pub time: TimeSpec,
    /// Background grid.
    pub grid: GridSpec,
    /// Materials by name.
    pub materials: BTreeMap<String, MaterialSpec>,
    /// Bodies seeded with particles.
    pub bodies: Vec<BodySpec>,
    /// Essential boundary conditions on node regions.
    #[serde(default)]
    pub boundaries: Vec<BoundarySpec>,
    /// Body force per unit mass (an acceleration), e.g. `(0.0, -9.81)`.
    #[serde(default)]
    pub body_force: Pair,
    /// What to write and how often.
    #[serde(default)]
    pub output: OutputSpec,
    /// What to do when the run goes wrong.
    #[serde(default)]
    pub safety: SafetySpec,
    /// The systems of the step, by name, each with its own parameters.
    pub pipeline: Vec<PipelineEntry>,
}

/// Unit system of every number in the scene.
#[derive(Debug, Default, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(deny_unknown_fields)]
pub enum Units {
    /// Metres, kilograms, seconds, pascals, newtons.
    #[default]
    SI,
}

/// Time stepping.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeSpec {
    /// How the step size is chosen.
    pub step: TimeStep,
    /// When the run ends.
    pub end: End,
}

/// Step size rule.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum TimeStep {
    /// A fixed step in seconds; must not exceed the stable limit `h / (c + |v|)`.
    Fixed(f64),
    /// A fraction in (0, 1] of the stable limit, re-evaluated every step.
    Cfl(f64),
}

/// End of the run.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum End {
    /// Simulated time in seconds.
    Time(f64),
    /// Number of steps.
    Steps(u64),
}

/// Uniform background grid over a box.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridSpec {
    /// Lower corner.
    pub min: Pair,
    /// Upper corner; `max − min` must be a whole number of cells.
    pub max: Pair,
    /// Node spacing.
    pub spacing: f64,
}

/// Elastic constants and density of a material.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    /// Mass density in kg/m³.
    pub density: f64,
    /// Young's modulus in Pa.
    pub youngs_modulus: f64,
    /// Poisson's ratio, in (−1, 0.5).
    pub poisson_ratio: f64,
}

/// A body filled with particles.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    /// Optional name, shown by `fractum check`.
    #[serde(default)]
    pub name: Option<String>,
    /// Region the particles fill.
    pub shape: Shape,
    /// Name of a material in `materials`.
    pub material: String,
    /// Particles per cell along each direction.
    #[serde(default = "default_particles_per_cell")]
    pub particles_per_cell: u32,
    /// Where particles sit inside a cell.
    #[serde(default)]
    pub placement: Placement,
    /// Initial velocity.
    #[serde(default)]
    pub velocity: InitialVelocity,
    /// Contact group (for contact algorithms).
    #[serde(default)]
    pub contact_group: u8,
    /// Existing cracks: particles of this body inside any of these shapes start failed
    /// (damage 1: they keep their mass and carry no stress).
    #[serde(default)]
    pub cracks: Vec<Shape>,
}

fn default_particles_per_cell() -> u32 {
    2
}

/// Geometric shapes a body can take.
#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum Shape {
    /// Axis-aligned rectangle.
    Rectangle {
        /// Lower corner.
        min: Pair,
        /// Upper corner.
        max: Pair,
    },
    /// Disk.
    Disk {
        /// Centre.
        center: Pair,
        /// Radius.
        radius: f64,
    },
    /// Simple polygon (vertices in order, either orientation).
    Polygon {
        /// Vertices.
        vertices: Vec<Pair>,
    },
}

/// Placement of particles inside each grid cell.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq, Default)]
#[serde(deny_unknown_fields)]
pub enum Placement {
    /// Centres of equal sub-cells; equal volumes.
    #[default]
    Uniform,
    /// Gauss–Legendre points of the cell (1 to 3 per direction), volumes from the Gauss weights.
    Gauss,
}

/// Initial velocity of a body.
#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum InitialVelocity {
    /// The same velocity everywhere.
    Uniform(Pair),
    /// A sine profile along one axis: `v(x) = amplitude · sin(2π (x_axis − origin) / wavelength)`.
    /// The first axial mode of a bar of length L fixed at x = 0 is `wavelength: 4L`.
    Sine {
        /// Velocity at the crests.
        amplitude: Pair,
        /// Coordinate the profile varies along.
        axis: Axis,
        /// Wavelength (m).
        wavelength: f64,
        /// Coordinate where the profile is zero.
        #[serde(default)]
        origin: f64,
    },
    /// A linear field `v(x) = G (x − origin)`, e.g. homogeneous stretching; `gradient` is
    /// `((∂vx/∂x, ∂vx/∂y), (∂vy/∂x, ∂vy/∂y))`.
    Linear {
        /// Velocity gradient, row by row.
        gradient: (Pair, Pair),
        /// Point where the velocity is zero.
        #[serde(default)]
        origin: Pair,
    },
}

impl InitialVelocity {
    /// The velocity at `(x, y)`.
    pub fn at(&self, x: f64, y: f64) -> Pair {
        match self {
            InitialVelocity::Uniform(v) => *v,
            InitialVelocity::Sine {
                amplitude,
                axis,
                wavelength,
                origin,
            } => {
                let s = match axis {
                    Axis::X => x,
                    Axis::Y => y,
                };
                let factor = (2.0 * std::f64::consts::PI * (s - origin) / wavelength).sin();
                (amplitude.0 * factor, amplitude.1 * factor)
            }
            InitialVelocity::Linear { gradient, origin } => {
                let (dx, dy) = (x - origin.0, y - origin.1);
                (
                    gradient.0.0 * dx + gradient.0.1 * dy,
                    gradient.1.0 * dx + gradient.1.1 * dy,
                )
            }
        }
    }

    /// The largest speed the profile can give within `extent` of its origin (for the linear
    /// field; the others are bounded everywhere).
    pub fn max_speed(&self, extent: f64) -> f64 {
        match self {
            Self::Uniform(v) | Self::Sine { amplitude: v, .. } => v.0.hypot(v.1),
            Self::Linear { gradient, .. } => {
                let norm = (gradient.0.0.powi(2)
                    + gradient.0.1.powi(2)
                    + gradient.1.0.powi(2)
                    + gradient.1.1.powi(2))
                .sqrt();
                norm * extent
            }
        }
    }

    /// True when every number is finite (and a wavelength positive).
    pub fn is_valid(&self) -> bool {
        match self {
            Self::Uniform(v) => v.0.is_finite() && v.1.is_finite(),
            Self::Sine {
                amplitude,
                wavelength,
                origin,
                ..
            } => {
                amplitude.0.is_finite()
                    && amplitude.1.is_finite()
                    && origin.is_finite()
                    && wavelength.is_finite()
                    && *wavelength > 0.0
            }
            Self::Linear { gradient, origin } => [
                gradient.0.0,
                gradient.0.1,
                gradient.1.0,
                gradient.1.1,
                origin.0,
                origin.1,
            ]
            .iter()
            .all(|v| v.is_finite()),
        }
    }
}

impl Default for InitialVelocity {
    fn default() -> Self {
        Self::Uniform((0.0, 0.0))
    }
}

/// A named essential boundary condition on a region of nodes.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundarySpec {
    /// Name; used in the `reaction_<name>_x/y` probe columns.
    pub name: String,
    /// Which nodes.
    pub nodes: Region,
    /// What is held.
    pub condition: Condition,
}

/// A region of grid nodes.
#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum Region {
    /// Nodes inside the box, boundary included.
    Box {
        /// Lower corner.
        min: Pair,
        /// Upper corner.
        max: Pair,
    },
}

/// An axis.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(deny_unknown_fields)]
pub enum Axis {
    /// x.
    X,
    /// y.
    Y,
}

/// What a boundary region holds.
#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum Condition {
    /// Both velocity components zero.
    Fixed,
    /// Velocity component along `normal` zero, the other free.
    Roller {
        /// Direction of the held component.
        normal: Axis,
    },
    /// Prescribed velocity components as piecewise-linear functions of time, `[(t, v), …]`;
    /// an absent component stays free.
    Velocity {
        /// x component.
        #[serde(default)]
        x: Option<Vec<Pair>>,
        /// y component.
        #[serde(default)]
        y: Option<Vec<Pair>>,
    },
}

/// Output settings.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Write a VTU frame every this many steps (0: none). The initial and final states are
    /// always written when frames are on.
    #[serde(default)]
    pub vtu_every: u64,
    /// Write a `series.csv` row every this many steps (0: initial and final rows only).
    #[serde(default = "default_csv_every")]
    pub csv_every: u64,
    /// Extra `series.csv` columns.
    #[serde(default)]
    pub probes: Vec<Probe>,
    /// Keep a copy of the particle state at the start of every step, so that a run that blows
    /// up can write the last good state (`frames/particles_last_good_<step>.vtu`).
    #[serde(default = "default_true")]
    pub last_good_frame: bool,
}

fn default_true() -> bool {
    true
}

fn default_csv_every() -> u64 {
    1
}

impl Default for OutputSpec {
    fn default() -> Self {
        Self {
            vtu_every: 0,
            csv_every: default_csv_every(),
            probes: Vec::new(),
            last_good_frame: true,
        }
    }
}

/// An extra time-series quantity.
#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum Probe {
    /// Force the named boundary region exerts on the body: `reaction_<name>_x`, `_y`.
    Reaction(String),
    /// Centre-of-mass velocity of all particles: `com_velocity_x`, `com_velocity_y`.
    CentreOfMassVelocity,
    /// Net force on the named body, `Σ m_p a_p` over its particles: `force_<name>_x`, `_y`
    /// (e.g. the impact force on a hammer is minus this).
    Force(String),
    /// Displacement the named region's prescribed velocity has imposed so far (its time
    /// integral; zero for components the region holds at rest or leaves free):
    /// `displacement_<name>_x`, `_y`.
    Displacement(String),
}

/// Run-safety settings.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SafetySpec {
    /// What happens to a particle that leaves the grid.
    #[serde(default)]
    pub on_leave_grid: LeaveGrid,
}

/// What happens to a particle that leaves the grid.
#[derive(Debug, Default, Deserialize, Clone, Copy, PartialEq, Eq, bevy_ecs::prelude::Resource)]
#[serde(deny_unknown_fields)]
pub enum LeaveGrid {
    /// Stop the run, naming the particle and its position (default).
    #[default]
    Stop,
    /// Remove the particle (its mass and momentum leave the system) and go on; the count is
    /// reported at the end of the run.
    Remove,
}

/// One system of the pipeline.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PipelineEntry {
    /// Registered name, `stage/algorithm`.
    pub system: String,
    /// The system's own parameters, parsed by its installer.
    #[serde(default)]
    pub params: Option<Box<RawValue>>,
}
