//! The [`Installer`]: what a registration's install function may do with the world and the
//! schedule while a scene is built. Its methods are grouped by concern, one file each:
//!
//! - here: what the installer is installing (the entry, its stage and materials, the scene's
//!   dimension and pipeline, the world as built);
//! - `schedule.rs`: systems, the step's windows, capabilities and the time step;
//! - `data.rs`: particle and node components, resources;
//! - `state.rs`: state carried by checkpoints and across ranks, and how far a step reaches;
//! - `memory.rs`: what the memory estimate counts;
//! - `columns.rs`: `series.csv` and frame columns.

mod columns;
mod data;
mod memory;
mod schedule;
mod state;

use super::MaterialFilter;
use crate::dim::Dimension;
use crate::stage::Stage;
use bevy_ecs::prelude::World;
use bevy_ecs::schedule::Schedule;

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

    /// The names of every system in the scene's pipeline, in the scene's order.
    pub fn pipeline(&self) -> &[&'static str] {
        &self.pipeline
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

    /// The number of space dimensions of the scene being built. An install function written
    /// once, generic over `D` ([`generic_install!`](crate::generic_install)), is called for it.
    pub fn dimension(&self) -> Dimension {
        *self.world.resource::<Dimension>()
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

    /// `pipeline[k].<what>` for this installer's entry, or `pipeline` outside a scene.
    pub(super) fn entry_field(&self, what: &str) -> String {
        self.entry
            .map_or("pipeline".to_string(), |k| format!("pipeline[{k}].{what}"))
    }
}
