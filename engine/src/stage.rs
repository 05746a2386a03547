//! The stages of one time step, defined and ordered in exactly one place.
//!
//! A step is one bevy schedule. Each stage is a [`SystemSet`]; [`configure_stages`] chains them
//! in [`Stage::ORDER`], with a [`StageCheck`] slot after each where the engine puts its health
//! check (after every stage that has systems), so a NaN or a particle leaving the grid is
//! reported with the stage that produced it.

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

/// Corrections of the predictor's grid update: systems of a later stage whose law must act on
/// the end-of-step nodal velocities before the stress stage reads them (contact with
/// update-stress-last, as the DFG paper orders it). The set runs after every predictor system
/// and before the predictor's health check; see [`crate::registry::Installer::add_grid_update_correction`].
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct GridUpdateCorrection;

/// The engine's check that runs after the systems of one stage.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct StageCheck(pub Stage);

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
}

impl fmt::Display for Stage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Chains the stages and their checks: `PreStep, check, Neighbour, check, …, PostStep, check`.
pub fn configure_stages(schedule: &mut Schedule) {
    for (i, stage) in Stage::ORDER.iter().enumerate() {
        schedule.configure_sets(stage.before(StageCheck(*stage)));
        if let Some(next) = Stage::ORDER.get(i + 1) {
            schedule.configure_sets(StageCheck(*stage).before(*next));
        }
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
}
