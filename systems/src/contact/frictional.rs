//! Frictional contact between the velocity fields of a node, with the separability condition.
//!
//! - Stage: contact. Registration name: `contact/frictional`. Needs a partition system.
//! - Implements dfg-partitioning-mpm.md §1.1.1 (eqs. 11–16) and Algorithm 3 (§2.3):
//!   - each field's normal is its normalised mass gradient `n = Σ ∇N_Ip m_p / ‖…‖` (eq. 11);
//!     with `∇N_Ip` the shape-function gradient at the particle it points out of the field's
//!     material. A pair uses `n = (n_a − n_b)/‖n_a − n_b‖` for field a and `−n` for field b,
//!     exactly opposite;
//!   - the pair's centre-of-mass velocity `v_cm = (q_a + q_b)/(m_a + m_b)` (eq. 12);
//!   - a separable pair is in contact only while approaching, `(v_cm − v̄_a)·n < 0` with this
//!     outward `n` (Algorithm 3 writes `> 0` for the opposite orientation of the normal); then
//!     the normal impulse is `m_a (v_cm − v̄_a)·n` (eq. 14) and the tangential one is the stick
//!     impulse capped at `μ` times the normal one (eqs. 15–16);
//!   - a pair that is not separable moves as one field: both take `v_cm`.
//!   - separability (§2.3): fields of different contact groups always; fields of one group only
//!     when some particle at the node has failed (`max D = 1`) and both fields' mean damage
//!     exceeds `separability` (D̄_min), from the partition stage's `NodeFieldDamage`.
//! - The tangential impulse is the tangential part of the stick impulse itself,
//!   `Δp − (Δp·n) n`, so no tangent basis is built: there is no basis that could differ between
//!   the two fields, and the friction acts against the actual slip direction in 2D and 3D.
//! - Impulses are computed once per pair and applied with opposite signs, so momentum is
//!   conserved to round-off. A node with more than two fields takes its pairs one after the
//!   other, each from the velocities the pairs before it left, in sweeps until no pair acts
//!   ([`node_impulses`]); summed from the velocities before contact, the pairs would stop a field
//!   once per partner. Velocity components held by a boundary condition are left alone on both
//!   fields.
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
//! - Slivers (`sliver_fraction`, update-stress-last only). A field that holds a tiny fraction
//!   of a shared node's mass (one particle at `N ≈ 10⁻⁵` leaving the node) gets
//!   `v̄ = (p + Δt f)/m` with a force that keeps the full `∇N` while the mass vanishes; with
//!   tent functions its velocity runs away (263 m/s in one step) and, through the velocity
//!   gradient, inverts the particle. Below `sliver_fraction` such a field moves with the other
//!   field of the pair (the stick impulse, momentum conserving), as a single field would there.
//!   Measured on the two disks with `basis/linear`: without it the run stops at step 2581 (a
//!   field at 2·10⁻⁷ of its node, under `min_mass_fraction`, was left alone), with 10⁻⁵ to 0.1
//!   it keeps 83.5–84% of the kinetic energy. It costs friction accuracy when it is large
//!   (merged slivers stick): the sliding block with `basis/gimp` decelerates at μg within 0.03%
//!   with 10⁻⁴, 2.3% above with 10⁻³ and stops far too early with 10⁻². The default is 10⁻⁴.
//!   The same runaway with no other field at the node is the tent functions' cell-crossing
//!   instability, with or without contact; `basis/gimp` has none (see `predictor/usl`).
//! - Normals (`normals`): `Difference` (the default) is eq. 11 as printed,
//!   `n = (n_a − n_b)/‖n_a − n_b‖`. `Heavier` takes the normal of the field with more mass at
//!   the node and its opposite for the other: the mass weighting that §1.1.1 notes "may improve
//!   the response, particularly when one field is present in a very small fraction". Measured
//!   (`tests/contact.rs`): for a block sliding on a larger flat substrate, `Heavier` gives μg
//!   within 0.1% and no braking with μ = 0, where `Difference` lets the block's corner normals
//!   (tilted 45°) plough it into the substrate (−29% against μg, 1.25 m/s² of braking with
//!   μ = 0). For two equal spheres meeting head-on `Difference` is the better choice (79% of the
//!   kinetic energy back; `Heavier` 70%, and it lets particles overlap where a field's interior
//!   node, with no meaningful mass gradient, is the heavier one). Weighting the normals by
//!   mass, mass² or mass⁴, or taking the larger mass gradient, did worse on both.

use crate::transfer::{ForceSources, ParticleSlices, force_contribution};
use bevy_ecs::system::SystemParam;
use fractum_engine::prelude::*;
use rayon::prelude::*;
use serde::Deserialize;

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
    install,
};

/// Parameters of `contact/frictional`.
#[derive(Resource, Deserialize, Clone, Debug, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FrictionalParams {
    /// Coulomb coefficient μ.
    #[serde(default)]
    pub friction: f64,
    /// Coefficients for particular pairs of contact groups.
    #[serde(default)]
    pub pairs: Vec<PairFriction>,
    /// Separability threshold D̄_min.
    #[serde(default = "default_separability")]
    pub separability: f64,
    /// How a pair's common normal is formed.
    #[serde(default)]
    pub normals: ContactNormals,
    /// Relative mass threshold ε_m.
    #[serde(default = "default_min_mass_fraction")]
    pub min_mass_fraction: f64,
    /// With update-stress-last, a field holding less than this fraction of a shared node's
    /// mass moves with the other fields there.
    #[serde(default = "default_sliver_fraction")]
    pub sliver_fraction: f64,
}

/// The friction coefficient of one pair of contact groups.
#[derive(Deserialize, Clone, Copy, Debug, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PairFriction {
    /// The two groups, in either order; the same group twice for self-contact.
    pub groups: (u8, u8),
    /// Coulomb coefficient μ between them.
    pub friction: f64,
}

impl FrictionalParams {
    /// The Coulomb coefficient between fields of groups `a` and `b`.
    pub fn friction_between(&self, a: u8, b: u8) -> f64 {
        self.pairs
            .iter()
            .find(|p| p.groups == (a, b) || p.groups == (b, a))
            .map_or(self.friction, |p| p.friction)
    }
}

/// Relative difference of two field masses within which [`ContactNormals::Heavier`] calls them
/// a tie, when their normals also disagree by more than 5° ([`TIE_AGREEMENT`]); the lower
/// contact group's field then sets the normal. Where two bodies of one density and particle
/// spacing both cover a node, their masses differ only by the particles' strain and phase
/// against the node (2·10⁻⁴ for a block resting on a substrate), so which one is heavier says
/// nothing about whose surface is flat. Measured on the sliding block with μ = 0
/// (`tests/contact.rs`):
/// - by mass alone, the block's normal, tilted 14° by its front edge one cell away, won such a
///   node and braked the block by 3 mN s in one step (0.26% of μg over 0.1 s, at four of five
///   step sizes); with the tie rule, 10–15 µN s at all five;
/// - without the 5° condition the tie also moved interior nodes, where the block's flat bottom
///   is the better normal and the substrate's is tilted by its dent: under USL with GIMP the
///   braking rose from 0.094% to 0.118% of μg (with the condition: 0.094%);
/// - breaking the tie by the shorter mass gradient, or by eq. 11's average, braked more.
pub const MASS_TIE: f64 = 1e-3;

/// Cosine of 5°: two fields' normals (one reversed) closer than this agree, and a mass tie
/// between them keeps the heavier field's normal (see [`MASS_TIE`]).
pub const TIE_AGREEMENT: f64 = 0.996_194_698_091_745_5;

/// How the common normal of a contact pair is formed from the fields' normals (eq. 11).
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
pub enum ContactNormals {
    /// Eq. 11's corrected normals `n_a* = −n_b* = (n_a − n_b)/‖n_a − n_b‖`.
    #[default]
    Difference,
    /// The normal of the field with more mass at the node, and its opposite for the other
    /// field. When the masses tie and the normals disagree ([`MASS_TIE`]), the field of the
    /// lower contact group sets it: give the body whose surface should rule (a substrate, an
    /// anvil) the lower group.
    Heavier,
}

impl ContactNormals {
    /// Outward unit normal of field `a` towards field `b`, or `None` when it is undefined.
    pub fn pair_normal<V: VectorOps>(self, a: &FieldState<V>, b: &FieldState<V>) -> Option<V> {
        let tie = (a.mass - b.mass).abs() <= MASS_TIE * a.mass.max(b.mass)
            && -a.normal.dot(b.normal) < TIE_AGREEMENT;
        let a_sets_it = if tie { a.key <= b.key } else { a.mass > b.mass };
        let direction = match self {
            Self::Heavier if a_sets_it => a.normal,
            Self::Heavier => -b.normal,
            Self::Difference => a.normal - b.normal,
        };
        let length = direction.length();
        (length > 0.0).then(|| direction / length)
    }
}

fn default_separability() -> f64 {
    0.25
}

fn default_min_mass_fraction() -> f64 {
    1e-6
}

fn default_sliver_fraction() -> f64 {
    1e-4
}

impl Default for FrictionalParams {
    fn default() -> Self {
        Self {
            friction: 0.0,
            pairs: Vec::new(),
            separability: default_separability(),
            normals: ContactNormals::default(),
            min_mass_fraction: default_min_mass_fraction(),
            sliver_fraction: default_sliver_fraction(),
        }
    }
}

fn install(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let parsed: FrictionalParams = params.parse()?;
    params.require_non_negative(
        "friction",
        parsed.friction,
        "expected a friction coefficient μ >= 0",
    )?;
    check_pairs(installer, params, &parsed.pairs)?;
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
    // The field assignment keeps inseparable sides of a group in one field with this D̄_min.
    installer.insert_resource(fractum_engine::fields::Separability(parsed.separability));
    installer.insert_resource(parsed);
    with_dim!(installer.dimension(), D => installer.add_impulse_systems(frictional_contact::<D>))
}

/// Every pair names groups some body belongs to, once, with μ >= 0.
fn check_pairs(
    installer: &mut Installer,
    params: &Params,
    pairs: &[PairFriction],
) -> Result<(), SceneError> {
    let mut groups: Vec<u8> = installer
        .world()
        .iter_entities()
        .filter_map(|e| e.get::<ContactGroup>().map(|g| g.0))
        .collect();
    groups.sort_unstable();
    groups.dedup();
    let listed = groups
        .iter()
        .map(|g| g.to_string())
        .collect::<Vec<_>>()
        .join(", ");
    for (k, pair) in pairs.iter().enumerate() {
        for group in [pair.groups.0, pair.groups.1] {
            if groups.binary_search(&group).is_err() {
                return Err(params.error(
                    &format!("pairs[{k}].groups"),
                    format!(
                        "unknown contact group {group}: the bodies' contact groups are {listed}"
                    ),
                ));
            }
        }
        params.require_non_negative(
            &format!("pairs[{k}].friction"),
            pair.friction,
            "expected a friction coefficient μ >= 0",
        )?;
        let (a, b) = pair.groups;
        if pairs[..k]
            .iter()
            .any(|p| p.groups == (a, b) || p.groups == (b, a))
        {
            return Err(params.error(
                &format!("pairs[{k}].groups"),
                format!("groups ({a}, {b}) are listed twice"),
            ));
        }
    }
    Ok(())
}

/// One field of a contact pair at a node: mass, trial velocity and normal (eq. 11).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldState<V> {
    /// Mass `m_ς`.
    pub mass: f64,
    /// Velocity before contact `v̄_ς`.
    pub velocity: V,
    /// Outward normal `n_ς`, the normalised mass gradient of eq. 11.
    pub normal: V,
    /// The field's key (contact group and side); it breaks `Heavier`'s mass ties.
    pub key: FieldKey,
}

/// Momentum change of field `a` from its contact with field `b` (Algorithm 3, lines 8–28);
/// field `b` receives the opposite.
pub fn pair_impulse<V: VectorOps>(
    a: &FieldState<V>,
    b: &FieldState<V>,
    friction: f64,
    separable: bool,
    normals: ContactNormals,
) -> V {
    let total = a.mass + b.mass;
    let v_cm = (a.velocity * a.mass + b.velocity * b.mass) / total;
    // The stick impulse: field a brought to the centre-of-mass velocity.
    let stick = (v_cm - a.velocity) * a.mass;
    if !separable {
        return stick;
    }
    // Outward normal of field a: from a towards b.
    let Some(n) = normals.pair_normal(a, b) else {
        return V::ZERO;
    };
    let normal = stick.dot(n);
    if normal >= 0.0 {
        // Separating or at rest relative to each other: no contact force (line 16).
        return V::ZERO;
    }
    let tangential = stick - n * normal;
    let slip = tangential.length();
    let limit = -friction * normal;
    if slip <= limit {
        stick
    } else {
        n * normal + tangential * (limit / slip)
    }
}

/// Whether two fields of a node may slide and separate (§2.3).
pub fn separable(
    a: FieldKey,
    b: FieldKey,
    damage: &NodeFieldDamage,
    (ka, kb): (usize, usize),
    threshold: f64,
) -> bool {
    a.group() != b.group()
        || (damage.max[ka].max(damage.max[kb]) >= 1.0
            && damage.mean[ka].min(damage.mean[kb]) > threshold)
}

/// Gauss–Seidel sweeps over the pairs of a node with three fields or more (two fields need one
/// pass, which is exact).
pub const MAX_SWEEPS: usize = 8;

/// Contact impulses of every field of one node. A pair in which one field holds less than
/// `merge_below` of the node's mass moves as one field (the stick impulse, whatever the
/// separability); `merge_below = 0` leaves every pair to Algorithm 3.
///
/// With three fields or more (two contact groups where one is split by its damage gradient),
/// the pairs are taken one after the other, each from the velocities the pairs before it left
/// (Gauss–Seidel), in sweeps until no pair is approaching, at most [`MAX_SWEEPS`]. Every pair's
/// impulse only removes approach and bounded slip, so no sweep can add energy. Summing the pairs'
/// impulses, each from the velocities before contact, applies a field's approach once per
/// partner: a platen field meeting both sides of a cracked disk at one node was stopped twice
/// and sent back, and the Brazilian disk with DFG partitioning at Δx = 0.067 mm created 13% of
/// its energy in 1.5 µs.
pub fn node_impulses<V: VectorOps>(
    fields: &NodeFields,
    states: &[FieldState<V>; MAX_FIELDS],
    damage: &NodeFieldDamage,
    params: &FrictionalParams,
    held: &[bool],
    merge_below: f64,
) -> [V; MAX_FIELDS] {
    let mut impulses = [V::ZERO; MAX_FIELDS];
    let count = fields.count as usize;
    let total: f64 = states[..count].iter().map(|s| s.mass).sum();
    let present = |k: usize| states[k].mass > params.min_mass_fraction * total;
    let mut current = *states;
    let sweeps = if count > 2 { MAX_SWEEPS } else { 1 };
    for sweep in 0..sweeps {
        let mut acted = false;
        for a in 0..count {
            for b in a + 1..count {
                let lighter = states[a].mass.min(states[b].mass);
                let merged = lighter > 0.0 && lighter < merge_below * total;
                let takes_part = merged || (present(a) && present(b));
                if !takes_part {
                    continue;
                }
                let can_separate = !merged
                    && separable(
                        fields.keys[a],
                        fields.keys[b],
                        damage,
                        (a, b),
                        params.separability,
                    );
                let friction =
                    params.friction_between(fields.keys[a].group(), fields.keys[b].group());
                let mut dp = pair_impulse(
                    &current[a],
                    &current[b],
                    friction,
                    can_separate,
                    params.normals,
                );
                for (c, is_held) in held.iter().enumerate() {
                    if *is_held {
                        dp[c] = 0.0;
                    }
                }
                if dp == V::ZERO {
                    continue;
                }
                // With sweeps: round-off of a pair already moving together is no reason for
                // another sweep, and after the first not worth applying. (Two fields take one
                // pass and every impulse.)
                if sweeps > 1 {
                    let scale = (current[a].velocity * current[a].mass).length()
                        + (current[b].velocity * current[b].mass).length();
                    let round_off = dp.length() <= 1e-14 * scale;
                    if round_off && sweep > 0 {
                        continue;
                    }
                    acted |= !round_off;
                }
                impulses[a] += dp;
                impulses[b] -= dp;
                current[a].velocity += dp / current[a].mass;
                current[b].velocity -= dp / current[b].mass;
            }
        }
        if !acted {
            break;
        }
    }
    impulses
}

type NodeQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static NodeFields,
        &'static NodeFieldDamage,
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
}

/// Algorithm 3 at every node with two fields or more: normals (eq. 11), impulses, and the
/// correction the integrator's description asks for.
pub fn apply_contact<D: Dim>(
    c: &Connectivity<D>,
    slices: &ParticleSlices<D>,
    nodes: ContactColumns<D>,
    step: &ContactStep<D::Vector>,
) {
    // Only nodes with two or more fields can be in contact: normals, trial velocities and
    // impulses are gathered there alone, from the node-major connectivity.
    let shared: Vec<usize> = (0..nodes.fields.len())
        .into_par_iter()
        .filter(|&i| nodes.fields[i].count >= 2)
        .collect();
    let results: Vec<NodeContact<D::Vector>> = shared
        .par_iter()
        .map(|&i| node_contact(c, slices, &nodes, step, i))
        .collect();
    write_contact(&shared, &results, nodes, step);
}

/// The statistics of fields failed throughout: every pair separable.
const SEPARABLE_EVERYWHERE: NodeFieldDamage = NodeFieldDamage {
    mean: [1.0; MAX_FIELDS],
    max: [1.0; MAX_FIELDS],
};

/// The contact law at shared node `i`: its fields' normals and impulses.
fn node_contact<D: Dim>(
    c: &Connectivity<D>,
    slices: &ParticleSlices<D>,
    nodes: &ContactColumns<D>,
    step: &ContactStep<D::Vector>,
    i: usize,
) -> NodeContact<D::Vector> {
    let (integration, params) = (step.integration, step.params);
    let entries = match c.node_offsets.get(i..i + 2) {
        Some(&[from, to]) => &c.node_entries[from..to],
        _ => &[],
    };
    let mut gradient = [D::Vector::ZERO; MAX_FIELDS];
    let mut force = [D::Vector::ZERO; MAX_FIELDS];
    for &(e, p) in entries {
        let (e, p) = (e as usize, p as usize);
        gradient[c.field(e)] += c.gradients[e] * slices.mass[p].0;
        if integration.needs_stress_forces() {
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
    let impulses = node_impulses(&nodes.fields[i], &states, stats, params, held, merge_below);
    // Newmark: the part of the impulse that a collision of the predicted velocities asks
    // for, when the pair is in contact at all.
    let splits = matches!(integration, GridIntegration::PredictorCorrector { .. });
    let collision = if splits && impulses.iter().any(|dp| *dp != D::Vector::ZERO) {
        let predicted = std::array::from_fn(|k| FieldState {
            velocity: velocity[k],
            ..states[k]
        });
        node_impulses(
            &nodes.fields[i],
            &predicted,
            stats,
            params,
            held,
            merge_below,
        )
    } else {
        [D::Vector::ZERO; MAX_FIELDS]
    };
    NodeContact {
        normals,
        impulses,
        collision,
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

/// Newmark's split of a field's contact impulse `Δp` into the kick `J` that acts on the
/// velocity at once and the force `(Δp − J)/(γΔt)` that the corrector integrates like any
/// other, given the `collision` impulse the contact law asks for between the predicted
/// velocities `ṽ`. The kick is the collision of what the bodies bring into the step; the force
/// balances what this step's stresses do to them, as the node's single field would. Over the
/// step the node velocity changes by `Δp/m` either way; the split decides what the particles
/// carry into the next predictor (see the module header). Returns `(J, force)`.
pub fn split_newmark_impulse<V: VectorOps>(impulse: V, collision: V, gamma_dt: f64) -> (V, V) {
    (collision, (impulse - collision) / gamma_dt)
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
}

/// The `contact/frictional` system, with either integrator: it runs where the integrator's
/// [`GridIntegration`] says a grid impulse acts and applies its impulses as that description
/// says (see the module header).
pub fn frictional_contact<D: Dim>(
    inputs: ContactInputs<D>,
    particles: ForceSources<D>,
    mut nodes: NodeQuery<D>,
) {
    let Some(slices) = ParticleSlices::of(&particles) else {
        return;
    };
    let Some((
        fields,
        damage,
        mass,
        mut velocity,
        mut acceleration,
        mut normal,
        mut contact,
        mut impulse,
    )) = single_table(nodes.contiguous_iter_mut(), "nodes")
    else {
        return;
    };
    let held = inputs.bcs.held_mask(fields.len());
    let columns = ContactColumns {
        fields,
        damage: Some(damage),
        mass,
        velocity: &mut velocity,
        acceleration: &mut acceleration,
        normal: &mut normal,
        contact: &mut contact,
        impulse: &mut impulse,
    };
    let step = ContactStep {
        params: &inputs.params,
        held: &held,
        integration: *inputs.integration,
        dt: inputs.clock.dt,
        body_force: inputs.body_force.0,
    };
    apply_contact(&inputs.connectivity, &slices, columns, &step);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `fractum systems` documents the fields its parameters read, and its documented defaults are theirs.
    #[test]
    fn parameter_docs_match_the_parameters() {
        crate::param_docs::assert_defaults::<FrictionalParams>(&REGISTRATION);
    }
    use fractum_engine::testing::*;

    fn state<V>(mass: f64, velocity: V, normal: V) -> FieldState<V> {
        FieldState {
            mass,
            velocity,
            normal,
            key: FieldKey::default(),
        }
    }

    #[test]
    fn approaching_fields_meet_at_the_centre_of_mass_without_friction() {
        // Field a, below field b (outward normal +y), moves up into b at rest.
        let a = state(1.0, DVec2::new(0.0, 2.0), DVec2::new(0.0, 1.0));
        let b = state(3.0, DVec2::ZERO, DVec2::new(0.0, -1.0));
        let dp = pair_impulse(&a, &b, 0.0, true, ContactNormals::Difference);
        assert!((dp - DVec2::new(0.0, -1.5)).length() < 1e-15);
        // Moving apart: nothing.
        let a_leaving = state(1.0, DVec2::new(0.0, -2.0), DVec2::new(0.0, 1.0));
        assert_eq!(
            pair_impulse(&a_leaving, &b, 0.3, true, ContactNormals::Difference),
            DVec2::ZERO
        );
        // Not separable: a single field, tangential velocity shared too.
        let sliding = state(1.0, DVec2::new(4.0, 2.0), DVec2::new(0.0, 1.0));
        let dp = pair_impulse(&sliding, &b, 0.0, false, ContactNormals::Difference);
        assert!((dp - DVec2::new(-3.0, -1.5)).length() < 1e-15);
    }

    /// Friction opposes the slip along a direction that is not a grid axis, in 3D, with a
    /// contact normal that is not a grid axis either.
    #[test]
    fn friction_opposes_the_slip_direction_in_3d() {
        let n = DVec3::new(0.0, 0.6, 0.8);
        let slip = DVec3::new(3.0, 2.4, -1.8); // tangential: n · slip = 0
        assert!(n.dot(slip).abs() < 1e-15);
        // Field a on the −n side of b, approaching it while slipping.
        let a = state(2.0, slip + n, n);
        let b = state(2.0, DVec3::ZERO, -n);
        let mu = 0.2;
        let dp = pair_impulse(&a, &b, mu, true, ContactNormals::Difference);
        let stick = ((a.velocity + b.velocity) * 0.5 - a.velocity) * 2.0;
        let normal = -stick.dot(n);
        assert!((normal - 1.0).abs() < 1e-14);
        assert!((dp.dot(n) + normal).abs() < 1e-14);
        let tangential = dp - n * dp.dot(n);
        // Sliding: the tangential impulse is μ × normal, against the slip.
        assert!((tangential.length() - mu * normal).abs() < 1e-14);
        assert!((tangential.normalize() + slip.normalize()).length() < 1e-14);
        // The same pair in 2D, slipping along x, with a normal at 30° to the axes.
        let n2 = DVec2::new(0.5, 3f64.sqrt() / 2.0);
        let t2 = DVec2::new(n2.y, -n2.x);
        let a2 = state(1.0, t2 * 5.0 + n2, n2);
        let b2 = state(1.0, DVec2::ZERO, -n2);
        let dp2 = pair_impulse(&a2, &b2, mu, true, ContactNormals::Difference);
        assert!(dp2.dot(n2) < 0.0);
        let tangential2 = dp2 - n2 * dp2.dot(n2);
        assert!((tangential2.normalize() + t2).length() < 1e-14);
    }

    /// At a node where a light field meets a heavy one, `Heavier` uses the heavy field's normal
    /// (a flat substrate under a block's tilted corner) and `Difference` averages the two.
    #[test]
    fn the_heavier_field_sets_the_pair_normal() {
        let corner = state(0.1, DVec2::new(1.0, 0.0), DVec2::new(1.0, -1.0).normalize());
        let substrate = state(2.0, DVec2::ZERO, DVec2::new(0.0, 1.0));
        let heavier = ContactNormals::Heavier;
        let n = heavier.pair_normal(&corner, &substrate).unwrap();
        assert!((n - DVec2::new(0.0, -1.0)).length() < 1e-15);
        assert_eq!(heavier.pair_normal(&substrate, &corner), Some(-n));
        let averaged = ContactNormals::Difference
            .pair_normal(&corner, &substrate)
            .unwrap();
        assert!(averaged.x > 0.3);
        // The corner slides along the flat substrate: no normal approach, so no impulse with
        // `Heavier`; the tilted average ploughs it (a backward impulse) without any friction.
        assert_eq!(
            pair_impulse(&corner, &substrate, 0.0, true, heavier),
            DVec2::ZERO
        );
        let ploughed = pair_impulse(&corner, &substrate, 0.0, true, ContactNormals::Difference);
        assert!(ploughed.x < 0.0);
    }

    #[test]
    fn pairs_of_groups_override_the_friction() {
        let params = FrictionalParams {
            friction: 0.1,
            pairs: vec![PairFriction {
                groups: (2, 0),
                friction: 0.04,
            }],
            ..FrictionalParams::default()
        };
        assert_eq!(params.friction_between(0, 2), 0.04);
        assert_eq!(params.friction_between(2, 0), 0.04);
        assert_eq!(params.friction_between(0, 1), 0.1);
        assert_eq!(params.friction_between(2, 2), 0.1);
    }

    /// A sliver field leaving a heavy one: Algorithm 3 leaves it alone (separating, or below
    /// ε_m); under `merge_below` it moves with the heavy field, and momentum is conserved.
    #[test]
    fn slivers_move_with_the_other_field_when_merged() {
        let fields = NodeFields {
            count: 2,
            keys: [FieldKey(0), FieldKey(2), FieldKey(0), FieldKey(0)],
        };
        let mut states = [state(0.0, DVec2::ZERO, DVec2::ZERO); MAX_FIELDS];
        states[0] = state(1e-7, DVec2::new(-263.0, 124.0), DVec2::new(-1.0, 0.0));
        states[1] = state(2.0, DVec2::new(0.0065, 0.0054), DVec2::new(1.0, 0.0));
        let damage = NodeFieldDamage::default();
        let params = FrictionalParams::default();
        let alone = node_impulses(&fields, &states, &damage, &params, &[false; 2], 0.0);
        assert_eq!(alone[0], DVec2::ZERO);
        let merged = node_impulses(&fields, &states, &damage, &params, &[false; 2], 1e-4);
        let after = states[0].velocity + merged[0] / states[0].mass;
        let v_cm = (states[0].velocity * 1e-7 + states[1].velocity * 2.0) / (2.0 + 1e-7);
        assert!((after - v_cm).length() < 1e-9, "{after}");
        assert_eq!(merged[0] + merged[1], DVec2::ZERO);
    }

    /// A light platen field meets both sides of a cracked body at one node, each side heavy and
    /// at rest. The pairs taken one after the other stop the platen once; summed, each pair
    /// would stop it again, and the particles, which take `Δp/(γ m)` of the contact impulse
    /// under Newmark (`γ = 1/2`), would leave at three times their speed.
    #[test]
    fn three_fields_at_a_node_stop_the_approach_once() {
        let fields = NodeFields {
            count: 3,
            keys: [FieldKey(0), FieldKey(1), FieldKey(2), FieldKey(0)],
        };
        let mut states = [state(0.0, DVec2::ZERO, DVec2::ZERO); MAX_FIELDS];
        // The two sides of group 0 below (normals up and a little apart), group 1 above.
        states[0] = state(100.0, DVec2::ZERO, DVec2::new(0.1, 1.0).normalize());
        states[1] = state(100.0, DVec2::ZERO, DVec2::new(-0.1, 1.0).normalize());
        states[2] = state(1.0, DVec2::new(0.0, -10.0), DVec2::new(0.0, -1.0));
        // The two sides are separable: failed and damaged beyond D̄_min.
        let damage = NodeFieldDamage {
            mean: [1.0; MAX_FIELDS],
            max: [1.0; MAX_FIELDS],
        };
        let params = FrictionalParams {
            friction: 0.3,
            ..FrictionalParams::default()
        };
        let dp = node_impulses(&fields, &states, &damage, &params, &[false; 2], 0.0);
        let momentum: DVec2 = (0..3).map(|k| dp[k]).sum();
        assert!(momentum.length() < 1e-12, "{momentum}");
        let energy = |scale: f64| -> f64 {
            (0..3)
                .map(|k| {
                    let v = states[k].velocity + dp[k] * scale / states[k].mass;
                    0.5 * states[k].mass * v.length_squared()
                })
                .sum()
        };
        let before = energy(0.0);
        // Nodal velocities: the approach is removed, and with it energy.
        assert!(energy(1.0) < before, "{} vs {before}", energy(1.0));
        let platen = states[2].velocity + dp[2] / states[2].mass;
        for side in 0..2 {
            let side_velocity = states[side].velocity + dp[side] / states[side].mass;
            let approach = (platen - side_velocity).dot(DVec2::new(0.0, -1.0));
            assert!(
                approach < 1e-9,
                "side {side} still approached at {approach}"
            );
        }
        // Particle velocities under Newmark (twice the impulse): about an elastic bounce (52 J
        // here, with the tilted normals and friction), where the summed pairs give 440 J.
        assert!(energy(2.0) < 1.1 * before, "{} vs {before}", energy(2.0));
    }

    #[test]
    fn stick_below_the_friction_limit() {
        let a = state(1.0, DVec2::new(0.1, 2.0), DVec2::new(0.0, 1.0));
        let b = state(1.0, DVec2::ZERO, DVec2::new(0.0, -1.0));
        let dp = pair_impulse(&a, &b, 0.5, true, ContactNormals::Difference);
        assert!((dp - DVec2::new(-0.05, -1.0)).length() < 1e-15);
    }

    #[test]
    fn one_group_separates_only_where_damage_allows() {
        let (a, b) = (FieldKey::new(0, 0), FieldKey::new(0, 1));
        let mut damage = NodeFieldDamage::default();
        damage.mean[..2].copy_from_slice(&[0.5, 0.3]);
        damage.max[..2].copy_from_slice(&[1.0, 0.4]);
        assert!(separable(a, b, &damage, (0, 1), 0.25));
        assert!(!separable(a, b, &damage, (0, 1), 0.35));
        damage.max[0] = 0.9;
        assert!(!separable(a, b, &damage, (0, 1), 0.25));
        assert!(separable(a, FieldKey::new(1, 0), &damage, (0, 1), 0.25));
    }

    /// Two particles of groups 0 and 1 approaching each other across one cell of a tiny world,
    /// with `predictor` run after the basis and the field assignment, and the integrator's
    /// description `integration` published as its installer would.
    fn two_groups_meeting<M>(
        predictor: impl IntoScheduleConfigs<bevy_ecs::system::ScheduleSystem, M>,
        integration: GridIntegration,
    ) -> World {
        let mut world = tiny_world::<Two>(2, 0.5, 1e-3);
        world.insert_resource(FrictionalParams::default());
        world.insert_resource(crate::predictor::usl::UslPredictorParams::default());
        world.insert_resource(crate::predictor::newmark::NewmarkParams::default());
        world.insert_resource(integration);
        let a = spawn_particle(&mut world, DVec2::new(0.4, 0.3), DVec2::X, 1.0, 0.01);
        let b = spawn_particle(&mut world, DVec2::new(0.6, 0.3), -DVec2::X, 1.0, 0.01);
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
        run_system(&mut world, frictional_contact::<Two>);
        let after = node_momentum(&mut world);
        assert!((after - before).length() < 1e-15);
        assert_no_approach_left(&mut world);
        assert!(
            node_values::<NodeContactForce<Two>>(&mut world)
                .iter()
                .any(|f| f.0[0].x < 0.0)
        );
    }

    /// Newmark splits an impulse into the kick and a force that together give it back over
    /// the corrector's `γΔt`.
    #[test]
    fn newmark_impulses_split_into_a_kick_and_a_force() {
        let (impulse, collision, gamma_dt) = (DVec2::new(3.0, -1.0), DVec2::new(2.0, 0.5), 0.25);
        let (kick, force) = split_newmark_impulse(impulse, collision, gamma_dt);
        assert_eq!(kick, collision);
        assert!((kick + force * gamma_dt - impulse).length() < 1e-15);
    }

    /// `Heavier` on masses within the tie: the lower contact group sets the normal, whichever
    /// slot it is in; beyond the tie the heavier field does.
    #[test]
    fn on_a_mass_tie_the_lower_group_sets_the_normal() {
        let flat = state(0.2, DVec2::ZERO, DVec2::Y);
        let edged = FieldState {
            key: FieldKey::new(1, 0),
            ..state(0.20004, DVec2::X, DVec2::new(0.243, -0.97).normalize())
        };
        let heavier = ContactNormals::Heavier;
        assert_eq!(heavier.pair_normal(&flat, &edged), Some(DVec2::Y));
        assert_eq!(heavier.pair_normal(&edged, &flat), Some(-DVec2::Y));
        let heavy_edged = FieldState { mass: 0.3, ..edged };
        let n = heavier.pair_normal(&flat, &heavy_edged).unwrap();
        assert!((n + heavy_edged.normal).length() < 1e-15, "{n}");
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
