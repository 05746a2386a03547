//! The components installers give to every particle or node, held until the whole pipeline is
//! installed (or an installer reads the world) and then inserted entity by entity.
//!
//! Inserting a component into every entity moves each to a new storage table, and the table it
//! leaves keeps its memory: a pipeline whose systems added their components one after another
//! left a full-size table behind for each (with partition and contact, about a third of the peak
//! memory at a million particles). Held here and inserted entity by entity, every component of
//! one entity goes in before the next entity moves, so the tables in between hold one entity at a
//! time. The entities keep their order, so particle rows are the same as with
//! component-by-component insertion. The table of the spawned bundle would still be left behind;
//! `registry/templates.rs` spawns the entities with these components instead, and then the
//! values inserted here replace the ones the entities were spawned with, in place.

use bevy_ecs::prelude::{Component, Entity, Resource, With, World};
use bevy_ecs::world::EntityWorldMut;
use std::any::{Any, TypeId};

/// One component type's values, one per entity in the order the entities were listed; `None`
/// leaves an entity as it is.
struct Column<C> {
    values: Vec<Option<C>>,
}

/// A [`Column`] of any component type.
trait PendingColumn: Send + Sync {
    fn insert_into(&mut self, row: usize, entity: &mut EntityWorldMut);
    fn as_any(&mut self) -> &mut dyn Any;
}

impl<C: Component + Send + Sync> PendingColumn for Column<C> {
    fn insert_into(&mut self, row: usize, entity: &mut EntityWorldMut) {
        if let Some(value) = self.values.get_mut(row).and_then(Option::take) {
            entity.insert(value);
        }
    }

    fn as_any(&mut self) -> &mut dyn Any {
        self
    }
}

/// The pending components of one kind of entity (particles or nodes), by type, in the order
/// they were first given.
#[derive(Default)]
pub(crate) struct PendingSet {
    columns: Vec<(TypeId, Box<dyn PendingColumn>)>,
}

impl PendingSet {
    /// The values pending for `C`, if some installer gave it.
    pub(crate) fn get_mut<C: Component>(&mut self) -> Option<&mut Vec<Option<C>>> {
        self.columns
            .iter_mut()
            .find(|(id, _)| *id == TypeId::of::<C>())
            .and_then(|(_, column)| column.as_any().downcast_mut::<Column<C>>())
            .map(|column| &mut column.values)
    }

    /// Sets the values pending for `C` (one per entity), replacing earlier ones.
    pub(crate) fn set<C: Component>(&mut self, values: Vec<Option<C>>) {
        match self.get_mut::<C>() {
            Some(pending) => *pending = values,
            None => self
                .columns
                .push((TypeId::of::<C>(), Box::new(Column { values }))),
        }
    }

    fn insert_into(&mut self, row: usize, entity: &mut EntityWorldMut) {
        for (_, column) in &mut self.columns {
            column.insert_into(row, entity);
        }
    }
}

/// The components held for particles and for nodes until the pipeline is installed.
#[derive(Resource, Default)]
pub(crate) struct PendingComponents {
    pub(crate) particles: PendingSet,
    pub(crate) nodes: PendingSet,
}

/// The entities with marker `M`, in storage order (the order pending values are listed in).
pub(crate) fn entities_with<M: Component>(world: &mut World) -> Vec<Entity> {
    world
        .query_filtered::<Entity, With<M>>()
        .iter(world)
        .collect()
}

/// Inserts every pending component, entity by entity (see the module's notes).
pub fn insert_pending_components(world: &mut World) {
    let Some(mut pending) = world.remove_resource::<PendingComponents>() else {
        return;
    };
    let particles = entities_with::<crate::components::Particle>(world);
    for (row, particle) in particles.into_iter().enumerate() {
        pending
            .particles
            .insert_into(row, &mut world.entity_mut(particle));
    }
    let nodes = entities_with::<crate::components::Node>(world);
    for (row, node) in nodes.into_iter().enumerate() {
        pending.nodes.insert_into(row, &mut world.entity_mut(node));
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

    #[test]
    fn pending_components_go_in_entity_by_entity_keeping_the_order() {
        let mut world = World::new();
        let spawned: Vec<Entity> = (0..5)
            .map(|k| world.spawn((Particle, Mark(k))).id())
            .collect();
        let mut pending = PendingComponents::default();
        pending
            .particles
            .set((0..5).map(|k| Some(Flag(k % 2 == 0))).collect());
        // A later value replaces an earlier one.
        pending
            .particles
            .set((0..5).map(|k| Some(Flag(k == 3))).collect());
        world.insert_resource(pending);
        insert_pending_components(&mut world);
        let order = entities_with::<Particle>(&mut world);
        assert_eq!(order, spawned, "rows keep their order");
        let flags: Vec<Flag> = order
            .iter()
            .map(|&e| *world.entity(e).get::<Flag>().unwrap())
            .collect();
        assert_eq!(flags, (0..5).map(|k| Flag(k == 3)).collect::<Vec<_>>());
        assert!(!world.contains_resource::<PendingComponents>());
    }

    #[test]
    fn a_none_leaves_the_entity_as_it_is() {
        let mut world = World::new();
        let a = world.spawn((Particle, Flag(true))).id();
        let b = world.spawn((Particle, Flag(true))).id();
        let mut pending = PendingComponents::default();
        pending.particles.set(vec![Some(Flag(false)), None]);
        world.insert_resource(pending);
        insert_pending_components(&mut world);
        assert_eq!(world.entity(a).get::<Flag>(), Some(&Flag(false)));
        assert_eq!(world.entity(b).get::<Flag>(), Some(&Flag(true)));
    }
}
