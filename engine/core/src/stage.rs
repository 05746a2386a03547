//! The schedule of one time step, declared and ordered in this file alone.
//!
//! A step is one bevy schedule. Its published shape is the chain of [`Stage`]s, each followed by
//! the engine's health check ([`StageCheck`]), so that a NaN or a particle leaving the grid is
//! reported with the stage that produced it. Inside that chain a few windows ([`StepSet`]) take
//! the engine's own work and the work that a registration of one stage must do at another
//! point of the step. Every set is declared here and [`configure_step`] orders them all; no
//! other file declares or orders a set of the step.
//!
//! # Steps
//!
//! 1. [`Stage::PreStep`]: a hook for diagnostics and probes.
//! 2. [`StepSet::ApplyLoads`] (engine): each particle's external force for the step, from the
//!    scene's ramped loads at the step's start time.
//! 3. [`Stage::Neighbour`]: ε-neighbourhoods for non-local damage.
//! 4. [`Stage::Basis`]: shape functions and the particle–node connectivity.
//! 5. [`StepSet::AssignFields`] (opened to the partition stage): each particle–node pair is
//!    given its velocity field (`Connectivity::fields`, `NodeFields`), on the connectivity just
//!    built, so that every transfer of the step sees the same fields. It reads what the
//!    partition stage left in the previous step (damage gradients, surface flags): the
//!    partition of step n+1 is decided from the damage of step n, as in the DFG paper's
//!    update-stress-last order.
//! 6. [`Stage::Predictor`]: particle-to-grid transfer and the nodal velocity predictor.
//! 7. [`StepSet::GridUpdateCorrection`] (opened to the contact stage): laws that must act on
//!    the end-of-step nodal velocities before the stress stage reads them. Contact joins it
//!    when the integrator says grid impulses act before the stress
//!    (`integration::GridIntegration`), as in the DFG paper's order (eqs. 6–7, 9–10).
//! 8. [`Stage::Stress`]: the constitutive update from the nodal velocity field.
//! 9. [`Stage::Damage`]: damage and failure.
//! 10. [`Stage::Partition`]: what the next step's field assignment needs (damage gradients,
//!     surface flags) and the separability statistics of this step's fields.
//! 11. [`Stage::Contact`]: contact between velocity fields, when the integrator says grid
//!     impulses act after the stress (Newmark's predictor-corrector).
//! 12. [`Stage::Corrector`]: the nodal velocity corrector.
//! 13. [`Stage::Advection`]: grid-to-particle transfer and particle motion.
//! 14. [`Stage::PostStep`]: a hook for diagnostics and probes.
//! 15. [`StepSet::AccountWork`] (engine): the work of loads and held boundaries over the step.
//!
//! Each stage's check runs right after its systems; a window inside a stage's span (5 and 7)
//! runs before that stage's check, so the check covers it too.

use bevy_ecs::schedule::{IntoScheduleConfigs, Schedule, SystemSet};
use std::fmt;

/// A stage of the step. Registered systems belong to exactly one.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Stage {
    /// Hook before the physics (diagnostics, user probes).
    PreStep,
    /// Particle neighbourhoods (ε-neighbourhoods for non-local damage).
    Neighbour,
    /// Shape functions and particle–node connectivity.
    Basis,
    /// Particle-to-grid transfer and the nodal velocity predictor.
    Predictor,
    /// Constitutive update from the nodal velocity field.
    Stress,
    /// Damage and failure.
    Damage,
    /// Partitioning of nodes into velocity fields.
    Partition,
    /// Contact between velocity fields.
    Contact,
    /// Nodal velocity corrector.
    Corrector,
    /// Grid-to-particle transfer and particle motion.
    Advection,
    /// Hook after the physics (diagnostics, user probes).
    PostStep,
}

/// The schedule set of pipeline entry `k`: the engine orders the entries of one stage as the
/// scene lists them.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PipelineEntrySet(pub usize);

/// The engine's check that runs after the systems of one stage.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct StageCheck(pub Stage);

/// The windows of the step besides the stages: the engine's own work, and the points where a
/// registration of one stage must act elsewhere in the step (see the module's list of steps).
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StepSet {
    /// The particles' external forces for the step (engine), before the neighbour stage.
    ApplyLoads,
    /// The velocity field of every particle–node pair, after the basis stage's systems and
    /// before its check. Opened to the partition stage.
    AssignFields,
    /// Corrections of the predictor's grid update, after the predictor's systems and before
    /// its check, so the stress stage reads the corrected nodal velocities. Opened to the
    /// contact stage.
    GridUpdateCorrection,
    /// The work of loads and held boundaries (engine), after the post-step check.
    AccountWork,
}

impl StepSet {
    /// Every window, in execution order.
    pub const ALL: [StepSet; 4] = [
        StepSet::ApplyLoads,
        StepSet::AssignFields,
        StepSet::GridUpdateCorrection,
        StepSet::AccountWork,
    ];

    /// The stage whose registrations may add systems to this window; `None` for the engine's
    /// own windows.
    pub fn opened_to(self) -> Option<Stage> {
        match self {
            StepSet::AssignFields => Some(Stage::Partition),
            StepSet::GridUpdateCorrection => Some(Stage::Contact),
            StepSet::ApplyLoads | StepSet::AccountWork => None,
        }
    }

    /// The name used in messages.
    pub fn name(self) -> &'static str {
        match self {
            StepSet::ApplyLoads => "apply_loads",
            StepSet::AssignFields => "assign_fields",
            StepSet::GridUpdateCorrection => "grid_update_correction",
            StepSet::AccountWork => "account_work",
        }
    }

    /// The stage whose span the window sits in: its failures are reported with that stage.
    pub fn reported_as(self) -> Stage {
        match self {
            StepSet::ApplyLoads => Stage::PreStep,
            StepSet::AssignFields => Stage::Basis,
            StepSet::GridUpdateCorrection => Stage::Predictor,
            StepSet::AccountWork => Stage::PostStep,
        }
    }

    /// Orders this window in the chain of stages and checks.
    fn configure(self, schedule: &mut Schedule) {
        match self {
            StepSet::ApplyLoads => schedule.configure_sets(
                self.after(StageCheck(Stage::PreStep))
                    .before(Stage::Neighbour),
            ),
            StepSet::AssignFields => {
                schedule.configure_sets(self.after(Stage::Basis).before(StageCheck(Stage::Basis)))
            }
            StepSet::GridUpdateCorrection => schedule.configure_sets(
                self.after(Stage::Predictor)
                    .before(StageCheck(Stage::Predictor)),
            ),
            StepSet::AccountWork => {
                schedule.configure_sets(self.after(StageCheck(Stage::PostStep)))
            }
        };
    }
}

impl fmt::Display for StepSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl Stage {
    /// Every stage in execution order. This is the only place the order is written down.
    pub const ORDER: [Stage; 11] = [
        Stage::PreStep,
        Stage::Neighbour,
        Stage::Basis,
        Stage::Predictor,
        Stage::Stress,
        Stage::Damage,
        Stage::Partition,
        Stage::Contact,
        Stage::Corrector,
        Stage::Advection,
        Stage::PostStep,
    ];

    /// Stages a runnable pipeline must fill.
    pub const REQUIRED: [Stage; 4] = [
        Stage::Basis,
        Stage::Predictor,
        Stage::Stress,
        Stage::Advection,
    ];

    /// The name used in system names (`"basis"` in `"basis/linear"`).
    pub fn name(self) -> &'static str {
        match self {
            Stage::PreStep => "pre_step",
            Stage::Neighbour => "neighbour",
            Stage::Basis => "basis",
            Stage::Predictor => "predictor",
            Stage::Stress => "stress",
            Stage::Damage => "damage",
            Stage::Partition => "partition",
            Stage::Contact => "contact",
            Stage::Corrector => "corrector",
            Stage::Advection => "advection",
            Stage::PostStep => "post_step",
        }
    }

    /// The stage with the given name.
    pub fn from_name(name: &str) -> Option<Stage> {
        Stage::ORDER.into_iter().find(|s| s.name() == name)
    }

    /// Position in [`Stage::ORDER`].
    pub fn position(self) -> usize {
        Stage::ORDER.iter().position(|s| *s == self).unwrap_or(0)
    }

    /// The windows opened to this stage's registrations.
    pub fn windows(self) -> impl Iterator<Item = StepSet> {
        StepSet::ALL
            .into_iter()
            .filter(move |w| w.opened_to() == Some(self))
    }
}

impl fmt::Display for Stage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Orders the whole step: the stages chained with their checks
/// (`PreStep, check, Neighbour, check, …, PostStep, check`) and every [`StepSet`] in its place.
pub fn configure_step(schedule: &mut Schedule) {
    for (i, stage) in Stage::ORDER.iter().enumerate() {
        schedule.configure_sets(stage.before(StageCheck(*stage)));
        if let Some(next) = Stage::ORDER.get(i + 1) {
            schedule.configure_sets(StageCheck(*stage).before(*next));
        }
    }
    for window in StepSet::ALL {
        window.configure(schedule);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_order_is_complete() {
        for (i, stage) in Stage::ORDER.iter().enumerate() {
            assert_eq!(Stage::from_name(stage.name()), Some(*stage));
            assert_eq!(stage.position(), i);
        }
        assert_eq!(Stage::from_name("velocity"), None);
    }

    #[test]
    fn windows_open_only_to_their_stage() {
        assert_eq!(
            Stage::Partition.windows().collect::<Vec<_>>(),
            vec![StepSet::AssignFields]
        );
        assert_eq!(
            Stage::Contact.windows().collect::<Vec<_>>(),
            vec![StepSet::GridUpdateCorrection]
        );
        assert_eq!(Stage::Stress.windows().count(), 0);
        for window in StepSet::ALL {
            if let Some(stage) = window.opened_to() {
                // A window opened to a stage lies before that stage: it is the stage's way of
                // acting earlier in the step, never of reordering later work.
                assert!(window.reported_as() < stage, "{window}");
            }
        }
    }
}
