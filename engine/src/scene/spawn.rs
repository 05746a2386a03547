//! From a checked [`Spec`] to a [`Simulation`]: spawning nodes and particles, resolving boundary
//! regions and probes, installing the pipeline, and the last checks that need the world (a
//! shape that seeds no particle, a region with no node, a fixed step above the stable limit).

use super::budget::{self, MemoryEstimate, ParticleMemory};
use super::format::Probe;
use super::seed::particles_in_shape;
use super::spec::{
    Body, Boundary, Built, Condition, PipelineEntry, PipelineSummary, SceneSummary, Spec,
};
use super::{SceneError, Source};
use crate::boundary::{BoundaryConditions, BoundaryRegion, PiecewiseLinear, Reactions};
use crate::components::{
    BodyId, ContactGroup, Damage, NodeBundle, ParticleBundle, Velocity, WaveSpeed,
};
use crate::connectivity::Connectivity;
use crate::dim::{Dim, VectorOps};
use crate::health::{LeaveGrid, remove_escaped_particles};
use crate::loads::{LoadShare, ParticleLoads, apply_loads};
use crate::output::{OutputPlan, ProbeKind};
use crate::registry::{Installer, MaterialFilter, PipelineEntrySet, Registration, Registry};
use crate::resources::{BodyForce, Grid, Materials, SimClock, Thickness, TimeStepLimit};
use crate::series::SeriesColumns;
use crate::simulation::{
    End, Simulation, TimeStep, add_stage_checks, stable_time_step, step_schedule,
};
use crate::stage::{Stage, StageCheck, StepSet};
use bevy_ecs::prelude::World;
use bevy_ecs::schedule::{IntoScheduleConfigs, Schedule};

impl<D: Dim> Spec<D> {
    /// Checks the spec, builds the world and the step schedule with systems from `registry`,
    /// and checks what only the built world can tell.
    pub fn build(self, registry: &Registry) -> Result<Built, SceneError> {
        self.check()?;
        let available = super::budget::available_memory();
        self.check_memory_before_spawning(available)?;
        let mut world = World::new();
        world.insert_resource(self.grid.clone());
        world.insert_resource(D::DIMENSION);
        world.insert_resource(Thickness(self.thickness));
        spawn_nodes(&mut world, &self.grid);
        let body_particles = self.spawn_bodies(&mut world)?;
        let boundaries = self.boundary_conditions()?;
        let mut output = self.output_plan(&mut world)?;
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
        crate::checkpoint::carry_engine_state::<D>(&mut world);
        let mut schedule = step_schedule();
        let pipeline = self.install_pipeline(registry, &mut schedule, &mut world)?;
        if let Some(key) = world
            .get_resource::<crate::checkpoint::CheckpointState>()
            .and_then(|state| state.collisions().first().copied())
        {
            return Err(self.source.error(
                "pipeline",
                format!(
                    "two systems carry different state under the checkpoint key \"{key}\"; give \
                     one of them its own key (checkpoint::State::KEY)"
                ),
            ));
        }
        output.system_columns = world
            .get_resource::<SeriesColumns>()
            .map(SeriesColumns::published)
            .unwrap_or_default();
        self.check_stable_step(&mut world)?;
        self.check_memory_after_install(&mut world, available)?;
        add_stage_checks::<D>(
            &mut schedule,
            pipeline.by_stage.iter().map(|(stage, _)| *stage),
        );
        if !world.resource::<ParticleLoads<D>>().0.is_empty() {
            schedule.add_systems(apply_loads::<D>.in_set(StepSet::ApplyLoads));
        }
        let start = crate::diagnostics::totals(&mut world);
        let moment = {
            let mut query = world.query_filtered::<(
                &crate::components::Mass,
                &crate::components::Position<D>,
            ), bevy_ecs::query::With<crate::components::Particle>>();
            crate::energy::first_moment::<D>(query.iter(&world).map(|(m, x)| (m.0, x.0)))
        };
        world.insert_resource(crate::energy::EnergyAccount::new(
            start.total_energy(),
            moment,
        ));
        schedule.add_systems(crate::energy::account_work::<D>.in_set(StepSet::AccountWork));
        if self.on_leave_grid == LeaveGrid::Remove {
            schedule
                .add_systems(remove_escaped_particles::<D>.in_set(StageCheck(Stage::Advection)));
        }
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

    /// Refuses a grid or bodies that cannot fit in `available` bytes before any is made: the
    /// nodes, and each body's particles bounded by its bounding box's cells (at the smallest
    /// cell width) times the particles per cell.
    fn check_memory_before_spawning(&self, available: f64) -> Result<(), SceneError> {
        let nodes = (0..D::N)
            .map(|a| (self.grid.cells[a] + 1) as f64)
            .product::<f64>();
        let mut estimate = MemoryEstimate::default();
        estimate.add(
            format!("{} grid nodes", budget::describe_count(nodes)),
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
            let particles = cells * f64::from(body.particles_per_cell).powi(D::N as i32);
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

    /// Refuses a scene whose particles, with the storage each installed system declared per
    /// particle (a basis's support, a neighbour search's lists), cannot fit in `available`
    /// bytes; checked before the first step allocates that storage.
    fn check_memory_after_install(
        &self,
        world: &mut World,
        available: f64,
    ) -> Result<(), SceneError> {
        let particles = world
            .query_filtered::<(), bevy_ecs::query::With<crate::components::Particle>>()
            .iter(world)
            .count() as f64;
        let nodes = self.grid.node_count() as f64;
        let mut estimate = MemoryEstimate::default();
        estimate.add(
            format!("{} grid nodes", budget::describe_count(nodes)),
            nodes * budget::node_bytes::<D>(),
        );
        estimate.add(
            format!("{} particles", budget::describe_count(particles)),
            particles * budget::particle_bytes::<D>(),
        );
        let mut largest = ("pipeline".to_string(), 0.0);
        if let Some(declared) = world.get_resource::<ParticleMemory>() {
            for (field, what, bytes) in &declared.0 {
                estimate.add(what.clone(), particles * bytes);
                if particles * bytes > largest.1 {
                    largest = (field.clone(), particles * bytes);
                }
            }
        }
        estimate.working = budget::WORKING_BUFFERS;
        match estimate.refusal(available) {
            None => {
                world.insert_resource(budget::MemoryUse {
                    needed: estimate.total(),
                    available,
                });
                Ok(())
            }
            Some(message) => Err(self.source.error(&largest.0, message)),
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

    fn spawn_bodies(&self, world: &mut World) -> Result<Vec<usize>, SceneError> {
        let mut counts = Vec::new();
        let mut next_id: u32 = 0;
        let mut loads = ParticleLoads::<D>::default();
        for (b, body) in self.bodies.iter().enumerate() {
            let mut bundles = self.body_particles(b, body, &mut next_id)?;
            self.share_loads(b, body, &mut bundles, &mut loads)?;
            counts.push(bundles.len());
            world.spawn_batch(bundles);
        }
        world.insert_resource(loads);
        Ok(counts)
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

    fn body_particles(
        &self,
        b: usize,
        body: &Body<D>,
        next_id: &mut u32,
    ) -> Result<Vec<ParticleBundle<D>>, SceneError> {
        let material = self.material_index(&body.material, &format!("bodies[{b}].material"))?;
        let seeded = particles_in_shape(
            &body.shape,
            &self.grid,
            body.particles_per_cell,
            body.placement,
            self.thickness,
        );
        if seeded.is_empty() {
            return Err(self.source.error(
                &format!("bodies[{b}].shape"),
                "no particle falls inside this shape; make it larger than a cell or use more \
                 particles per cell",
            ));
        }
        if (*next_id as usize).saturating_add(seeded.len()) > u32::MAX as usize {
            return Err(self.source.error("bodies", "more than 2^32 particles"));
        }
        let m = &self.materials[material];
        let (density, wave_speed) = (m.density, m.wave_speed());
        if let Some(&(x, volume)) = seeded.iter().find(|&&(x, volume)| {
            let v = body.velocity.at(x);
            !(v.is_finite() && (0.5 * density * volume * v.dot(v)).is_finite())
        }) {
            let v = body.velocity.at(x);
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
                let mut p = ParticleBundle::<D>::new(
                    *next_id,
                    x,
                    density * volume,
                    volume,
                    material as u16,
                );
                *next_id += 1;
                p.velocity = Velocity(body.velocity.at(x));
                p.body = BodyId(b as u16);
                p.wave_speed = WaveSpeed(wave_speed);
                if body
                    .cracks
                    .iter()
                    .any(|crack| crack.contains(x.to_3d().into()))
                {
                    p.damage = Damage(1.0);
                }
                p.group = ContactGroup(body.contact_group);
                p
            })
            .collect())
    }

    fn boundary_conditions(&self) -> Result<BoundaryConditions, SceneError> {
        let regions = self
            .boundaries
            .iter()
            .enumerate()
            .map(|(r, region)| self.region(r, region))
            .collect::<Result<_, _>>()?;
        Ok(BoundaryConditions { regions })
    }

    fn region(&self, r: usize, region: &Boundary<D>) -> Result<BoundaryRegion, SceneError> {
        let grid = &self.grid;
        let tol = 1e-9 * grid.spacing;
        let nodes: Vec<u32> = (0..grid.node_count())
            .filter(|&i| {
                let x = grid.node_position(i);
                (0..D::N).all(|a| x[a] >= region.min[a] - tol && x[a] <= region.max[a] + tol)
            })
            .map(|i| i as u32)
            .collect();
        if nodes.is_empty() {
            return Err(self.source.error(
                &format!("boundaries[{r}].nodes"),
                "no grid node lies in this box",
            ));
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

    fn output_plan(&self, world: &mut World) -> Result<OutputPlan, SceneError> {
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
                Probe::Track {
                    name,
                    body,
                    at,
                    relative_to,
                } => {
                    let at = D::Vector::from_fn(|a| at.0[a]);
                    let body = self.body_index(body, k)? as u16;
                    let reference = match relative_to {
                        Some(other) => {
                            nearest_particle::<D>(world, self.body_index(other, k)? as u16, at)
                        }
                        None => None,
                    };
                    ProbeKind::Track {
                        name: name.clone(),
                        particle: nearest_particle::<D>(world, body, at),
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
        })
    }

    /// Where errors about pipeline entry `k` point: its place in the file when it is the
    /// entry written there, otherwise nowhere in particular.
    fn entry_source(&self, entry: &PipelineEntry) -> Source {
        if entry.in_source {
            self.source.clone()
        } else {
            Source::code(self.source.name())
        }
    }

    fn install_pipeline(
        &self,
        registry: &Registry,
        schedule: &mut Schedule,
        world: &mut World,
    ) -> Result<PipelineSummary, SceneError> {
        let chosen = self.chosen_systems(registry)?;
        let mut summary = PipelineSummary::default();
        for stage in Stage::ORDER {
            let names: Vec<String> = chosen
                .iter()
                .filter(|(_, r)| r.stage() == Some(stage))
                .map(|(_, r)| r.name.to_string())
                .collect();
            if !names.is_empty() {
                summary.by_stage.push((stage, names));
            }
        }
        let names: Vec<&'static str> = chosen.iter().map(|(_, r)| r.name).collect();
        let filters = self.material_filters(&chosen)?;
        // Installed in stage order (the scene's order within a stage), so an installer can read
        // what the stages before it published: a grid law reads the predictor's integration, a
        // damage law the stress system's capabilities.
        let mut order: Vec<usize> = (0..chosen.len()).collect();
        order.sort_by_key(|&c| chosen[c].1.stage());
        for c in order {
            let ((k, registration), filter) = (&chosen[c], &filters[c]);
            let entry = &self.pipeline[*k];
            let source = self.entry_source(entry);
            let params = source.params(entry.params.as_deref(), format!("pipeline[{k}].params"));
            let stage = registration.stage().unwrap_or(Stage::PostStep);
            params.check_declared(registration)?;
            let mut installer = Installer::new(stage, schedule, world)
                .with_pipeline(names.clone())
                .for_entry(*k, filter.clone());
            (registration.install)(&mut installer, &params)?;
        }
        // Entries of one stage run in the order the scene lists them.
        for (a, (ka, ra)) in chosen.iter().enumerate() {
            if let Some((kb, _)) = chosen[a + 1..]
                .iter()
                .find(|(_, rb)| rb.stage() == ra.stage())
            {
                schedule.configure_sets(PipelineEntrySet(*ka).before(PipelineEntrySet(*kb)));
            }
        }
        Ok(summary)
    }

    /// Each chosen entry's [`MaterialFilter`], checked: known names, only on stress and damage
    /// systems, no material shared by two entries of a stage, and a stress system for every
    /// material a body uses.
    fn material_filters(
        &self,
        chosen: &[(usize, &Registration)],
    ) -> Result<Vec<MaterialFilter>, SceneError> {
        let known = || {
            self.materials
                .iter()
                .map(|m| format!("\"{}\"", m.name))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let mut filters = Vec::with_capacity(chosen.len());
        for (k, registration) in chosen {
            let entry = &self.pipeline[*k];
            let source = self.entry_source(entry);
            let field = format!("pipeline[{k}].materials");
            let Some(names) = &entry.materials else {
                filters.push(MaterialFilter::all());
                continue;
            };
            if !matches!(registration.stage(), Some(Stage::Stress | Stage::Damage)) {
                return Err(source.error(
                    &field,
                    format!(
                        "`materials` limits stress and damage systems only; {} is not one",
                        registration.name
                    ),
                ));
            }
            if names.is_empty() {
                return Err(source.error(&field, "expected at least one material name"));
            }
            let mut mask = vec![false; self.materials.len()];
            for (j, name) in names.iter().enumerate() {
                let Some(i) = self.materials.iter().position(|m| &m.name == name) else {
                    return Err(source.error(
                        &format!("{field}[{j}]"),
                        format!(
                            "unknown material \"{name}\"; the scene defines: {}",
                            known()
                        ),
                    ));
                };
                mask[i] = true;
            }
            filters.push(MaterialFilter::only(mask));
        }
        let used: Vec<usize> = (0..self.materials.len())
            .filter(|&i| {
                self.bodies
                    .iter()
                    .any(|b| b.material == self.materials[i].name)
            })
            .collect();
        for stage in [Stage::Stress, Stage::Damage] {
            let entries: Vec<usize> = (0..chosen.len())
                .filter(|&c| chosen[c].1.stage() == Some(stage))
                .collect();
            if entries.iter().all(|&c| filters[c].is_all()) {
                continue;
            }
            for &i in &used {
                let id = crate::components::MaterialId(i as u16);
                let covering: Vec<usize> = entries
                    .iter()
                    .copied()
                    .filter(|&c| filters[c].applies(id))
                    .collect();
                let name = &self.materials[i].name;
                if covering.len() > 1 {
                    let (k, registration) = chosen[covering[1]];
                    return Err(self.entry_source(&self.pipeline[k]).error(
                        &format!("pipeline[{k}].materials"),
                        format!(
                            "{} and {} both apply to material \"{name}\"; give the {} systems \
                             disjoint `materials` lists",
                            chosen[covering[0]].1.name,
                            registration.name,
                            stage.name()
                        ),
                    ));
                }
                if covering.is_empty() && stage == Stage::Stress {
                    let (k, _) = chosen[entries[0]];
                    return Err(self.entry_source(&self.pipeline[k]).error(
                        &format!("pipeline[{k}].materials"),
                        format!(
                            "no stress system applies to material \"{name}\"; add it to the \
                             `materials` of a stress entry"
                        ),
                    ));
                }
            }
        }
        Ok(filters)
    }

    /// The registration of every entry, checked: known, listed once, required stages filled,
    /// partners present.
    fn chosen_systems<'r>(
        &self,
        registry: &'r Registry,
    ) -> Result<Vec<(usize, &'r Registration)>, SceneError> {
        let mut chosen: Vec<(usize, &Registration)> = Vec::new();
        for (k, entry) in self.pipeline.iter().enumerate() {
            let field = format!("pipeline[{k}].system");
            let source = self.entry_source(entry);
            let Some(registration) = registry.get(&entry.system) else {
                return Err(source.error(
                    &field,
                    format!(
                        "unknown system \"{}\"; known systems: {}",
                        entry.system,
                        registry.names().join(", ")
                    ),
                ));
            };
            if chosen.iter().any(|(_, r)| r.name == registration.name) {
                return Err(source.error(
                    &field,
                    format!("system \"{}\" is listed twice", entry.system),
                ));
            }
            chosen.push((k, registration));
        }
        for stage in Stage::REQUIRED {
            if !chosen.iter().any(|(_, r)| r.stage() == Some(stage)) {
                let options: Vec<_> = registry
                    .iter()
                    .filter(|r| r.stage() == Some(stage))
                    .map(|r| r.name)
                    .collect();
                return Err(self.source.error(
                    "pipeline",
                    format!(
                        "the pipeline has no system for the required stage `{stage}`; add one of: {}",
                        options.join(", ")
                    ),
                ));
            }
        }
        for (k, registration) in &chosen {
            for needed in registration.requires {
                // `stage/*` asks for any system of that stage.
                let satisfied = match needed.strip_suffix("/*") {
                    Some(stage) => chosen
                        .iter()
                        .any(|(_, r)| r.stage().is_some_and(|s| s.name() == stage)),
                    None => chosen.iter().any(|(_, r)| r.name == *needed),
                };
                if !satisfied {
                    let source = self.entry_source(&self.pipeline[*k]);
                    return Err(source.error(
                        &format!("pipeline[{k}].system"),
                        format!(
                            "system \"{}\" needs {} in the pipeline",
                            registration.name,
                            match needed.strip_suffix("/*") {
                                Some(stage) => format!("a `{stage}` system"),
                                None => format!("\"{needed}\""),
                            }
                        ),
                    ));
                }
            }
        }
        Ok(chosen)
    }

    /// A fixed step must not exceed the stable limit of the particles as spawned (the one
    /// rule, [`stable_time_step`], that CFL steps follow too).
    fn check_stable_step(&self, world: &mut World) -> Result<(), SceneError> {
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

/// The most steps a scene may ask for: at the fastest measured rates a longer run would take
/// years, so more means a mistaken end time, speed or material.
pub const MAX_STEPS: f64 = 1e10;

fn spawn_nodes<D: Dim>(world: &mut World, grid: &Grid<D>) {
    let nodes: Vec<NodeBundle<D>> = (0..grid.node_count())
        .map(|i| NodeBundle::new(i as u32, grid.node_position(i)))
        .collect();
    world.spawn_batch(nodes);
}

/// The particle of `body` that is nearest `at` (the lowest entity on a tie) and its position.
fn nearest_particle<D: Dim>(
    world: &mut World,
    body: u16,
    at: D::Vector,
) -> Option<(bevy_ecs::entity::Entity, [f64; 3])> {
    world
        .query::<(
            bevy_ecs::entity::Entity,
            &crate::components::BodyId,
            &crate::components::Position<D>,
        )>()
        .iter(world)
        .filter(|(_, b, _)| b.0 == body)
        .map(|(e, _, x)| (e, x.0, (x.0 - at).length()))
        .min_by(|a, b| a.2.total_cmp(&b.2).then(a.0.cmp(&b.0)))
        .map(|(e, x, _)| {
            (
                e,
                std::array::from_fn(|a| if a < D::N { x[a] } else { 0.0 }),
            )
        })
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
