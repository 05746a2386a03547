//! Data a system adds: particle and node components, resources.

use super::Installer;
use crate::components::Particle;
use crate::registry::ParticleState;
use bevy_ecs::prelude::{Component, FromWorld, Resource};

impl Installer<'_> {
    /// Declares that the system being installed reads the scene's real time (`why`: what in
    /// it, in a few words), so that mass scaling changes its answer: `fractum check` and the
    /// run warn when such a pipeline is mass scaled (`time.quasi_static`).
    pub fn declare_real_time(&mut self, system: &str, why: &str) {
        use crate::quasi_static::{RealTimeLaw, RealTimeLaws};
        let mut laws = self.world.get_resource_or_init::<RealTimeLaws>();
        if !laws.0.iter().any(|law| law.system == system) {
            laws.0.push(RealTimeLaw {
                system: system.to_string(),
                why: why.to_string(),
            });
        }
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
        let count = crate::registry::pending::entities_with::<Particle>(self.world).len();
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
        crate::registry::pending::insert_pending_components(self.world);
        let particles = crate::registry::pending::entities_with::<Particle>(self.world);
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
        let nodes = crate::registry::pending::entities_with::<crate::components::Node>(self.world);
        let values: Vec<Option<C>> = nodes
            .iter()
            .map(|&node| (!self.world.entity(node).contains::<C>()).then(|| value.clone()))
            .collect();
        self.pending().nodes.set(values);
    }

    pub(super) fn templates(
        &mut self,
    ) -> bevy_ecs::world::Mut<'_, crate::registry::templates::ComponentTemplates> {
        self.world
            .get_resource_or_init::<crate::registry::templates::ComponentTemplates>()
    }

    pub(super) fn pending(
        &mut self,
    ) -> bevy_ecs::world::Mut<'_, crate::registry::pending::PendingComponents> {
        self.world
            .get_resource_or_init::<crate::registry::pending::PendingComponents>()
    }

    /// Inserts a resource (typically the system's parsed parameters).
    pub fn insert_resource<R: Resource>(&mut self, resource: R) {
        self.world.insert_resource(resource);
    }

    /// Inserts a resource built from the world unless one exists (typically a scratch buffer).
    pub fn init_resource<R: Resource + FromWorld>(&mut self) {
        self.world.init_resource::<R>();
    }

    /// Registers a damage law's check on per-particle strengths, run on the strengths it gave
    /// at install and again on any changed before the first step
    /// ([`StrengthChecks`](crate::strength::StrengthChecks)).
    pub fn add_strength_check(
        &mut self,
        check: impl Fn(&[(crate::components::MaterialId, f64)]) -> Result<(), String>
        + Send
        + Sync
        + 'static,
    ) {
        self.world
            .get_resource_or_init::<crate::strength::StrengthChecks>()
            .add(check);
    }
}
