//! From a checked [`Spec`] to a [`Simulation`]: spawning nodes and particles, resolving boundary
//! regions and probes, and the engine's own systems. The pipeline is installed by
//! `scene::pipeline`; the checks that need the world (memory, the stable step) are
//! `scene::world_checks`.

use super::SceneError;
use super::format::Probe;
use super::mesh::Facet;
use super::seed::{Seeds, particles_in_shape};
use super::spec::{Body, Boundary, Built, Condition, SceneSummary, Spec};
use bevy_ecs::prelude::{With, World};
use bevy_ecs::schedule::IntoScheduleConfigs;
use fractum_engine::boundary::{BoundaryConditions, BoundaryRegion, PiecewiseLinear, Reactions};
use fractum_engine::components::{
    BodyId, ContactGroup, Damage, NodeBundle, ParticleBundle, Velocity, WaveSpeed,
};
use fractum_engine::connectivity::Connectivity;
use fractum_engine::decomposition::{Layout, Ownership, RankRebuild};
use fractum_engine::dim::{Dim, Lattice, VectorOps, lattice_range};
use fractum_engine::health::{LeaveGrid, mark_escaped_particles, remove_escaped_particles};
use fractum_engine::loads::{LoadShare, ParticleLoads, apply_loads};
use fractum_engine::registry::Registry;
use fractum_engine::registry::templates::{ComponentTemplates, TemplateSet};
use fractum_engine::resources::{BodyForce, Grid, Materials, SimClock, Thickness};
use fractum_engine::series::SeriesColumns;
use fractum_engine::simulation::{Simulation, add_stage_checks, step_schedule};
use fractum_engine::stage::{Stage, StageCheck, StepSet};
use fractum_io::output::{OutputPlan, ProbeKind};

/// What a seeded particle starts with: its material index, velocity and damage.
type SeedState<D> = (usize, <D as Dim>::Vector, f64);

/// The particle a `Track` probe follows: its id and its position at the start (x, y, z).
type TrackedParticle = Option<(u32, [f64; 3])>;

/// Which rank a world is built for, and the slabs.
struct RankPlan {
    rank: usize,
    layout: Layout,
    /// The run's particles, every rank's.
    total: u64,
}

impl RankPlan {
    /// Whether the rank holds a particle at `x` (in its slab or its halo).
    fn holds<D: Dim>(&self, grid: &Grid<D>, x: D::Vector) -> bool {
        let layer = grid.clamped_axis_cell(self.layout.axis, x[self.layout.axis]);
        self.layout.held(self.rank).contains(&layer)
    }
}

/// A scene's world with its pipeline installed, before the engine's own systems.
struct Installed {
    world: World,
    schedule: bevy_ecs::schedule::Schedule,
    body_particles: Vec<usize>,
    output: OutputPlan,
    pipeline: super::spec::PipelineSummary,
}

impl<D: Dim> Spec<D> {
    /// Checks the spec, builds the world and the step schedule with systems from `registry`,
    /// and checks what only the built world can tell. The memory the scene needs is estimated
    /// from counts (the grid, the seeds, what the pipeline gives each entity and declares)
    /// before any entity is spawned.
    pub fn build(self, registry: &Registry) -> Result<Built, SceneError> {
        self.build_for(registry, None)
    }

    /// [`Spec::build`] for rank `rank` of a distributed run of `ranks`: the world holds the
    /// particles of the rank's slab and its halo ([`fractum_engine::decomposition::Ownership`]), and is
    /// stepped with [`fractum_io::run::distributed::step`]. Every rank builds the same slabs from the
    /// same seeds.
    pub fn build_rank(
        self,
        registry: &Registry,
        rank: usize,
        ranks: usize,
    ) -> Result<Built, SceneError> {
        self.build_for(registry, Some((rank, ranks, None)))
    }

    /// [`Spec::build_rank`] on the slabs of `layout` rather than a cut of the seeds: a world
    /// for slabs that were re-cut during the run (a resume, a rebalance), holding the particles
    /// it spawns from the seeds in its slab and halo and the nodes they reach. The run's
    /// particles are then put into it ([`fractum_io::run::distributed`]).
    pub fn build_rank_on(
        self,
        registry: &Registry,
        rank: usize,
        layout: Layout,
    ) -> Result<Built, SceneError> {
        let ranks = layout.slabs.len();
        self.build_for(registry, Some((rank, ranks, Some(layout))))
    }

    fn build_for(
        mut self,
        registry: &Registry,
        rank: Option<(usize, usize, Option<Layout>)>,
    ) -> Result<Built, SceneError> {
        let rebuild = rank.as_ref().map(|_| (self.clone(), registry.clone()));
        let ranks = rank.as_ref().map_or(1, |r| r.1);
        let (available, seeds, probe) = self.seeded_and_probed(registry, ranks)?;
        let plan = match rank {
            Some((rank, ranks, layout)) => {
                Some(self.rank_plan(&seeds, &probe, rank, ranks, layout)?)
            }
            None => None,
        };
        if let Some(plan) = &plan {
            // A rank holds the nodes its particles reach; positions stay the whole grid's.
            self.grid = self.rank_grid(&plan.layout, plan.rank, &probe);
        }
        // A rank needs memory for what it holds, not for the whole scene.
        let memory = match &plan {
            Some(plan) => {
                let held = self.rank_seeds(&seeds, &plan.layout, plan.rank);
                self.check_memory_from_counts(&held, &probe, available)?
            }
            None => self.check_memory_from_counts(&seeds, &probe, available)?,
        };
        let Installed {
            mut world,
            mut schedule,
            body_particles,
            mut output,
            pipeline,
        } = self.spawn_and_install(registry, seeds, &probe.templates, plan.as_ref())?;
        if let (Some(plan), Some((spec, registry))) = (&plan, rebuild) {
            world.insert_resource(rank_rebuild(spec, registry, plan.rank, &probe));
            self.distribute(&mut world, probe.templates.particles)?;
        }
        world.insert_resource(memory);
        self.check_checkpoint_keys(&world)?;
        self.check_strength_scales(&mut world)?;
        self.check_frame_fields(&world)?;
        output.system_columns = world
            .get_resource::<SeriesColumns>()
            .map(SeriesColumns::published)
            .unwrap_or_default();
        self.check_stable_step(&mut world)?;
        self.add_engine_systems(&mut schedule, &mut world, &pipeline);
        let simulation =
            Simulation::new::<D>(world, schedule, self.time_step, self.end).map_err(|e| {
                self.source.error(
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

    /// The slabs of `ranks` ranks, with halos as deep as the pipeline's step reaches.
    fn rank_plan(
        &self,
        seeds: &[Seeds<D>],
        probe: &super::estimate::PipelineProbe,
        rank: usize,
        ranks: usize,
        layout: Option<Layout>,
    ) -> Result<RankPlan, SceneError> {
        if probe.reach.support.is_none() {
            return Err(self.source.error(
                "pipeline",
                "no basis system of this pipeline declares its support radius \
                 (Installer::declare_support_radius), so the halo a rank needs is unknown; run \
                 it as one process",
            ));
        }
        let layout = match layout {
            Some(layout) => layout,
            None => self.layout(self.slabs(seeds, ranks)?.slabs, probe),
        };
        Ok(RankPlan {
            rank,
            layout,
            total: seeds.iter().map(Vec::len).sum::<usize>() as u64,
        })
    }

    /// Makes `world`, built for a rank, a rank's world: the particle templates that particles
    /// arriving from other ranks are spawned with. Refuses a pipeline
    /// that carries state from step to step outside its particles and their rows (a running
    /// total), which a rank cannot yet split between ranks.
    fn distribute(&self, world: &mut World, templates: TemplateSet) -> Result<(), SceneError> {
        let engine_state = {
            let mut engine = World::new();
            fractum_io::checkpoint::carry_engine_state::<D>(&mut engine);
            let mut names = engine
                .resource::<fractum_io::checkpoint::CheckpointState>()
                .resource_names();
            // The first step with a split node, which each rank records at the nodes it owns.
            names.push(<fractum_engine::fields::FieldSplits as fractum_io::checkpoint::State>::KEY);
            names
        };
        let state = world
            .get_resource::<fractum_io::checkpoint::CheckpointState>()
            .cloned()
            .unwrap_or_default();
        let carried = state.resource_names();
        // State kept by particle row travels with the particles; other state cannot yet.
        if let Some(own) = carried.iter().find(|n| {
            !engine_state.contains(n) && !state.is_row_resource(n) && !state.is_rank_resource(n)
        }) {
            return Err(self.source.error(
                "pipeline",
                format!(
                    "a system of this pipeline carries \"{own}\" from step to step, which a \
                     distributed run cannot yet split between ranks; run it as one process"
                ),
            ));
        }
        if let Some(column) = world
            .get_resource::<SeriesColumns>()
            .and_then(SeriesColumns::not_summed_over_ranks)
        {
            return Err(self.source.error(
                "pipeline",
                format!(
                    "a system of this pipeline publishes the series column \"{column}\" as \
                     something other than a sum over the particles a rank owns, which a \
                     distributed run cannot yet add up over ranks; run it as one process"
                ),
            ));
        }
        world.insert_resource(fractum_engine::registry::templates::RankParticles(
            templates,
        ));
        Ok(())
    }

    /// What the rank of `plan` owns of the particles spawned in `world`, and of the nodes.
    fn ownership(&self, world: &mut World, plan: &RankPlan) -> Ownership {
        let axis = plan.layout.axis;
        let node_layers = (0..self.grid.node_count()).map(|n| self.grid.node_lattice(n)[axis]);
        let mut ownership = Ownership::new(plan.layout.clone(), plan.rank, plan.total, node_layers);
        let mut query = world
            .query_filtered::<&fractum_engine::components::Position<D>, With<fractum_engine::components::Particle>>();
        let layers: Vec<usize> = query
            .iter(world)
            .map(|x| self.grid.clamped_axis_cell(axis, x.0[axis]))
            .collect();
        ownership.mark(layers.into_iter());
        ownership
    }

    /// Every name in `output.fields` is an array a particle frame of this pipeline has.
    fn check_frame_fields(&self, world: &World) -> Result<(), SceneError> {
        let Some(fields) = &self.output.fields else {
            return Ok(());
        };
        let mut known: Vec<&str> = fractum_io::output::ENGINE_FRAME_FIELDS.to_vec();
        if let Some(columns) = world.get_resource::<fractum_io::output::FrameColumns>() {
            known.extend(columns.names());
        }
        if world.contains_resource::<fractum_engine::fields::FieldsAssigned>() {
            known.push("velocity_field");
        }
        for (i, name) in fields.iter().enumerate() {
            let field = format!("output.fields[{i}]");
            if fields[..i].contains(name) {
                return Err(self
                    .source
                    .error(&field, format!("{name:?} is listed twice")));
            }
            if !known.contains(&name.as_str()) {
                return Err(self.source.error(
                    &field,
                    format!(
                        "no frame field {name:?} in this pipeline (positions are always \
                         written); expected one of: {}",
                        known.join(", ")
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The world with the pipeline installed, each entity spawned with the components the
    /// pipeline gives it (`templates`, recorded by [`Spec::probe_pipeline`]; why:
    /// `registry/templates.rs`), each body's particles from its `seeds`.
    fn spawn_and_install(
        &self,
        registry: &Registry,
        seeds: Vec<Seeds<D>>,
        templates: &ComponentTemplates,
        plan: Option<&RankPlan>,
    ) -> Result<Installed, SceneError> {
        let (mut world, body_particles, output) = self.spawn_world(templates, seeds, plan)?;
        let mut schedule = step_schedule();
        let pipeline = self.install_pipeline(registry, &mut schedule, &mut world)?;
        world.remove_resource::<ComponentTemplates>();
        fractum_engine::registry::pending::insert_pending_components(&mut world);
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
        spawn_nodes(&mut world, &self.grid, &templates.nodes);
        // From every seed: a rank's world holds only some of the particles.
        let tracked = self.tracked_particles(&seeds)?;
        let (body_particles, loads) =
            self.spawn_bodies(&mut world, &templates.particles, seeds, plan)?;
        if let Some(plan) = plan {
            // Before the pipeline is installed: installers sum what the rank owns.
            let ownership = self.ownership(&mut world, plan);
            world.insert_resource(ownership);
        }
        self.insert_scene_resources(&mut world, loads)?;
        if let Some(nodes) = world.get_resource::<Ownership>().map(|o| o.nodes.clone()) {
            // Each rank measures the reactions at the nodes it owns.
            world.resource_mut::<BoundaryConditions>().measured_nodes = Some(nodes);
        }
        let output = self.output_plan(tracked)?;
        Ok((world, body_particles, output))
    }

    /// The resources every world of the scene has, its particles' `loads` among them.
    pub(super) fn insert_scene_resources(
        &self,
        world: &mut World,
        loads: ParticleLoads<D>,
    ) -> Result<(), SceneError> {
        let boundaries = self.boundary_conditions()?;
        world.insert_resource(self.grid.clone());
        world.insert_resource(D::DIMENSION);
        world.insert_resource(Thickness(self.thickness));
        world.insert_resource(loads);
        world.insert_resource(Materials(self.materials.clone()));
        world.insert_resource(BodyForce::<D>(self.body_force));
        world.insert_resource(Reactions::<D>(vec![
            D::Vector::ZERO;
            boundaries.regions.len()
        ]));
        world.insert_resource(boundaries);
        world.insert_resource(SimClock::default());
        world.insert_resource(self.on_leave_grid);
        world.init_resource::<Connectivity<D>>();
        fractum_io::checkpoint::carry_engine_state::<D>(world);
        Ok(())
    }

    /// Refuses a pipeline in which two systems carry different state under one checkpoint key.
    fn check_checkpoint_keys(&self, world: &World) -> Result<(), SceneError> {
        match world
            .get_resource::<fractum_io::checkpoint::CheckpointState>()
            .and_then(|state| state.collisions().first().copied())
        {
            Some(key) => Err(self.source.error(
                "pipeline",
                format!(
                    "two systems carry different state under the checkpoint key \"{key}\"; give \
                     one of them its own key (checkpoint::State::KEY)"
                ),
            )),
            None => Ok(()),
        }
    }

    /// The engine's own systems: a health check after every stage that has systems, the loads,
    /// the energy account (from the state as built) and, with `on_leave_grid: Remove`, the
    /// removal of escaped particles.
    fn add_engine_systems(
        &self,
        schedule: &mut bevy_ecs::schedule::Schedule,
        world: &mut World,
        pipeline: &super::spec::PipelineSummary,
    ) {
        add_stage_checks::<D>(schedule, pipeline.by_stage.iter().map(|(stage, _)| *stage));
        if !world.resource::<ParticleLoads<D>>().0.is_empty() {
            schedule.add_systems(apply_loads::<D>.in_set(StepSet::ApplyLoads));
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
        schedule
            .add_systems(fractum_engine::energy::account_work::<D>.in_set(StepSet::AccountWork));
        if self.on_leave_grid == LeaveGrid::Remove {
            if world.contains_resource::<Ownership>() {
                // A rank despawns none in the step, which would move its rows: it disowns
                // them after the check, before the work is accounted, and the step's
                // redistribution drops them (`run::distributed`).
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
        }
    }

    fn summary(&self, body_particles: &[usize]) -> SceneSummary {
        SceneSummary {
            source: self.source.name().to_string(),
            title: self.title.clone(),
            thickness: self.thickness,
            bodies: self
                .bodies
                .iter()
                .zip(body_particles)
                .enumerate()
                .map(|(b, (body, n))| (body.name.clone().unwrap_or(format!("body {b}")), *n))
                .collect(),
            boundaries: self
                .boundaries
                .iter()
                .map(|r| (r.name.clone(), describe_condition::<D>(&r.condition)))
                .collect(),
            time_step: Some(self.time_step),
        }
    }

    /// Each body's seeds (position, volume), overlaps with other bodies resolved, in body
    /// order.
    pub(super) fn seed_bodies(&self) -> Result<Vec<Seeds<D>>, SceneError> {
        self.bodies
            .iter()
            .enumerate()
            .map(|(b, body)| self.seed_body(b, body))
            .collect()
    }

    fn seed_body(&self, b: usize, body: &Body<D>) -> Result<Vec<(D::Vector, f64)>, SceneError> {
        let seeded = particles_in_shape(
            &body.shape,
            &self.grid,
            body.particles_per_cell,
            body.placement,
            self.thickness,
        );
        let seeded = self.resolve_overlaps(b, seeded)?;
        if seeded.is_empty() {
            return Err(self.source.error(
                &format!("bodies[{b}].shape"),
                "no particle falls inside this shape; make it larger than a cell or use more \
                 particles per cell",
            ));
        }
        Ok(seeded)
    }

    /// Spawns each body's particles from its seeds; returns each body's count and the
    /// particles' shares of the loads.
    fn spawn_bodies(
        &self,
        world: &mut World,
        templates: &TemplateSet,
        seeds: Vec<Seeds<D>>,
        plan: Option<&RankPlan>,
    ) -> Result<(Vec<usize>, ParticleLoads<D>), SceneError> {
        let mut counts = Vec::new();
        let mut next_id: u32 = 0;
        let mut loads = ParticleLoads::<D>::default();
        for ((b, body), seeded) in self.bodies.iter().enumerate().zip(seeds) {
            let mut bundles = self.body_particles(b, body, seeded, &mut next_id)?;
            self.share_loads(b, body, &mut bundles, &mut loads)?;
            if let Some(plan) = plan {
                // Ids, load shares and strength scales are the whole body's; the rank keeps its
                // own.
                bundles.retain(|p| plan.holds(&self.grid, p.position.0));
            }
            counts.push(bundles.len());
            let scales = strength_scales(body, &bundles);
            let entities = templates.spawn(world, bundles);
            for (k, scale) in scales {
                // Spawned with a scale of 1 (`Spec::probe_pipeline`): set in place, in the
                // same table.
                if let Some(mut given) =
                    world.get_mut::<fractum_engine::components::StrengthScale>(entities[k])
                {
                    given.0 = scale;
                }
            }
        }
        Ok((counts, loads))
    }

    /// Gives each particle of `body` its share of the first of the body's loads that covers it.
    fn share_loads(
        &self,
        b: usize,
        body: &Body<D>,
        bundles: &mut [ParticleBundle<D>],
        loads: &mut ParticleLoads<D>,
    ) -> Result<(), SceneError> {
        if body.loads.is_empty() {
            return Ok(());
        }
        let first = loads.0.len();
        if first + body.loads.len() >= LoadShare::NONE as usize {
            return Err(self.source.error("bodies", "more than 65534 loads"));
        }
        let mut volumes = vec![0.0; body.loads.len()];
        for p in bundles.iter_mut() {
            let x = p.position.0.to_3d().into();
            let covering = body
                .loads
                .iter()
                .position(|l| l.region.as_ref().is_none_or(|r| r.contains(x)));
            if let Some(k) = covering {
                volumes[k] += p.volume.0;
                p.load = LoadShare {
                    load: (first + k) as u16,
                    share: p.volume.0,
                };
            }
        }
        for (k, load) in body.loads.iter().enumerate() {
            if volumes[k] == 0.0 {
                return Err(self.source.error(
                    &format!("bodies[{b}].loads[{k}].region"),
                    "no particle of the body lies in this region",
                ));
            }
            let ramp = if load.ramp.is_empty() {
                PiecewiseLinear::constant(1.0)
            } else {
                PiecewiseLinear::new(load.ramp.clone()).map_err(|e| {
                    self.source
                        .error(&format!("bodies[{b}].loads[{k}].ramp"), e)
                })?
            };
            loads.0.push((load.total, ramp));
        }
        for p in bundles
            .iter_mut()
            .filter(|p| p.load.load != LoadShare::NONE)
        {
            p.load.share /= volumes[p.load.load as usize - first];
        }
        Ok(())
    }

    /// What a particle of `body` seeded at `x` starts with: its material index, velocity and
    /// damage, from the body, its point file's attributes, its image's phases and its cracks.
    pub(super) fn seed_state<'a>(
        &'a self,
        b: usize,
        body: &'a Body<D>,
    ) -> Result<impl Fn(D::Vector) -> SeedState<D> + 'a, SceneError> {
        let material = self.material_index(&body.material, &format!("bodies[{b}].material"))?;
        // What a point file gives of each particle overrides the body's defaults.
        let points = body.shape.point_set();
        let point_materials: Vec<usize> = match points {
            Some(set) => set
                .material_names()
                .iter()
                .map(|name| self.point_material(set, name, &format!("bodies[{b}].shape")))
                .collect::<Result<_, _>>()?,
            None => Vec::new(),
        };
        // An image's phases may name their own materials.
        let image = body.shape.image();
        let phase_materials: Vec<usize> = match image {
            Some(image) => image
                .phases()
                .iter()
                .map(|p| match &p.material {
                    Some(name) => self.material_index(name, &format!("bodies[{b}].shape")),
                    None => Ok(material),
                })
                .collect::<Result<_, _>>()?,
            None => Vec::new(),
        };
        Ok(move |x: D::Vector| {
            let given = points.and_then(|set| set.attributes(x.to_3d().into()));
            let material = given
                .and_then(|g| g.material)
                .and_then(|name| points?.material_names().iter().position(|n| n == name))
                .map_or(material, |k| point_materials[k]);
            let material = image
                .and_then(|image| image.phase_at(x.to_3d().into()))
                .map_or(material, |k| phase_materials[k]);
            let velocity = given
                .and_then(|g| g.velocity)
                .map_or_else(|| body.velocity.at(x), |v| D::Vector::from_fn(|a| v[a]));
            let cracked = body
                .cracks
                .iter()
                .any(|crack| crack.contains(x.to_3d().into()));
            let damage = if cracked {
                1.0
            } else {
                given.and_then(|g| g.damage).unwrap_or(0.0)
            };
            (material, velocity, damage)
        })
    }

    pub(super) fn body_particles(
        &self,
        b: usize,
        body: &Body<D>,
        seeded: Vec<(D::Vector, f64)>,
        next_id: &mut u32,
    ) -> Result<Vec<ParticleBundle<D>>, SceneError> {
        if (*next_id as usize).saturating_add(seeded.len()) > u32::MAX as usize {
            return Err(self.source.error("bodies", "more than 2^32 particles"));
        }
        let initial = self.seed_state(b, body)?;
        if let Some((x, volume, v, density)) = seeded.iter().find_map(|&(x, volume)| {
            let (material, v, _) = initial(x);
            let density = self.materials[material].density;
            let finite = v.is_finite() && (0.5 * density * volume * v.dot(v)).is_finite();
            (!finite).then_some((x, volume, v, density))
        }) {
            return Err(self.source.error(
                &format!("bodies[{b}].velocity"),
                format!(
                    "the velocity at the particle at {:?} is {:?} m/s, whose kinetic energy ½mv² \
                     = {:e} J is not a finite number; expected finite velocities of finite energy",
                    x.to_3d(),
                    v.to_3d(),
                    0.5 * density * volume * v.dot(v)
                ),
            ));
        }
        Ok(seeded
            .iter()
            .map(|&(x, volume)| {
                let (material, velocity, damage) = initial(x);
                let m = &self.materials[material];
                let mut p = ParticleBundle::<D>::new(
                    *next_id,
                    x,
                    m.density * volume,
                    volume,
                    material as u16,
                );
                *next_id += 1;
                p.velocity = Velocity(velocity);
                p.body = BodyId(b as u16);
                p.wave_speed = WaveSpeed(m.wave_speed());
                p.damage = Damage(damage);
                p.group = ContactGroup(body.contact_group);
                p
            })
            .collect())
    }

    /// The scene's material a point file's `material` value names: a name (CSV) or an index
    /// into the scene's materials (VTU, as Fractum's frames write it).
    fn point_material(
        &self,
        set: &super::points::PointSet,
        name: &str,
        field: &str,
    ) -> Result<usize, SceneError> {
        if !set.materials_by_index() {
            return self.material_index(name, field);
        }
        match name.parse::<usize>() {
            Ok(k) if k < self.materials.len() => Ok(k),
            _ => Err(self.source.error(
                field,
                format!(
                    "the point file's `material` holds {name}; expected an index of the scene's \
                     materials, 0 to {}",
                    self.materials.len() - 1
                ),
            )),
        }
    }

    fn boundary_conditions(&self) -> Result<BoundaryConditions, SceneError> {
        let regions = self
            .boundaries
            .iter()
            .enumerate()
            .map(|(r, region)| self.region(r, region))
            .collect::<Result<_, _>>()?;
        Ok(BoundaryConditions {
            regions,
            measured_nodes: None,
        })
    }

    fn region(&self, r: usize, region: &Boundary<D>) -> Result<BoundaryRegion, SceneError> {
        let nodes = region_nodes(&self.grid, region);
        // A rank's world may hold none of a region's nodes; the scene must have some.
        if nodes.is_empty()
            && (self.grid.window.is_none() || region_nodes(&self.grid.whole(), region).is_empty())
        {
            let what = match region.facets {
                Some(_) => "no grid node lies within half a cell of this boundary group",
                None => "no grid node lies in this box",
            };
            return Err(self.source.error(&format!("boundaries[{r}].nodes"), what));
        }
        let rest = || Some(PiecewiseLinear::constant(0.0));
        let velocity = match &region.condition {
            Condition::Fixed => std::array::from_fn(|a| if a < D::N { rest() } else { None }),
            Condition::Roller { normal } => {
                std::array::from_fn(|a| if a == *normal { rest() } else { None })
            }
            // Checked by `Spec::check`: each given list is a valid function.
            Condition::Velocity(components) => std::array::from_fn(|a| {
                components[a]
                    .clone()
                    .and_then(|points| PiecewiseLinear::new(points).ok())
            }),
        };
        Ok(BoundaryRegion {
            name: region.name.clone(),
            nodes,
            velocity,
        })
    }

    /// For each probe, the particle a `Track` probe follows and the one it is relative to, from
    /// the seeds of every body: the particle nearest its point, by id (particles take ids in
    /// seed order), the lowest id of the nearest on a tie.
    fn tracked_particles(
        &self,
        seeds: &[Seeds<D>],
    ) -> Result<Vec<[TrackedParticle; 2]>, SceneError> {
        let first_ids: Vec<u32> = seeds
            .iter()
            .scan(0u32, |next, body| {
                let first = *next;
                *next = next.saturating_add(body.len() as u32);
                Some(first)
            })
            .collect();
        let nearest = |body: usize, at: D::Vector| -> TrackedParticle {
            let found = seeds[body]
                .iter()
                .enumerate()
                .map(|(k, (x, _))| (k, *x, (*x - at).length()))
                .min_by(|a, b| a.2.total_cmp(&b.2).then(a.0.cmp(&b.0)));
            found.map(|(k, x, _)| {
                let start = std::array::from_fn(|a| if a < D::N { x[a] } else { 0.0 });
                (first_ids[body] + k as u32, start)
            })
        };
        let mut tracked = Vec::new();
        for (k, probe) in self.output.probes.iter().enumerate() {
            tracked.push(match probe {
                Probe::Track {
                    body,
                    at,
                    relative_to,
                    ..
                } => {
                    let at = D::Vector::from_fn(|a| at.0[a]);
                    let reference = match relative_to {
                        Some(other) => nearest(self.body_index(other, k)?, at),
                        None => None,
                    };
                    [nearest(self.body_index(body, k)?, at), reference]
                }
                _ => [None, None],
            });
        }
        Ok(tracked)
    }

    fn output_plan(&self, tracked: Vec<[TrackedParticle; 2]>) -> Result<OutputPlan, SceneError> {
        let mut probes = Vec::new();
        for (k, probe) in self.output.probes.iter().enumerate() {
            probes.push(match probe {
                Probe::Reaction(name) => ProbeKind::Reaction {
                    name: name.clone(),
                    index: self.region_index(name, k)?,
                },
                Probe::CentreOfMassVelocity => ProbeKind::CentreOfMassVelocity,
                Probe::Force(name) => ProbeKind::Force {
                    name: name.clone(),
                    index: self.body_index(name, k)? as u16,
                },
                Probe::Displacement(name) => ProbeKind::Displacement {
                    name: name.clone(),
                    index: self.region_index(name, k)?,
                },
                Probe::Track { name, .. } => {
                    let [particle, reference] = tracked[k];
                    ProbeKind::Track {
                        name: name.clone(),
                        particle,
                        reference,
                    }
                }
            });
        }
        Ok(OutputPlan {
            dimension: D::DIMENSION,
            vtu_every: self.output.vtu_every,
            grid_every: self.output.grid_every,
            csv_every: self.output.csv_every,
            probes,
            last_good_frame: self.output.last_good_frame,
            system_columns: Vec::new(),
            compression: self.output.compression,
            frame_fields: self.output.fields.clone(),
        })
    }
}

/// The grid nodes within half a cell (the smallest width of the cells around the node) of any
/// of `facets`, in index order: each facet looks only at the nodes of its own bounding box.
fn nodes_near_facets<D: Dim>(grid: &Grid<D>, facets: &[Facet]) -> Vec<u32> {
    let mut nodes = Vec::new();
    for facet in facets {
        let (lo, hi) = facet.bounds();
        // The nodes of the cells holding the facet's box, and one cell more each way: half a
        // cell of reach.
        let reach = |a: usize, x: f64, up: bool| {
            let x = x.clamp(grid.min[a], grid.coordinate(a, grid.cells[a]));
            let cell = grid
                .axis_cell(a, x)
                .unwrap_or(if up { grid.cells[a] - 1 } else { 0 });
            if up {
                (cell + 2).min(grid.cells[a])
            } else {
                cell.saturating_sub(1)
            }
        };
        let first = D::Cell::from_fn(|a| reach(a, lo[a], false));
        let end = D::Cell::from_fn(|a| reach(a, hi[a], true) + 1);
        for node in lattice_range(first, end) {
            let x = grid.lattice_position(node);
            let half = 0.5 * grid.smallest_width_near(x);
            if facet.distance(x.to_3d().into()) <= half
                && let Some(index) = grid.held_node_index(node)
            {
                nodes.push(index as u32);
            }
        }
    }
    nodes.sort_unstable();
    nodes.dedup();
    nodes
}

/// The strength scale a point file gives each of `bundles`, by index, when it has a
/// `strength_scale` column.
fn strength_scales<D: Dim>(body: &Body<D>, bundles: &[ParticleBundle<D>]) -> Vec<(usize, f64)> {
    let Some(set) = body.shape.point_set().filter(|s| s.has_strength_scale()) else {
        return Vec::new();
    };
    bundles
        .iter()
        .enumerate()
        .filter_map(|(k, p)| {
            let given = set.attributes(p.position.0.to_3d().into())?;
            Some((k, given.strength_scale?))
        })
        .collect()
}

/// The indices of the held nodes of `grid` in `region`: within its box, or within half a cell
/// of its facets.
fn region_nodes<D: Dim>(grid: &Grid<D>, region: &Boundary<D>) -> Vec<u32> {
    let tol = 1e-9 * grid.spacing;
    match &region.facets {
        Some(facets) => nodes_near_facets(grid, &facets.facets),
        None => (0..grid.node_count())
            .filter(|&i| {
                let x = grid.node_position(i);
                (0..D::N).all(|a| x[a] >= region.min[a] - tol && x[a] <= region.max[a] + tol)
            })
            .map(|i| i as u32)
            .collect(),
    }
}

/// What rebuilds the world of rank `rank` of `spec` for other slabs: the spec as the scene
/// gave it, with the nodes a rank reaches from the probed pipeline's support.
fn rank_rebuild<D: Dim>(
    spec: Spec<D>,
    registry: Registry,
    rank: usize,
    probe: &super::estimate::PipelineProbe,
) -> RankRebuild {
    let reach = spec.node_reach(probe);
    RankRebuild::new(reach, move |layout: &Layout| {
        let built = spec
            .clone()
            .build_rank_on(&registry, rank, layout.clone())
            .map_err(|e| e.to_string())?;
        Ok(built.simulation)
    })
}

fn spawn_nodes<D: Dim>(world: &mut World, grid: &Grid<D>, templates: &TemplateSet) {
    let nodes: Vec<NodeBundle<D>> = (0..grid.node_count())
        .map(|i| NodeBundle::new(i as u32, grid.node_position(i)))
        .collect();
    templates.spawn(world, nodes);
}

fn describe_condition<D: Dim>(condition: &Condition) -> String {
    match condition {
        Condition::Fixed => "fixed".into(),
        Condition::Roller { normal } => format!("roller, {} held", D::AXES[*normal]),
        Condition::Velocity(components) => {
            let given: Vec<&str> = (0..D::N)
                .filter(|a| components[*a].is_some())
                .map(|a| D::AXES[a])
                .collect();
            format!("prescribed velocity ({})", given.join(", "))
        }
    }
}
