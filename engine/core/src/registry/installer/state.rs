//! State carried from step to step (checkpoints) and across the ranks of a distributed run,
//! and how far a step reaches.

use super::Installer;
use bevy_ecs::prelude::{FromWorld, Resource};

impl Installer<'_> {
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
}
