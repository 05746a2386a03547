//! Penalty contact between particles of different contact groups, and between the faces a
//! damage-gradient partition opens within a group: a potential of the particles' positions on a
//! smoothed surface, applied to each field through the shape functions.
//!
//! - Stage: contact. Registration name: `contact/penalty`. Needs a partition system:
//!   - `partition/bodies`: one velocity field per contact group, which alone would let the
//!     bodies pass through each other; this system is then their only interaction.
//!   - `partition/dfg`: the groups' fields as with `partition/bodies`, and within a group the
//!     two sides of a crack (or of a self-contact surface) as two more fields. `between` says
//!     who meets those sides:
//!     - `Groups` (the default): this system acts between the groups, and the pipeline lists
//!       `contact/frictional` with `between: CrackFaces` before it for the crack faces
//!       (Algorithm 3 between the two sides of one group). The two laws then touch disjoint
//!       pairs of fields; this system runs after the nodal law and adds its forces to the node
//!       columns the nodal law wrote.
//!     - `All`: this system alone, with no nodal law, acts on the crack faces too. Two
//!       particles of one group are partners when some node they share holds them on
//!       different sides (`penalty_faces::FaceSides`): the partition splits a node only where
//!       both sides could separate (the separability condition, dfg-partitioning-mpm.md §2.3,
//!       with this system's `separability` as D̄_min), so intact material never is. The faces
//!       touch where their particles lay at the start of the run (`ReferencePosition`, and
//!       `penalty_law::face_touch_level`): a crack that opens feels nothing, and one pressed
//!       shut is pushed back from where the body was whole, even along a staircase of particle
//!       rows. Self-contact surfaces found by `surface` detection are faces of the same kind.
//! - The law is `contact::penalty_law` (penalty contact in MPM on the smoothed surface of each
//!   body's particles; see its header for the potential, the stiffness and the friction). It is
//!   the energy-conserving alternative to `contact/frictional` (dfg-partitioning-mpm.md §1.1.1,
//!   Algorithm 3), whose nodal projection is a plastic collision of the fields at every step
//!   and engages as soon as two bodies share a node.
//! - Per step: each particle's contact position and velocity; in bins of the largest kernel
//!   reach, each particle's depth in the other groups' material, then its pair forces; and the
//!   node force of each field `f_Ik = Σ_p N_Ip f_p` over the particles of field `k`. Sums run
//!   per particle and per node in a fixed order, so the result is the same for any thread count.
//! - Integrators. The system reads the integrator's `GridIntegration` and is placed where it
//!   says a grid force acts (`Installer::add_impulse_systems`):
//!   - Newmark (`predictor/newmark`), after the stress: the stress is evaluated in the
//!     predicted configuration `x_p + Δt Σ N ṽ_I`, so the contact is too (a force taken at the
//!     start-of-step positions lags the motion and pumps energy into a vibrating contact); the
//!     forces go to `NodeContactForce`, which the corrector integrates with the stress. With
//!     `advection/newmark`'s `Consistent` update (the default) the particles then move to that
//!     configuration; its `Published` update damps the contact's fast vibration and, with it,
//!     the energy (Charpy's elastic striker and bar lose 12.4% with it, 0.05% created without).
//!   - Update-stress-last (`predictor/usl`), in the grid-update window: the contact at the
//!     start-of-step positions, the end-of-step velocities and accelerations corrected in
//!     place, before the stress takes its velocity gradient (a symplectic Euler step of the
//!     potential).
//!   - The friction reads the grid velocity at each particle: `ṽ` (Newmark) or the end-of-step
//!     velocity before contact (update-stress-last). Held velocity components take no contact
//!     force.
//! - Particle sizes come from the initial volumes, so that the potential depends on positions
//!   alone (a size that followed the strain would change the stored energy without work).
//! - Energy: the contact energy `Σ ½ K (S − s₀)₊²` is stored energy, published as the engine's
//!   `ContactPotential` (which the energy totals add) and as the `series.csv` column
//!   `contact_energy`; the column `friction_work` accumulates the friction's work on the pairs'
//!   relative motion (≤ 0, the energy friction has dissipated).

use super::frictional_law::{ContactPairs, FrictionalParams};
pub use super::penalty_faces::{CrackFaces, FaceData, FaceQueries, FaceSides, crack_faces};
use super::penalty_faces::{check_no_nodal_law, install_crack_faces};
use super::penalty_law::KERNEL_REACH;
pub use super::penalty_law::{ContactParticle, PairContact, PairLaw, PenaltyPairs, PenaltyParams};
pub use super::penalty_pairs::{BinFrame, ContactSet, ParticleContact, particle_contacts};
use crate::transfer::velocity_gradient;
use bevy_ecs::system::SystemParam;
use fractum_engine::decomposition::{Owned, OwnedRows, RankMaximum};
use fractum_engine::energy::ContactPotential;
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// Registration of `contact/penalty`.
pub const REGISTRATION: Registration = Registration {
    name: "contact/penalty",
    summary: "penalty contact between particles of different contact groups: ½ k δ² on \
              overlapping particle domains, with Coulomb friction",
    params: &[
        ParamDoc {
            name: "stiffness",
            ty: "f64",
            default: Some("1.0"),
            doc: "κ > 0: pair stiffness k = κ Ē A / (r_a + r_b); 1 makes a layer of pairs as \
                  stiff as one particle spacing of the material",
        },
        ParamDoc {
            name: "friction",
            ty: "f64",
            default: Some("0.0"),
            doc: "Coulomb friction coefficient μ >= 0",
        },
        ParamDoc {
            name: "pairs",
            ty: "[(groups: (u8, u8), friction: f64)]",
            default: Some("[]"),
            doc: "friction coefficients for particular pairs of contact groups; other pairs use \
                  `friction`",
        },
        ParamDoc {
            name: "between",
            ty: "Groups | All",
            default: Some("Groups"),
            doc: "which particles the contact acts between: Groups (different contact groups; \
                  under partition/dfg, contact/frictional with `between: CrackFaces` listed \
                  before this entry takes the crack faces), or All, the groups and the two \
                  sides of the faces partition/dfg opens within a group (crack faces, \
                  self-contact), with no nodal law",
        },
        ParamDoc {
            name: "separability",
            ty: "f64",
            default: Some("0.25"),
            doc: "D̄_min in (0, 1), with `between: All`: the two sides of a group at a node \
                  separate only when both sides' mean damage there exceeds it (and some particle \
                  there has failed)",
        },
    ],
    requires: &["partition/*"],
    install: generic_install!(install),
};

/// Whether a nodal law (`contact/frictional`, between the sides of one group) runs before
/// this system in the same step: its forces are then in the node columns, and this system adds
/// its own to them rather than replacing them.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AddsToNodalContact(pub bool);

/// Upper bound of a pair's stiffness factor: beyond it a pair vibrates faster than the
/// material's fastest mode by more than the stable step allows (`√(2κ)` times a particle's
/// `c/h`, against a step of a fraction of `h/c`).
const MAX_STIFFNESS: f64 = 2.0;

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let parsed: PenaltyParams = params.parse()?;
    params.require(
        "stiffness",
        parsed.stiffness > 0.0 && parsed.stiffness <= MAX_STIFFNESS,
        &format!(
            "expected κ in (0, {MAX_STIFFNESS}]: a stiffer pair vibrates faster than the time \
             step resolves"
        ),
    )?;
    params.require_non_negative(
        "friction",
        parsed.friction,
        "expected a friction coefficient μ >= 0",
    )?;
    super::check_pairs(installer, params, &parsed.pairs)?;
    params.require(
        "separability",
        parsed.separability > 0.0 && parsed.separability < 1.0,
        "expected D̄_min in (0, 1)",
    )?;
    let after_nodal_law = match parsed.between {
        PenaltyPairs::Groups => check_partner_law(installer, params)?,
        PenaltyPairs::All => {
            check_no_nodal_law(installer, params)?;
            install_crack_faces::<D>(installer, parsed.separability);
            false
        }
    };
    installer.insert_resource(AddsToNodalContact(after_nodal_law));
    let moduli = ContactModuli(
        installer
            .world()
            .get_resource::<Materials>()
            .map(|m| m.0.iter().map(|m| m.youngs_modulus).collect())
            .unwrap_or_default(),
    );
    installer.insert_resource(moduli);
    installer.insert_resource(parsed);
    // Each rank of a distributed run holds the energy of the particles it owns, and sums their
    // columns; the run adds the ranks'.
    installer.init_rank_state::<ContactPotential>();
    let energy = installer.add_owned_sum_column("contact_energy");
    let friction = installer.add_owned_sum_column("friction_work");
    installer.insert_resource(PenaltyColumns { energy, friction });
    {
        // A particle's force reads its partners' depths, which read theirs: two kernel
        // reaches of the widest particle (no narrower than a cell, as seeded particles are).
        let widest = widest_particle::<D>(installer.world()).max(widest_cell::<D>(installer));
        installer.declare_particle_reach(
            "contact/penalty's depths and pair forces",
            2.0 * KERNEL_REACH * widest,
        );
        installer.add_rank_maximum(RankMaximum {
            name: "contact/penalty: the widest particle",
            wanted: |world| !world.contains_resource::<SceneWidestParticle>(),
            local: |world| widest_particle::<D>(world),
            apply: |world, widest| world.insert_resource(SceneWidestParticle(widest)),
        });
        installer.add_node_component(NodeContactForce::<D>::default());
        installer.add_node_component(NodeContactImpulse::<D>::default());
        if after_nodal_law {
            installer.add_impulse_systems(
                penalty_contact::<D>.after(super::frictional::frictional_contact::<D>),
            )
        } else {
            installer.add_impulse_systems(penalty_contact::<D>)
        }
    }
}

/// The contact law for the fields this system leaves alone: under `partition/dfg`, the two
/// sides of one group need `contact/frictional` with `between: CrackFaces`, installed (listed)
/// before this entry. Returns whether that law is there.
fn check_partner_law(installer: &Installer, params: &Params) -> Result<bool, SceneError> {
    if let Some(nodal) = installer.world().get_resource::<FrictionalParams>() {
        if nodal.between != ContactPairs::CrackFaces {
            return Err(params.error(
                "",
                "the pipeline's contact/frictional acts between contact groups as well (its \
                 `between` is All): give it `between: CrackFaces`, so that the fields of \
                 different groups meet through contact/penalty alone",
            ));
        }
        return Ok(true);
    }
    if installer.pipeline_has("contact/frictional") {
        return Err(params.error(
            "",
            "contact/penalty is listed before contact/frictional: list the nodal law first, so \
             that contact/penalty runs after it and adds its forces to the ones it writes",
        ));
    }
    if installer.pipeline_has("partition/dfg") {
        return Err(params.error(
            "",
            "under partition/dfg, contact/penalty acts between contact groups only: list \
             `contact/frictional` with `between: CrackFaces` before it, for the crack faces \
             within a group",
        ));
    }
    Ok(false)
}

/// The widest contact particle of the whole scene, which sizes the bins that find each
/// particle's partners: given by the ranks of a distributed run before the first step, so that
/// every rank bins as one process does ([`RankMaximum`]); absent in one process, whose system
/// finds it over its own particles.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct SceneWidestParticle(pub f64);

/// The widest of the particles `world` counts (a rank's owned particles; every particle in one
/// process): their domains' side from the initial volumes.
fn widest_particle<D: Dim>(world: &World) -> f64 {
    let thickness = if D::N == 2 {
        world.get_resource::<Thickness>().map_or(1.0, |t| t.0)
    } else {
        1.0
    };
    let Some(mut query) = world.try_query_filtered::<&InitialVolume, With<Particle>>() else {
        return 0.0;
    };
    Owned::in_world(world)
        .particles(query.iter(world))
        .map(|v| contact_width(v.0, thickness, D::N))
        .fold(0.0, f64::max)
}

/// The widest cell of the grid.
fn widest_cell<D: Dim>(installer: &Installer) -> f64 {
    let grid = installer.world().resource::<Grid<D>>();
    (0..D::N)
        .flat_map(|a| (0..grid.cells[a]).map(move |i| grid.cell_width(a, i)))
        .fold(0.0, f64::max)
}

/// A contact particle's width, the side of its undeformed domain.
fn contact_width(initial_volume: f64, thickness: f64, dimensions: usize) -> f64 {
    2.0 * crate::basis::domain_half_width(initial_volume, thickness, dimensions)
}

/// Young's modulus of each material, by `MaterialId`.
#[derive(Resource, Clone, Debug, Default, PartialEq)]
pub struct ContactModuli(pub Vec<f64>);

/// The slots of the `contact_energy` and `friction_work` series columns.
#[derive(Resource, Clone, Copy, Debug, PartialEq, Eq)]
pub struct PenaltyColumns {
    /// `contact_energy`: the pairs' stored energy now.
    pub energy: usize,
    /// `friction_work`: the friction's work since the start.
    pub friction: usize,
}

/// The contact force on each field of each node, `f_Ik = Σ_p (N_Ip f_p + M_p ∇N_Ip)` over the
/// particles of field `k` (node-major, in particle order), with `M_p = Σ f_t ⊗ a` the moment of
/// the particle's friction about it, and held components cleared.
pub fn node_forces<D: Dim>(
    c: &Connectivity<D>,
    forces: &[ParticleContact<D::Vector>],
    held: &[[bool; fractum_engine::boundary::MAX_COMPONENTS]],
    out: &mut [NodeContactForce<D>],
) {
    out.par_iter_mut().enumerate().for_each(|(i, node)| {
        let mut f = [D::Vector::ZERO; MAX_FIELDS];
        if let Some(&[from, to]) = c.node_offsets.get(i..i + 2) {
            for &(e, p) in &c.node_entries[from..to] {
                let (e, p) = (e as usize, p as usize);
                let contact = &forces[p];
                f[c.field(e)] += contact.force * c.weights[e];
                if contact.moment.iter().any(|m| *m != D::Vector::ZERO) {
                    f[c.field(e)] += contact.moment_force(c.gradient(e, p));
                }
            }
        }
        for fk in &mut f {
            for (a, &h) in held[i].iter().enumerate().take(D::N) {
                if h {
                    fk[a] = 0.0;
                }
            }
        }
        node.0 = f;
    });
}

/// Adds `own` to the node contact forces another law wrote this step.
fn add_forces<D: Dim>(contact: &mut [NodeContactForce<D>], own: &[NodeContactForce<D>]) {
    contact.par_iter_mut().zip(own).for_each(|(total, f)| {
        for (t, f) in total.0.iter_mut().zip(f.0) {
            *t += f;
        }
    });
}

/// The grid's spin at each particle, the skew part `Ω = ½ (L − Lᵀ)` of its velocity gradient
/// `L = Σ v_Ik ⊗ ∇N_Ip`, by rows (see [`ContactParticle::velocity_gradient`]); empty (every
/// particle's spin zero) unless friction acts at the contact point (`wanted`), which alone
/// reads it, so that a FLIP run pays nothing for it. The friction's moment reaches the nodes
/// as a pure moment (`ParticleContact::moment_force`), whose work-conjugate velocity at the
/// contact point is `v + Ω a`.
fn grid_gradients<D: Dim>(
    c: &Connectivity<D>,
    velocity: &[NodeVelocity<D>],
    wanted: bool,
) -> Vec<[D::Vector; 3]> {
    if !wanted {
        return Vec::new();
    }
    (0..c.particle_count())
        .into_par_iter()
        .map(|p| {
            let l = velocity_gradient(c, velocity, p);
            std::array::from_fn(|i| {
                D::Vector::from_fn(|j| {
                    if i < D::N && j < D::N {
                        0.5 * (l.get(i, j) - l.get(j, i))
                    } else {
                        0.0
                    }
                })
            })
        })
        .collect()
}

/// The grid velocity of each particle's field, `Σ N_Ip v_Ik` (the field of each entry).
fn grid_velocities<D: Dim>(c: &Connectivity<D>, velocity: &[NodeVelocity<D>]) -> Vec<D::Vector> {
    (0..c.particle_count())
        .into_par_iter()
        .map(|p| {
            c.row(p).fold(D::Vector::ZERO, |v, e| {
                v + velocity[c.nodes[e] as usize].0[c.field(e)] * c.weights[e]
            })
        })
        .collect()
}

/// The resources the penalty system reads.
#[derive(SystemParam)]
pub struct PenaltyInputs<'w, D: Dim> {
    clock: Res<'w, SimClock>,
    params: Res<'w, PenaltyParams>,
    moduli: Res<'w, ContactModuli>,
    integration: Res<'w, GridIntegration>,
    bcs: Res<'w, BoundaryConditions>,
    connectivity: Res<'w, Connectivity<D>>,
    thickness: Option<Res<'w, Thickness>>,
    slots: Res<'w, PenaltyColumns>,
    columns: ResMut<'w, SeriesColumns>,
    potential: ResMut<'w, ContactPotential>,
    grid: Res<'w, Grid<D>>,
    widest: Option<Res<'w, SceneWidestParticle>>,
    owned: OwnedRows<'w>,
    adds: Option<Res<'w, AddsToNodalContact>>,
}

type ParticleQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static Position<D>,
        &'static Mass,
        &'static InitialVolume,
        &'static MaterialId,
        &'static ContactGroup,
    ),
    With<Particle>,
>;

type NodeQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static NodeMass,
        &'static mut NodeVelocity<D>,
        &'static mut NodeAcceleration<D>,
        &'static mut NodeContactForce<D>,
    ),
    With<Node>,
>;

/// The particle columns the law's states are built from: positions, masses, initial volumes
/// and materials.
type ParticleColumns<'a, D> = (
    &'a [Position<D>],
    &'a [Mass],
    &'a [InitialVolume],
    &'a [MaterialId],
);

/// Each particle's state for the law: its position `lookahead` ahead along the grid's velocity
/// at it, that velocity (and the grid's spin at it where friction acts at the contact point),
/// its domain's width and its material's modulus.
fn contact_states<D: Dim>(
    (c, velocity): (&Connectivity<D>, &[NodeVelocity<D>]),
    (positions, mass, volume, material): ParticleColumns<D>,
    moduli: &ContactModuli,
    (thickness, lookahead, at_contact_point): (f64, f64, bool),
) -> Vec<ContactParticle<D::Vector>> {
    let grid_velocity = grid_velocities(c, velocity);
    let grid_gradient = grid_gradients(c, velocity, at_contact_point);
    (0..positions.len())
        .into_par_iter()
        .map(|p| ContactParticle {
            position: positions[p].0 + grid_velocity[p] * lookahead,
            velocity: grid_velocity[p],
            velocity_gradient: grid_gradient
                .get(p)
                .copied()
                .unwrap_or([D::Vector::ZERO; 3]),
            width: contact_width(volume[p].0, thickness, D::N),
            mass: mass[p].0,
            modulus: moduli
                .0
                .get(usize::from(material[p].0))
                .copied()
                .unwrap_or(0.0),
        })
        .collect()
}

/// The `contact/penalty` system, with either integrator (see the module header).
pub fn penalty_contact<D: Dim>(
    mut inputs: PenaltyInputs<D>,
    particles: ParticleQuery<D>,
    affine: Query<(), (With<Particle>, With<AffineVelocity<D>>)>,
    mut nodes: NodeQuery<D>,
    faces: FaceQueries<D>,
) {
    let Some((positions, mass, volume, material, groups)) =
        single_table(particles.contiguous_iter(), "particles")
    else {
        return;
    };
    let Some((node_mass, velocity, acceleration, contact)) =
        single_table_mut(nodes.contiguous_iter_mut(), "nodes")
    else {
        return;
    };
    let c = &*inputs.connectivity;
    let (integration, dt) = (*inputs.integration, inputs.clock.dt);
    let thickness = if D::N == 2 {
        inputs.thickness.as_ref().map_or(1.0, |t| t.0)
    } else {
        1.0
    };
    let friction =
        inputs.params.friction > 0.0 || inputs.params.pairs.iter().any(|p| p.friction > 0.0);
    // Friction at the contact point only where the transfers carry its moment (APIC).
    let at_contact_point = friction && !affine.is_empty();
    // Newmark's stress sees the predicted configuration; update-stress-last's grid update
    // the start-of-step one.
    let lookahead = match integration {
        GridIntegration::PredictorCorrector { .. } => dt,
        GridIntegration::UpdateStressLast => 0.0,
    };
    let states = contact_states(
        (c, velocity),
        (positions, mass, volume, material),
        &inputs.moduli,
        (thickness, lookahead, at_contact_point),
    );
    let law = PairLaw {
        stiffness: inputs.params.stiffness,
        friction: inputs.params.friction,
        thickness,
        dimension: D::N,
        window: integration.force_window(dt),
        at_contact_point,
    };
    let faces = crack_faces(inputs.params.between, c, &faces, groups);
    let set = ContactSet {
        particles: &states,
        groups,
        faces: faces.as_ref().map(FaceData::view),
    };
    let frame = bin_frame(&inputs, &states);
    let forces = particle_contacts(&set, &inputs.params, &law, frame);
    let held = inputs.bcs.held_mask(node_mass.len());
    let mut own = vec![NodeContactForce::<D>::default(); node_mass.len()];
    node_forces(c, &forces, &held, &mut own);
    if integration == GridIntegration::UpdateStressLast {
        kick_nodes((velocity, acceleration), (node_mass, &own), dt);
    }
    if inputs.adds.as_ref().is_some_and(|a| a.0) {
        add_forces(contact, &own);
    } else {
        contact.copy_from_slice(&own);
    }
    // Sequential sums in particle order: the same bits for any thread count. A rank of a
    // distributed run sums the particles it owns.
    let owned = inputs.owned.get();
    let energy: f64 = owned.particles(&forces).map(|f| f.energy).sum();
    let power: f64 = owned.particles(&forces).map(|f| f.friction_power).sum();
    inputs.potential.0 = energy;
    let slots = *inputs.slots;
    inputs.columns.values[slots.energy] = energy;
    inputs.columns.values[slots.friction] += power * dt;
}

/// Where the contact bins lie: from the grid's corner, as wide as the scene's widest particle
/// (this process's widest when no scene-wide one is kept).
fn bin_frame<D: Dim>(inputs: &PenaltyInputs<D>, states: &[ContactParticle<D::Vector>]) -> BinFrame {
    let widest = inputs.widest.as_ref().map_or_else(
        || states.iter().map(|p| p.width).fold(0.0, f64::max),
        |w| w.0,
    );
    let min = inputs.grid.min.to_3d();
    BinFrame {
        origin: std::array::from_fn(|a| if a < D::N { min[a] } else { 0.0 }),
        widest,
    }
}

/// Update-stress-last: the contact forces' kick of each node's velocity and acceleration
/// (Newmark's corrector applies them itself).
fn kick_nodes<D: Dim>(
    (velocity, acceleration): (&mut [NodeVelocity<D>], &mut [NodeAcceleration<D>]),
    (node_mass, contact): (&[NodeMass], &[NodeContactForce<D>]),
    dt: f64,
) {
    velocity
        .par_iter_mut()
        .zip(acceleration.par_iter_mut())
        .zip(node_mass.par_iter().zip(contact.par_iter()))
        .for_each(|((v, a), (m, f))| {
            for k in 0..MAX_FIELDS {
                if m.0[k] > 0.0 {
                    v.0[k] += f.0[k] * (dt / m.0[k]);
                    a.0[k] += f.0[k] / m.0[k];
                }
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use fractum_engine::testing::*;

    /// `fractum systems` documents the fields its parameters read, and its documented defaults
    /// are theirs.
    #[test]
    fn parameter_docs_match_the_parameters() {
        fractum_engine::testing::assert_defaults::<PenaltyParams>(&REGISTRATION);
    }

    /// Two particles of groups 0 and 1, 0.4 apart with domains 0.5 wide (overlap 0.1), on a
    /// tiny world after the basis, the field assignment and `predictor`, with the resources
    /// the installer gives.
    fn overlapping_pair<M>(
        predictor: impl IntoScheduleConfigs<bevy_ecs::system::ScheduleSystem, M>,
        integration: GridIntegration,
    ) -> World {
        pair_world(predictor, integration, |world, [a, b]| {
            world.entity_mut(a).insert(ContactGroup(0));
            world.entity_mut(b).insert(ContactGroup(1));
        })
    }

    /// The two particles of [`overlapping_pair`], given their groups and whatever else by
    /// `setup` before the basis and the field assignment run.
    fn pair_world<M>(
        predictor: impl IntoScheduleConfigs<bevy_ecs::system::ScheduleSystem, M>,
        integration: GridIntegration,
        setup: impl FnOnce(&mut World, [Entity; 2]),
    ) -> World {
        let mut world = tiny_world::<Two>(2, 0.5, 1e-3);
        world.insert_resource(PenaltyParams::default());
        world.insert_resource(ContactModuli(vec![100.0]));
        world.insert_resource(ContactPotential::default());
        let mut columns = SeriesColumns::default();
        let energy = columns.declare("contact_energy");
        let friction = columns.declare("friction_work");
        world.insert_resource(columns);
        world.insert_resource(PenaltyColumns { energy, friction });
        world.insert_resource(crate::predictor::usl::UslPredictorParams::default());
        world.insert_resource(crate::predictor::newmark::NewmarkParams::default());
        world.insert_resource(integration);
        give_nodes(&mut world, NodeContactForce::<Two>::default());
        give_nodes(&mut world, NodeContactImpulse::<Two>::default());
        // Volume 0.25 m² at unit thickness: half-width 0.25.
        let a = spawn_particle(&mut world, DVec2::new(0.3, 0.3), DVec2::ZERO, 1.0, 0.25);
        let b = spawn_particle(&mut world, DVec2::new(0.7, 0.3), DVec2::ZERO, 1.0, 0.25);
        setup(&mut world, [a, b]);
        run_system(&mut world, crate::basis::linear::linear_basis::<Two>);
        run_system(
            &mut world,
            crate::partition::field_assignment::assign_fields_system::<Two>,
        );
        run_system(&mut world, predictor);
        world
    }

    /// Sum of a node column's field vectors over all nodes and fields.
    fn total<C: Component + Copy>(
        world: &mut World,
        of: impl Fn(&C) -> [DVec2; MAX_FIELDS],
    ) -> DVec2 {
        node_values::<C>(world)
            .iter()
            .flat_map(of)
            .fold(DVec2::ZERO, |s, v| s + v)
    }

    /// What the law gives the pair of [`overlapping_pair`] at rest, computed without the ECS.
    fn pair_at_rest() -> Vec<ParticleContact<DVec2>> {
        let at = |x: f64| ContactParticle {
            position: DVec2::new(x, 0.3),
            velocity: DVec2::ZERO,
            velocity_gradient: [DVec2::ZERO; 3],
            width: 0.5,
            mass: 1.0,
            modulus: 100.0,
        };
        let law = crate::contact::penalty_law::plane_test_law();
        let set = ContactSet {
            particles: &[at(0.3), at(0.7)],
            groups: &[ContactGroup(0), ContactGroup(1)],
            faces: None,
        };
        particle_contacts(&set, &PenaltyParams::default(), &law, BinFrame::of(&set))
    }

    /// Newmark: each particle's contact force reaches the nodes of its own field, equal and
    /// opposite; the contact energy is in the potential and the series column.
    #[test]
    fn the_pair_force_reaches_each_fields_nodes_with_newmark() {
        let mut world = overlapping_pair(
            crate::predictor::newmark::newmark_predictor::<Two>,
            GridIntegration::PredictorCorrector { gamma: 0.5 },
        );
        run_system(&mut world, penalty_contact::<Two>);
        let forces = node_values::<NodeContactForce<Two>>(&mut world);
        let fields = node_values::<NodeFields>(&mut world);
        let (mut on_0, mut on_1) = (DVec2::ZERO, DVec2::ZERO);
        for (f, keys) in forces.iter().zip(&fields) {
            for (k, key) in keys.active().iter().enumerate() {
                if key.group() == 0 {
                    on_0 += f.0[k];
                } else {
                    on_1 += f.0[k];
                }
            }
        }
        let expected = pair_at_rest();
        // The domains (0.5 wide, 0.4 apart) overlap: the pair pushes apart along x.
        assert!(expected[0].force.x < 0.0 && expected[0].force.y.abs() < 1e-15);
        assert!((on_0 - expected[0].force).length() < 1e-12, "{on_0}");
        assert!((on_0 + on_1).length() < 1e-14);
        let potential = world.resource::<ContactPotential>().0;
        assert!(potential > 0.0);
        assert_eq!(potential, expected[0].energy + expected[1].energy);
        let columns = world.resource::<SeriesColumns>();
        assert_eq!(columns.value("contact_energy"), Some(potential));
        let momentum_change = total::<NodeContactForce<Two>>(&mut world, |f| f.0);
        assert!(momentum_change.length() < 1e-14);
    }

    /// The pair of [`overlapping_pair`] in one group, failed, on the two sides of a crack
    /// between them (damage gradients pointing at each other), with `between: All` and the
    /// start-of-run positions `reference`; returns the contact force on each particle, read
    /// back from its fields at its nodes, and the contact energy.
    fn crack_face_pair(reference: [f64; 2]) -> ([DVec2; 2], f64) {
        let mut world = pair_world(
            crate::predictor::newmark::newmark_predictor::<Two>,
            GridIntegration::PredictorCorrector { gamma: 0.5 },
            |world, particles| {
                world.insert_resource(fractum_engine::fields::Separability(0.25));
                let towards_the_crack = [1.0, -1.0];
                for (p, (x, g)) in particles
                    .into_iter()
                    .zip(reference.iter().zip(towards_the_crack))
                {
                    world.entity_mut(p).insert((
                        ContactGroup(0),
                        Damage(1.0),
                        DamageGradient::<Two>(DVec2::new(g, 0.0)),
                        ReferencePosition::<Two>(DVec2::new(*x, 0.3)),
                    ));
                }
            },
        );
        world.insert_resource(PenaltyParams {
            between: PenaltyPairs::All,
            ..PenaltyParams::default()
        });
        run_system(&mut world, penalty_contact::<Two>);
        let forces = node_values::<NodeContactForce<Two>>(&mut world);
        let c = world.resource::<Connectivity<Two>>();
        // Each particle's force: its field's share at each of its nodes. The two particles
        // share the nodes at x = 0.5, where they must then hold different fields.
        let on = |p: usize| {
            c.row(p).fold(DVec2::ZERO, |sum, e| {
                sum + forces[c.nodes[e] as usize].0[c.field(e)]
            })
        };
        let shared = c
            .row(0)
            .filter(|&e| c.row(1).any(|f| c.nodes[f] == c.nodes[e]));
        assert!(shared.clone().count() > 0);
        for e in shared {
            let f = c.row(1).find(|&f| c.nodes[f] == c.nodes[e]).unwrap();
            assert_ne!(c.field(e), c.field(f));
        }
        ([on(0), on(1)], world.resource::<ContactPotential>().0)
    }

    /// `between: All`: two particles of one body on the two sides of a crack press on each
    /// other as two bodies do, once they are closer than they lay when the body was whole,
    /// and not before. Laid 0.5 apart (their domains just touching), 0.4 apart now: the pair's
    /// force and energy are the two groups' of [`pair_at_rest`]. Laid where they are now:
    /// nothing, though their domains overlap.
    #[test]
    fn crack_faces_press_only_closer_than_they_lay() {
        let expected = pair_at_rest();
        let (pressed, energy) = crack_face_pair([0.25, 0.75]);
        assert!(
            (pressed[0] - expected[0].force).length() < 1e-12,
            "{pressed:?}"
        );
        assert!((pressed[0] + pressed[1]).length() < 1e-14);
        assert_eq!(energy, expected[0].energy + expected[1].energy);
        let (resting, energy) = crack_face_pair([0.3, 0.7]);
        assert_eq!(resting, [DVec2::ZERO; 2]);
        assert_eq!(energy, 0.0);
    }

    /// After a nodal law (`contact/frictional` with `between: CrackFaces` under DFG): the
    /// pair's forces are added to the node forces that law left, which stay; alone, this
    /// system replaces last step's.
    #[test]
    fn after_a_nodal_law_the_forces_add_to_its_own() {
        let nodal = DVec2::new(0.25, -2.0);
        let mut runs = Vec::new();
        for adds in [false, true] {
            let mut world = overlapping_pair(
                crate::predictor::newmark::newmark_predictor::<Two>,
                GridIntegration::PredictorCorrector { gamma: 0.5 },
            );
            world.insert_resource(AddsToNodalContact(adds));
            let mut query = world.query::<&mut NodeContactForce<Two>>();
            for mut force in query.iter_mut(&mut world) {
                force.0[0] = nodal;
            }
            let nodes = node_values::<NodeContactForce<Two>>(&mut world).len() as f64;
            run_system(&mut world, penalty_contact::<Two>);
            runs.push((total::<NodeContactForce<Two>>(&mut world, |f| f.0), nodes));
        }
        let ((alone, _), (added, nodes)) = (runs[0], runs[1]);
        // The pair's forces are equal and opposite: alone they sum to zero, added they leave
        // the nodal law's.
        assert!(alone.length() < 1e-14, "{alone}");
        assert!((added - nodal * nodes).length() < 1e-12, "{added}");
    }

    /// Update-stress-last: the force changes the end-of-step velocities of the two fields in
    /// place, by `Δt f / m` at each node, and pushes them apart.
    #[test]
    fn update_stress_last_kicks_the_fields_apart_in_the_grid_update() {
        let mut world = overlapping_pair(
            crate::predictor::usl::usl_predictor::<Two>,
            GridIntegration::UpdateStressLast,
        );
        let before = node_values::<NodeVelocity<Two>>(&mut world);
        run_system(&mut world, penalty_contact::<Two>);
        let after = node_values::<NodeVelocity<Two>>(&mut world);
        let masses = node_values::<NodeMass>(&mut world);
        let fields = node_values::<NodeFields>(&mut world);
        let mut momentum = [DVec2::ZERO; 2];
        for i in 0..after.len() {
            for (k, key) in fields[i].active().iter().enumerate() {
                momentum[usize::from(key.group())] +=
                    (after[i].0[k] - before[i].0[k]) * masses[i].0[k];
            }
        }
        // Δt f on each particle.
        let dt_force = pair_at_rest()[0].force * 1e-3;
        assert!(dt_force.x < 0.0);
        assert!((momentum[0] - dt_force).length() < 1e-15);
        assert!((momentum[1] + dt_force).length() < 1e-15);
    }

    /// Particles of one group never act on each other, however close: two of group 3
    /// overlapping each other and one of group 4 push only across the groups.
    #[test]
    fn one_group_is_left_to_the_continuum() {
        let state = |x: f64| ContactParticle {
            position: DVec2::new(x, 0.0),
            velocity: DVec2::ZERO,
            velocity_gradient: [DVec2::ZERO; 3],
            width: 1.0,
            mass: 1.0,
            modulus: 1.0,
        };
        let law = PairLaw {
            stiffness: 1.0,
            friction: 0.0,
            thickness: 1.0,
            dimension: 2,
            window: 1.0,
            at_contact_point: false,
        };
        let particles = [state(0.0), state(0.2), state(0.9)];
        let alone = ContactSet {
            particles: &particles[..2],
            groups: &[ContactGroup(3), ContactGroup(3)],
            faces: None,
        };
        let forces = particle_contacts(
            &alone,
            &PenaltyParams::default(),
            &law,
            BinFrame::of(&alone),
        );
        assert!(
            forces
                .iter()
                .all(|f| f.force == DVec2::ZERO && f.energy == 0.0)
        );
        let groups = [ContactGroup(3), ContactGroup(3), ContactGroup(4)];
        let set = ContactSet {
            particles: &particles,
            groups: &groups,
            faces: None,
        };
        let forces = particle_contacts(&set, &PenaltyParams::default(), &law, BinFrame::of(&set));
        assert!(forces[0].force.x < 0.0 && forces[1].force.x < 0.0 && forces[2].force.x > 0.0);
        let net: DVec2 = forces.iter().map(|f| f.force).sum();
        assert!(net.length() < 1e-15);
    }
    /// A particle's friction moment reaches the nodes as a moment: the node forces sum to the
    /// particle's force, and their moment about the origin is that of the friction at the
    /// contact point, `x_p × f + a × f_t`.
    #[test]
    fn the_friction_moment_turns_the_nodes_about_the_contact_point() {
        let mut world = tiny_world::<Two>(3, 0.5, 1e-3);
        let x = DVec2::new(0.6, 0.8);
        spawn_particle(&mut world, x, DVec2::ZERO, 1.0, 0.25);
        run_system(&mut world, crate::basis::linear::linear_basis::<Two>);
        let (friction, lever) = (DVec2::new(0.0, -2.0), DVec2::new(0.2, 0.05));
        let force = DVec2::new(-3.0, 0.0) + friction;
        let contact = ParticleContact {
            force,
            moment: [friction * lever.x, friction * lever.y, DVec2::ZERO],
            ..ParticleContact::default()
        };
        let grid = world.resource::<Grid<Two>>().clone();
        let c = world.resource::<Connectivity<Two>>();
        let mut nodes = vec![NodeContactForce::<Two>::default(); grid.node_count()];
        node_forces(c, &[contact], &grid_held(grid.node_count()), &mut nodes);
        let sum: DVec2 = nodes.iter().map(|f| f.0[0]).sum();
        let moment: f64 = nodes
            .iter()
            .enumerate()
            .map(|(i, f)| grid.node_position(i).perp_dot(f.0[0]))
            .sum();
        assert!((sum - force).length() < 1e-14, "{sum}");
        let expected = x.perp_dot(force) + lever.perp_dot(friction);
        assert!((moment - expected).abs() < 1e-13, "{moment} {expected}");
    }

    fn grid_held(count: usize) -> Vec<[bool; fractum_engine::boundary::MAX_COMPONENTS]> {
        vec![[false; fractum_engine::boundary::MAX_COMPONENTS]; count]
    }
}
