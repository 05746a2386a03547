//! Systems, the step's windows and the promises between stages.

use super::Installer;
use crate::capability::{Capabilities, Capability};
use crate::integration::{GridIntegration, ImpulseWindow};
use crate::registry::PipelineEntrySet;
use crate::resources::TimeStepLimit;
use crate::stage::{Stage, StepSet};
use crate::text::SceneError;
use bevy_ecs::schedule::{IntoScheduleConfigs, ScheduleConfigs};
use bevy_ecs::system::ScheduleSystem;

impl Installer<'_> {
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
    /// provides capability `C`, and that there is one; an entry that provides
    /// [`Bystander`](crate::capability::Bystander) is passed by. The error says what is missing and
    /// which entry lacks it; place it with [`Params::error`](crate::registry::Params::error).
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
            if capabilities.is_some_and(|c| c.provides::<crate::capability::Bystander>(k)) {
                continue;
            }
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
}
