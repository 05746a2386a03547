//! The checks of a scene around its world: memory before seeding (a bound from the bodies'
//! boxes) and before spawning (from counts), a fixed step against the stable limit of the
//! particles as spawned, strength scales that something reads.

use super::SceneError;
use super::budget::{self, MemoryEstimate};
use super::spec::Spec;
use bevy_ecs::prelude::World;
use fractum_engine::dim::{Dim, VectorOps};
use fractum_engine::resources::TimeStepLimit;
use fractum_engine::simulation::{End, TimeStep, stable_time_step};

/// The most steps a scene may ask for: at the fastest measured rates a longer run would take
/// years, so more means a mistaken end time, speed or material.
pub const MAX_STEPS: f64 = 1e10;

impl<D: Dim> Spec<D> {
    /// Refuses a grid or bodies that cannot fit in `available` before any particle is seeded:
    /// the nodes, and each body's particles bounded by its bounding box's cells (at the
    /// smallest cell width) times the particles per cell. A cheap bound, so that a mistaken
    /// spacing is refused before its seeds fill the memory. A rank of `ranks` holds only the
    /// nodes its particles reach, a share of at least `1/ranks` for the most loaded; it seeds
    /// every body to find its own particles.
    pub(super) fn check_memory_before_seeding(
        &self,
        available: budget::Available,
        ranks: usize,
    ) -> Result<(), SceneError> {
        let nodes = (0..D::N)
            .map(|a| (self.grid.cells[a] + 1) as f64)
            .product::<f64>()
            / ranks.max(1) as f64;
        let share = if ranks > 1 { " (a rank's share)" } else { "" };
        let mut estimate = MemoryEstimate::default();
        estimate.add(
            format!("{} grid nodes{share}", budget::describe_count(nodes)),
            nodes * budget::node_bytes::<D>(),
        );
        let (lo, hi) = (self.grid.min.to_3d(), self.grid.max().to_3d());
        let mut largest_body = (0, 0.0);
        for (b, body) in self.bodies.iter().enumerate() {
            let (min, max) = body.shape.bounds();
            let cells: f64 = (0..D::N)
                .map(|a| {
                    let extent = (max[a].min(hi[a]) - min[a].max(lo[a])).max(0.0);
                    (extent / self.grid.spacing).ceil() + 1.0
                })
                .product();
            let particles = body
                .shape
                .own_particle_bound(body.particles_per_cell)
                .unwrap_or(cells * f64::from(body.particles_per_cell).powi(D::N as i32));
            if particles > largest_body.1 {
                largest_body = (b, particles);
            }
            estimate.add(
                format!(
                    "up to {} particles of bodies[{b}]",
                    budget::describe_count(particles)
                ),
                particles * budget::particle_bytes::<D>(),
            );
        }
        match estimate.refusal(available) {
            None => Ok(()),
            Some(message) => {
                let node_bytes = estimate.parts[0].1;
                let field = if node_bytes >= largest_body.1 * budget::particle_bytes::<D>() {
                    "grid.spacing".to_string()
                } else {
                    format!("bodies[{}].particles_per_cell", largest_body.0)
                };
                Err(self.source.error(&field, message))
            }
        }
    }

    /// A fixed step must not exceed the stable limit of the particles as spawned (the one
    /// rule, [`stable_time_step`], that CFL steps follow too).
    pub(super) fn check_stable_step(&self, world: &mut World) -> Result<(), SceneError> {
        let stable = stable_time_step::<D>(world);
        let dt = match self.time_step {
            TimeStep::Fixed(dt) => dt,
            TimeStep::Cfl(factor) => factor * stable.dt,
        };
        if !dt.is_normal() && dt <= stable.dt {
            return Err(self.source.error(
                "time.step",
                format!(
                    "the step would be {dt:e} s (stable limit {:e} s, from a signal speed \
                     c + |v| = {:e} m/s), too small to advance the clock",
                    stable.dt, stable.speed
                ),
            ));
        }
        if let End::Time(end) = self.end
            && end / dt > MAX_STEPS
        {
            return Err(self.source.error(
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
                self.materials[material as usize].name
            ),
            None => String::new(),
        };
        Err(self.source.error(
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
}

impl<D: Dim> Spec<D> {
    /// Refuses strength scales that nothing reads: a particle file gave them, but no damage law
    /// of the pipeline gives the particles a finite tensile strength to scale.
    pub(super) fn check_strength_scales(&self, world: &mut World) -> Result<(), SceneError> {
        use fractum_engine::components::{BodyId, ParticleId, Strength, StrengthScale};
        // Every particle of such a scene carries a scale; those of the files' bodies need a
        // strength to scale.
        let scaled = self.scaled_bodies();
        let mut query = world.query::<(&StrengthScale, &BodyId, &ParticleId, Option<&Strength>)>();
        let unread = query.iter(world).find(|(_, body, _, strength)| {
            scaled.contains(&body.0) && !strength.is_some_and(|s| s.0.is_finite())
        });
        let Some((_, body, id, _)) = unread else {
            return Ok(());
        };
        Err(self.source.error(
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
}
