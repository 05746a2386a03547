//! What the world builder and the estimator start from: the spec checked, the memory the
//! process may use, a bound from the bodies' boxes held against it, the bodies seeded, and the
//! pipeline probed: installed on a world with the scene's resources, no node and a sample of
//! particles, to learn what it gives each entity and declares per particle.

use super::resources::insert_scene_resources;
use crate::SceneError;
use crate::budget;
use crate::estimate::{Estimator, PipelineProbe, Probed};
use crate::pipeline::PipelineBuilder;
use crate::seed::Seeds;
use crate::seeder::Seeder;
use crate::spec::Spec;
use bevy_ecs::prelude::World;
use fractum_engine::dim::Dim;
use fractum_engine::loads::ParticleLoads;
use fractum_engine::registry::Registry;
use fractum_engine::registry::templates::ComponentTemplates;
use fractum_engine::simulation::step_schedule;

/// What `build` and [`Spec::estimate`] do before anything is spawned: the spec checked,
/// the memory the process may use, a bound from the bodies' boxes held against it, the
/// bodies seeded and the pipeline probed.
pub(crate) fn seeded_and_probed<D: Dim>(
    spec: &Spec<D>,
    registry: &Registry,
    ranks: usize,
) -> Result<Probed<D>, SceneError> {
    spec.check()?;
    let available = budget::available_memory();
    Estimator::new(spec).check_memory_before_seeding(available, ranks)?;
    let seeds = Seeder::new(spec).bodies()?;
    let probe = probe_pipeline(spec, registry, &seeds)?;
    Ok(Probed {
        available,
        seeds,
        probe,
    })
}

/// The pipeline installed on a world with the scene's resources, no node and a sample of
/// particles ([`Seeder::sample`]): what it gives every particle and node, and the
/// storage it declares per particle. Installers read a mean particles-per-cell from all
/// the seeds ([`budget::SeedDensity`]).
pub(crate) fn probe_pipeline<D: Dim>(
    spec: &Spec<D>,
    registry: &Registry,
    seeds: &[Seeds<D>],
) -> Result<PipelineProbe, SceneError> {
    let mut world = World::new();
    let mut next_id = 0;
    for ((b, body), seeded) in spec.bodies.iter().enumerate().zip(seeds) {
        let seeder = Seeder::new(spec);
        let sample = seeder.sample(b, body, seeded)?;
        world.spawn_batch(seeder.particles(b, body, sample, &mut next_id)?);
    }
    insert_scene_resources(spec, &mut world, ParticleLoads::<D>::default())?;
    world.insert_resource(seed_density(spec, seeds));
    let mut schedule = step_schedule();
    PipelineBuilder::new(spec).install(registry, &mut schedule, &mut world)?;
    let mut templates = world
        .remove_resource::<ComponentTemplates>()
        .unwrap_or_default();
    if !Seeder::new(spec).scaled_bodies().is_empty() {
        // Every particle carries a strength scale, 1 where no file gives one, so that all
        // of them share one table (and so do those that arrive at a rank later).
        templates
            .particles
            .record(&fractum_engine::components::StrengthScale(1.0));
    }
    Ok(PipelineProbe {
        templates,
        declared: world
            .remove_resource::<budget::ParticleMemory>()
            .unwrap_or_default(),
        reach: world
            .remove_resource::<fractum_engine::decomposition::StepReach>()
            .unwrap_or_default(),
    })
}

/// The mean number of particles per cell of the smallest width over every seed.
pub(crate) fn seed_density<D: Dim>(spec: &Spec<D>, seeds: &[Seeds<D>]) -> budget::SeedDensity {
    let (count, volume) = seeds
        .iter()
        .flatten()
        .fold((0.0, 0.0), |(n, v), &(_, vol)| (n + 1.0, v + vol));
    let cell = spec.grid.spacing.powi(D::N as i32) * thickness_factor(spec);
    budget::SeedDensity(if count == 0.0 || volume <= 0.0 {
        0.0
    } else {
        cell / (volume / count)
    })
}

/// A 2D scene's thickness (seeded volumes carry it), 1 in 3D.
pub(crate) fn thickness_factor<D: Dim>(spec: &Spec<D>) -> f64 {
    if D::N == 2 { spec.thickness } else { 1.0 }
}
