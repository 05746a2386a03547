//! Components: one small `Copy` component per physical quantity.
//!
//! Particles carry the [`Particle`] marker, grid nodes the [`Node`] marker; every query filters
//! by one of them. Components are never added or removed during a run (that would split the
//! storage tables): state changes are written into fields.
//!
//! Components that hold vectors or tensors are generic over the dimension `D` ([`Dim`]): a 2D
//! scene's particles carry `Position<Two>`, a 3D scene's `Position<Three>`.
//!
//! Every node has room for [`MAX_FIELDS`] velocity fields. Which material a field holds is the
//! node's business: [`NodeFields`] lists the field keys (contact group and damage side) in slot
//! order, and the connectivity says which slot each particle–node pair maps to. A single-field
//! pipeline uses slot 0 everywhere. Why a small fixed number of slots per node instead of
//! `groups × 2` fields everywhere: see ARCHITECTURE.md (velocity fields).

use crate::dim::{Dim, MatrixOps, SymOps};
use bevy_ecs::prelude::Component;
use serde::{Deserialize, Serialize};

/// Velocity fields one node can hold at once.
///
/// Four is two contact groups meeting at a node, each split in two by damage-field-gradient
/// partitioning. The number of contact groups in a scene is not limited by it: the slots are
/// assigned per node to the groups present there, and a node that would need more stops the
/// run with a message naming the node.
pub const MAX_FIELDS: usize = 4;

/// A per-field array holding `values` in the first slots and the default in the rest, e.g.
/// `NodeMass(slots(&[2.0]))` for a node with 2 kg in its one field.
pub fn slots<T: Copy + Default>(values: &[T]) -> [T; MAX_FIELDS] {
    std::array::from_fn(|k| values.get(k).copied().unwrap_or_default())
}

/// Key of a velocity field: `2 × contact group + side`, where the side (0 or 1) is the
/// particle's side of the damage-field gradient at the node (always 0 without partitioning).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
pub struct FieldKey(pub u16);

impl FieldKey {
    /// The key of `side` (0 or 1) of contact group `group`.
    pub fn new(group: u8, side: u8) -> Self {
        Self(2 * group as u16 + side as u16)
    }

    /// Contact group.
    pub fn group(self) -> u8 {
        (self.0 / 2) as u8
    }

    /// Side of the damage-field gradient (0 or 1).
    pub fn side(self) -> u8 {
        (self.0 % 2) as u8
    }
}

/// Which field each slot of a node holds: `keys[..count]`, in the order their first particle
/// appears. Without partitioning every node holds one field, key 0.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct NodeFields {
    /// Number of slots in use.
    pub count: u8,
    /// Key of each slot in use.
    pub keys: [FieldKey; MAX_FIELDS],
}

impl Default for NodeFields {
    fn default() -> Self {
        Self {
            count: 1,
            keys: [FieldKey::default(); MAX_FIELDS],
        }
    }
}

impl NodeFields {
    /// Keys of the slots in use.
    pub fn active(&self) -> &[FieldKey] {
        &self.keys[..self.count as usize]
    }
}

/// Damage state of each field at a node, for the separability condition
/// (dfg-partitioning-mpm.md §2.3, eq. 21): mass-weighted mean and maximum particle damage.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NodeFieldDamage {
    /// `Σ N m D / Σ N m` of each slot.
    pub mean: [f64; MAX_FIELDS],
    /// Largest particle damage of each slot.
    pub max: [f64; MAX_FIELDS],
}

/// Gradient of the normalised kernel damage field at the particle, `∇D̄(x_p)`
/// (dfg-partitioning-mpm.md eqs. 17–19); written by a partition system.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DamageGradient<D: Dim>(pub D::Vector);

/// Surface flag `s_p` (dfg-partitioning-mpm.md §2.4): 1 for particles detected on a surface at
/// the start of the run, 0 inside. Partitioning uses `max(s_p, D_p)` in place of `D_p`.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SurfaceFlag(pub f64);

/// External force on the particle from scene loads (N), refreshed every step.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ExternalForce<D: Dim>(pub D::Vector);

/// Marker of a material point.
#[derive(Component, Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct Particle;

/// Stable particle number, assigned at creation in seeding order; used in messages and output.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct ParticleId(pub u32);

/// Current position.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Position<D: Dim>(pub D::Vector);

/// Current velocity.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Velocity<D: Dim>(pub D::Vector);

/// Current acceleration (used by integrators that carry it between steps).
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Acceleration<D: Dim>(pub D::Vector);

/// Affine velocity `C_p` of the affine particle-in-cell transfer (APIC): the particle carries
/// the velocity field `v_p + C_p (x − x_p)` around itself, which the next particle-to-grid
/// transfer hands to its nodes, so the transfers keep angular momentum. On every particle when
/// the pipeline's advection uses `transfer: Apic`, on none otherwise.
#[derive(Component, Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AffineVelocity<D: Dim>(pub D::Matrix);

impl<D: Dim> Default for AffineVelocity<D> {
    fn default() -> Self {
        Self(D::Matrix::ZERO)
    }
}

/// Where the particle was at the start of the run. On every particle when the pipeline's
/// `contact/penalty` acts between the faces a damage-gradient partition opens within a body
/// (`between: All`): two such faces touch where their particles lay while the body was whole.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ReferencePosition<D: Dim>(pub D::Vector);

/// Mass (constant).
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Mass(pub f64);

/// Current volume (area × unit thickness in 2D).
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Volume(pub f64);

/// Volume at creation.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct InitialVolume(pub f64);

/// Deformation gradient F.
#[derive(Component, Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DeformationGradient<D: Dim>(pub D::Matrix);

impl<D: Dim> Default for DeformationGradient<D> {
    fn default() -> Self {
        Self(D::Matrix::IDENTITY)
    }
}

/// Cauchy stress (in plane strain with `zz` kept).
#[derive(Component, Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stress<D: Dim>(pub D::Sym);

impl<D: Dim> Default for Stress<D> {
    fn default() -> Self {
        Self(D::Sym::ZERO)
    }
}

/// Small-strain measure accumulated from the strain increments.
#[derive(Component, Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Strain<D: Dim>(pub D::Sym);

impl<D: Dim> Default for Strain<D> {
    fn default() -> Self {
        Self(D::Sym::ZERO)
    }
}

/// Stored elastic energy per unit reference volume, written by the stress system.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StrainEnergyDensity(pub f64);

/// Current dilatational wave speed of the particle's material state (m/s), for the stable time
/// step. Set from the material at creation; stress systems whose stiffness changes with
/// deformation keep it current.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WaveSpeed(pub f64);

/// Viscous pressure `q ≥ 0` of a shock viscosity (Pa), added to the material's pressure in the
/// internal force only: the transfers use `σ − q I`, while [`Stress`] stays the material's own
/// stress. On every particle when the pipeline has a shock viscosity, on none otherwise.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ViscousPressure(pub f64);

/// Energy a particle's viscous pressure has dissipated since the start (J; per scene thickness
/// in 2D), accumulated by the shock viscosity.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ViscousDissipation(pub f64);

/// Energy a particle's damage has dissipated since the start (J; per scene thickness in 2D):
/// the stored energy each step's damage growth released at that step's strain, accumulated by
/// the damage laws that degrade the stress (`damage/rankine`, `damage/time_to_failure`). Damage
/// a scene seeds released nothing, so it is not counted. On every particle when the pipeline
/// has such a law, on none otherwise.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DamageDissipation(pub f64);

/// Damage in `[0, 1]`: 0 intact, 1 fully failed. Internal force is scaled by `1 − damage`.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Damage(pub f64);

/// Tensile strength `σ_f` of one particle (Pa), for damage laws whose strength varies from
/// particle to particle (Weibull, dfg-partitioning-mpm.md eq. 25). Written to the frames as
/// `strength` when the pipeline has it.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Strength(pub f64);

/// A factor on a particle's tensile strength, given per particle by a particle file's
/// `strength_scale` column (as GEOS's particle files give it): the damage laws that give each
/// particle a [`Strength`] multiply it by this factor. In a scene with such a file every
/// particle carries one, 1 where no file gives it, so that all particles share one table (and
/// particles arriving at a rank of a distributed run join it).
#[derive(Component, Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct StrengthScale(pub f64);

/// Largest crack opening `w` (m) a cracking particle has reached, for damage laws with a
/// cohesive crack band (eigensoftening). Written to the frames as `crack_opening` when the
/// pipeline has it.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CrackOpening(pub f64);

/// History variable of the damage law, e.g. the strain at crack onset; 0 until the law sets it.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DamageHistory(pub f64);

/// Index into the scene's material table ([`crate::resources::Materials`]).
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MaterialId(pub u16);

/// Index of the body (in scene order) the particle was seeded from.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct BodyId(pub u16);

/// Contact group declared by the body; used by contact algorithms.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ContactGroup(pub u8);

/// Marker of a background grid node.
#[derive(Component, Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct Node;

/// Linear node number (`i + nx (j + ny k)`); equals the node's row in its storage table.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct NodeIndex(pub u32);

/// Node position (fixed for a background grid).
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NodePosition<D: Dim>(pub D::Vector);

/// Lumped mass of each velocity field.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NodeMass(pub [f64; MAX_FIELDS]);

/// Momentum of each velocity field.
#[derive(Component, Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NodeMomentum<D: Dim>(pub [D::Vector; MAX_FIELDS]);

impl<D: Dim> Default for NodeMomentum<D> {
    fn default() -> Self {
        Self([D::Vector::default(); MAX_FIELDS])
    }
}

/// Velocity of each velocity field.
#[derive(Component, Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NodeVelocity<D: Dim>(pub [D::Vector; MAX_FIELDS]);

impl<D: Dim> Default for NodeVelocity<D> {
    fn default() -> Self {
        Self([D::Vector::default(); MAX_FIELDS])
    }
}

/// Acceleration of each velocity field over the current step.
#[derive(Component, Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NodeAcceleration<D: Dim>(pub [D::Vector; MAX_FIELDS]);

impl<D: Dim> Default for NodeAcceleration<D> {
    fn default() -> Self {
        Self([D::Vector::default(); MAX_FIELDS])
    }
}

/// Total (internal + external) force on each velocity field.
#[derive(Component, Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NodeForce<D: Dim>(pub [D::Vector; MAX_FIELDS]);

impl<D: Dim> Default for NodeForce<D> {
    fn default() -> Self {
        Self([D::Vector::default(); MAX_FIELDS])
    }
}

/// Contact force on each velocity field over the current step (zero without contact).
#[derive(Component, Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NodeContactForce<D: Dim>(pub [D::Vector; MAX_FIELDS]);

impl<D: Dim> Default for NodeContactForce<D> {
    fn default() -> Self {
        Self([D::Vector::default(); MAX_FIELDS])
    }
}

/// Contact impulse on each velocity field this step that acts as a kick on the velocity, not as
/// a force (Newmark's collision part; zero without contact or with update-stress-last).
#[derive(Component, Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NodeContactImpulse<D: Dim>(pub [D::Vector; MAX_FIELDS]);

impl<D: Dim> Default for NodeContactImpulse<D> {
    fn default() -> Self {
        Self([D::Vector::default(); MAX_FIELDS])
    }
}

/// Unit normal of each velocity field, the normalised mass gradient `Σ ∇N_Ip m_p` (eq. 11) with
/// the shape-function gradient at the particle, so it points out of the field's material;
/// written by contact.
#[derive(Component, Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NodeNormal<D: Dim>(pub [D::Vector; MAX_FIELDS]);

impl<D: Dim> Default for NodeNormal<D> {
    fn default() -> Self {
        Self([D::Vector::default(); MAX_FIELDS])
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
    /// Force of scene loads.
    pub external_force: ExternalForce<D>,
    /// Which load the particle carries.
    pub load: LoadShare,
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
            external_force: ExternalForce::default(),
            load: LoadShare::default(),
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
    /// Field keys.
    pub fields: NodeFields,
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
            fields: NodeFields::default(),
        }
    }
}

/// Which load a particle carries and its share of the total (its volume over the load's).
#[derive(Component, Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LoadShare {
    /// Index into the scene's loads (`loads::ParticleLoads`), or [`LoadShare::NONE`].
    pub load: u16,
    /// Fraction of the load's total force.
    pub share: f64,
}

impl LoadShare {
    /// Index meaning "no load".
    pub const NONE: u16 = u16::MAX;
}

impl Default for LoadShare {
    fn default() -> Self {
        Self {
            load: Self::NONE,
            share: 0.0,
        }
    }
}
