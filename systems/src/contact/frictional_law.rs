//! The Coulomb frictional contact law between the velocity fields of a node, with the
//! separability condition: the pure kernels of `contact/frictional`, with its parameters.
//!
//! - Stage: contact (used by the `contact/frictional` system; not a registration itself).
//! - Implements dfg-partitioning-mpm.md §1.1.1 (eqs. 11–16) and Algorithm 3 (§2.3):
//!   - each field's normal is its normalised mass gradient `n = Σ ∇N_Ip m_p / ‖…‖` (eq. 11),
//!     pointing out of the field's material. A pair uses `n = (n_a − n_b)/‖n_a − n_b‖` for field
//!     a and `−n` for field b, exactly opposite ([`ContactNormals`]);
//!   - the pair's centre-of-mass velocity `v_cm = (q_a + q_b)/(m_a + m_b)` (eq. 12);
//!   - a separable pair is in contact only while approaching, `(v_cm − v̄_a)·n < 0` with this
//!     outward `n` (Algorithm 3 writes `> 0` for the opposite orientation of the normal); then
//!     the normal impulse is `m_a (v_cm − v̄_a)·n` (eq. 14) and the tangential one is the stick
//!     impulse capped at `μ` times the normal one (eqs. 15–16);
//!   - a pair that is not separable moves as one field: both take `v_cm`;
//!   - separability (§2.3): fields of different contact groups always; fields of one group only
//!     when some particle at the node has failed (`max D = 1`) and both fields' mean damage
//!     exceeds `separability` (D̄_min), from the partition stage's `NodeFieldDamage`.
//! - The tangential impulse is the tangential part of the stick impulse itself,
//!   `Δp − (Δp·n) n`, so no tangent basis is built: none could differ between the two fields,
//!   and the friction acts against the actual slip direction in 2D and 3D.
//! - Impulses are computed once per pair and applied with opposite signs, so momentum is
//!   conserved to round-off. A node with more than two fields takes its pairs one after the
//!   other, each from the velocities the pairs before it left, in sweeps until no pair acts
//!   ([`node_impulses`]): summed from the velocities before contact, the pairs would stop a
//!   field once per partner. Velocity components held by a boundary condition are left alone
//!   on both fields.
//! - Normals (`normals`): `Difference` (the default) is eq. 11 as printed. `Heavier` takes the
//!   normal of the field with more mass at the node and its opposite for the other, the mass
//!   weighting §1.1.1 notes "may improve the response, particularly when one field is present
//!   in a very small fraction": the better choice for a small body on a large flat one, where
//!   `Difference` lets the small body's tilted corner normals plough it; `Difference` is the
//!   better one for equal bodies meeting head-on (docs/history/development-log.md has the measurements).
//! - Newmark's split of an impulse into a kick and a force ([`split_newmark_impulse`]): see
//!   `contact/frictional`.

use fractum_engine::prelude::*;
use serde::Deserialize;

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
    /// When an approaching pair of separable fields is in contact.
    #[serde(default)]
    pub detection: ContactDetection,
    /// Which pairs of a node's fields the law acts between.
    #[serde(default)]
    pub between: ContactPairs,
}

/// Which pairs of a node's fields the law acts between (`between`).
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
pub enum ContactPairs {
    /// Every pair: fields of different contact groups, and the two sides of one group that a
    /// DFG partition opens (Algorithm 3 as published).
    #[default]
    All,
    /// Only the two sides of one group (crack faces, self-contact): the fields of different
    /// groups are left to the contact law listed after this one (`contact/penalty`).
    CrackFaces,
}

impl ContactPairs {
    /// Whether the law acts between the fields keyed `a` and `b`.
    pub fn includes(self, a: FieldKey, b: FieldKey) -> bool {
        match self {
            Self::All => true,
            Self::CrackFaces => a.group() == b.group(),
        }
    }
}

/// When a separable pair of fields at a node is in contact (`detection`).
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
pub enum ContactDetection {
    /// Algorithm 3 as published: whenever the two fields approach each other. Two bodies so
    /// meet as soon as their particles share a node, up to two cells before their surfaces
    /// touch with the linear tents, and crack faces collide while they are still apart.
    #[default]
    Approach,
    /// While approaching, and only where the two fields' particles touch: the pair's gap at the
    /// node ([`PairGaps`], from the particles' own domains along the pair normal) closes
    /// within the step. Nairn's position check for multi-material contact, with the particles'
    /// extents in place of a critical separation.
    Gap,
}

/// The gap between each pair of fields at a node: along the pair normal `n` of field `a`
/// (towards `b`), the least `x·n − r(n)` over `b`'s particles at the node less the largest
/// `x·n + r(n)` over `a`'s, with `r(n) = l Σ|n_i|` the reach of a particle's square (cubic)
/// domain of half-width `l` along `n`. Negative where the domains overlap. With the step `dt`,
/// a pair is in contact when `gap − dt (v̄_a − v̄_b)·n ≤ 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairGaps {
    /// `gaps[a][b]` for `a < b` (the rest unused).
    pub gaps: [[f64; MAX_FIELDS]; MAX_FIELDS],
    /// The step.
    pub dt: f64,
}

impl PairGaps {
    /// Whether fields `a` and `b` (`a < b`), with outward normal `n` of `a`, touch within the
    /// step at their velocities.
    pub fn touch<V: VectorOps>(&self, a: usize, b: usize, states: &[FieldState<V>], n: V) -> bool {
        let closing = (states[a].velocity - states[b].velocity).dot(n);
        self.gaps[a][b] - self.dt * closing.max(0.0) <= 0.0
    }
}

/// The reach `l Σ|n_i|` of a square (cubic) particle domain of half-width `l` along unit `n`.
pub fn domain_reach<V: VectorOps>(half_width: f64, n: V) -> f64 {
    half_width * n.to_3d().iter().map(|c| c.abs()).sum::<f64>()
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
/// against the node, so which one is heavier says nothing about whose surface is flat
/// (docs/history/development-log.md has the sliding-block measurements that set 10⁻³ and 5°).
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
            detection: ContactDetection::default(),
            between: ContactPairs::default(),
        }
    }
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
/// separability); `merge_below = 0` leaves every pair to Algorithm 3. With `gaps`
/// ([`ContactDetection::Gap`]), a separable pair acts only where its particles touch within
/// the step.
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
    gaps: Option<&PairGaps>,
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
                if !params.between.includes(fields.keys[a], fields.keys[b]) {
                    continue;
                }
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
                if can_separate
                    && let Some(gaps) = gaps
                    && let Some(n) = params.normals.pair_normal(&current[a], &current[b])
                    && !gaps.touch(a, b, &current, n)
                {
                    continue;
                }
                let friction =
                    params.friction_between(fields.keys[a].group(), fields.keys[b].group());
                let mut dp = pair_impulse(
                    &current[a],
                    &current[b],
                    friction,
                    can_separate,
                    params.normals,
                );
                hold_components(&mut dp, held);
                if dp == V::ZERO {
                    continue;
                }
                // With sweeps: round-off of a pair already moving together is no reason for
                // another sweep, and after the first not worth applying. (Two fields take one
                // pass and every impulse.)
                if sweeps > 1 {
                    let round_off = is_round_off(dp, &current[a], &current[b]);
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

/// Zeroes the components of an impulse that the node's boundary holds.
fn hold_components<V: VectorOps>(dp: &mut V, held: &[bool]) {
    for (c, is_held) in held.iter().enumerate() {
        if *is_held {
            dp[c] = 0.0;
        }
    }
}

/// Whether impulse `dp` between two fields is round-off of their momenta.
fn is_round_off<V: VectorOps>(dp: V, a: &FieldState<V>, b: &FieldState<V>) -> bool {
    let scale = (a.velocity * a.mass).length() + (b.velocity * b.mass).length();
    dp.length() <= 1e-14 * scale
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

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    pub(crate) fn state<V>(mass: f64, velocity: V, normal: V) -> FieldState<V> {
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
        let alone = node_impulses(&fields, &states, &damage, &params, &[false; 2], 0.0, None);
        assert_eq!(alone[0], DVec2::ZERO);
        let merged = node_impulses(&fields, &states, &damage, &params, &[false; 2], 1e-4, None);
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
        let dp = node_impulses(&fields, &states, &damage, &params, &[false; 2], 0.0, None);
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

    /// `between: CrackFaces` at a node with both sides of a cracked group 0 and a field of
    /// group 1, all approaching: only the pair of group 0's sides takes an impulse (the pairs
    /// with group 1 are `contact/penalty`'s), and momentum is conserved.
    #[test]
    fn crack_faces_only_leaves_the_groups_alone() {
        let fields = NodeFields {
            count: 3,
            keys: [FieldKey(0), FieldKey(1), FieldKey(2), FieldKey(0)],
        };
        let mut states = [state(0.0, DVec2::ZERO, DVec2::ZERO); MAX_FIELDS];
        states[0] = state(1.0, DVec2::new(1.0, 0.0), DVec2::X);
        states[1] = state(1.0, DVec2::new(-1.0, 0.0), -DVec2::X);
        states[2] = state(1.0, DVec2::new(0.0, -1.0), -DVec2::Y);
        let damage = NodeFieldDamage {
            mean: [1.0; MAX_FIELDS],
            max: [1.0; MAX_FIELDS],
        };
        let params = FrictionalParams {
            between: ContactPairs::CrackFaces,
            ..FrictionalParams::default()
        };
        let dp = node_impulses(&fields, &states, &damage, &params, &[false; 2], 0.0, None);
        assert_eq!(dp[2], DVec2::ZERO);
        assert!(dp[0].x < 0.0 && dp[1].x > 0.0, "{dp:?}");
        assert_eq!(dp[0] + dp[1], DVec2::ZERO);
        // Every pair, as published: the group-1 field is stopped too.
        let all = node_impulses(
            &fields,
            &states,
            &damage,
            &FrictionalParams::default(),
            &[false; 2],
            0.0,
            None,
        );
        assert_ne!(all[2], DVec2::ZERO);
        assert!(ContactPairs::All.includes(FieldKey::new(0, 0), FieldKey::new(1, 0)));
        assert!(!ContactPairs::CrackFaces.includes(FieldKey::new(0, 0), FieldKey::new(1, 0)));
        assert!(ContactPairs::CrackFaces.includes(FieldKey::new(2, 0), FieldKey::new(2, 1)));
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

    /// A square domain reaches `l` along an axis and `l √2` along a diagonal; a pair touches
    /// when its gap is closed by the step's approach, and an opening pair never does.
    #[test]
    fn pairs_touch_when_the_step_closes_their_gap() {
        assert_eq!(domain_reach(0.5, DVec2::X), 0.5);
        let diagonal = DVec2::ONE / 2f64.sqrt();
        assert!((domain_reach(0.5, diagonal) - 0.5 * 2f64.sqrt()).abs() < 1e-15);
        let mut gaps = PairGaps {
            gaps: [[f64::INFINITY; MAX_FIELDS]; MAX_FIELDS],
            dt: 0.1,
        };
        // a moves at 1 m/s towards b at rest: 0.1 m closes in the step.
        let states = [
            state(1.0, DVec2::X, DVec2::X),
            state(1.0, DVec2::ZERO, -DVec2::X),
        ];
        for (gap, touches) in [(0.2, false), (0.1, true), (0.0, true), (-0.05, true)] {
            gaps.gaps[0][1] = gap;
            assert_eq!(gaps.touch(0, 1, &states, DVec2::X), touches, "gap {gap}");
        }
        // Opening at 1 m/s: only an overlap touches.
        let opening = [states[0], state(1.0, DVec2::X * 2.0, -DVec2::X)];
        gaps.gaps[0][1] = 0.01;
        assert!(!gaps.touch(0, 1, &opening, DVec2::X));
        gaps.gaps[0][1] = -0.01;
        assert!(gaps.touch(0, 1, &opening, DVec2::X));
    }
}
