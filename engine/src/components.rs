//! Components: one small `Copy` component per physical quantity.
//!
//! Particles carry the [`Particle`] marker, grid nodes the [`Node`] marker; every query filters
//! by one of them. Components are never added or removed during a run (that would split the
//! storage tables): state changes are written into fields.
//!
//! Components that hold vectors or tensors are generic over the dimension `D` ([`Dim`]): a 2D
//! scene's particles carry `Position<Two>`, a 3D scene's `Position<Three>`.
//!
//! Nodes carry [`FIELDS`] velocity fields from the start. A single-field pipeline uses field 0;
//! damage-field-gradient partitioning and contact (a later stage of the work) spread material
//! over both.

use crate::dim::{Dim, MatrixOps, SymOps};
use bevy_ecs::prelude::Component;

/// Number of velocity fields every node carries.
pub const FIELDS: usize = 2;

/// Marker of a material point.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct Particle;

/// Stable particle number, assigned at creation in seeding order; used in messages and output.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct ParticleId(pub u32);

/// Current position.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct Position<D: Dim>(pub D::Vector);

/// Current velocity.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct Velocity<D: Dim>(pub D::Vector);

/// Current acceleration (used by integrators that carry it between steps).
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct Acceleration<D: Dim>(pub D::Vector);

/// Mass (constant).
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct Mass(pub f64);

/// Current volume (area × unit thickness in 2D).
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct Volume(pub f64);

/// Volume at creation.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct InitialVolume(pub f64);

/// Deformation gradient F.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct DeformationGradient<D: Dim>(pub D::Matrix);

impl<D: Dim> Default for DeformationGradient<D> {
    fn default() -> Self {
        Self(D::Matrix::IDENTITY)
    }
}

/// Cauchy stress (in plane strain with `zz` kept).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct Stress<D: Dim>(pub D::Sym);

impl<D: Dim> Default for Stress<D> {
    fn default() -> Self {
        Self(D::Sym::ZERO)
    }
}

/// Small-strain measure accumulated from the strain increments.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct Strain<D: Dim>(pub D::Sym);

impl<D: Dim> Default for Strain<D> {
    fn default() -> Self {
        Self(D::Sym::ZERO)
    }
}

/// Stored elastic energy per unit reference volume, written by the stress system.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct StrainEnergyDensity(pub f64);

/// Current dilatational wave speed of the particle's material state (m/s), for the stable time
/// step. Set from the material at creation; stress systems whose stiffness changes with
/// deformation keep it current.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct WaveSpeed(pub f64);

/// Damage in `[0, 1]`: 0 intact, 1 fully failed. Internal force is scaled by `1 − damage`.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct Damage(pub f64);

/// History variable of the damage law, e.g. the strain at crack onset; 0 until the law sets it.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct DamageHistory(pub f64);

/// Index into the scene's material table ([`crate::resources::Materials`]).
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MaterialId(pub u16);

/// Index of the body (in scene order) the particle was seeded from.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BodyId(pub u16);

/// Contact group declared by the body; used by contact algorithms.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ContactGroup(pub u8);

/// Marker of a background grid node.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct Node;

/// Linear node number (`i + nx (j + ny k)`); equals the node's row in its storage table.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
pub struct NodeIndex(pub u32);

/// Node position (fixed for a background grid).
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct NodePosition<D: Dim>(pub D::Vector);

/// Lumped mass of each velocity field.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct NodeMass(pub [f64; FIELDS]);

/// Momentum of each velocity field.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct NodeMomentum<D: Dim>(pub [D::Vector; FIELDS]);

impl<D: Dim> Default for NodeMomentum<D> {
    fn default() -> Self {
        Self([D::Vector::default(); FIELDS])
    }
}

/// Velocity of each velocity field.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct NodeVelocity<D: Dim>(pub [D::Vector; FIELDS]);

impl<D: Dim> Default for NodeVelocity<D> {
    fn default() -> Self {
        Self([D::Vector::default(); FIELDS])
    }
}

/// Acceleration of each velocity field over the current step.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct NodeAcceleration<D: Dim>(pub [D::Vector; FIELDS]);

impl<D: Dim> Default for NodeAcceleration<D> {
    fn default() -> Self {
        Self([D::Vector::default(); FIELDS])
    }
}

/// Total (internal + external) force on each velocity field.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct NodeForce<D: Dim>(pub [D::Vector; FIELDS]);

impl<D: Dim> Default for NodeForce<D> {
    fn default() -> Self {
        Self([D::Vector::default(); FIELDS])
    }
}

/// Outward surface normal of each velocity field (for contact).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct NodeNormal<D: Dim>(pub [D::Vector; FIELDS]);

impl<D: Dim> Default for NodeNormal<D> {
    fn default() -> Self {
        Self([D::Vector::default(); FIELDS])
    }
}

/// Every component a particle is created with.
#[derive(bevy_ecs::bundle::Bundle, Clone, Copy, Debug)]
pub struct ParticleBundle<D: Dim> {
    /// Marker.
    pub marker: Particle,
    /// Stable id.
    pub id: ParticleId,
    /// Position.
    pub position: Position<D>,
    /// Velocity.
    pub velocity: Velocity<D>,
    /// Acceleration.
    pub acceleration: Acceleration<D>,
    /// Mass.
    pub mass: Mass,
    /// Current volume.
    pub volume: Volume,
    /// Initial volume.
    pub initial_volume: InitialVolume,
    /// Deformation gradient.
    pub deformation_gradient: DeformationGradient<D>,
    /// Stress.
    pub stress: Stress<D>,
    /// Strain.
    pub strain: Strain<D>,
    /// Stored energy density.
    pub energy_density: StrainEnergyDensity,
    /// Wave speed.
    pub wave_speed: WaveSpeed,
    /// Damage.
    pub damage: Damage,
    /// Damage-law history.
    pub damage_history: DamageHistory,
    /// Material.
    pub material: MaterialId,
    /// Body.
    pub body: BodyId,
    /// Contact group.
    pub group: ContactGroup,
}

impl<D: Dim> ParticleBundle<D> {
    /// An unstressed particle at rest with the given id, position, mass, volume and material.
    pub fn new(id: u32, position: D::Vector, mass: f64, volume: f64, material: u16) -> Self {
        Self {
            marker: Particle,
            id: ParticleId(id),
            position: Position(position),
            velocity: Velocity::default(),
            acceleration: Acceleration::default(),
            mass: Mass(mass),
            volume: Volume(volume),
            initial_volume: InitialVolume(volume),
            deformation_gradient: DeformationGradient::default(),
            stress: Stress::default(),
            strain: Strain::default(),
            energy_density: StrainEnergyDensity::default(),
            wave_speed: WaveSpeed::default(),
            damage: Damage::default(),
            damage_history: DamageHistory::default(),
            material: MaterialId(material),
            body: BodyId(0),
            group: ContactGroup(0),
        }
    }
}

/// Every component a grid node is created with.
#[derive(bevy_ecs::bundle::Bundle, Clone, Copy, Debug)]
pub struct NodeBundle<D: Dim> {
    /// Marker.
    pub marker: Node,
    /// Linear index.
    pub index: NodeIndex,
    /// Position.
    pub position: NodePosition<D>,
    /// Field masses.
    pub mass: NodeMass,
    /// Field momenta.
    pub momentum: NodeMomentum<D>,
    /// Field velocities.
    pub velocity: NodeVelocity<D>,
    /// Field accelerations.
    pub acceleration: NodeAcceleration<D>,
    /// Field forces.
    pub force: NodeForce<D>,
    /// Field normals.
    pub normal: NodeNormal<D>,
}

impl<D: Dim> NodeBundle<D> {
    /// An empty node with the given index and position.
    pub fn new(index: u32, position: D::Vector) -> Self {
        Self {
            marker: Node,
            index: NodeIndex(index),
            position: NodePosition(position),
            mass: NodeMass::default(),
            momentum: NodeMomentum::default(),
            velocity: NodeVelocity::default(),
            acceleration: NodeAcceleration::default(),
            force: NodeForce::default(),
            normal: NodeNormal::default(),
        }
    }
}
