//! The engine's own step systems, added to a schedule for a dimension given as a value: the
//! health check after each stage, the scene's loads, the work account and the removal of
//! particles that leave the grid.
//!
//! These functions take a [`Dimension`] rather than a type parameter on purpose. A generic
//! function is compiled in the crate that names its dimension, and the scene crate, which
//! builds every schedule, is optimised less than the engine in the test profile (Cargo.toml);
//! compiled here, the systems run at the engine's optimisation whichever crate adds them.

use crate::dim::Dimension;
use crate::energy::account_work;
use crate::health::{healthy, mark_escaped_particles, remove_escaped_particles, stage_check};
use crate::loads::apply_loads;
use crate::stage::{Stage, StageCheck, StepSet};
use crate::with_dim;
use bevy_ecs::prelude::*;

/// Puts the engine's health check after each of `stages` (the stages that have systems: an
/// empty stage changes nothing, so checking after it would only repeat the previous check).
#[inline(never)]
pub fn add_stage_checks(
    schedule: &mut Schedule,
    dimension: Dimension,
    stages: impl IntoIterator<Item = Stage>,
) {
    let stages: Vec<Stage> = stages.into_iter().collect();
    with_dim!(dimension, D => {
        for &stage in &stages {
            schedule.add_systems(
                stage_check::<D>(stage)
                    .in_set(StageCheck(stage))
                    .run_if(healthy),
            );
        }
    })
}

/// Adds [`apply_loads`], in [`StepSet::ApplyLoads`].
#[inline(never)]
pub fn add_loads(schedule: &mut Schedule, dimension: Dimension) {
    with_dim!(dimension, D => {
        schedule.add_systems(apply_loads::<D>.in_set(StepSet::ApplyLoads));
    })
}

/// Adds [`account_work`], in [`StepSet::AccountWork`].
#[inline(never)]
pub fn add_work_account(schedule: &mut Schedule, dimension: Dimension) {
    with_dim!(dimension, D => {
        schedule.add_systems(account_work::<D>.in_set(StepSet::AccountWork));
    })
}

/// Adds the removal of particles that leave the grid (policy
/// [`crate::health::LeaveGrid::Remove`]): [`remove_escaped_particles`] in the advection
/// stage's check, or on a rank of a distributed run (`on_a_rank`) [`mark_escaped_particles`],
/// between that check and the step's work account. A rank despawns none in the step, which
/// would move its rows: it disowns them, and the step's redistribution drops them.
#[inline(never)]
pub fn add_escape_removal(schedule: &mut Schedule, dimension: Dimension, on_a_rank: bool) {
    with_dim!(dimension, D => {
        if on_a_rank {
            schedule.add_systems(
                mark_escaped_particles::<D>
                    .after(StageCheck(Stage::Advection))
                    .before(StageCheck(Stage::PostStep))
                    .before(StepSet::AccountWork),
            );
        } else {
            schedule.add_systems(
                remove_escaped_particles::<D>.in_set(StageCheck(Stage::Advection)),
            );
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::boundary::PiecewiseLinear;
    use crate::components::{ExternalForce, LoadShare, Particle, ParticleId, Position};
    use crate::dim::{Three, Two};
    use crate::health::EscapedParticles;
    use crate::loads::ParticleLoads;
    use crate::resources::{Grid, SimClock};
    use glam::{DVec2, DVec3};

    /// The loads added for 2D set each particle's external force at the clock's time.
    #[test]
    fn the_added_loads_set_the_external_force() {
        let ramp = PiecewiseLinear::new(vec![(0.0, 0.0), (2.0, 1.0)]).unwrap();
        let mut world = World::new();
        world.insert_resource(SimClock {
            time: 1.0,
            ..Default::default()
        });
        world.insert_resource(ParticleLoads::<Two>(vec![(DVec2::new(0.0, -10.0), ramp)]));
        let share = LoadShare {
            load: 0,
            share: 0.25,
        };
        let particle = world
            .spawn((Particle, share, ExternalForce::<Two>::default()))
            .id();
        let mut schedule = Schedule::default();
        add_loads(&mut schedule, Dimension::Two);
        schedule.run(&mut world);
        let force = world.get::<ExternalForce<Two>>(particle).unwrap().0;
        assert_eq!(force, DVec2::new(0.0, -1.25));
    }

    /// The removal added for 3D despawns the particle outside the grid and counts it.
    #[test]
    fn the_added_removal_takes_the_escaped_particle_out() {
        let mut world = World::new();
        world.insert_resource(Grid::<Three> {
            min: DVec3::ZERO,
            spacing: 0.5,
            cells: [2, 2, 2],
            graded: None,
            window: None,
        });
        world.init_resource::<EscapedParticles>();
        let inside = world
            .spawn((
                Particle,
                ParticleId(0),
                Position::<Three>(DVec3::splat(0.5)),
            ))
            .id();
        world.spawn((
            Particle,
            ParticleId(1),
            Position::<Three>(DVec3::splat(2.0)),
        ));
        let mut schedule = Schedule::default();
        add_escape_removal(&mut schedule, Dimension::Three, false);
        schedule.run(&mut world);
        assert_eq!(world.resource::<EscapedParticles>().removed, vec![1]);
        let mut particles = world.query_filtered::<Entity, With<Particle>>();
        assert_eq!(particles.iter(&world).collect::<Vec<_>>(), vec![inside]);
    }
}
