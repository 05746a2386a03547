//! The energy account of a run: the work the loads do on the system, so that `series.csv` can
//! close the balance `W_ext = ΔK + ΔU + D + R` (kinetic, stored, dissipated by damage, and the
//! residual R, the energy the numerical scheme itself dissipates or creates).
//!
//! The engine's `account_work` system runs after every step (after the post-step stage and its
//! check) and adds the step's work:
//! - prescribed-velocity regions: the region's reaction (the force the boundary exerts on the
//!   body) times its prescribed displacement over the step, `R · (u(t + Δt) − u(t))` with `u`
//!   the exact integral of the velocity table; held components of fixed and roller regions do
//!   not move and do no work;
//! - the body force: `b · Δ(Σ m x)`, the exact change of the potential `−Σ m b·x` (the body
//!   force is uniform);
//! - loads on particles: `Σ f · v Δt` with the velocities at the end of the step.
//!
//! `series.csv` gets `external_work` (accumulated since the start) and `energy_residual`
//! `= W_ext − (E − E₀) − D`, with `E` the total (kinetic + stored) energy and `D` the sum of the
//! damage systems' `dissipated_energy` column when there is one.

use crate::boundary::{BoundaryConditions, Reactions};
use crate::components::{ExternalForce, Mass, Particle, Position, Velocity};
use crate::dim::{Dim, VectorOps};
use crate::resources::{BodyForce, SimClock};
use bevy_ecs::prelude::*;

/// The engine's set of [`account_work`]: after the post-step stage and its check.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct AccountWork;

/// The work done on the system since the start, and the state it was measured from.
#[derive(Resource, Clone, Debug, Default, PartialEq)]
pub struct EnergyAccount {
    /// Work of the loads since the start (J; per scene thickness in 2D).
    pub external_work: f64,
    /// Total (kinetic + stored) energy at the start.
    pub initial_energy: f64,
    /// `Σ m x` after the previous step, per axis.
    first_moment: [f64; 3],
}

impl EnergyAccount {
    /// An account starting from total energy `initial_energy` and first moment of mass
    /// `first_moment` (`Σ m x`).
    pub fn new(initial_energy: f64, first_moment: [f64; 3]) -> Self {
        Self {
            external_work: 0.0,
            initial_energy,
            first_moment,
        }
    }
}

/// `Σ m x` of the particles, per axis (zero beyond the dimension).
pub fn first_moment<D: Dim>(particles: impl Iterator<Item = (f64, D::Vector)>) -> [f64; 3] {
    let mut moment = [0.0; 3];
    for (m, x) in particles {
        for (a, s) in moment.iter_mut().enumerate().take(D::N) {
            *s += m * x[a];
        }
    }
    moment
}

/// The work of prescribed-velocity regions over a step from `time` to `time + dt`.
pub fn boundary_work<D: Dim>(
    bcs: &BoundaryConditions,
    reactions: &Reactions<D>,
    time: f64,
    dt: f64,
) -> f64 {
    bcs.regions
        .iter()
        .zip(&reactions.0)
        .map(|(region, reaction)| {
            (0..D::N)
                .map(|a| {
                    region.velocity[a].as_ref().map_or(0.0, |f| {
                        reaction[a] * (f.integral(time + dt) - f.integral(time))
                    })
                })
                .sum::<f64>()
        })
        .sum()
}

type WorkQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static Mass,
        &'static Position<D>,
        &'static Velocity<D>,
        &'static ExternalForce<D>,
    ),
    With<Particle>,
>;

/// Adds the work of the step just taken to the [`EnergyAccount`] (sequential sums, so the same
/// bits for any thread count).
pub fn account_work<D: Dim>(
    clock: Res<SimClock>,
    body_force: Res<BodyForce<D>>,
    bcs: Res<BoundaryConditions>,
    reactions: Res<Reactions<D>>,
    particles: WorkQuery<D>,
    mut account: ResMut<EnergyAccount>,
) {
    // One pass over the particles for both sums.
    let mut power = 0.0;
    let moment = first_moment::<D>(particles.iter().map(|(m, x, v, f)| {
        power += f.0.dot(v.0);
        (m.0, x.0)
    }));
    let b = body_force.0;
    let body: f64 = (0..D::N)
        .map(|a| b[a] * (moment[a] - account.first_moment[a]))
        .sum();
    let loads = power * clock.dt;
    account.external_work += boundary_work(&bcs, &reactions, clock.time, clock.dt) + body + loads;
    account.first_moment = moment;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::boundary::{BoundaryRegion, PiecewiseLinear};
    use crate::dim::Two;
    use crate::testing::*;
    use glam::DVec2;

    /// A falling particle under gravity, a pulled region and a pushed particle, one step.
    #[test]
    fn the_step_adds_the_work_of_every_load() {
        let mut world = tiny_world::<Two>(2, 0.5, 0.1);
        world.insert_resource(BodyForce::<Two>(DVec2::new(0.0, -10.0)));
        let p = spawn_particle(
            &mut world,
            DVec2::new(0.5, 0.5),
            DVec2::new(1.0, 0.0),
            2.0,
            0.1,
        );
        world.get_mut::<ExternalForce<Two>>(p).unwrap().0 = DVec2::new(3.0, 0.0);
        world.insert_resource(EnergyAccount::new(0.0, [1.0, 1.0, 0.0]));
        // The particle then drops 0.05 m during the step.
        world.get_mut::<Position<Two>>(p).unwrap().0 = DVec2::new(0.6, 0.45);
        let region = BoundaryRegion {
            name: "pulled".into(),
            nodes: vec![0],
            velocity: [Some(PiecewiseLinear::constant(2.0)), None, None],
        };
        world.insert_resource(BoundaryConditions {
            regions: vec![region],
        });
        world.insert_resource(Reactions::<Two>(vec![DVec2::new(5.0, 7.0)]));
        run_system(&mut world, account_work::<Two>);
        let work = world.resource::<EnergyAccount>().external_work;
        // Gravity: m g Δy = 2 × 10 × 0.05 = 1; the load: 3 × 1 × 0.1 = 0.3; the region: 5 × 0.2.
        assert!((work - 2.3).abs() < 1e-12, "{work}");
    }
}
