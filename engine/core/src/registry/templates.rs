//! The components a pipeline gives every particle and every node, each with the value an entity
//! starts with, so that a scene's entities can be spawned straight into the table they will
//! run in.
//!
//! Why: an ECS table keeps its memory when every entity leaves it, and installers run on a
//! world whose particles already exist (they read them: contact groups, seeded damage). Spawned
//! with their bundle alone and given the installers' components afterwards, a million particles
//! left the spawned bundle's table behind, full size and resident for the whole run (about 400
//! bytes per particle, and 100 more per node, with DFG + contact). The pipeline is therefore
//! installed twice (`scene::spawn`): first on a world with no node and a sample of particles,
//! which records here what each installer gives
//! ([`crate::registry::Installer::add_particle_component`] and its kin) and how many bytes
//! that adds to each entity (for the memory estimate); then the entities
//! are spawned a few thousand at a time, each given the recorded components at once, so the
//! spawned table never holds more than one batch, and the installers run again and write their
//! values into components the entities already have, in place.
//!
//! The value recorded for a type is the first one an installer gave, which is the value an
//! entity ends with whenever no installer sets it explicitly (`registry/pending.rs`): spawned
//! with it or given it by the install, an entity ends in the same state.

use bevy_ecs::bundle::{Bundle, NoBundleEffect};
use bevy_ecs::prelude::{Component, Entity, Resource, World};
use bevy_ecs::world::EntityWorldMut;
use std::any::TypeId;

/// How many entities are spawned before they are given the recorded components: the capacity
/// the spawned bundle's table is left with.
pub const SPAWN_BATCH: usize = 4096;

/// One component type's starting value.
trait Template: Send + Sync {
    /// Gives `entity` the value unless it has the component already (from its bundle).
    fn insert_if_missing(&self, entity: &mut EntityWorldMut);
}

struct Value<C>(C);

impl<C: Component + Clone> Template for Value<C> {
    fn insert_if_missing(&self, entity: &mut EntityWorldMut) {
        if !entity.contains::<C>() {
            entity.insert(self.0.clone());
        }
    }
}

/// The starting values of one kind of entity (particles or nodes), by type, in the order the
/// installers first gave them.
#[derive(Default)]
pub struct TemplateSet {
    templates: Vec<(TypeId, Box<dyn Template>)>,
    bytes: usize,
}

impl TemplateSet {
    /// Records `value` as the starting value of `C`, unless one is recorded already.
    pub fn record<C: Component + Clone>(&mut self, value: &C) {
        if !self
            .templates
            .iter()
            .any(|(id, _)| *id == TypeId::of::<C>())
        {
            self.templates
                .push((TypeId::of::<C>(), Box::new(Value(value.clone()))));
            self.bytes += std::mem::size_of::<C>();
        }
    }

    /// The bytes the recorded components add to each entity.
    pub fn bytes(&self) -> usize {
        self.bytes
    }

    /// Whether no component is recorded.
    pub fn is_empty(&self) -> bool {
        self.templates.is_empty()
    }

    /// How many component types are recorded.
    pub fn len(&self) -> usize {
        self.templates.len()
    }

    /// Spawns one entity per bundle, in order, each with every recorded component it lacks:
    /// [`SPAWN_BATCH`] bundles at a time, each entity given its components before the next
    /// batch is spawned. Returns the entities in spawn order.
    pub fn spawn<B>(&self, world: &mut World, bundles: Vec<B>) -> Vec<Entity>
    where
        B: Bundle<Effect: NoBundleEffect>,
    {
        if self.is_empty() {
            return world.spawn_batch(bundles).collect();
        }
        let mut spawned = Vec::with_capacity(bundles.len());
        let mut bundles = bundles.into_iter();
        loop {
            let batch: Vec<B> = bundles.by_ref().take(SPAWN_BATCH).collect();
            if batch.is_empty() {
                return spawned;
            }
            let first = spawned.len();
            spawned.extend(world.spawn_batch(batch));
            for &entity in &spawned[first..] {
                let mut entity = world.entity_mut(entity);
                for (_, template) in &self.templates {
                    template.insert_if_missing(&mut entity);
                }
            }
        }
    }
}

/// What the installers gave particles and nodes, recorded by the install on a sample of
/// particles.
#[derive(Resource, Default)]
pub struct ComponentTemplates {
    /// Components of every particle.
    pub particles: TemplateSet,
    /// Components of every node.
    pub nodes: TemplateSet,
}

impl ComponentTemplates {
    /// Whether the installers gave neither particles nor nodes a component.
    pub fn is_empty(&self) -> bool {
        self.particles.is_empty() && self.nodes.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::components::Particle;

    #[derive(Component, Clone, Copy, Debug, PartialEq)]
    struct Mark(u32);

    #[derive(Component, Clone, Copy, Debug, PartialEq)]
    struct Flag(bool);

    #[derive(Component, Clone, Copy, Debug, PartialEq)]
    struct Count(u8);

    #[test]
    fn spawned_entities_get_the_first_recorded_value_of_what_their_bundle_lacks() {
        let mut templates = TemplateSet::default();
        templates.record(&Flag(true));
        templates.record(&Flag(false));
        templates.record(&Mark(99));
        templates.record(&Count(7));
        assert_eq!(templates.len(), 3, "one template per type");
        let mut world = World::new();
        let count = 2 * SPAWN_BATCH + 5;
        let bundles: Vec<(Particle, Mark)> =
            (0..count).map(|k| (Particle, Mark(k as u32))).collect();
        let spawned = templates.spawn(&mut world, bundles);
        assert_eq!(spawned.len(), count);
        let mut query = world.query::<(Entity, &Mark, &Flag, &Count)>();
        let rows: Vec<(Entity, Mark, Flag, Count)> = query
            .iter(&world)
            .map(|(e, m, f, c)| (e, *m, *f, *c))
            .collect();
        assert_eq!(rows.len(), count, "every entity has every component");
        for (k, (entity, mark, flag, c)) in rows.into_iter().enumerate() {
            assert_eq!(entity, spawned[k], "rows keep the spawn order");
            assert_eq!(mark, Mark(k as u32), "the bundle's value stays");
            assert_eq!((flag, c), (Flag(true), Count(7)));
        }
    }

    #[test]
    fn the_spawned_bundles_table_holds_one_batch_at_most() {
        let mut templates = TemplateSet::default();
        templates.record(&Flag(true));
        let mut world = World::new();
        let count = 3 * SPAWN_BATCH;
        templates.spawn(
            &mut world,
            (0..count).map(|k| (Particle, Mark(k as u32))).collect(),
        );
        let tables = &world.storages().tables;
        let capacities: Vec<(u32, usize)> = tables
            .iter()
            .map(|t| (t.entity_count(), t.entity_capacity()))
            .collect();
        assert!(
            capacities
                .iter()
                .all(|&(entities, capacity)| entities > 0 || capacity <= SPAWN_BATCH),
            "an emptied table holds at most one batch: {capacities:?}"
        );
        assert!(
            capacities
                .iter()
                .any(|&(entities, _)| entities as usize == count)
        );
    }

    #[test]
    fn without_templates_the_bundles_are_spawned_as_they_are() {
        let mut world = World::new();
        let spawned = TemplateSet::default().spawn(&mut world, vec![(Particle, Mark(1))]);
        assert_eq!(world.entity(spawned[0]).get::<Mark>(), Some(&Mark(1)));
        assert!(world.entity(spawned[0]).get::<Flag>().is_none());
    }
}

/// The components a distributed run's particles are spawned with, kept in a rank's world for
/// the particles that arrive from other ranks: each is spawned with them, then given its state
/// (`run::distributed`).
#[derive(bevy_ecs::prelude::Resource)]
pub struct RankParticles(pub TemplateSet);
