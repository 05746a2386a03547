//! The system registry: names such as `basis/linear` mapped to installers.
//!
//! A [`Registration`] describes one algorithm: its name (`stage/algorithm`), a one-line summary,
//! its parameters, the systems it needs alongside it, and an install function. The install
//! function receives an [`Installer`] that can add systems to the registration's own stage only,
//! and a [`Params`] holding the raw RON of the pipeline entry's `params`, which it parses into
//! its own typed struct. Users register their own algorithms from their own crates the same way.

use crate::capability::{Capabilities, Capability};
use crate::components::Particle;
use crate::dim::Dimension;
use crate::integration::{GridIntegration, ImpulseWindow};
use crate::resources::TimeStepLimit;
use crate::series::SeriesColumns;
use crate::stage::{Stage, StepSet};
use crate::text::{Location, SceneError, parse_fragment};
use bevy_ecs::prelude::{Component, Entity, FromWorld, Resource, With, World};
use bevy_ecs::schedule::{IntoScheduleConfigs, Schedule, ScheduleConfigs};
use bevy_ecs::system::ScheduleSystem;
use serde::de::DeserializeOwned;
use std::collections::BTreeMap;

/// A particle component a system adds: mutable, and serde both ways so that checkpoints can
/// carry it (derive `serde::Serialize` and `serde::Deserialize`).
pub trait ParticleState:
    Component<Mutability = bevy_ecs::component::Mutable> + crate::checkpoint::State
{
}

impl<C: Component<Mutability = bevy_ecs::component::Mutable> + crate::checkpoint::State>
    ParticleState for C
{
}

/// Documentation of one parameter, shown by `fractum systems`.
#[derive(Clone, Copy, Debug)]
pub struct ParamDoc {
    /// Field name in `params: (...)`.
    pub name: &'static str,
    /// Type as a user writes it, e.g. `f64`.
    pub ty: &'static str,
    /// Default value, or `None` when the parameter is required.
    pub default: Option<&'static str>,
    /// What it means, with units.
    pub doc: &'static str,
}

/// Installs a registration's systems and resources for one pipeline entry.
pub type InstallFn = fn(&mut Installer, &Params) -> Result<(), SceneError>;

/// One registered algorithm.
#[derive(Clone, Copy, Debug)]
pub struct Registration {
    /// `stage/algorithm`, e.g. `basis/linear`.
    pub name: &'static str,
    /// One line: what it does.
    pub summary: &'static str,
    /// Its parameters.
    pub params: &'static [ParamDoc],
    /// Other systems that must be in the same pipeline (e.g. a predictor's matching advection);
    /// `stage/*` asks for any system of that stage.
    pub requires: &'static [&'static str],
    /// Adds its systems to the schedule.
    pub install: InstallFn,
}

impl Registration {
    /// The stage named by the prefix of [`Registration::name`].
    pub fn stage(&self) -> Option<Stage> {
        self.name
            .split_once('/')
            .and_then(|(s, _)| Stage::from_name(s))
    }
}

/// Why a registration was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RegistryError {
    /// The name is not `stage/algorithm` with a known stage.
    #[error("system name `{0}` must be `stage/algorithm` with a stage among: {1}")]
    BadName(String, String),
    /// The name is taken.
    #[error("a system named `{0}` is already registered")]
    Duplicate(String),
}

/// Every algorithm the engine can install, by name.
#[derive(Clone, Debug, Default)]
pub struct Registry {
    entries: BTreeMap<&'static str, Registration>,
}

impl Registry {
    /// An empty registry.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a registration.
    pub fn register(&mut self, registration: Registration) -> Result<(), RegistryError> {
        let stage_ok = registration.stage().is_some()
            && registration
                .name
                .split_once('/')
                .is_some_and(|(_, algo)| !algo.is_empty() && !algo.contains('/'));
        if !stage_ok {
            let stages: Vec<_> = Stage::ORDER.iter().map(|s| s.name()).collect();
            return Err(RegistryError::BadName(
                registration.name.to_string(),
                stages.join(", "),
            ));
        }
        if self.entries.contains_key(registration.name) {
            return Err(RegistryError::Duplicate(registration.name.to_string()));
        }
        self.entries.insert(registration.name, registration);
        Ok(())
    }

    /// The registration with this name.
    pub fn get(&self, name: &str) -> Option<&Registration> {
        self.entries.get(name)
    }

    /// All registrations, ordered by stage then name.
    pub fn iter(&self) -> impl Iterator<Item = &Registration> {
        let mut all: Vec<_> = self.entries.values().collect();
        all.sort_by_key(|r| (r.stage(), r.name));
        all.into_iter()
    }

    /// All names, ordered by stage then name.
    pub fn names(&self) -> Vec<&'static str> {
        self.iter().map(|r| r.name).collect()
    }
}

/// The materials a pipeline entry applies to (`materials: [...]` on the entry), by material
/// index. Stress and damage systems keep the filter their installer hands them and leave the
/// particles of other materials alone; the engine checks that the entries of one stage never
/// share a material and that every material has a stress system.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct MaterialFilter(Option<Vec<bool>>);

impl MaterialFilter {
    /// Every material.
    pub fn all() -> Self {
        Self(None)
    }

    /// Only the materials whose index is `true` in `mask`.
    pub fn only(mask: Vec<bool>) -> Self {
        Self(Some(mask))
    }

    /// Whether the entry applies to particles of `material`.
    pub fn applies(&self, material: crate::components::MaterialId) -> bool {
        self.0
            .as_ref()
            .is_none_or(|mask| mask.get(material.0 as usize).copied().unwrap_or(false))
    }

    /// Whether the filter lets every material through.
    pub fn is_all(&self) -> bool {
        self.0.is_none()
    }
}

/// The schedule set of pipeline entry `k`: the engine orders the entries of one stage as the
/// scene lists them.
#[derive(bevy_ecs::schedule::SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PipelineEntrySet(pub usize);

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
    /// which entry lacks it; place it with [`Params::error`].
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
    pub fn add_particle_component<C: ParticleState + Clone>(&mut self, value: C) {
        crate::checkpoint::carry_component::<C>(self.world);
        let particles: Vec<Entity> = self
            .world
            .query_filtered::<Entity, With<Particle>>()
            .iter(self.world)
            .collect();
        for particle in particles {
            self.world.entity_mut(particle).insert(value.clone());
        }
    }

    /// Gives particles a component of the system's own computed per particle: `value` is
    /// asked for each particle (read-only, with every component it has) and returns the
    /// particle's value, or `None` for a particle this entry does not own (another material),
    /// which gets `default` unless it already has the component (from another entry). All
    /// particles end with the component, so they stay in one storage table.
    pub fn add_particle_component_with<C: ParticleState + Clone>(
        &mut self,
        default: C,
        mut value: impl FnMut(bevy_ecs::world::EntityRef<'_>) -> Option<C>,
    ) {
        crate::checkpoint::carry_component::<C>(self.world);
        let particles: Vec<Entity> = self
            .world
            .query_filtered::<Entity, With<Particle>>()
            .iter(self.world)
            .collect();
        let values: Vec<(Entity, Option<C>, bool)> = particles
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

    /// Declares storage this system will allocate per particle during the run (`bytes` per
    /// particle, described by `what`, e.g. "basis/lme: support of about 40 nodes"), so that
    /// building the scene refuses, with the estimate, a scene that cannot fit in memory
    /// instead of aborting in the first step ([`crate::scene::budget`]).
    pub fn declare_particle_memory(&mut self, what: impl Into<String>, bytes: f64) {
        let field = self
            .entry
            .map_or("pipeline".to_string(), |k| format!("pipeline[{k}]"));
        self.world
            .get_resource_or_init::<crate::budget::ParticleMemory>()
            .0
            .push((field, what.into(), bytes));
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

    /// Registers a per-particle scalar column of the VTU frames, `value` of each particle's
    /// `C` (a component this system added), e.g.
    /// `installer.add_frame_scalar::<CrackOpening>("crack_opening", |w| w.0)`. A column name
    /// registered before keeps its first reader. Write NaN where the law defines no value.
    pub fn add_frame_scalar<C: Component>(&mut self, name: &str, value: fn(&C) -> f64) {
        self.world
            .get_resource_or_init::<crate::output::FrameColumns>()
            .scalar(name, value);
    }

    /// Registers a per-particle vector column of the VTU frames (three components, zero beyond
    /// the dimension), `value` of each particle's `C`.
    pub fn add_frame_vector<C: Component>(&mut self, name: &str, value: fn(&C) -> [f64; 3]) {
        self.world
            .get_resource_or_init::<crate::output::FrameColumns>()
            .vector(name, value);
    }

    /// Read access to the world as built from the scene (grid, materials, particles).
    pub fn world(&self) -> &World {
        self.world
    }
}

/// The raw `params` of one pipeline entry, with where it sits in the scene file.
#[derive(Clone, Debug)]
pub struct Params<'a> {
    raw: Option<&'a str>,
    file: &'a str,
    origin: Location,
    field: String,
}

impl<'a> Params<'a> {
    /// Params text `raw` (None when the entry has no `params`) found at `origin` in `file`,
    /// whose field path is `field` (e.g. `pipeline[2].params`).
    pub fn new(raw: Option<&'a str>, file: &'a str, origin: Location, field: String) -> Self {
        Self {
            raw,
            file,
            origin,
            field,
        }
    }

    /// No params, as for a test or a programmatic pipeline.
    pub fn none() -> Params<'static> {
        Params {
            raw: None,
            file: "<no params>",
            origin: Location { line: 1, col: 1 },
            field: "params".to_string(),
        }
    }

    /// Params from a string, as for a test or a programmatic pipeline.
    pub fn inline(raw: &'a str) -> Self {
        Self {
            raw: Some(raw),
            file: "<params>",
            origin: Location { line: 1, col: 1 },
            field: "params".to_string(),
        }
    }

    /// Parses the params into `T`. An entry without `params` parses as `()`, so `T` must give
    /// every field a default for that to succeed; otherwise the error names the missing field.
    pub fn parse<T: DeserializeOwned>(&self) -> Result<T, SceneError> {
        parse_fragment(
            self.file,
            self.raw.unwrap_or("()"),
            self.origin,
            &self.field,
        )
    }

    /// Refuses `field` with `message` (placed at its value) unless `holds`: the one shape of
    /// every range check, e.g.
    /// `params.require("separability", (0.0..1.0).contains(&d) && d > 0.0, "expected D̄_min in (0, 1)")?`.
    pub fn require(&self, field: &str, holds: bool, message: &str) -> Result<(), SceneError> {
        if holds {
            Ok(())
        } else {
            Err(self.error(field, message))
        }
    }

    /// Refuses `value` of `field` with `message` unless it is finite and positive.
    pub fn require_positive(
        &self,
        field: &str,
        value: f64,
        message: &str,
    ) -> Result<(), SceneError> {
        self.require(field, value.is_finite() && value > 0.0, message)
    }

    /// Refuses `value` of `field` with `message` unless it is finite and not negative.
    pub fn require_non_negative(
        &self,
        field: &str,
        value: f64,
        message: &str,
    ) -> Result<(), SceneError> {
        self.require(field, value.is_finite() && value >= 0.0, message)
    }

    /// An error about these params (e.g. a value out of range), placed at the params.
    pub fn error(&self, relative: &str, message: impl Into<String>) -> SceneError {
        let field = if relative.is_empty() {
            self.field.clone()
        } else {
            format!("{}.{relative}", self.field)
        };
        let location = self
            .raw
            .and_then(|raw| {
                let at = crate::text::locate::locate(raw, relative)?;
                Some(self.origin.offset_by(Location::of_offset(raw, at)))
            })
            .unwrap_or(self.origin);
        SceneError::at(self.file, location, &field, message)
    }
}

/// The top-level field names of a pipeline entry's `params: (...)`, whatever their values.
struct ParamNames(Vec<String>);

impl<'de> serde::Deserialize<'de> for ParamNames {
    fn deserialize<De: serde::Deserializer<'de>>(deserializer: De) -> Result<Self, De::Error> {
        struct Names;
        impl<'de> serde::de::Visitor<'de> for Names {
            type Value = ParamNames;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("parameters written as `(name: value, …)`")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut map: A,
            ) -> Result<ParamNames, A::Error> {
                let mut names = Vec::new();
                while let Some(name) = map.next_key::<String>()? {
                    map.next_value::<serde::de::IgnoredAny>()?;
                    names.push(name);
                }
                Ok(ParamNames(names))
            }
            fn visit_unit<E: serde::de::Error>(self) -> Result<ParamNames, E> {
                Ok(ParamNames(Vec::new()))
            }
        }
        deserializer.deserialize_struct("params", &[], Names)
    }
}

impl Params<'_> {
    /// Refuses a parameter that `registration` does not declare in its
    /// [`Registration::params`]: the declared list is a system's interface, so a misspelt or
    /// foreign field is an error for every system, whether or not its installer parses its
    /// params with `deny_unknown_fields`.
    pub fn check_declared(&self, registration: &Registration) -> Result<(), SceneError> {
        if self.raw.is_none() {
            return Ok(());
        }
        let ParamNames(names) = self.parse()?;
        let declared: Vec<&str> = registration.params.iter().map(|p| p.name).collect();
        match names.iter().find(|n| !declared.contains(&n.as_str())) {
            None => Ok(()),
            Some(unknown) if declared.is_empty() => Err(self.error(
                unknown,
                format!(
                    "unknown field `{unknown}`; {} takes no parameters",
                    registration.name
                ),
            )),
            Some(unknown) => {
                let quoted: Vec<String> = declared.iter().map(|d| format!("`{d}`")).collect();
                let expected = match quoted.as_slice() {
                    [one] => format!("expected {one}"),
                    _ => format!("expected one of {}", quoted.join(", ")),
                };
                Err(self.error_at_name(unknown, format!("unknown field `{unknown}`; {expected}")))
            }
        }
    }

    /// [`Params::error`] placed at the field's name rather than its value.
    fn error_at_name(&self, field: &str, message: String) -> SceneError {
        let mut error = self.error(field, message);
        let name_at = self.raw.and_then(|raw| {
            let value = crate::text::locate::locate(raw, field)?;
            raw[..value].rfind(field)
        });
        if let (Some(raw), Some(at)) = (self.raw, name_at) {
            error.location = Some(self.origin.offset_by(Location::of_offset(raw, at)));
        }
        error
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nothing(_: &mut Installer, _: &Params) -> Result<(), SceneError> {
        Ok(())
    }

    fn registration(name: &'static str) -> Registration {
        Registration {
            name,
            summary: "test",
            params: &[],
            requires: &[],
            install: nothing,
        }
    }

    #[test]
    fn names_must_start_with_a_stage() {
        let mut registry = Registry::new();
        assert!(registry.register(registration("basis/test")).is_ok());
        assert!(matches!(
            registry.register(registration("basis/test")),
            Err(RegistryError::Duplicate(_))
        ));
        assert!(matches!(
            registry.register(registration("shape/test")),
            Err(RegistryError::BadName(..))
        ));
        assert!(registry.register(registration("basis/")).is_err());
        registry.register(registration("advection/a")).unwrap();
        assert_eq!(registry.names(), vec!["basis/test", "advection/a"]);
    }

    #[test]
    fn param_errors_point_inside_the_params() {
        #[derive(serde::Deserialize, Debug)]
        #[serde(deny_unknown_fields)]
        #[allow(dead_code)]
        struct P {
            k: f64,
        }
        let params = Params::new(
            Some("(\n  k: -1.0)"),
            "s.ron",
            Location { line: 4, col: 13 },
            "pipeline[0].params".into(),
        );
        let p: P = params.parse().unwrap();
        assert_eq!(p.k, -1.0);
        let e = params.error("k", "must be positive");
        assert_eq!(
            e.to_string(),
            "s.ron:5:6: `pipeline[0].params.k`: must be positive"
        );
        assert!(
            Params::none()
                .parse::<P>()
                .unwrap_err()
                .message
                .contains("`k`")
        );
    }
}
