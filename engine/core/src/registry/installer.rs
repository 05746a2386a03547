//! The [`Installer`]: what a registration's install function may do with the world and the
//! schedule while a scene is built.

use super::{MaterialFilter, ParticleState, PipelineEntrySet};
use crate::capability::{Capabilities, Capability};
use crate::components::Particle;
use crate::dim::Dimension;
use crate::integration::{GridIntegration, ImpulseWindow};
use crate::resources::TimeStepLimit;
use crate::series::SeriesColumns;
use crate::stage::{Stage, StepSet};
use crate::text::SceneError;
use bevy_ecs::prelude::{Component, FromWorld, Resource, World};
use bevy_ecs::schedule::{IntoScheduleConfigs, Schedule, ScheduleConfigs};
use bevy_ecs::system::ScheduleSystem;

/// What an install function may do: add systems to its own stage and set up resources.
pub struct Installer<'a> {
    stage: Stage,
    schedule: &'a mut Schedule,
    world: &'a mut World,
    pipeline: Vec<&'static str>,
    materials: MaterialFilter,
    entry: Option<usize>,
}

impl<'a> Installer<'a> {
    /// An installer for `stage`.
    pub fn new(stage: Stage, schedule: &'a mut Schedule, world: &'a mut World) -> Self {
        Self {
            stage,
            schedule,
            world,
            pipeline: Vec::new(),
            materials: MaterialFilter::all(),
            entry: None,
        }
    }

    /// Tells the installer which pipeline entry it installs and the materials it applies to.
    pub fn for_entry(mut self, entry: usize, materials: MaterialFilter) -> Self {
        self.entry = Some(entry);
        self.materials = materials;
        self
    }

    /// The materials this entry applies to: a stress or damage system keeps it (in its
    /// parameters resource) and updates only the particles it lets through.
    pub fn materials(&self) -> &MaterialFilter {
        &self.materials
    }

    /// Tells the installer the names of every system in the scene's pipeline.
    pub fn with_pipeline(mut self, names: Vec<&'static str>) -> Self {
        self.pipeline = names;
        self
    }

    /// Whether the scene's pipeline has a system whose name starts with `prefix` (a stage such
    /// as `"damage/"`, or a full name).
    pub fn pipeline_has(&self, prefix: &str) -> bool {
        self.pipeline.iter().any(|name| name.starts_with(prefix))
    }

    /// The stage this installer adds to.
    pub fn stage(&self) -> Stage {
        self.stage
    }

    /// The number of space dimensions of the scene being built: install the systems
    /// instantiated for it, e.g. `with_dim!(installer.dimension(), D => installer.add_systems(my_system::<D>))`.
    pub fn dimension(&self) -> Dimension {
        *self.world.resource::<Dimension>()
    }

    /// Adds systems to this installer's stage (and only there).
    pub fn add_systems<M>(&mut self, systems: impl IntoScheduleConfigs<ScheduleSystem, M>) {
        let configs: ScheduleConfigs<ScheduleSystem> = systems.into_configs();
        match self.entry {
            Some(entry) => self
                .schedule
                .add_systems(configs.in_set(self.stage).in_set(PipelineEntrySet(entry))),
            None => self.schedule.add_systems(configs.in_set(self.stage)),
        };
    }

    /// Adds systems to a window of the step that [`crate::stage`] opens to this installer's
    /// stage ([`StepSet::opened_to`]), e.g. a partition system's field assignment
    /// ([`StepSet::AssignFields`]) or a contact law that acts before the stress update
    /// ([`StepSet::GridUpdateCorrection`]). Any other window is refused, naming the stage it is
    /// opened to.
    pub fn add_systems_to<M>(
        &mut self,
        window: StepSet,
        systems: impl IntoScheduleConfigs<ScheduleSystem, M>,
    ) -> Result<(), SceneError> {
        if window.opened_to() != Some(self.stage) {
            let owner = window
                .opened_to()
                .map_or("the engine alone".to_string(), |s| format!("the {s} stage"));
            return Err(SceneError::unplaced(
                "pipeline",
                &self.entry_field("system"),
                format!(
                    "a {} system may not add systems to the step's `{window}` window, which is \
                     opened to {owner}",
                    self.stage
                ),
            ));
        }
        if window == StepSet::AssignFields {
            self.world.insert_resource(crate::fields::FieldsAssigned);
        }
        let configs: ScheduleConfigs<ScheduleSystem> = systems.into_configs();
        self.schedule.add_systems(configs.in_set(window));
        Ok(())
    }

    /// Adds the systems of a law that acts on the end-of-step nodal velocities (contact)
    /// where the pipeline's integrator says such a law runs ([`crate::integration`]): in the
    /// `grid_update_correction` window when impulses act before the stress, in this stage
    /// otherwise. Refused when no integrator has published its [`GridIntegration`].
    pub fn add_impulse_systems<M>(
        &mut self,
        systems: impl IntoScheduleConfigs<ScheduleSystem, M>,
    ) -> Result<(), SceneError> {
        match self.integration()?.impulse_window() {
            ImpulseWindow::BeforeStress => {
                self.add_systems_to(StepSet::GridUpdateCorrection, systems)
            }
            ImpulseWindow::AfterStress => {
                self.add_systems(systems);
                Ok(())
            }
        }
    }

    /// The integrator's description of how grid impulses become particle motion, as its
    /// predictor published it (predictors install before every later stage).
    pub fn integration(&self) -> Result<GridIntegration, SceneError> {
        self.world
            .get_resource::<GridIntegration>()
            .copied()
            .ok_or_else(|| {
                SceneError::unplaced(
                    "pipeline",
                    &self.entry_field("system"),
                    "this system acts on nodal velocities, and the pipeline's predictor does not \
                     say how its integrator turns a grid impulse into particle motion (it \
                     publishes no GridIntegration); use predictor/usl or predictor/newmark, or \
                     publish one from your own predictor",
                )
            })
    }

    /// Declares that this entry provides capability `C` ([`crate::capability`]), for the laws
    /// of later stages that require it.
    pub fn provide<C: Capability>(&mut self) {
        let (stage, entry) = (self.stage, self.entry.unwrap_or(usize::MAX));
        self.world
            .get_resource_or_init::<Capabilities>()
            .provide::<C>(stage, entry);
    }

    /// Checks that every pipeline entry of `stage` (an earlier stage than this installer's)
    /// provides capability `C`, and that there is one. The error says what is missing and
    /// which entry lacks it; place it with [`Params::error`](super::Params::error).
    pub fn require_from<C: Capability>(&self, stage: Stage) -> Result<(), String> {
        let me = self
            .entry
            .and_then(|k| self.pipeline.get(k).copied())
            .unwrap_or("this system");
        if stage >= self.stage {
            return Err(format!(
                "{me} asks a capability of the {stage} stage, which installs after it"
            ));
        }
        let of_stage = self.pipeline.iter().enumerate().filter(|(_, name)| {
            name.split_once('/').and_then(|(s, _)| Stage::from_name(s)) == Some(stage)
        });
        let capabilities = self.world.get_resource::<Capabilities>();
        let mut any = false;
        for (k, name) in of_stage {
            any = true;
            if !capabilities.is_some_and(|c| c.provides::<C>(k)) {
                return Err(format!(
                    "{me} needs every {stage} system to provide {}; {name} does not",
                    C::DESCRIPTION
                ));
            }
        }
        if !any {
            return Err(format!(
                "{me} needs a {stage} system that provides {}",
                C::DESCRIPTION
            ));
        }
        Ok(())
    }

    /// `pipeline[k].<what>` for this installer's entry, or `pipeline` outside a scene.
    fn entry_field(&self, what: &str) -> String {
        self.entry
            .map_or("pipeline".to_string(), |k| format!("pipeline[{k}].{what}"))
    }

    /// Gives every particle a component of the system's own (a damage gradient, a surface flag,
    /// a strength), starting at `value`. All particles get it at once, before the first step, so
    /// they stay in one storage table. Checkpoints carry it ([`crate::checkpoint`]).
    ///
    /// The values go in once every system is installed, with the other systems' components,
    /// entity by entity (`registry/pending.rs`): an install function cannot read them back (its
    /// systems can), and a later call for the same component replaces the values. A scene is
    /// then built a second time with its particles spawned with the component
    /// (`registry/templates.rs`), so that no table is left behind.
    pub fn add_particle_component<C: ParticleState + Clone>(&mut self, value: C) {
        crate::checkpoint::carry_component::<C>(self.world);
        self.templates().particles.record(&value);
        let count = super::pending::entities_with::<Particle>(self.world).len();
        self.pending().particles.set(vec![Some(value); count]);
    }

    /// Gives particles a component of the system's own computed per particle: `value` is
    /// asked for each particle (read-only, with every component it has) and returns the
    /// particle's value, or `None` for a particle this entry does not own (another material),
    /// which gets `default` unless it already has the component (from another entry). All
    /// particles end with the component, so they stay in one storage table. It goes in at once
    /// (with the components held so far), so the install function can read it back.
    pub fn add_particle_component_with<C: ParticleState + Clone>(
        &mut self,
        default: C,
        mut value: impl FnMut(bevy_ecs::world::EntityRef<'_>) -> Option<C>,
    ) {
        crate::checkpoint::carry_component::<C>(self.world);
        self.templates().particles.record(&default);
        super::pending::insert_pending_components(self.world);
        let particles = super::pending::entities_with::<Particle>(self.world);
        let values: Vec<(bevy_ecs::prelude::Entity, Option<C>, bool)> = particles
            .into_iter()
            .map(|particle| {
                let entity = self.world.entity(particle);
                (particle, value(entity), entity.contains::<C>())
            })
            .collect();
        for (particle, value, has) in values {
            match value {
                Some(v) => {
                    self.world.entity_mut(particle).insert(v);
                }
                None if !has => {
                    self.world.entity_mut(particle).insert(default.clone());
                }
                None => {}
            }
        }
    }

    /// Gives every node a component of the system's own (a contact law's normals and forces,
    /// a partition's field statistics), starting at `value`, unless another entry gave it
    /// already. All nodes get it before the first step, with the other systems' components,
    /// entity by entity (`registry/pending.rs`), so they stay in one table. Nothing carries node
    /// components across a checkpoint: a system must write them every step before any system
    /// reads them.
    pub fn add_node_component<C: Component + Clone>(&mut self, value: C) {
        self.templates().nodes.record(&value);
        if self.pending().nodes.get_mut::<C>().is_some() {
            return;
        }
        let nodes = super::pending::entities_with::<crate::components::Node>(self.world);
        let values: Vec<Option<C>> = nodes
            .iter()
            .map(|&node| (!self.world.entity(node).contains::<C>()).then(|| value.clone()))
            .collect();
        self.pending().nodes.set(values);
    }

    fn templates(&mut self) -> bevy_ecs::world::Mut<'_, super::templates::ComponentTemplates> {
        self.world
            .get_resource_or_init::<super::templates::ComponentTemplates>()
    }

    fn pending(&mut self) -> bevy_ecs::world::Mut<'_, super::pending::PendingComponents> {
        self.world
            .get_resource_or_init::<super::pending::PendingComponents>()
    }

    /// Declares storage this system will allocate per particle during the run (`bytes` per
    /// particle, described by `what`, e.g. "basis/lme: support of about 40 nodes"), so that
    /// building the scene refuses, with the estimate, a scene that cannot fit in memory
    /// instead of aborting in the first step ([`crate::budget`]).
    pub fn declare_particle_memory(&mut self, what: impl Into<String>, bytes: f64) {
        let field = self
            .entry
            .map_or("pipeline".to_string(), |k| format!("pipeline[{k}]"));
        self.world
            .get_resource_or_init::<crate::budget::ParticleMemory>()
            .0
            .push((field, what.into(), bytes));
    }

    /// Declares the basis's support radius along an axis (m): how far from a particle the
    /// nodes it exchanges with lie. With [`Installer::declare_grid_round_trip`] and
    /// [`Installer::declare_particle_reach`] it sets how deep a distributed run's halo is
    /// ([`crate::decomposition::StepReach`]).
    pub fn declare_support_radius(&mut self, metres: f64) {
        self.world
            .get_resource_or_init::<crate::decomposition::StepReach>()
            .support = Some(metres);
    }

    /// Declares that this system transfers particle values to the nodes for particles to read
    /// back later in the step (a particle-to-grid transfer): one particle's update then reaches
    /// the particles two support radii away.
    pub fn declare_grid_round_trip(&mut self) {
        self.world
            .get_resource_or_init::<crate::decomposition::StepReach>()
            .round_trips += 1;
    }

    /// Declares that this system makes a particle's update read other particles up to
    /// `metres` away (a neighbourhood, a kernel), described by `what`.
    pub fn declare_particle_reach(&mut self, what: impl Into<String>, metres: f64) {
        let field = self.entry_field("");
        let field = field.trim_end_matches('.').to_string();
        self.world
            .get_resource_or_init::<crate::decomposition::StepReach>()
            .neighbourhoods
            .push((format!("{field}: {}", what.into()), metres));
    }

    /// The mean number of particles per cell of the smallest width, as built (for a
    /// neighbour list's [`Installer::declare_particle_memory`]).
    pub fn particles_per_cell(&mut self) -> f64 {
        crate::with_dim!(self.dimension(), D => crate::budget::particles_per_cell::<D>(self.world))
    }

    /// Inserts a resource that carries values from one step to the next (a running total, a
    /// warm start, a cached list): checkpoints save and restore it ([`crate::checkpoint`]).
    /// Parameters and scratch buffers that every step refills are plain resources.
    pub fn insert_state<R: Resource + crate::checkpoint::State>(&mut self, resource: R) {
        self.world.insert_resource(resource);
        crate::checkpoint::carry_resource::<R>(self.world);
    }

    /// [`Installer::insert_state`] with the resource built from the world unless one exists.
    pub fn init_state<R: Resource + FromWorld + crate::checkpoint::State>(&mut self) {
        self.world.init_resource::<R>();
        crate::checkpoint::carry_resource::<R>(self.world);
    }

    /// [`Installer::init_state`] for a resource that keeps a value per particle row (a warm
    /// start, a cached list): in a distributed run, its rows go with their particles between
    /// ranks ([`crate::checkpoint::RowState`]).
    pub fn init_row_state<R: crate::checkpoint::RowState + FromWorld>(&mut self) {
        self.world.init_resource::<R>();
        self.world
            .get_resource_or_init::<crate::checkpoint::CheckpointState>()
            .row_resource::<R>();
    }

    /// [`Installer::insert_state`] for a resource that each rank of a distributed run keeps
    /// as its own, correct on every rank: a value every rank holds alike (a flag every rank
    /// sets at the same step, a value agreed over ranks with [`Installer::add_rank_maximum`]),
    /// or the rank's part of a sum over the particles or nodes it owns (a running total behind
    /// an [`Installer::add_owned_sum_column`]). Unlike other carried state, it lets the
    /// pipeline run over ranks.
    pub fn insert_rank_state<R: Resource + crate::checkpoint::State>(&mut self, resource: R) {
        self.world.insert_resource(resource);
        self.world
            .get_resource_or_init::<crate::checkpoint::CheckpointState>()
            .rank_resource::<R>();
    }

    /// [`Installer::insert_rank_state`] with the resource built from the world unless one
    /// exists.
    pub fn init_rank_state<R: Resource + FromWorld + crate::checkpoint::State>(&mut self) {
        self.world.init_resource::<R>();
        self.world
            .get_resource_or_init::<crate::checkpoint::CheckpointState>()
            .rank_resource::<R>();
    }

    /// Asks a distributed run for a value of the whole scene before a step: each rank's
    /// maximum over what it owns, the greatest over ranks given to every rank
    /// ([`crate::decomposition::RankMaximum`]). A system that needs, say, the largest of a
    /// quantity over every particle reads it from what `apply` stored, where one process
    /// finds it itself.
    pub fn add_rank_maximum(&mut self, maximum: crate::decomposition::RankMaximum) {
        let mut maxima = self
            .world
            .get_resource_or_init::<crate::decomposition::RankMaxima>();
        if !maxima.0.iter().any(|m| m.name == maximum.name) {
            maxima.0.push(maximum);
        }
    }

    /// Inserts a resource (typically the system's parsed parameters).
    pub fn insert_resource<R: Resource>(&mut self, resource: R) {
        self.world.insert_resource(resource);
    }

    /// Inserts a resource built from the world unless one exists (typically a scratch buffer).
    pub fn init_resource<R: Resource + FromWorld>(&mut self) {
        self.world.init_resource::<R>();
    }

    /// Lowers the stable time step to `factor` times the central-difference limit (the lowest
    /// factor any system asks for wins); `reason` is shown when a scene's step is too large.
    pub fn restrict_time_step(&mut self, factor: f64, reason: impl Into<String>) {
        let mut limit = self.world.get_resource_or_init::<TimeStepLimit>();
        if factor < limit.factor {
            *limit = TimeStepLimit {
                factor,
                reason: reason.into(),
            };
        }
    }

    /// Declares a `series.csv` column this system will fill, returning its slot in
    /// [`SeriesColumns::values`]. The slot is this entry's own: another entry publishing the
    /// same column (for other materials) adds to it.
    pub fn add_series_column(&mut self, name: &str) -> usize {
        let entry = self.entry;
        self.world
            .get_resource_or_init::<SeriesColumns>()
            .declare_for(entry, name)
    }

    /// [`Installer::add_series_column`] for a column whose value is a sum over the particles
    /// and nodes this rank owns (`Option<Res<Ownership>>` in the system; every one in a single
    /// process), accumulated or not: a distributed run publishes the sum of its ranks' values.
    /// A column declared with `add_series_column` keeps the pipeline to one process.
    pub fn add_owned_sum_column(&mut self, name: &str) -> usize {
        let slot = self.add_series_column(name);
        let mut columns = self.world.resource_mut::<SeriesColumns>();
        columns.owned_sums.resize(slot + 1, false);
        columns.owned_sums[slot] = true;
        slot
    }

    /// Registers a per-particle scalar column of the VTU frames, `value` of each particle's
    /// `C` (a component this system added), e.g.
    /// `installer.add_frame_scalar::<CrackOpening>("crack_opening", |w| w.0)`. A column name
    /// registered before keeps its first reader. Write NaN where the law defines no value.
    pub fn add_frame_scalar<C: Component>(&mut self, name: &str, value: fn(&C) -> f64) {
        self.world
            .get_resource_or_init::<crate::columns::FrameColumns>()
            .scalar(name, value);
    }

    /// Registers a per-particle vector column of the VTU frames (three components, zero beyond
    /// the dimension), `value` of each particle's `C`.
    pub fn add_frame_vector<C: Component>(&mut self, name: &str, value: fn(&C) -> [f64; 3]) {
        self.world
            .get_resource_or_init::<crate::columns::FrameColumns>()
            .vector(name, value);
    }

    /// Read access to the world as built from the scene (grid, materials, particles). The
    /// values given with [`Installer::add_particle_component`] and
    /// [`Installer::add_node_component`] are not in it yet; those of
    /// [`Installer::add_particle_component_with`] are. Where the pipeline gives entities
    /// components, the scene is built twice and the second build spawns every entity with them
    /// at their first given value (`registry/templates.rs`), so whether such a component is
    /// present tells nothing.
    pub fn world(&self) -> &World {
        self.world
    }
}
