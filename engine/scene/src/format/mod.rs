//! The scene file format: plain serde structs, every one rejecting unknown fields.
//!
//! A scene is one RON value of type [`Scene`]. This module only describes what a file may
//! say; the validator (`validate/`) turns it into a checked [`super::Spec`], which is what the engine builds
//! from. SCENES.md documents every field (a test keeps the two in step). Units are SI.
//!
//! Coordinates are tuples of two numbers in a 2D scene and three in a 3D one; the grid's
//! corners decide which, and every other coordinate of the scene must agree.

use ron::value::RawValue;
use serde::Deserialize;
use serde::de::{Deserializer, SeqAccess, Visitor};
use std::collections::BTreeMap;
use std::fmt;

mod shapes;
pub use shapes::*;

/// A RON tuple of two or three items, `(x, y)` or `(x, y, z)`: the dimension is checked
/// against the scene's when the scene is validated.
#[derive(Debug, Clone, PartialEq)]
pub struct Tuple<T>(pub Vec<T>);

/// A point or vector: `(x, y)` in 2D, `(x, y, z)` in 3D.
pub type Coords = Tuple<f64>;

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Tuple<T> {
    fn deserialize<De: Deserializer<'de>>(deserializer: De) -> Result<Self, De::Error> {
        struct TupleVisitor<T>(std::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de>> Visitor<'de> for TupleVisitor<T> {
            type Value = Tuple<T>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a tuple of 2 values (x, y) or 3 values (x, y, z)")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Tuple<T>, A::Error> {
                let mut items = Vec::new();
                while let Some(item) = seq.next_element()? {
                    items.push(item);
                    if items.len() > 3 {
                        return Err(serde::de::Error::invalid_length(items.len(), &self));
                    }
                }
                if items.len() < 2 {
                    return Err(serde::de::Error::invalid_length(items.len(), &self));
                }
                Ok(Tuple(items))
            }
        }
        deserializer.deserialize_tuple(3, TupleVisitor(std::marker::PhantomData))
    }
}

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
    /// Background grid; its corners decide the dimension.
    pub grid: GridSpec,
    /// Out-of-plane thickness of a 2D scene in m (default 1): masses, forces and energies in
    /// the outputs are for this thickness.
    #[serde(default)]
    pub thickness: Option<f64>,
    /// Materials by name (a name given twice is an error, not "the last wins").
    #[serde(deserialize_with = "unique_keys")]
    pub materials: BTreeMap<String, MaterialSpec>,
    /// Bodies seeded with particles.
    pub bodies: Vec<BodySpec>,
    /// Essential boundary conditions on node regions.
    #[serde(default)]
    pub boundaries: Vec<BoundarySpec>,
    /// Body force per unit mass (an acceleration), e.g. `(0.0, -9.81)`; zero by default.
    #[serde(default)]
    pub body_force: Option<Coords>,
    /// What to write and how often.
    #[serde(default)]
    pub output: OutputSpec,
    /// What to do when the run goes wrong.
    #[serde(default)]
    pub safety: SafetySpec,
    /// The systems of the step, by name, each with its own parameters.
    pub pipeline: Vec<PipelineEntrySpec>,
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
    pub step: TimeStepSpec,
    /// When the run ends.
    pub end: EndSpec,
    /// A quasi-static run: mass scaling and the kinetic-energy check (none by default).
    #[serde(default)]
    pub quasi_static: Option<QuasiStaticSpec>,
}

/// A quasi-static run's settings (`fractum_engine::quasi_static`).
#[derive(Debug, Deserialize, Clone, Copy, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct QuasiStaticSpec {
    /// Factor on every density, at least 1 (default 1: no scaling); the stable step grows by
    /// its square root.
    #[serde(default)]
    pub mass_scaling: Option<f64>,
    /// The kinetic fraction `K / U` past which the run warns that it is dynamic, in (0, 1]
    /// (default 0.05).
    #[serde(default)]
    pub kinetic_limit: Option<f64>,
}

/// Step size rule.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum TimeStepSpec {
    /// A fixed step in seconds; must not exceed the stable limit `h / (√d (c + |v|))`.
    Fixed(f64),
    /// A fraction in (0, 1] of the stable limit, re-evaluated every step.
    Cfl(f64),
}

/// End of the run.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum EndSpec {
    /// Simulated time in seconds.
    Time(f64),
    /// Number of steps.
    Steps(u64),
}

/// Background grid over a box: uniform, or graded by refinement intervals along the axes.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridSpec {
    /// Lower corner: `(x, y)` makes a 2D scene, `(x, y, z)` a 3D one.
    pub min: Coords,
    /// Upper corner; `max − min` must be a whole number of cells along each axis.
    pub max: Coords,
    /// Node spacing (outside the refinement intervals).
    pub spacing: f64,
    /// Intervals along an axis with their own spacing: the grid is rectilinear, each axis's
    /// nodes uniform inside each interval and at `spacing` between them.
    #[serde(default)]
    pub refine: Vec<RefineSpec>,
}

/// An interval along one axis of the grid with its own node spacing.
#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RefineSpec {
    /// The axis.
    pub axis: Axis,
    /// Lower end (m); the segment from the previous interval's end (or the grid's `min`) to it
    /// must hold a whole number of cells of the grid's `spacing`.
    pub min: f64,
    /// Upper end (m); `max − min` must be a whole number of cells of this interval's spacing.
    pub max: f64,
    /// Node spacing inside the interval (m).
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
    /// Optional name, shown by `fractum check` and used by `Force` probes.
    #[serde(default)]
    pub name: Option<String>,
    /// Region the particles fill.
    pub shape: ShapeSpec,
    /// Name of a material in `materials`.
    pub material: String,
    /// Particles per cell along each direction.
    #[serde(default = "default_particles_per_cell")]
    pub particles_per_cell: u32,
    /// Where particles sit inside a cell.
    #[serde(default)]
    pub placement: Placement,
    /// Initial velocity (at rest by default).
    #[serde(default)]
    pub velocity: Option<VelocitySpec>,
    /// Contact group (for contact algorithms).
    #[serde(default)]
    pub contact_group: u8,
    /// Existing cracks: particles of this body inside any of these shapes start failed
    /// (damage 1: they keep their mass and carry no stress).
    #[serde(default)]
    pub cracks: Vec<ShapeSpec>,
    /// Loads on the particles of this body (or of a region of it).
    #[serde(default)]
    pub loads: Vec<LoadSpec>,
    /// Names of bodies this body overlaps on purpose: it keeps the overlap, and their particles
    /// inside its shape are not seeded. Overlapping bodies that neither names are refused.
    #[serde(default)]
    pub wins_over: Vec<String>,
}

/// A force on the particles of a body or of a region of it, shared in proportion to their
/// volume, scaled in time by `ramp`.
#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LoadSpec {
    /// Only the body's particles inside this shape carry the load (default: all of them).
    #[serde(default)]
    pub region: Option<ShapeSpec>,
    /// Total force in N (in 2D, on the scene's thickness).
    #[serde(default)]
    pub force: Option<Coords>,
    /// Force per unit area in Pa; the total is `traction × area`.
    #[serde(default)]
    pub traction: Option<Coords>,
    /// Loaded area in m² for a traction (in 2D: loaded length × thickness).
    #[serde(default)]
    pub area: Option<f64>,
    /// `(time, factor)` points, linear between them and held outside (default: factor 1).
    #[serde(default)]
    pub ramp: Option<Vec<(f64, f64)>>,
}

fn default_particles_per_cell() -> u32 {
    2
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
    /// Concentric rings (`Disk` shapes only): `particles_per_cell` rings per cell width of the
    /// grid at the centre, each ring's particles as far apart along it as the rings are, the
    /// outermost ring's domains ending on the circle. A lattice disk's edge is a staircase whose
    /// bottom run is about `√(R h)` long and carries a rolling disk's normal force like the flat
    /// face of a box; a ring disk's edge is a polygon with sides one spacing long.
    Rings,
}

/// Initial velocity of a body.
#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum VelocitySpec {
    /// The same velocity everywhere.
    Uniform(Coords),
    /// A sine profile along one axis: `v(x) = amplitude · sin(2π (x_axis − origin) / wavelength)`.
    /// The first axial mode of a bar of length L fixed at x = 0 is `wavelength: 4L`.
    Sine {
        /// Velocity at the crests.
        amplitude: Coords,
        /// Coordinate the profile varies along.
        axis: Axis,
        /// Wavelength (m).
        wavelength: f64,
        /// Coordinate where the profile is zero.
        #[serde(default)]
        origin: f64,
    },
    /// A linear field `v(x) = G (x − origin)`, e.g. homogeneous stretching; `gradient` is
    /// written row by row, `((∂vx/∂x, ∂vx/∂y), (∂vy/∂x, ∂vy/∂y))` in 2D.
    Linear {
        /// Velocity gradient, row by row.
        gradient: Tuple<Coords>,
        /// Point where the velocity is zero (the origin by default).
        #[serde(default)]
        origin: Option<Coords>,
    },
}

/// A named essential boundary condition on a region of nodes.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundarySpec {
    /// Name; used in the `reaction_<name>_x/y/z` probe columns.
    pub name: String,
    /// Which nodes.
    pub nodes: RegionSpec,
    /// What is held.
    pub condition: ConditionSpec,
}

/// A region of grid nodes.
#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum RegionSpec {
    /// Nodes inside the box, boundary included. `Rectangle` is accepted too, as bodies name
    /// the 2D shape.
    #[serde(alias = "Rectangle")]
    Box {
        /// Lower corner.
        min: Coords,
        /// Upper corner.
        max: Coords,
    },
    /// Nodes within half a cell of a boundary group of a Gmsh mesh: a physical group of lines
    /// (2D meshes) or surfaces (3D meshes), `Mesh(file: "geometry/beam.msh", physical:
    /// "support")`.
    Mesh {
        /// The mesh file, its path relative to the scene file.
        file: String,
        /// The physical group's name.
        physical: String,
    },
}

/// A coordinate axis.
#[derive(Debug, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(deny_unknown_fields)]
pub enum Axis {
    /// x.
    X,
    /// y.
    Y,
    /// z (3D only).
    Z,
}

impl Axis {
    /// Index of the axis: 0, 1 or 2.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }
}

/// What a boundary region holds.
#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum ConditionSpec {
    /// Every velocity component zero.
    Fixed,
    /// Velocity component along `normal` zero, the others free.
    Roller {
        /// Direction of the held component.
        normal: Axis,
    },
    /// Prescribed velocity components as piecewise-linear functions of time, `[(t, v), …]`;
    /// an absent component stays free.
    Velocity {
        /// x component.
        #[serde(default)]
        x: Option<Vec<(f64, f64)>>,
        /// y component.
        #[serde(default)]
        y: Option<Vec<(f64, f64)>>,
        /// z component (3D only).
        #[serde(default)]
        z: Option<Vec<(f64, f64)>>,
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
    /// Write a VTU frame of the grid nodes that carry mass, with each velocity field's mass,
    /// velocity, normal and key, every this many steps (0: none).
    #[serde(default)]
    pub grid_every: u64,
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
    /// How frame arrays are encoded: `Zlib` (the default; ParaView and VTK read it) or `None`.
    #[serde(default)]
    pub compression: CompressionSpec,
    /// The arrays each particle frame carries beside positions (`["velocity", "damage",
    /// "stress"]`): engine fields and the columns the pipeline's systems register; every one of
    /// them when absent.
    #[serde(default)]
    pub fields: Option<Vec<String>>,
}

/// Frame compression, as the scene names it.
#[derive(Debug, Deserialize, Clone, Copy, Default, PartialEq, Eq)]
pub enum CompressionSpec {
    /// Uncompressed arrays.
    None,
    /// zlib-compressed arrays.
    #[default]
    Zlib,
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
            grid_every: 0,
            csv_every: default_csv_every(),
            probes: Vec::new(),
            last_good_frame: true,
            compression: CompressionSpec::default(),
            fields: None,
        }
    }
}

/// An extra time-series quantity, one column per axis.
#[derive(Debug, Deserialize, Clone, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum Probe {
    /// Force the named boundary region exerts on the body: `reaction_<name>_x`, `_y` (`_z`).
    Reaction(String),
    /// Centre-of-mass velocity of all particles: `com_velocity_x`, `_y` (`_z`).
    CentreOfMassVelocity,
    /// Net force on the named body, `Σ m_p a_p` over its particles: `force_<name>_x`, `_y`
    /// (`_z`) (e.g. the impact force on a hammer is minus this).
    Force(String),
    /// Displacement the named region's prescribed velocity has imposed so far (its time
    /// integral; zero for components the region holds at rest or leaves free):
    /// `displacement_<name>_x`, `_y` (`_z`).
    Displacement(String),
    /// Displacement of one particle of a body, the one that starts nearest `at`:
    /// `track_<name>_x`, `_y` (`_z`), m (NaN once the particle has left the grid). With
    /// `relative_to`, minus the displacement of that body's particle nearest `at` (the slip or
    /// opening across an interface).
    Track {
        /// Column name: letters, digits, `_` or `-`.
        name: String,
        /// Name of the body.
        body: String,
        /// Where to pick the particle at the start.
        at: Coords,
        /// Name of a second body whose particle nearest `at` is subtracted.
        #[serde(default)]
        relative_to: Option<String>,
    },
}

/// Run-safety settings.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SafetySpec {
    /// What happens to a particle that leaves the grid.
    #[serde(default)]
    pub on_leave_grid: LeaveGridSpec,
}

/// What happens to a particle that leaves the grid.
#[derive(Debug, Default, Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(deny_unknown_fields)]
pub enum LeaveGridSpec {
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
pub struct PipelineEntrySpec {
    /// Registered name, `stage/algorithm`.
    pub system: String,
    /// The system's own parameters, parsed by its installer.
    #[serde(default)]
    pub params: Option<Box<RawValue>>,
    /// Limit a stress or damage system to the particles of these materials (names in
    /// `materials`); all materials when absent.
    #[serde(default)]
    pub materials: Option<Vec<String>>,
}

/// A map whose keys must differ: RON maps read into a `BTreeMap` keep the last of two equal
/// keys, which would silently drop a material the user wrote.
fn unique_keys<'de, De, V>(deserializer: De) -> Result<BTreeMap<String, V>, De::Error>
where
    De: serde::Deserializer<'de>,
    V: Deserialize<'de>,
{
    struct UniqueKeys<V>(std::marker::PhantomData<V>);
    impl<'de, V: Deserialize<'de>> serde::de::Visitor<'de> for UniqueKeys<V> {
        type Value = BTreeMap<String, V>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a map of names to values")
        }
        fn visit_map<A: serde::de::MapAccess<'de>>(
            self,
            mut map: A,
        ) -> Result<Self::Value, A::Error> {
            let mut out = BTreeMap::new();
            while let Some(key) = map.next_key::<String>()? {
                if out.contains_key(&key) {
                    return Err(serde::de::Error::custom(format!(
                        "the name \"{key}\" is given twice; each needs its own name"
                    )));
                }
                let value = map.next_value()?;
                out.insert(key, value);
            }
            Ok(out)
        }
    }
    deserializer.deserialize_map(UniqueKeys(std::marker::PhantomData))
}
