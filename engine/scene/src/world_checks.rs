//! The checks of a scene that need its built world: a fixed step against the stable limit of
//! the particles as spawned, strength scales that something reads, one state per checkpoint
//! key. (The memory is checked before anything is spawned, by the estimator.)

use super::SceneError;
use super::seeder::Seeder;
use super::spec::Spec;
use bevy_ecs::prelude::World;
use fractum_engine::dim::Dim;
use fractum_engine::resources::TimeStepLimit;
use fractum_engine::simulation::{End, TimeStep, stable_time_step};

/// The most steps a scene may ask for: at the fastest measured rates a longer run would take
/// years, so more means a mistaken end time, speed or material.
pub const MAX_STEPS: f64 = 1e10;

/// The checks of one spec on the world built from it.
pub(crate) struct WorldChecks<'s, D: Dim> {
    spec: &'s Spec<D>,
}

impl<'s, D: Dim> WorldChecks<'s, D> {
    /// The world checks of `spec`.
    pub(crate) fn new(spec: &'s Spec<D>) -> Self {
        Self { spec }
    }

    /// A fixed step must not exceed the stable limit of the particles as spawned (the one
    /// rule, [`stable_time_step`], that CFL steps follow too).
    pub(crate) fn stable_step(&self, world: &mut World) -> Result<(), SceneError> {
        let stable = stable_time_step::<D>(world);
        let dt = match self.spec.time_step {
            TimeStep::Fixed(dt) => dt,
            TimeStep::Cfl(factor) => factor * stable.dt,
        };
        if !dt.is_normal() && dt <= stable.dt {
            return Err(self.spec.source.error(
                "time.step",
                format!(
                    "the step would be {dt:e} s (stable limit {:e} s, from a signal speed \
                     c + |v| = {:e} m/s), too small to advance the clock",
                    stable.dt, stable.speed
                ),
            ));
        }
        if let End::Time(end) = self.spec.end
            && end / dt > MAX_STEPS
        {
            return Err(self.spec.source.error(
                "time.step",
                format!(
                    "the run would take {:.3e} steps of {dt:e} s to reach t = {end} s, more than \
                     the 10^10 a scene may ask for; check the end time, the speeds and the \
                     materials' wave speeds",
                    end / dt
                ),
            ));
        }
        if dt <= stable.dt {
            return Ok(());
        }
        let reason = &world.resource::<TimeStepLimit>().reason;
        let restriction = if reason.is_empty() {
            String::new()
        } else {
            format!(" × {} ({reason})", stable.factor)
        };
        let culprit = match stable.particle {
            Some((id, material)) => format!(
                " (particle {id}, material \"{}\")",
                self.spec.materials[material as usize].name
            ),
            None => String::new(),
        };
        Err(self.spec.source.error(
            "time.step",
            format!(
                "the time step {dt:e} s exceeds the stable limit {:e} s = h / (√{} (c + |v|)){restriction} \
                 with h = {} m and c + |v| = {:.6e} m/s{culprit}; use `Fixed({:.3e})` or less, or \
                 `Cfl(0.5)`",
                stable.dt,
                stable.dimensions,
                stable.spacing,
                stable.speed,
                0.9 * stable.dt
            ),
        ))
    }

    /// Refuses strength scales that nothing reads: a particle file gave them, but no damage law
    /// of the pipeline gives the particles a finite tensile strength to scale.
    pub(crate) fn strength_scales(&self, world: &mut World) -> Result<(), SceneError> {
        use fractum_engine::components::{BodyId, ParticleId, Strength, StrengthScale};
        // Every particle of such a scene carries a scale; those of the files' bodies need a
        // strength to scale.
        let scaled = Seeder::new(self.spec).scaled_bodies();
        let mut query = world.query::<(&StrengthScale, &BodyId, &ParticleId, Option<&Strength>)>();
        let unread = query.iter(world).find(|(_, body, _, strength)| {
            scaled.contains(&body.0) && !strength.is_some_and(|s| s.0.is_finite())
        });
        let Some((_, body, id, _)) = unread else {
            return Ok(());
        };
        Err(self.spec.source.error(
            &format!("bodies[{}].shape", body.0),
            format!(
                "the particle file gives strength scales, but no damage law of the pipeline \
                 gives its particles a tensile strength to scale (particle {} has none); use \
                 a law with per-particle strengths (damage/rankine, damage/time_to_failure) \
                 for the body's material, or drop the `strength_scale` column",
                id.0
            ),
        ))
    }

    /// Refuses a pipeline in which two systems carry different state under one checkpoint key.
    pub(crate) fn checkpoint_keys(&self, world: &World) -> Result<(), SceneError> {
        match world
            .get_resource::<fractum_io::checkpoint::CheckpointState>()
            .and_then(|state| state.collisions().first().copied())
        {
            Some(key) => Err(self.spec.source.error(
                "pipeline",
                format!(
                    "two systems carry different state under the checkpoint key \"{key}\"; give \
                     one of them its own key (checkpoint::State::KEY)"
                ),
            )),
            None => Ok(()),
        }
    }
}
