//! From a checked [`Spec`] to a [`Simulation`]: the world builder. It seeds the bodies and
//! probes the pipeline on a sample world (`probe.rs`, which the estimator starts from too),
//! spawns the nodes and the bodies' particles (`bodies.rs`) into a world with the scene's
//! resources (`resources.rs`), resolves the boundary regions (`regions.rs`), plans the frames,
//! series and probes (`outputs.rs`), cuts a distributed run's world to a rank (`ranks.rs`),
//! and adds the engine's own systems. The pipeline is installed by `pipeline.rs`; what only
//! the built world can tell is checked by `world_checks.rs`; the memory and a rank's slabs
//! come from the estimator (`estimate.rs`).

mod bodies;
mod outputs;
pub(crate) mod probe;
mod ranks;
mod regions;
mod resources;

use super::SceneError;
use super::estimate::{Estimator, Probed};
use super::pipeline::PipelineBuilder;
use super::seed::Seeds;
use super::spec::{Built, PipelineSummary, SceneSummary, Spec};
use super::world_checks::WorldChecks;
use bevy_ecs::prelude::World;
use bevy_ecs::schedule::Schedule;
use fractum_engine::boundary::BoundaryConditions;
use fractum_engine::decomposition::{Layout, Ownership};
use fractum_engine::dim::Dim;
use fractum_engine::engine_systems;
use fractum_engine::health::LeaveGrid;
use fractum_engine::loads::ParticleLoads;
use fractum_engine::registry::Registry;
use fractum_engine::registry::templates::ComponentTemplates;
use fractum_engine::series::SeriesColumns;
use fractum_engine::simulation::{Simulation, step_schedule};
use fractum_io::output::OutputPlan;
use ranks::{RankPlan, rank_rebuild};

/// Builds the world and the step schedule of one spec with the systems of one registry. It
/// owns the spec: a rank's world narrows the spec's grid to the nodes the rank reaches.
pub(crate) struct WorldBuilder<'r, D: Dim> {
    spec: Spec<D>,
    registry: &'r Registry,
}

/// A scene's world with its pipeline installed, before the engine's own systems.
struct Installed {
    world: World,
    schedule: Schedule,
    body_particles: Vec<usize>,
    output: OutputPlan,
    pipeline: PipelineSummary,
}

impl<'r, D: Dim> WorldBuilder<'r, D> {
    /// A builder of `spec` with the systems of `registry`.
    pub(crate) fn new(spec: Spec<D>, registry: &'r Registry) -> Self {
        Self { spec, registry }
    }

    /// The estimator of the spec as it stands (a rank's grid once narrowed).
    fn estimator(&self) -> Estimator<'_, D> {
        Estimator::new(&self.spec)
    }

    /// Checks the spec, builds the world and the step schedule, and checks what only the built
    /// world can tell; for rank `rank` of `ranks` on the slabs of `layout` (or a cut of the
    /// seeds) when `rank` is given.
    pub(crate) fn build(
        mut self,
        rank: Option<(usize, usize, Option<Layout>)>,
    ) -> Result<Built, SceneError> {
        let rebuild = rank
            .as_ref()
            .map(|_| (self.spec.clone(), self.registry.clone()));
        let ranks = rank.as_ref().map_or(1, |r| r.1);
        let Probed {
            available,
            seeds,
            probe,
        } = probe::seeded_and_probed(&self.spec, self.registry, ranks)?;
        let plan = match rank {
            Some((rank, ranks, layout)) => {
                Some(self.rank_plan(&seeds, &probe, rank, ranks, layout)?)
            }
            None => None,
        };
        if let Some(plan) = &plan {
            // A rank holds the nodes its particles reach; positions stay the whole grid's.
            self.spec.grid = self.estimator().rank_grid(&plan.layout, plan.rank, &probe);
        }
        // A rank needs memory for what it holds, not for the whole scene.
        let memory = match &plan {
            Some(plan) => {
                let held = self.estimator().rank_seeds(&seeds, &plan.layout, plan.rank);
                self.estimator()
                    .check_memory_from_counts(&held, &probe, available)?
            }
            None => self
                .estimator()
                .check_memory_from_counts(&seeds, &probe, available)?,
        };
        let Installed {
            mut world,
            mut schedule,
            body_particles,
            mut output,
            pipeline,
        } = self.spawn_and_install(seeds, &probe.templates, plan.as_ref())?;
        if let (Some(plan), Some((spec, registry))) = (&plan, rebuild) {
            world.insert_resource(rank_rebuild(spec, registry, plan.rank, &probe));
            self.distribute(&mut world, probe.templates.particles)?;
        }
        world.insert_resource(memory);
        let checks = WorldChecks::new(&self.spec);
        checks.checkpoint_keys(&world)?;
        checks.strength_scales(&mut world)?;
        self.check_frame_fields(&world)?;
        output.system_columns = world
            .get_resource::<SeriesColumns>()
            .map(SeriesColumns::published)
            .unwrap_or_default();
        checks.stable_step(&mut world)?;
        self.add_engine_systems(&mut schedule, &mut world, &pipeline);
        let simulation = Simulation::new::<D>(world, schedule, self.spec.time_step, self.spec.end)
            .map_err(|e| {
                self.spec.source.error(
                    "pipeline",
                    format!(
                        "systems in one stage touch the same data without an order between \
                         them; order them or split them into stages:\n{e}"
                    ),
                )
            })?;
        let summary = self.summary(&body_particles);
        Ok(Built {
            simulation,
            pipeline,
            output,
            body_particles,
            summary,
        })
    }

    /// The world with the pipeline installed, each entity spawned with the components the
    /// pipeline gives it (`templates`, recorded by [`probe::probe_pipeline`]; why:
    /// `registry/templates.rs`), each body's particles from its `seeds`.
    fn spawn_and_install(
        &self,
        seeds: Vec<Seeds<D>>,
        templates: &ComponentTemplates,
        plan: Option<&RankPlan>,
    ) -> Result<Installed, SceneError> {
        let (mut world, body_particles, output) = self.spawn_world(templates, seeds, plan)?;
        let mut schedule = step_schedule();
        let pipeline =
            PipelineBuilder::new(&self.spec).install(self.registry, &mut schedule, &mut world)?;
        world.remove_resource::<ComponentTemplates>();
        fractum_engine::registry::pending::insert_pending_components(&mut world);
        self.start_affine_velocities(&mut world);
        Ok(Installed {
            world,
            schedule,
            body_particles,
            output,
            pipeline,
        })
    }

    /// The world before the pipeline: the engine's resources, the nodes and the bodies'
    /// particles from their seeds, each spawned with the components of `templates`. Returns it
    /// with each body's particle count and the output plan.
    fn spawn_world(
        &self,
        templates: &ComponentTemplates,
        seeds: Vec<Seeds<D>>,
        plan: Option<&RankPlan>,
    ) -> Result<(World, Vec<usize>, OutputPlan), SceneError> {
        let mut world = World::new();
        bodies::spawn_nodes(&mut world, &self.spec.grid, &templates.nodes);
        // From every seed: a rank's world holds only some of the particles.
        let tracked = self.tracked_particles(&seeds)?;
        let (body_particles, loads) =
            self.spawn_bodies(&mut world, &templates.particles, seeds, plan)?;
        if let Some(plan) = plan {
            // Before the pipeline is installed: installers sum what the rank owns.
            let ownership = self.ownership(&mut world, plan);
            world.insert_resource(ownership);
        }
        resources::insert_scene_resources(&self.spec, &mut world, loads)?;
        if let Some(nodes) = world.get_resource::<Ownership>().map(|o| o.nodes.clone()) {
            // Each rank measures the reactions at the nodes it owns.
            world.resource_mut::<BoundaryConditions>().measured_nodes = Some(nodes);
        }
        let output = self.output_plan(tracked)?;
        Ok((world, body_particles, output))
    }

    /// The engine's own systems: a health check after every stage that has systems, the loads,
    /// the energy account (from the state as built) and, with `on_leave_grid: Remove`, the
    /// removal of escaped particles.
    fn add_engine_systems(
        &self,
        schedule: &mut Schedule,
        world: &mut World,
        pipeline: &PipelineSummary,
    ) {
        let stages = pipeline.by_stage.iter().map(|(stage, _)| *stage);
        engine_systems::add_stage_checks(schedule, D::DIMENSION, stages);
        if !world.resource::<ParticleLoads<D>>().0.is_empty() {
            engine_systems::add_loads(schedule, D::DIMENSION);
        }
        let start = fractum_engine::diagnostics::totals(world);
        let moment = fractum_engine::energy::first_moment::<D>(world);
        world.insert_resource(fractum_engine::energy::EnergyAccount::new(
            start.total_energy(),
            moment,
        ));
        let floor = {
            let moduli: Vec<f64> = world
                .resource::<fractum_engine::resources::Materials>()
                .0
                .iter()
                .map(|m| m.youngs_modulus)
                .collect();
            let mut query = world.query_filtered::<(
                &fractum_engine::components::InitialVolume,
                &fractum_engine::components::MaterialId,
            ), bevy_ecs::query::With<fractum_engine::components::Particle>>(
            );
            // A rank's floor is its owned particles' part; a distributed run adds the parts.
            let ownership = world.get_resource::<Ownership>();
            fractum_engine::energy::energy_floor(
                query
                    .iter(world)
                    .enumerate()
                    .filter(|(row, _)| fractum_engine::decomposition::counts_here(ownership, *row))
                    .map(|(_, (v, m))| (v.0, moduli.get(usize::from(m.0)).copied().unwrap_or(0.0))),
            )
        };
        world.insert_resource(fractum_engine::energy::EnergyWatch::with_floor(floor));
        if let Some(q) = self.spec.quasi_static {
            use fractum_engine::quasi_static::KineticWatch;
            world.insert_resource(KineticWatch::new(q.kinetic_limit, floor));
            fractum_engine::checkpoint::carry_resource::<KineticWatch>(world);
        }
        engine_systems::add_work_account(schedule, D::DIMENSION);
        if self.spec.on_leave_grid == LeaveGrid::Remove {
            let on_a_rank = world.contains_resource::<Ownership>();
            engine_systems::add_escape_removal(schedule, D::DIMENSION, on_a_rank);
        }
    }

    fn summary(&self, body_particles: &[usize]) -> SceneSummary {
        SceneSummary {
            source: self.spec.source.name().to_string(),
            title: self.spec.title.clone(),
            thickness: self.spec.thickness,
            bodies: self
                .spec
                .bodies
                .iter()
                .zip(body_particles)
                .enumerate()
                .map(|(b, (body, n))| (body.name.clone().unwrap_or(format!("body {b}")), *n))
                .collect(),
            boundaries: self
                .spec
                .boundaries
                .iter()
                .map(|r| {
                    (
                        r.name.clone(),
                        regions::describe_condition::<D>(&r.condition),
                    )
                })
                .collect(),
            time_step: Some(self.spec.time_step),
        }
    }
}
