//! Explicit Newmark predictor-corrector, particle part.
//!
//! - Stage: advection. Registration name: `advection/newmark`. Pairs with `predictor/newmark`.
//! - Implements eigensoftening-lme-mpm.md Appendix A (Algorithm 1), step 9, eqs. (3)–(5), with
//!   `v_I` the corrected nodal velocity and `a_p = Σ N_Ip f_I / m_I` (as in the authors'
//!   implementation, where the particle update follows the corrector). Two particle updates
//!   (`particle_update`):
//!   - `Published`: as printed, `v_p ← v_p + Δt a_p` and
//!     `x_p ← x_p + Δt Σ N_Ip v_I + ½ Δt² a_p`. The velocity takes the whole step's change from
//!     the new acceleration alone, and the position runs `Δt² a_p` (γ = ½) ahead of the
//!     configuration the stress was computed in (`x_p + Δt Σ N ṽ_I`, step 4). The result damps
//!     a vibration of frequency ω at a rate of about `ω² Δt / 2`: unnoticed in a body's lowest
//!     modes, but a contact ringing at a particle's frequency loses most of its energy within
//!     a few periods, and the drop-weight and Charpy elastic baselines lose energy that the
//!     papers' own figures do not.
//!   - `Consistent` (the default): Newmark's own update (β = 0) on the particles, as the authors' later code
//!     does it: `v_p ← v_p + Δt ((1 − γ) a_pⁿ + γ a_p)` and `x_p ← x_p + Δt Σ N_Ip ṽ_I` with
//!     `ṽ_I = v_I − γ Δt a_I` the predicted velocity the stress was computed from, so that the
//!     particles move to the configuration whose stress (and contact force) the step used.
//!     With γ = ½ it is second order and conserves the energy of a vibrating body to `O(ω²Δt²)`;
//!     γ > ½ damps as Newmark's γ does.
//! - Contact: the particles also take the contact stage's collision impulse as a velocity kick,
//!   `v_p += Σ N_Ip Δp_I / m_I`, outside `a_p`, as the node velocities took it (see
//!   `contact/frictional`).
//! - Transfer (`transfer`). `Flip` (the default) is the update above: the particle velocity
//!   takes the grid's change, as both papers do. `Apic` is the affine particle-in-cell transfer
//!   (Jiang, Schroeder, Selle, Teran & Stomakhin 2015) fitted to the predictor-corrector: the
//!   particle takes the grid's velocity, `v_p = Σ N_Ip v_I`, and an affine velocity
//!   `C_p = B_p D_p⁻¹` of the field `w_I = v_I + (1 − γ) Δt a_I` that `predictor/newmark`
//!   rebuilds next step (`transfer::affine_interpolation`); the predictor then hands each node
//!   `Σ N m (v_p + (1 − γ) Δt a_p + C_p (x_I − x_p))`. The transfers then keep angular
//!   momentum: a torque the grid receives (a contact's friction at a body's surface nodes)
//!   reaches the particles whole, where `Flip` gives it to them at the mass centre of each
//!   node's particles, a lever arm short by about 0.65 of a cell at a disk's rim. The
//!   position update is the consistent one, `x_p += Δt Σ N ṽ_I`, and the contact kicks are
//!   already in `v_I`.

use crate::transfer::{
    AdvectedQuery, AffineAdvectedQuery, GridMotion, NodeMotionQuery, NodePositionQuery,
    advect_particles_affine, advect_particles_with_kicks,
};
use fractum_engine::prelude::*;
use rayon::prelude::*;
use serde::Deserialize;

/// Registration of `advection/newmark`.
pub const REGISTRATION: Registration = Registration {
    name: "advection/newmark",
    summary: "Newmark particle update: a = Σ N f/m, v += Δt((1-γ)a_old + γa), x += Δt Σ N ṽ_I \
              (or eqs. 3-5 as printed)",
    params: &[
        ParamDoc {
            name: "particle_update",
            ty: "Published | Consistent",
            default: Some("Consistent"),
            doc: "Published: eqs. 3-5 as printed (damps a vibration of frequency ω at about \
                  ω²Δt/2); Consistent: Newmark's own update, v += Δt((1-γ)a_old + γa), \
                  x += Δt Σ N ṽ_I (conserves a vibration's energy)",
        },
        ParamDoc {
            name: "transfer",
            ty: "Flip | Apic",
            default: Some("Flip"),
            doc: "Flip: the particle velocity takes the grid's change (both papers); Apic: the \
                  particle takes the grid velocity and an affine velocity C_p, and the \
                  transfers keep angular momentum (with the Consistent update only)",
        },
    ],
    requires: &["predictor/newmark"],
    install: generic_install!(install),
};

/// Parameters of `advection/newmark`.
#[derive(Resource, Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[serde(deny_unknown_fields)]
pub struct NewmarkAdvectionParams {
    /// Which particle update.
    #[serde(default)]
    pub particle_update: ParticleUpdate,
    /// Which grid-to-particle transfer.
    #[serde(default)]
    pub transfer: Transfer,
}

pub use super::Transfer;

/// The particle update of `advection/newmark` (see the module header).
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
pub enum ParticleUpdate {
    /// Eqs. 3–5 as printed: `v += Δt a`, `x += Δt Σ N v_I + ½ Δt² a`.
    Published,
    /// Newmark's update: `v += Δt ((1 − γ) a_old + γ a)`, `x += Δt Σ N ṽ_I`.
    #[default]
    Consistent,
}

impl ParticleUpdate {
    /// Moves one particle over step `dt` with Newmark's `gamma`, from what the grid gives it.
    pub fn apply<V: VectorOps>(
        self,
        (x, v): (&mut V, &mut V),
        motion: GridMotion<V>,
        dt: f64,
        gamma: f64,
    ) {
        let a = motion.acceleration;
        match self {
            Self::Published => {
                *v += a * dt + motion.kick;
                *x += motion.velocity * dt + a * (0.5 * dt * dt);
            }
            Self::Consistent => {
                *v += (motion.previous_acceleration * (1.0 - gamma) + a * gamma) * dt + motion.kick;
                *x += (motion.velocity - a * (gamma * dt)) * dt;
            }
        }
    }
}

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let parsed: NewmarkAdvectionParams = params.parse()?;
    if parsed.transfer == Transfer::Apic {
        if parsed.particle_update == ParticleUpdate::Published {
            return Err(params.error(
                "transfer",
                "`transfer: Apic` moves the particles by the consistent update; leave \
                 `particle_update` at Consistent (the default)",
            ));
        }
        installer.add_particle_component(AffineVelocity::<D>::default());
        installer.insert_resource(parsed);
        installer.add_systems(apic_advection::<D>);
        return Ok(());
    }
    installer.insert_resource(parsed);
    installer.add_systems(newmark_advection::<D>);
    Ok(())
}

/// The `advection/newmark` system with `transfer: Apic`: `v_p = Σ N v_I`, `a_p = Σ N a_I`,
/// `x_p += Δt Σ N ṽ_I` and `C_p` of `v_I + (1 − γ) Δt a_I`.
pub fn apic_advection<D: Dim>(
    clock: Res<SimClock>,
    integration: Option<Res<GridIntegration>>,
    node_positions: NodePositionQuery<D>,
    connectivity: Res<Connectivity<D>>,
    nodes: NodeMotionQuery<D>,
    mut particles: AffineAdvectedQuery<D>,
) {
    let dt = clock.dt;
    let gamma = match integration.as_deref() {
        Some(&GridIntegration::PredictorCorrector { gamma }) => gamma,
        _ => 0.5,
    };
    advect_particles_affine(
        (&connectivity, &node_positions),
        &nodes,
        &mut particles,
        (dt, (1.0 - gamma) * dt, gamma * dt),
    );
}

/// Node columns for the contact kicks: field masses and the contact stage's impulses.
pub type NodeKickQuery<'w, 's, D> =
    Query<'w, 's, (&'static NodeMass, &'static NodeContactImpulse<D>), With<Node>>;

/// The `advection/newmark` system.
#[allow(clippy::too_many_arguments)]
pub fn newmark_advection<D: Dim>(
    clock: Res<SimClock>,
    params: Option<Res<NewmarkAdvectionParams>>,
    integration: Option<Res<GridIntegration>>,
    connectivity: Res<Connectivity<D>>,
    nodes: NodeMotionQuery<D>,
    impulses: NodeKickQuery<D>,
    mut particles: AdvectedQuery<D>,
    mut kicks: Local<Vec<[D::Vector; MAX_FIELDS]>>,
) {
    let dt = clock.dt;
    let update = params.map_or(ParticleUpdate::default(), |p| p.particle_update);
    // The predictor publishes γ; a world without one (a unit test) uses the default ½.
    let gamma = match integration.as_deref() {
        Some(&GridIntegration::PredictorCorrector { gamma }) => gamma,
        _ => 0.5,
    };
    contact_kicks(&impulses, &mut kicks);
    advect_particles_with_kicks(
        &connectivity,
        &nodes,
        &kicks,
        &mut particles,
        |x, v, motion| update.apply((x, v), motion, dt, gamma),
    );
}

/// The velocity kick `Δp/m` of every node field from the contact stage's impulses, into
/// `kicks`; left empty when no field has one (no contact system, or no collision this step),
/// so the particles skip its interpolation.
pub fn contact_kicks<D: Dim>(
    impulses: &NodeKickQuery<D>,
    kicks: &mut Vec<[D::Vector; MAX_FIELDS]>,
) {
    kicks.clear();
    let Some((mass, impulse)) = single_table(impulses.contiguous_iter(), "nodes") else {
        return;
    };
    if impulse
        .par_iter()
        .any(|j| j.0.iter().any(|j| *j != D::Vector::ZERO))
    {
        mass.par_iter()
            .zip(impulse.par_iter())
            .map(|(m, j)| {
                std::array::from_fn(|k| {
                    if m.0[k] > 0.0 {
                        j.0[k] / m.0[k]
                    } else {
                        D::Vector::ZERO
                    }
                })
            })
            .collect_into_vec(kicks);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::linear::linear_basis;
    use fractum_engine::testing::*;

    /// With the published update, a particle in a uniform grid motion moves by
    /// `Δt v_I + ½ Δt² a` and speeds up by `Δt a`.
    fn newmark_update<D: Dim>(x: D::Vector, v: D::Vector, a: D::Vector)
    where
        D::Vector: SpaceVector,
    {
        let mut world = tiny_world::<D>(2, 0.5, 0.1);
        world.insert_resource(NewmarkAdvectionParams {
            particle_update: ParticleUpdate::Published,
            ..Default::default()
        });
        spawn_particle(&mut world, x, D::Vector::ONE, 1.0, 0.1);
        let mut query = world.query::<(&mut NodeVelocity<D>, &mut NodeAcceleration<D>)>();
        for (mut nv, mut na) in query.iter_mut(&mut world) {
            nv.0[0] = v;
            na.0[0] = a;
        }
        run_system(
            &mut world,
            (linear_basis::<D>, newmark_advection::<D>).chain(),
        );
        let moved = particle_values::<Position<D>>(&mut world)[0].0;
        let speed = particle_values::<Velocity<D>>(&mut world)[0].0;
        assert!(
            (moved - (x + v * 0.1 + a * 0.005)).length() < 1e-14,
            "{moved:?}"
        );
        assert!(
            (speed - (D::Vector::ONE + a * 0.1)).length() < 1e-14,
            "{speed:?}"
        );
    }

    /// `fractum systems` documents the fields its parameters read, and its documented defaults
    /// are theirs.
    #[test]
    fn parameter_docs_match_the_parameters() {
        fractum_engine::testing::assert_defaults::<NewmarkAdvectionParams>(&REGISTRATION);
    }

    /// The consistent update moves a particle to where the predicted velocity took it, and
    /// averages the old and new accelerations with γ.
    #[test]
    fn the_consistent_update_is_newmarks_own() {
        let mut world = tiny_world::<Two>(2, 0.5, 0.1);
        world.insert_resource(NewmarkAdvectionParams {
            particle_update: ParticleUpdate::Consistent,
            ..Default::default()
        });
        world.insert_resource(GridIntegration::PredictorCorrector { gamma: 0.6 });
        let p = spawn_particle(&mut world, DVec2::new(0.3, 0.7), DVec2::ONE, 1.0, 0.1);
        let old = DVec2::new(1.0, -2.0);
        world.entity_mut(p).insert(Acceleration::<Two>(old));
        let (v, a) = (DVec2::new(2.0, 0.0), DVec2::new(0.0, -10.0));
        let mut query = world.query::<(&mut NodeVelocity<Two>, &mut NodeAcceleration<Two>)>();
        for (mut nv, mut na) in query.iter_mut(&mut world) {
            nv.0[0] = v;
            na.0[0] = a;
        }
        run_system(
            &mut world,
            (linear_basis::<Two>, newmark_advection::<Two>).chain(),
        );
        let moved = particle_values::<Position<Two>>(&mut world)[0].0;
        let speed = particle_values::<Velocity<Two>>(&mut world)[0].0;
        let predicted = v - a * (0.6 * 0.1);
        assert!((moved - (DVec2::new(0.3, 0.7) + predicted * 0.1)).length() < 1e-14);
        let expected = DVec2::ONE + (old * 0.4 + a * 0.6) * 0.1;
        assert!((speed - expected).length() < 1e-14, "{speed}");
        assert_eq!(particle_values::<Acceleration<Two>>(&mut world)[0].0, a);
    }

    #[test]
    fn uniform_acceleration_moves_particles_by_the_published_update() {
        newmark_update::<Two>(
            DVec2::new(0.3, 0.7),
            DVec2::new(2.0, 0.0),
            DVec2::new(0.0, -10.0),
        );
        newmark_update::<Three>(
            DVec3::new(0.3, 0.7, 0.4),
            DVec3::new(2.0, 0.0, 1.0),
            DVec3::new(0.0, -10.0, 3.0),
        );
    }

    /// A contact kick `J` on the node fields reaches the particle as `Σ N J/m` in velocity, and
    /// stays out of its acceleration and position update.
    #[test]
    fn contact_kicks_change_the_velocity_only() {
        let mut world = tiny_world::<Two>(2, 0.5, 0.1);
        let x = DVec2::new(0.3, 0.7);
        spawn_particle(&mut world, x, DVec2::ZERO, 1.0, 0.1);
        give_nodes(&mut world, NodeContactImpulse::<Two>::default());
        let mut query = world.query::<(&mut NodeMass, &mut NodeContactImpulse<Two>)>();
        for (mut m, mut j) in query.iter_mut(&mut world) {
            m.0[0] = 2.0;
            j.0[0] = DVec2::new(0.5, -1.0);
        }
        run_system(
            &mut world,
            (linear_basis::<Two>, newmark_advection::<Two>).chain(),
        );
        let speed = particle_values::<Velocity<Two>>(&mut world)[0].0;
        assert!(
            (speed - DVec2::new(0.25, -0.5)).length() < 1e-14,
            "{speed:?}"
        );
        assert_eq!(particle_values::<Position<Two>>(&mut world)[0].0, x);
        assert_eq!(
            particle_values::<Acceleration<Two>>(&mut world)[0].0,
            DVec2::ZERO
        );
    }
    /// Under `transfer: Apic` a particle in an affine grid field `v_I = v₀ + G x_I` (uniform
    /// acceleration `a₀`) takes `v_p = v₀ + G x_p`, `a_p = a₀` and `C_p = G`, and moves by
    /// `Δt (v_p − γ Δt a₀)`.
    fn affine_field_is_taken_exactly<D: Dim>(x: D::Vector, v0: D::Vector, a0: D::Vector)
    where
        D::Vector: SpaceVector,
    {
        let mut world = tiny_world::<D>(4, 0.5, 0.1);
        world.insert_resource(GridIntegration::PredictorCorrector { gamma: 0.6 });
        let p = spawn_particle(&mut world, x, D::Vector::ZERO, 1.0, 0.1);
        world
            .entity_mut(p)
            .insert(AffineVelocity::<D>(D::Matrix::IDENTITY));
        let gradient = D::Matrix::from_fn(|i, j| 0.5 + i as f64 - 2.0 * j as f64);
        let grid = world.resource::<Grid<D>>().clone();
        let mut query =
            world.query::<(&NodeIndex, &mut NodeVelocity<D>, &mut NodeAcceleration<D>)>();
        for (i, mut nv, mut na) in query.iter_mut(&mut world) {
            nv.0[0] = v0 + gradient * grid.node_position(i.0 as usize);
            na.0[0] = a0;
        }
        run_system(&mut world, (linear_basis::<D>, apic_advection::<D>).chain());
        let speed = particle_values::<Velocity<D>>(&mut world)[0].0;
        assert!((speed - (v0 + gradient * x)).length() < 1e-12, "{speed:?}");
        assert!((particle_values::<Acceleration<D>>(&mut world)[0].0 - a0).length() < 1e-12);
        let affine = particle_values::<AffineVelocity<D>>(&mut world)[0].0;
        assert!((affine - gradient).max_abs() < 1e-10, "{affine:?}");
        let moved = particle_values::<Position<D>>(&mut world)[0].0;
        let expected = x + (v0 + gradient * x - a0 * (0.6 * 0.1)) * 0.1;
        assert!((moved - expected).length() < 1e-12, "{moved:?}");
    }

    #[test]
    fn apic_takes_an_affine_grid_field_exactly() {
        affine_field_is_taken_exactly::<Two>(
            DVec2::new(0.8, 1.1),
            DVec2::new(1.0, -2.0),
            DVec2::new(0.0, -10.0),
        );
        affine_field_is_taken_exactly::<Three>(
            DVec3::new(0.8, 1.1, 0.65),
            DVec3::new(1.0, -2.0, 0.5),
            DVec3::new(0.0, -10.0, 3.0),
        );
    }

    /// The affine transfer's round trip keeps angular momentum: grid velocities handed to the
    /// particles (`apic_advection`, a zero step) and back (`predictor/newmark`) give the nodes
    /// the angular momentum `Σ m_I x_I × v_I` they had, for any velocity field.
    #[test]
    fn apic_round_trip_keeps_the_grids_angular_momentum() {
        use crate::advection::round_trip::{
            grid_angular_momentum, scatter_affine_particles, set_grid_field,
        };
        use crate::predictor::newmark::{NewmarkParams, newmark_predictor};
        let mut world = tiny_world::<Two>(6, 0.5, 0.0);
        world.insert_resource(NewmarkParams { gamma: 0.5 });
        world.insert_resource(GridIntegration::PredictorCorrector { gamma: 0.5 });
        world.resource_mut::<SimClock>().step = 1;
        scatter_affine_particles(&mut world, 0.1);
        run_system(
            &mut world,
            (linear_basis::<Two>, newmark_predictor::<Two>).chain(),
        );
        let before = set_grid_field(&mut world);
        run_system(&mut world, apic_advection::<Two>);
        run_system(
            &mut world,
            (linear_basis::<Two>, newmark_predictor::<Two>).chain(),
        );
        let after = grid_angular_momentum(&mut world);
        assert!(
            (after - before).abs() < 1e-10 * before.abs(),
            "{before} {after}"
        );
    }
}
