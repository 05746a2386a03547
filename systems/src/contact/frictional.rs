//! Frictional contact between the velocity fields of a node, with the separability condition.
//!
//! - Stage: contact. Registration name: `contact/frictional`. Needs a partition system.
//! - Implements dfg-partitioning-mpm.md §1.1.1 (eqs. 11–16) and Algorithm 3 (§2.3) at every node
//!   with two fields or more: each field's normal (eq. 11) from the node-major connectivity, and
//!   the impulses of the law in `contact::frictional_law`.
//! - Integrators. The system never asks which integrator runs: it reads the integrator's
//!   `GridIntegration` (published by the predictor's installer) and the installer places it
//!   with `Installer::add_impulse_systems`, where that description says a grid impulse acts.
//!   - Predictor-corrector (`predictor/newmark`): it runs in the contact stage, after the
//!     stress. The end-of-step velocity is `ṽ + γΔt f/m` with the forces of the new stress
//!     (`GridIntegration::end_of_step_velocity`); the system gathers those forces, finds the
//!     impulse `Δp` Algorithm 3 asks for there, and splits it ([`split_newmark_impulse`]): the
//!     collision part `J`, the impulse the same law gives between the predicted velocities `ṽ`
//!     (what the bodies bring into the step), is a kick that corrects `ṽ` in place and goes to
//!     `NodeContactImpulse`, which the advection adds to the particle velocities as `Σ N J/m`;
//!     the rest, `(Δp − J)/(γΔt)`, is a force (what this step's stresses push across the
//!     contact) left in `NodeContactForce` for the corrector to integrate like any other. The
//!     corrected `v_I`, which moves the particles, is then exactly the one Algorithm 3 asks
//!     for, and in lasting contact (`J ≈ 0`) the node's fields move as its single field would.
//!     Taking all of `Δp/(γΔt)` as a force instead makes the fields part and the contact force
//!     alternate between twice its value and zero from step to step; taking all of `Δp` as a
//!     kick leaves the fields' own interface forces in `a_p` without the contact force that
//!     balances them (`tests/contact.rs` has the two bars that show both).
//!   - Update-stress-last (`predictor/usl`): the law must act before the stress update, as in
//!     the paper's order (eqs. 6–7: `L` from the corrected `v_i^{n+1}`), so it runs in the
//!     step's `grid_update_correction` window, after the predictor and before its health
//!     check; it corrects `v̄ⁿ⁺¹` and the nodal acceleration in place (eqs. 9–10, 13), and the
//!     stress stage takes the velocity gradient from the corrected velocities. Every pair is
//!     separable there: the field assignment has already kept inseparable sides of a group in
//!     one field, from the damage at the start of the step as the paper's partition does.
//! - Pairs (`between`). `All` acts between every pair of fields at a node, as Algorithm 3 is
//!   published. `CrackFaces` acts between the two sides of one contact group only (the crack
//!   faces and self-contact surfaces `partition/dfg` opens) and leaves the fields of different
//!   groups to `contact/penalty`, listed after this entry: that law keeps energy and lets a body
//!   roll, where the nodal projection collides the fields plastically at every step.
//! - Publishes the `series.csv` column `contact_work`: the work the contact law has done on the
//!   node fields since the start, `Σ_steps Σ_nodes Σ_k (Δp_k · v_k + |Δp_k|² / 2m_k)` with `v_k`
//!   the end-of-step velocity before contact and `Δp_k` the field's whole impulse (kick and
//!   force alike: over the step the node velocity changes by `Δp/m` either way). Negative is
//!   kinetic energy the nodal law removed: a frictionless law that only stops approach can
//!   only remove it, so this is the share of a run's energy loss that the contact takes.
//! - Slivers (`sliver_fraction`, update-stress-last only). A field that holds a tiny fraction
//!   of a shared node's mass (one particle at `N ≈ 10⁻⁵` leaving the node) gets
//!   `v̄ = (p + Δt f)/m` with a force that keeps the full `∇N` while the mass vanishes; with
//!   tent functions its velocity runs away and, through the velocity gradient, inverts the
//!   particle. Below `sliver_fraction` such a field moves with the other field of the pair (the
//!   stick impulse, momentum conserving), as a single field would there. Large values cost
//!   friction accuracy (merged slivers stick); the default 10⁻⁴ keeps the sliding block's
//!   deceleration at μg. The same runaway with no other field at the node is the tent
//!   functions' cell-crossing instability, which `basis/gimp` does not have.

pub use super::frictional_law::{
    ContactDetection, ContactNormals, ContactPairs, FieldState, FrictionalParams, PairFriction,
    PairGaps,
};
use super::frictional_law::{domain_reach, node_impulses, split_newmark_impulse};
use crate::transfer::{ForceSources, ParticleSlices, force_contribution};
use bevy_ecs::system::SystemParam;
use fractum_engine::decomposition::OwnedRows;
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// Registration of `contact/frictional`.
pub const REGISTRATION: Registration = Registration {
    name: "contact/frictional",
    summary: "Coulomb frictional contact between a node's velocity fields with the \
              separability condition (eqs. 11-16, Algorithm 3)",
    params: &[
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
            doc: "friction coefficients for particular pairs of contact groups (a group with \
                  itself for self-contact); other pairs use `friction`",
        },
        ParamDoc {
            name: "separability",
            ty: "f64",
            default: Some("0.25"),
            doc: "D̄_min in (0, 1): fields of one group separate only when both fields' mean \
                  damage at the node exceeds it (and some particle there has failed)",
        },
        ParamDoc {
            name: "normals",
            ty: "Difference | Heavier",
            default: Some("Difference"),
            doc: "pair normal: eq. 11's corrected normal (n_a - n_b)/|n_a - n_b|, or the heavier \
                  field's own normal (better for a small body on a large flat one)",
        },
        ParamDoc {
            name: "detection",
            ty: "Approach | Gap",
            default: Some("Approach"),
            doc: "when an approaching separable pair is in contact: Approach, whenever its \
                  fields share a node (Algorithm 3 as published); Gap, only where the two \
                  fields' particle domains at the node touch within the step",
        },
        ParamDoc {
            name: "between",
            ty: "All | CrackFaces",
            default: Some("All"),
            doc: "which pairs of fields the law acts between: All (Algorithm 3 as published), \
                  or CrackFaces, the two sides of one group only, with contact/penalty listed \
                  after this entry for the pairs of different groups",
        },
        ParamDoc {
            name: "sliver_fraction",
            ty: "f64",
            default: Some("1e-4"),
            doc: "update-stress-last only: a field with less than this fraction of a shared \
                  node's mass moves with the other fields there (see the module header)",
        },
        ParamDoc {
            name: "min_mass_fraction",
            ty: "f64",
            default: Some("1e-6"),
            doc: "a field takes part at a node when it holds more than this fraction of the \
                  node's mass (the ε_m of Algorithm 3, relative)",
        },
    ],
    requires: &["partition/*"],
    install: generic_install!(install),
};

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let parsed: FrictionalParams = params.parse()?;
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
    params.require(
        "min_mass_fraction",
        parsed.min_mass_fraction >= 0.0 && parsed.min_mass_fraction < 1.0,
        "expected a fraction in [0, 1)",
    )?;
    params.require(
        "sliver_fraction",
        parsed.sliver_fraction >= 0.0 && parsed.sliver_fraction < 0.5,
        "expected a fraction in [0, 0.5)",
    )?;
    if parsed.between == ContactPairs::CrackFaces && !installer.pipeline_has("contact/penalty") {
        return Err(params.error(
            "between",
            "`between: CrackFaces` leaves the fields of different contact groups to \
             contact/penalty, which the pipeline lacks: add it after this entry, or use \
             `between: All`",
        ));
    }
    // The field assignment keeps inseparable sides of a group in one field with this D̄_min.
    installer.insert_resource(fractum_engine::fields::Separability(parsed.separability));
    installer.insert_resource(parsed);
    // The work at the nodes a rank owns: a distributed run adds the ranks' columns.
    let slot = installer.add_owned_sum_column("contact_work");
    // No reach of its own for a distributed run's halo: a node's normals come from the
    // particles whose masses and momenta the node already sums, and its impulses go where
    // its velocity goes.
    installer.insert_resource(ContactWorkColumn(slot));
    {
        installer.add_node_component(NodeNormal::<D>::default());
        installer.add_node_component(NodeContactForce::<D>::default());
        installer.add_node_component(NodeContactImpulse::<D>::default());
        installer.add_impulse_systems(frictional_contact::<D>)
    }
}

type NodeQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static NodeFields,
        &'static NodeMass,
        &'static mut NodeVelocity<D>,
        &'static mut NodeAcceleration<D>,
        &'static mut NodeNormal<D>,
        &'static mut NodeContactForce<D>,
        &'static mut NodeContactImpulse<D>,
    ),
    With<Node>,
>;

/// What the contact law gives one shared node: each field's normal and impulse.
struct NodeContact<V> {
    normals: [V; MAX_FIELDS],
    impulses: [V; MAX_FIELDS],
    /// Newmark: the collision part of `impulses` (zero otherwise).
    collision: [V; MAX_FIELDS],
    /// The work of `impulses` on the node's fields ([`impulse_work`]).
    work: f64,
}

/// The work an impulse `dp` does on a field of mass `mass` moving at `velocity`: its change of
/// kinetic energy, `dp · v + |dp|² / 2m` (zero for an empty field).
pub fn impulse_work<V: VectorOps>(dp: V, mass: f64, velocity: V) -> f64 {
    if mass > 0.0 {
        dp.dot(velocity) + dp.dot(dp) / (2.0 * mass)
    } else {
        0.0
    }
}

/// The node columns the contact law reads and corrects, as plain slices in node order.
pub struct ContactColumns<'a, D: Dim> {
    /// Fields per node.
    pub fields: &'a [NodeFields],
    /// Separability statistics per node (eq. 21), read when the law acts after the stress;
    /// `None` treats every pair of fields as separable. Before the stress the field
    /// assignment has already kept inseparable sides of a group in one field.
    pub damage: Option<&'a [NodeFieldDamage]>,
    /// Field masses.
    pub mass: &'a [NodeMass],
    /// Field velocities: with update-stress-last the end-of-step velocities, corrected here.
    pub velocity: &'a mut [NodeVelocity<D>],
    /// Field accelerations, corrected with the velocities (update-stress-last).
    pub acceleration: &'a mut [NodeAcceleration<D>],
    /// Field normals, written here (zero where a node has one field).
    pub normal: &'a mut [NodeNormal<D>],
    /// Contact force per field, written here.
    pub contact: &'a mut [NodeContactForce<D>],
    /// Contact kick per field, written here (Newmark's collision part; zero otherwise).
    pub impulse: &'a mut [NodeContactImpulse<D>],
}

/// What the contact law needs besides the node columns: its parameters, the held velocity
/// components, and how the integrator turns its impulses into motion.
pub struct ContactStep<'a, V> {
    /// The law's parameters.
    pub params: &'a FrictionalParams,
    /// Per node, the velocity components a boundary condition holds.
    pub held: &'a [[bool; fractum_engine::boundary::MAX_COMPONENTS]],
    /// The integrator's description ([`GridIntegration`]).
    pub integration: GridIntegration,
    /// The step size.
    pub dt: f64,
    /// The body force per unit mass, for the forces of the new stress (Newmark).
    pub body_force: V,
    /// Per node index, whether its work counts here: the nodes a rank owns in a distributed
    /// run, every node (`None`) in one process.
    pub owned: Option<&'a [bool]>,
}

/// The particles' positions and the scene thickness (2D), from which
/// [`ContactDetection::Gap`] finds each pair's gap: a particle's domain is the square (cube) of
/// its current volume, of half-width `½ (V/t)^{1/d}`.
pub struct ParticleDomains<'a, D: Dim> {
    /// Positions, in the particle table's row order.
    pub positions: &'a [Position<D>],
    /// The scene thickness in 2D (volumes are per it); 1 in 3D.
    pub thickness: f64,
}

impl<D: Dim> ParticleDomains<'_, D> {
    /// Half-width of the domain of a particle of volume `volume`.
    fn half_width(&self, volume: f64) -> f64 {
        crate::basis::domain_half_width(volume, self.thickness, D::N)
    }
}

/// The gaps between the fields of node `i` along their pair normals ([`PairGaps`]).
fn pair_gaps<D: Dim>(
    entries: &[(u32, u32)],
    c: &Connectivity<D>,
    (slices, domains): (&ParticleSlices<D>, &ParticleDomains<D>),
    states: &[FieldState<D::Vector>],
    normals: ContactNormals,
    dt: f64,
) -> PairGaps {
    let mut gaps = [[f64::INFINITY; MAX_FIELDS]; MAX_FIELDS];
    for a in 0..states.len() {
        for b in a + 1..states.len() {
            let Some(n) = normals.pair_normal(&states[a], &states[b]) else {
                continue;
            };
            let (mut front_a, mut front_b) = (f64::NEG_INFINITY, f64::INFINITY);
            for &(e, p) in entries {
                let (field, p) = (c.field(e as usize), p as usize);
                if field != a && field != b {
                    continue;
                }
                let along = domains.positions[p].0.dot(n);
                let reach = domain_reach(domains.half_width(slices.volume[p].0), n);
                if field == a {
                    front_a = front_a.max(along + reach);
                } else {
                    front_b = front_b.min(along - reach);
                }
            }
            gaps[a][b] = front_b - front_a;
        }
    }
    PairGaps { gaps, dt }
}

/// Algorithm 3 at every node with two fields or more: normals (eq. 11), impulses, and the
/// correction the integrator's description asks for. Returns the work of the impulses on the
/// node fields (summed in node order, the same for any thread count).
pub fn apply_contact<D: Dim>(
    c: &Connectivity<D>,
    slices: &ParticleSlices<D>,
    domains: &ParticleDomains<D>,
    nodes: ContactColumns<D>,
    step: &ContactStep<D::Vector>,
) -> f64 {
    // Only nodes with two or more fields can be in contact: normals, trial velocities and
    // impulses are gathered there alone, from the node-major connectivity.
    let shared: Vec<usize> = (0..nodes.fields.len())
        .into_par_iter()
        .filter(|&i| nodes.fields[i].count >= 2)
        .collect();
    let results: Vec<NodeContact<D::Vector>> = shared
        .par_iter()
        .map(|&i| node_contact(c, (slices, domains), &nodes, step, i))
        .collect();
    write_contact(&shared, &results, nodes, step);
    let counts = |i: usize| {
        step.owned
            .is_none_or(|o| o.get(i).copied().unwrap_or(false))
    };
    shared
        .iter()
        .zip(&results)
        .filter(|(i, _)| counts(**i))
        .map(|(_, r)| r.work)
        .sum()
}

/// The statistics of fields failed throughout: every pair separable.
const SEPARABLE_EVERYWHERE: NodeFieldDamage = NodeFieldDamage {
    mean: [1.0; MAX_FIELDS],
    max: [1.0; MAX_FIELDS],
};

/// Each velocity field's normal at a node (its mass gradient, unit length; zero where the
/// field has none) and, when the integrator needs them, its force from the particles of
/// `entries` (the node's entries of the transposed table).
fn field_normals_and_forces<D: Dim>(
    c: &Connectivity<D>,
    slices: &ParticleSlices<D>,
    step: &ContactStep<D::Vector>,
    entries: &[(u32, u32)],
) -> ([D::Vector; MAX_FIELDS], [D::Vector; MAX_FIELDS]) {
    let mut gradient = [D::Vector::ZERO; MAX_FIELDS];
    let mut force = [D::Vector::ZERO; MAX_FIELDS];
    for &(e, p) in entries {
        let (e, p) = (e as usize, p as usize);
        gradient[c.field(e)] += c.gradient(e, p) * slices.mass[p].0;
        if step.integration.needs_stress_forces() {
            force[c.field(e)] += force_contribution(c, slices, step.body_force, e, p);
        }
    }
    let normals = gradient.map(|g| {
        let length = g.length();
        if length > 0.0 {
            g / length
        } else {
            D::Vector::ZERO
        }
    });
    (normals, force)
}

/// The contact law at shared node `i`: its fields' normals and impulses.
fn node_contact<D: Dim>(
    c: &Connectivity<D>,
    (slices, domains): (&ParticleSlices<D>, &ParticleDomains<D>),
    nodes: &ContactColumns<D>,
    step: &ContactStep<D::Vector>,
    i: usize,
) -> NodeContact<D::Vector> {
    let (integration, params) = (step.integration, step.params);
    let entries = match c.node_offsets.get(i..i + 2) {
        Some(&[from, to]) => &c.node_entries[from..to],
        _ => &[],
    };
    let (normals, force) = field_normals_and_forces(c, slices, step, entries);
    // The end-of-step velocity the contact acts on.
    let (mass, velocity) = (&nodes.mass[i].0, &nodes.velocity[i].0);
    let states = std::array::from_fn(|k| FieldState {
        mass: mass[k],
        velocity: integration.end_of_step_velocity(mass[k], velocity[k], force[k], step.dt),
        normal: normals[k],
        key: nodes.fields[i].keys[k],
    });
    // Before the stress the field assignment has settled which sides of a group can
    // separate; after it the partition stage's statistics of this step say so. Slivers
    // (see the module header) arise only where the end-of-step velocity comes from the
    // predictor's own forces.
    let (stats, merge_below) = match integration.impulse_window() {
        ImpulseWindow::BeforeStress => (&SEPARABLE_EVERYWHERE, params.sliver_fraction),
        ImpulseWindow::AfterStress => (nodes.damage.map_or(&SEPARABLE_EVERYWHERE, |d| &d[i]), 0.0),
    };
    let held = &step.held[i][..D::N];
    let gaps = (params.detection == ContactDetection::Gap).then(|| {
        let count = nodes.fields[i].count as usize;
        let fields = &states[..count];
        pair_gaps(
            entries,
            c,
            (slices, domains),
            fields,
            params.normals,
            step.dt,
        )
    });
    let impulses_of = |states: &[FieldState<D::Vector>; MAX_FIELDS]| {
        node_impulses(
            &nodes.fields[i],
            states,
            stats,
            params,
            held,
            merge_below,
            gaps.as_ref(),
        )
    };
    let impulses = impulses_of(&states);
    // Newmark: the part of the impulse that a collision of the predicted velocities asks
    // for, when the pair is in contact at all.
    let splits = matches!(integration, GridIntegration::PredictorCorrector { .. });
    let collision = if splits && impulses.iter().any(|dp| *dp != D::Vector::ZERO) {
        let predicted = std::array::from_fn(|k| FieldState {
            velocity: velocity[k],
            ..states[k]
        });
        impulses_of(&predicted)
    } else {
        [D::Vector::ZERO; MAX_FIELDS]
    };
    let work = (0..MAX_FIELDS)
        .map(|k| impulse_work(impulses[k], states[k].mass, states[k].velocity))
        .sum();
    NodeContact {
        normals,
        impulses,
        collision,
        work,
    }
}

/// Writes the normals, and applies each shared node's impulses as the integrator's
/// description says; every other node's contact columns are cleared.
fn write_contact<D: Dim>(
    shared: &[usize],
    results: &[NodeContact<D::Vector>],
    nodes: ContactColumns<D>,
    step: &ContactStep<D::Vector>,
) {
    let ContactColumns {
        mass,
        velocity,
        acceleration,
        normal,
        contact,
        impulse,
        ..
    } = nodes;
    normal
        .par_iter_mut()
        .for_each(|n| *n = NodeNormal::default());
    contact
        .par_iter_mut()
        .for_each(|f| *f = NodeContactForce::default());
    impulse
        .par_iter_mut()
        .for_each(|j| *j = NodeContactImpulse::default());
    let (dt, window) = (step.dt, step.integration.force_window(step.dt));
    for (&i, result) in shared.iter().zip(results) {
        normal[i].0 = result.normals;
        let dp = &result.impulses;
        match step.integration {
            GridIntegration::PredictorCorrector { .. } => {
                for (k, &m) in mass[i].0.iter().enumerate() {
                    if m > 0.0 {
                        let (kick, force) =
                            split_newmark_impulse(dp[k], result.collision[k], window);
                        velocity[i].0[k] += kick / m;
                        impulse[i].0[k] = kick;
                        contact[i].0[k] = force;
                    }
                }
            }
            GridIntegration::UpdateStressLast => {
                contact[i].0 = dp.map(|dp| dp / dt);
                for (k, (&m, &dp)) in mass[i].0.iter().zip(dp).enumerate() {
                    if m > 0.0 {
                        velocity[i].0[k] += dp / m;
                        acceleration[i].0[k] += dp / (m * dt);
                    }
                }
            }
        }
    }
}

/// The resources the contact system reads.
#[derive(SystemParam)]
pub struct ContactInputs<'w, D: Dim> {
    clock: Res<'w, SimClock>,
    params: Res<'w, FrictionalParams>,
    integration: Res<'w, GridIntegration>,
    body_force: Res<'w, BodyForce<D>>,
    bcs: Res<'w, BoundaryConditions>,
    connectivity: Res<'w, Connectivity<D>>,
    thickness: Option<Res<'w, Thickness>>,
    work_column: Res<'w, ContactWorkColumn>,
    columns: ResMut<'w, SeriesColumns>,
    owned: OwnedRows<'w>,
}

/// The slot of the `contact_work` series column.
#[derive(Resource, Clone, Copy, Debug, PartialEq, Eq)]
pub struct ContactWorkColumn(pub usize);

/// The `contact/frictional` system, with either integrator: it runs where the integrator's
/// [`GridIntegration`] says a grid impulse acts and applies its impulses as that description
/// says (see the module header).
pub fn frictional_contact<D: Dim>(
    mut inputs: ContactInputs<D>,
    particles: ForceSources<D>,
    positions: Query<&Position<D>, With<Particle>>,
    mut nodes: NodeQuery<D>,
    field_damage: Query<&NodeFieldDamage, With<Node>>,
) {
    let Some(slices) = ParticleSlices::of(&particles) else {
        return;
    };
    // The partition's separability statistics, where a partition system computes them.
    let damage = single_table(field_damage.contiguous_iter(), "nodes");
    let Some((fields, mass, velocity, acceleration, normal, contact, impulse)) =
        single_table_mut(nodes.contiguous_iter_mut(), "nodes")
    else {
        return;
    };
    let held = inputs.bcs.held_mask(fields.len());
    let columns = ContactColumns {
        fields,
        damage,
        mass,
        velocity,
        acceleration,
        normal,
        contact,
        impulse,
    };
    let step = ContactStep {
        params: &inputs.params,
        held: &held,
        integration: *inputs.integration,
        dt: inputs.clock.dt,
        body_force: inputs.body_force.0,
        owned: inputs.owned.get().node_flags(),
    };
    let domains = ParticleDomains {
        positions: single_table(positions.contiguous_iter(), "particles").unwrap_or(&[]),
        thickness: if D::N == 2 {
            inputs.thickness.map_or(1.0, |t| t.0)
        } else {
            1.0
        },
    };
    let work = apply_contact(&inputs.connectivity, &slices, &domains, columns, &step);
    // Accumulated in the column itself, which checkpoints carry.
    let slot = inputs.work_column.0;
    inputs.columns.values[slot] += work;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `fractum systems` documents the fields its parameters read, and its documented defaults are theirs.
    #[test]
    fn parameter_docs_match_the_parameters() {
        fractum_engine::testing::assert_defaults::<FrictionalParams>(&REGISTRATION);
    }
    use super::super::frictional_law::tests::state;
    use fractum_engine::testing::*;

    /// Two particles of groups 0 and 1 approaching each other across one cell of a tiny world,
    /// with `predictor` run after the basis and the field assignment, and the integrator's
    /// description `integration` published as its installer would.
    fn two_groups_meeting<M>(
        predictor: impl IntoScheduleConfigs<bevy_ecs::system::ScheduleSystem, M>,
        integration: GridIntegration,
    ) -> World {
        two_groups_at(
            predictor,
            integration,
            (0.4, 0.6),
            FrictionalParams::default(),
        )
    }

    /// As [`two_groups_meeting`], with the particles at `x` along y = 0.3 and the law's
    /// parameters `params`.
    fn two_groups_at<M>(
        predictor: impl IntoScheduleConfigs<bevy_ecs::system::ScheduleSystem, M>,
        integration: GridIntegration,
        x: (f64, f64),
        params: FrictionalParams,
    ) -> World {
        let mut world = tiny_world::<Two>(2, 0.5, 1e-3);
        world.insert_resource(params);
        let mut columns = SeriesColumns::default();
        let slot = columns.declare("contact_work");
        world.insert_resource(columns);
        world.insert_resource(ContactWorkColumn(slot));
        world.insert_resource(crate::predictor::usl::UslPredictorParams::default());
        world.insert_resource(crate::predictor::newmark::NewmarkParams::default());
        world.insert_resource(integration);
        // The node columns the installer gives nodes.
        give_nodes(&mut world, NodeNormal::<Two>::default());
        give_nodes(&mut world, NodeContactForce::<Two>::default());
        give_nodes(&mut world, NodeContactImpulse::<Two>::default());
        let a = spawn_particle(&mut world, DVec2::new(x.0, 0.3), DVec2::X, 1.0, 0.01);
        let b = spawn_particle(&mut world, DVec2::new(x.1, 0.3), -DVec2::X, 1.0, 0.01);
        world.entity_mut(a).insert(ContactGroup(0));
        world.entity_mut(b).insert(ContactGroup(1));
        run_system(&mut world, crate::basis::linear::linear_basis::<Two>);
        run_system(
            &mut world,
            crate::partition::field_assignment::assign_fields_system::<Two>,
        );
        run_system(&mut world, predictor);
        world
    }

    /// Total kinetic energy of the node fields.
    fn node_kinetic_energy(world: &mut World) -> f64 {
        let m = node_values::<NodeMass>(world);
        let v = node_values::<NodeVelocity<Two>>(world);
        m.iter()
            .zip(&v)
            .map(|(m, v)| {
                (0..MAX_FIELDS)
                    .map(|k| 0.5 * m.0[k] * v.0[k].length_squared())
                    .sum::<f64>()
            })
            .sum()
    }

    /// Total momentum of the node fields.
    fn node_momentum(world: &mut World) -> DVec2 {
        let m = node_values::<NodeMass>(world);
        let v = node_values::<NodeVelocity<Two>>(world);
        m.iter()
            .zip(&v)
            .map(|(m, v)| (0..MAX_FIELDS).map(|k| v.0[k] * m.0[k]).sum::<DVec2>())
            .sum()
    }

    /// The shared nodes (asserted to be two): their fields no longer approach along the pair
    /// normal. Returns the shared nodes' indices.
    fn assert_no_approach_left(world: &mut World) -> Vec<usize> {
        let fields = node_values::<NodeFields>(world);
        let masses = node_values::<NodeMass>(world);
        let velocities = node_values::<NodeVelocity<Two>>(world);
        let normals = node_values::<NodeNormal<Two>>(world);
        let shared: Vec<usize> = (0..fields.len())
            .filter(|&i| fields[i].count == 2)
            .collect();
        assert_eq!(shared.len(), 2);
        for &i in &shared {
            let field = |k: usize| state(masses[i].0[k], velocities[i].0[k], normals[i].0[k]);
            let n = ContactNormals::default()
                .pair_normal(&field(0), &field(1))
                .unwrap();
            let closing = (velocities[i].0[0] - velocities[i].0[1]).dot(n);
            assert!(closing.abs() < 1e-14, "node {i}: {closing}");
        }
        shared
    }

    /// With `detection: Gap` the system leaves two approaching particles alone while their
    /// domains (0.1 m squares) are apart by more than the step closes (2 m/s × 1 ms), and stops
    /// their approach once they touch within the step, as `Approach` does at once.
    #[test]
    fn the_gap_check_waits_for_the_particles_domains_to_touch() {
        let gap = FrictionalParams {
            detection: ContactDetection::Gap,
            ..FrictionalParams::default()
        };
        let usl = || crate::predictor::usl::usl_predictor::<Two>;
        // Domains [0.25, 0.35] and [0.65, 0.75]: 0.3 m apart.
        let mut apart = two_groups_at(
            usl(),
            GridIntegration::UpdateStressLast,
            (0.3, 0.7),
            gap.clone(),
        );
        let before = node_values::<NodeVelocity<Two>>(&mut apart);
        run_system(&mut apart, frictional_contact::<Two>);
        assert_eq!(node_values::<NodeVelocity<Two>>(&mut apart), before);
        assert!(
            node_values::<NodeContactForce<Two>>(&mut apart)
                .iter()
                .all(|f| f.0 == [DVec2::ZERO; MAX_FIELDS])
        );
        // Algorithm 3 as published stops them there already: they share the nodes at x = 0.5.
        let mut early = two_groups_at(
            usl(),
            GridIntegration::UpdateStressLast,
            (0.3, 0.7),
            FrictionalParams::default(),
        );
        run_system(&mut early, frictional_contact::<Two>);
        assert_no_approach_left(&mut early);
        // Domains [0.3995, 0.4995] and [0.5005, 0.6005]: 1 mm apart, closed within the step.
        let mut touching = two_groups_at(
            usl(),
            GridIntegration::UpdateStressLast,
            (0.4495, 0.5505),
            gap,
        );
        let before = node_momentum(&mut touching);
        run_system(&mut touching, frictional_contact::<Two>);
        assert!((node_momentum(&mut touching) - before).length() < 1e-15);
        assert_no_approach_left(&mut touching);
    }

    /// The system alone on a tiny world: two groups approaching across one cell (USL: the node
    /// velocities are the end-of-step velocities). Momentum is unchanged and the shared nodes'
    /// fields no longer approach.
    #[test]
    fn the_system_stops_approach_and_keeps_momentum() {
        let mut world = two_groups_meeting(
            crate::predictor::usl::usl_predictor::<Two>,
            GridIntegration::UpdateStressLast,
        );
        let before = node_momentum(&mut world);
        let kinetic = node_kinetic_energy(&mut world);
        run_system(&mut world, frictional_contact::<Two>);
        let after = node_momentum(&mut world);
        assert!((after - before).length() < 1e-15);
        assert_no_approach_left(&mut world);
        // The `contact_work` column is the kinetic energy the collision took from the fields.
        let removed = node_kinetic_energy(&mut world) - kinetic;
        let work = world.resource::<SeriesColumns>().values[0];
        assert!(
            removed < 0.0 && (work - removed).abs() < 1e-12 * removed.abs(),
            "{work} {removed}"
        );
        assert!(
            node_values::<NodeContactForce<Two>>(&mut world)
                .iter()
                .any(|f| f.0[0].x < 0.0)
        );
    }

    /// The Newmark system alone on a tiny world: two unstressed particles of two groups
    /// approaching across one cell. Everything the contact does is a collision of the
    /// predicted velocities, so it is all kick: `ṽ` is corrected in place (momentum unchanged,
    /// no approach left), the kick is in `NodeContactImpulse` and no contact force is left.
    #[test]
    fn the_newmark_system_turns_a_collision_into_a_kick() {
        let mut world = two_groups_meeting(
            crate::predictor::newmark::newmark_predictor::<Two>,
            GridIntegration::PredictorCorrector { gamma: 0.5 },
        );
        let before = node_momentum(&mut world);
        run_system(&mut world, frictional_contact::<Two>);
        assert!((node_momentum(&mut world) - before).length() < 1e-15);
        let shared = assert_no_approach_left(&mut world);
        let kicks = node_values::<NodeContactImpulse<Two>>(&mut world);
        for &i in &shared {
            assert!(kicks[i].0[0].x < 0.0, "node {i}: {:?}", kicks[i].0);
            assert!((kicks[i].0[0] + kicks[i].0[1]).length() < 1e-15);
        }
        for (i, force) in node_values::<NodeContactForce<Two>>(&mut world)
            .iter()
            .enumerate()
        {
            for k in 0..MAX_FIELDS {
                assert!(force.0[k].length() < 1e-9, "node {i}: {:?}", force.0);
            }
        }
    }
}
