//! What a checkpoint carries and how a world's state is captured and restored (see the
//! module [`crate::checkpoint`]).

use super::codecs::{
    BlockRows, ENCODED, NOT_PICKED, load_component, load_resource, permute_column, pick_column,
    pick_component, pick_rows, save_column, save_component, save_resource, save_rows,
};
use super::keys::{CheckpointError, RowState, State};
use crate::components::{Particle, ParticleId};
use bevy_ecs::prelude::*;
use serde::{Deserialize, Serialize};

type SaveComponent = fn(&mut World, &[Entity]) -> Result<Vec<u8>, CheckpointError>;
type LoadComponent = fn(&mut World, &[Entity], &[u8]) -> Result<(), CheckpointError>;
type PickComponent =
    fn(&mut World, &[Entity], &[&[u8]], &[(u32, u32)]) -> Result<(), CheckpointError>;
type SaveColumn = fn(&mut World, &[usize], usize) -> Option<Result<Vec<u8>, CheckpointError>>;
type PickColumn =
    fn(&mut World, &[&[u8]], (&BlockRows, usize)) -> Option<Result<(), CheckpointError>>;
type SaveRows = fn(&World, &[usize]) -> Result<Vec<u8>, CheckpointError>;
type PickRows =
    fn(&mut World, &[&[u8]], &[(u32, u32)], &[Option<usize>]) -> Result<(), CheckpointError>;
type PermuteColumn = fn(&mut World, &[usize]) -> bool;
type SaveResource = fn(&World) -> Result<Option<Vec<u8>>, CheckpointError>;
type LoadResource = fn(&mut World, &[u8]) -> Result<(), CheckpointError>;

#[derive(Clone, Copy)]
struct ComponentEntry {
    name: &'static str,
    type_id: std::any::TypeId,
    save: SaveComponent,
    load: LoadComponent,
    pick: PickComponent,
    save_column: SaveColumn,
    pick_column: PickColumn,
    permute_column: PermuteColumn,
}

#[derive(Clone, Copy)]
struct ResourceEntry {
    name: &'static str,
    type_id: std::any::TypeId,
    save: SaveResource,
    load: LoadResource,
}

#[derive(Clone, Copy)]
struct RowEntry {
    name: &'static str,
    save: SaveRows,
    pick: PickRows,
}

/// The components and resources a checkpoint carries (see the module header).
#[derive(Resource, Clone, Default)]
pub struct CheckpointState {
    components: Vec<ComponentEntry>,
    resources: Vec<ResourceEntry>,
    /// The carried resources that keep a value per particle row.
    rows: Vec<RowEntry>,
    /// The carried resources each rank of a distributed run keeps as its own
    /// ([`Self::rank_resource`]).
    per_rank: Vec<&'static str>,
    /// Keys asked for by two different types (a scene with any is refused).
    collisions: Vec<&'static str>,
}

impl std::fmt::Debug for CheckpointState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CheckpointState")
            .field("components", &self.component_names())
            .field("resources", &self.resource_names())
            .finish()
    }
}

impl CheckpointState {
    /// Carries particle component `C` (once, however often it is asked).
    pub fn component<C: Component<Mutability = bevy_ecs::component::Mutable> + State>(&mut self) {
        let (name, type_id) = (C::KEY, std::any::TypeId::of::<C>());
        if self.is_new(name, type_id) {
            self.components.push(ComponentEntry {
                name,
                type_id,
                save: save_component::<C>,
                load: load_component::<C>,
                pick: pick_component::<C>,
                save_column: save_column::<C>,
                pick_column: pick_column::<C>,
                permute_column: permute_column::<C>,
            });
        }
    }

    /// Carries resource `R` (once, however often it is asked).
    pub fn resource<R: Resource + State>(&mut self) {
        let (name, type_id) = (R::KEY, std::any::TypeId::of::<R>());
        if self.is_new(name, type_id) {
            self.resources.push(ResourceEntry {
                name,
                type_id,
                save: save_resource::<R>,
                load: load_resource::<R>,
            });
        }
    }

    /// Part `c` (a component, or a row resource after the components) of each of `blocks`.
    fn block_parts<'b>(
        &self,
        blocks: &'b [Vec<Vec<u8>>],
        c: usize,
    ) -> Result<Vec<&'b [u8]>, CheckpointError> {
        let carried = self.components.len() + self.rows.len();
        blocks
            .iter()
            .map(|block| match block.get(c) {
                Some(bytes) if block.len() == carried => Ok(bytes.as_slice()),
                _ => Err(CheckpointError::Mismatch(format!(
                    "a block of {} parts, {carried} carried",
                    block.len()
                ))),
            })
            .collect()
    }

    /// Writes into every particle of `world`, in storage order, every carried component of
    /// particle `picks[k] = (b, i)` for the `k`-th: the `i`-th particle of `blocks[b]`, which
    /// [`CheckpointState::save_particles`] encoded (with the same carried components); and makes
    /// the picked rows, in order, the rows of each [`RowState`] resource. Each particle is
    /// picked at most once, and a particle carries a component exactly where its source did.
    /// Component by component into each column when every particle has the component, entity
    /// by entity otherwise. With `same_rows` (every row holds the particle it held), the
    /// [`RowState`] resources keep their rows as they are: their cached lists stay valid; and a
    /// row picked as [`KEEP_ROW`](super::KEEP_ROW) keeps its components.
    pub fn load_picked_rows(
        &self,
        world: &mut World,
        blocks: &[Vec<Vec<u8>>],
        picks: &[(u32, u32)],
        same_rows: bool,
    ) -> Result<(), CheckpointError> {
        let part = |c: usize| self.block_parts(blocks, c);
        self.write_picked_components(world, blocks, picks)?;
        if same_rows {
            return Ok(());
        }
        for (r, entry) in self.rows.iter().enumerate() {
            (entry.pick)(world, &part(self.components.len() + r)?, picks, &[])?;
        }
        Ok(())
    }

    /// Moves every carried component of the particles within its column so that row `n`
    /// holds what row `from[n]` held (`from` a permutation of the particles' rows): a rank's
    /// kept particles take their new rows without being encoded and decoded. `false`, with
    /// nothing moved, when the particles are not all in one table (then their state is to be
    /// encoded and picked, [`Self::load_picked_rows`]).
    pub fn permute_rows(&self, world: &mut World, from: &[usize]) -> Result<bool, CheckpointError> {
        let mut query = world.query_filtered::<&ParticleId, With<Particle>>();
        let one_table = query.contiguous_iter(world).is_ok_and(|mut tables| {
            tables.next().is_some_and(|t| t.len() == from.len()) && tables.next().is_none()
        });
        if !one_table {
            return Ok(false);
        }
        let mut check = from.to_vec();
        check.sort_unstable();
        if check.iter().enumerate().any(|(n, &r)| n != r) {
            return Err(CheckpointError::Mismatch(
                "the rows' new order is not a permutation of the rows".into(),
            ));
        }
        for entry in &self.components {
            if !(entry.permute_column)(world, from) {
                return Err(CheckpointError::Mismatch(format!(
                    "{}: not a column of the particles' one table",
                    entry.name
                )));
            }
        }
        Ok(true)
    }

    /// After [`Self::permute_rows`]: writes the particles that arrived, as
    /// [`Self::load_picked_rows`] with the moved rows picked as [`KEEP_ROW`](super::KEEP_ROW),
    /// and makes the rows of each [`RowState`] resource the picked ones, a kept row's value
    /// taken from its old row `kept[n]`.
    pub fn load_arrived_rows(
        &self,
        world: &mut World,
        blocks: &[Vec<Vec<u8>>],
        picks: &[(u32, u32)],
        kept: &[Option<usize>],
    ) -> Result<(), CheckpointError> {
        let part = |c: usize| self.block_parts(blocks, c);
        self.write_picked_components(world, blocks, picks)?;
        for (r, entry) in self.rows.iter().enumerate() {
            (entry.pick)(world, &part(self.components.len() + r)?, picks, kept)?;
        }
        Ok(())
    }

    /// Writes every carried component of each particle row from its pick (see
    /// [`Self::load_picked_rows`]): column by column, or particle by particle where the
    /// particles are not all in one table.
    fn write_picked_components(
        &self,
        world: &mut World,
        blocks: &[Vec<Vec<u8>>],
        picks: &[(u32, u32)],
    ) -> Result<(), CheckpointError> {
        let (targets, _) = particles_in_order(world);
        if targets.len() != picks.len() {
            return Err(CheckpointError::Mismatch(format!(
                "{} particles to fill from {} picked",
                targets.len(),
                picks.len()
            )));
        }
        let block_rows = block_rows(blocks.len(), picks)?;
        for (c, entry) in self.components.iter().enumerate() {
            let sources = self.block_parts(blocks, c)?;
            match (entry.pick_column)(world, &sources, (&block_rows, targets.len())) {
                Some(done) => done?,
                None => (entry.pick)(world, &targets, &sources, picks)?,
            }
        }
        Ok(())
    }

    /// Carries resource `R`, which keeps a value per particle row: in a checkpoint whole, and
    /// in a distributed run row by row with the particles ([`RowState`]).
    pub fn row_resource<R: RowState>(&mut self) {
        self.resource::<R>();
        let type_id = std::any::TypeId::of::<R>();
        let carried = self.resources.iter().any(|e| e.type_id == type_id);
        if carried && !self.is_row_resource(R::KEY) {
            self.rows.push(RowEntry {
                name: R::KEY,
                save: save_rows::<R>,
                pick: pick_rows::<R>,
            });
        }
    }

    /// Carries resource `R` as one that each rank of a distributed run keeps as its own: a
    /// value every rank holds alike (a flag every rank sets at the same step, a value agreed
    /// over ranks), or the rank's part of a sum over what it owns (a running total published
    /// as an owned-sum column). Each rank's checkpoint piece holds its copy.
    pub fn rank_resource<R: Resource + State>(&mut self) {
        self.resource::<R>();
        if !self.per_rank.contains(&R::KEY) {
            self.per_rank.push(R::KEY);
        }
    }

    /// Whether each rank keeps resource `name` as its own ([`Self::rank_resource`]).
    pub fn is_rank_resource(&self, name: &str) -> bool {
        self.per_rank.contains(&name)
    }

    /// Whether resource `name` keeps its values by particle row ([`RowState`]).
    pub fn is_row_resource(&self, name: &str) -> bool {
        self.rows.iter().any(|r| r.name == name)
    }

    /// Whether `name` is not carried yet; a key already taken by another type is recorded as
    /// a collision.
    fn is_new(&mut self, name: &'static str, type_id: std::any::TypeId) -> bool {
        let taken = self
            .components
            .iter()
            .map(|e| (e.name, e.type_id))
            .chain(self.resources.iter().map(|e| (e.name, e.type_id)))
            .find(|(n, _)| *n == name);
        match taken {
            None => true,
            Some((_, t)) if t == type_id => false,
            Some(_) => {
                self.collisions.push(name);
                false
            }
        }
    }

    /// Keys that two different types asked for.
    pub fn collisions(&self) -> &[&'static str] {
        &self.collisions
    }

    /// Names of the carried components.
    pub fn component_names(&self) -> Vec<&'static str> {
        self.components.iter().map(|e| e.name).collect()
    }

    /// Every carried component of `particles` (storage rows `rows`), in the order the
    /// components are carried, then their rows of each [`RowState`] resource: the particles'
    /// state, to be sent to another rank of a distributed run and put back with
    /// [`CheckpointState::load_picked_rows`]. A component's part is a format byte and the
    /// values: as their numbers for a component of numbers ([`State::NUMBERS`]) in the
    /// particles' one table, encoded as a checkpoint encodes them otherwise.
    pub fn save_particles(
        &self,
        world: &mut World,
        particles: &[Entity],
        rows: &[usize],
    ) -> Result<Vec<Vec<u8>>, CheckpointError> {
        let mut saved = Vec::with_capacity(self.components.len() + self.rows.len());
        for entry in &self.components {
            // From the component's column when every particle has it, as they do in one table;
            // entity by entity otherwise.
            let bytes = match (entry.save_column)(world, rows, particles.len()) {
                Some(column) => column?,
                None => {
                    let mut part = vec![ENCODED];
                    part.extend((entry.save)(world, particles)?);
                    part
                }
            };
            saved.push(bytes);
        }
        for entry in &self.rows {
            saved.push((entry.save)(world, rows)?);
        }
        Ok(saved)
    }

    /// Names of the carried resources.
    pub fn resource_names(&self) -> Vec<&'static str> {
        self.resources.iter().map(|e| e.name).collect()
    }
}

/// Registers particle component `C` with the world's [`CheckpointState`].
pub fn carry_component<C: Component<Mutability = bevy_ecs::component::Mutable> + State>(
    world: &mut World,
) {
    world
        .get_resource_or_init::<CheckpointState>()
        .component::<C>();
}

/// Registers resource `R` with the world's [`CheckpointState`].
pub fn carry_resource<R: Resource + State>(world: &mut World) {
    world
        .get_resource_or_init::<CheckpointState>()
        .resource::<R>();
}

/// Registers what the engine itself carries from step to step: every component particles are
/// spawned with (their id is the key, not carried), the clock, and the running totals.
pub fn carry_engine_state<D: crate::dim::Dim>(world: &mut World) {
    carry_engine_state_of(world, D::DIMENSION);
}

/// [`carry_engine_state`] for `dimension`. Not generic, so that the carried components'
/// encoders (which a distributed run calls every step) are generated here with the engine's
/// optimisation, whichever crate registers them (the scene crate, optimised less in the test
/// profile).
#[inline(never)]
fn carry_engine_state_of(world: &mut World, dimension: crate::dim::Dimension) {
    crate::with_dim!(dimension, D => carry_engine_components::<D>(world));
}

fn carry_engine_components<D: crate::dim::Dim>(world: &mut World) {
    use crate::components::*;
    let mut state = world.get_resource_or_init::<CheckpointState>();
    state.component::<Position<D>>();
    state.component::<Velocity<D>>();
    state.component::<Acceleration<D>>();
    state.component::<Mass>();
    state.component::<Volume>();
    state.component::<InitialVolume>();
    state.component::<DeformationGradient<D>>();
    state.component::<Stress<D>>();
    state.component::<Strain<D>>();
    state.component::<StrainEnergyDensity>();
    state.component::<WaveSpeed>();
    state.component::<Damage>();
    state.component::<DamageHistory>();
    state.component::<MaterialId>();
    state.component::<BodyId>();
    state.component::<ContactGroup>();
    state.component::<ExternalForce<D>>();
    state.component::<crate::loads::LoadShare>();
    state.resource::<crate::resources::SimClock>();
    state.resource::<crate::energy::EnergyAccount>();
    state.resource::<crate::energy::EnergyWatch>();
    state.resource::<crate::series::ForceProbeMemory>();
    state.resource::<crate::health::EscapedParticles>();
    state.resource::<crate::series::SeriesColumns>();
}

/// The state of a world: its particles in storage order, those removed so far in the order
/// they went, and each carried component and resource, encoded.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WorldState {
    /// The live particles' ids, in storage (query) order.
    pub particles: Vec<u32>,
    /// The removed particles' ids, in the order they were removed.
    pub removed: Vec<u32>,
    /// Component name and its values, one per live particle in `particles` order.
    pub components: Vec<(String, Vec<u8>)>,
    /// Resource name and its value (absent resources are not listed).
    pub resources: Vec<(String, Vec<u8>)>,
}

/// The row each particle of each of `blocks` blocks fills, from the rows' `picks` (block,
/// index; [`KEEP_ROW`](super::KEEP_ROW) for none), found once for every column:
/// [`NOT_PICKED`] where no row picks it. A pick of a block that was not sent is a mismatch.
fn block_rows(blocks: usize, picks: &[(u32, u32)]) -> Result<Vec<Vec<usize>>, CheckpointError> {
    let mut rows = vec![Vec::new(); blocks];
    for (row, &(block, index)) in picks.iter().enumerate() {
        if (block, index) == super::KEEP_ROW {
            continue;
        }
        let block_rows = rows.get_mut(block as usize).ok_or_else(|| {
            CheckpointError::Mismatch(format!(
                "particle {index} of block {block} was picked, and {blocks} blocks were sent"
            ))
        })?;
        let index = index as usize;
        if block_rows.len() <= index {
            block_rows.resize(index + 1, NOT_PICKED);
        }
        block_rows[index] = row;
    }
    Ok(rows)
}

/// The particles' entities and ids, in storage order.
fn particles_in_order(world: &mut World) -> (Vec<Entity>, Vec<u32>) {
    let mut query = world.query_filtered::<(Entity, &ParticleId), With<Particle>>();
    // Table by table, as the query's iterator goes, over the columns' slices: a rank finds its
    // particles after every step's exchange, and the iterator's fetch of each one costs more.
    if let Ok(tables) = query.contiguous_iter(world) {
        let (mut entities, mut ids) = (Vec::new(), Vec::new());
        for (table_entities, table_ids) in tables {
            entities.extend_from_slice(table_entities);
            ids.extend(table_ids.iter().map(|id| id.0));
        }
        return (entities, ids);
    }
    query.iter(world).map(|(e, id)| (e, id.0)).unzip()
}

/// Captures the state of `world` that its [`CheckpointState`] lists.
pub fn capture(world: &mut World) -> Result<WorldState, CheckpointError> {
    let state = world
        .get_resource::<CheckpointState>()
        .cloned()
        .unwrap_or_default();
    let (entities, particles) = particles_in_order(world);
    let removed = world
        .get_resource::<crate::health::EscapedParticles>()
        .map(|e| e.removed.clone())
        .unwrap_or_default();
    let mut components = Vec::new();
    for entry in &state.components {
        components.push((entry.name.to_string(), (entry.save)(world, &entities)?));
    }
    let mut resources = Vec::new();
    for entry in &state.resources {
        if let Some(bytes) = (entry.save)(world)? {
            resources.push((entry.name.to_string(), bytes));
        }
    }
    Ok(WorldState {
        particles,
        removed,
        components,
        resources,
    })
}

/// Puts `saved` into `world`, a world freshly built from the same scene: removes the particles
/// removed before the checkpoint in their order, checks that the storage order is the saved
/// one, and overwrites every carried component and resource.
pub fn restore(world: &mut World, saved: &WorldState) -> Result<(), CheckpointError> {
    let state = world
        .get_resource::<CheckpointState>()
        .cloned()
        .unwrap_or_default();
    let (entities, ids) = particles_in_order(world);
    let by_id: std::collections::HashMap<u32, Entity> =
        ids.iter().copied().zip(entities.iter().copied()).collect();
    for id in &saved.removed {
        let entity = by_id.get(id).copied().ok_or_else(|| {
            CheckpointError::Mismatch(format!(
                "the checkpoint removed particle {id}, which the scene does not have"
            ))
        })?;
        world.despawn(entity);
    }
    let (entities, ids) = particles_in_order(world);
    if ids != saved.particles {
        return Err(CheckpointError::Mismatch(format!(
            "the scene's particles ({}) are not the checkpoint's ({}) in the same order",
            ids.len(),
            saved.particles.len()
        )));
    }
    let saved_names: Vec<&str> = saved.components.iter().map(|(n, _)| n.as_str()).collect();
    let names = state.component_names();
    if names != saved_names {
        return Err(CheckpointError::Mismatch(format!(
            "the pipeline carries the particle components {names:?}, the checkpoint \
             {saved_names:?}"
        )));
    }
    for (entry, (_, bytes)) in state.components.iter().zip(&saved.components) {
        (entry.load)(world, &entities, bytes)?;
    }
    for (name, bytes) in &saved.resources {
        let entry = state
            .resources
            .iter()
            .find(|e| e.name == name)
            .ok_or_else(|| {
                CheckpointError::Mismatch(format!(
                    "the checkpoint carries {name}, which this scene's pipeline does not have"
                ))
            })?;
        (entry.load)(world, bytes)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::components::{Position, Velocity};
    use crate::dim::Two;
    use crate::testing::{spawn_particle, tiny_world};
    use glam::DVec2;

    /// A resource that keeps one number per row, as a warm start does.
    #[derive(Resource, Default, Serialize, Deserialize)]
    struct PerRow(Vec<f64>);
    crate::checkpoint_keys! { PerRow => "test/per_row" }
    impl RowState for PerRow {
        type Row = f64;
        fn row(&self, row: usize) -> f64 {
            self.0[row]
        }
        fn set_rows(&mut self, rows: Vec<f64>) {
            self.0 = rows;
        }
    }

    fn world_of(xs: &[f64]) -> World {
        let mut world = tiny_world::<Two>(4, 1.0, 1e-3);
        carry_engine_state::<Two>(&mut world);
        world
            .resource_mut::<CheckpointState>()
            .row_resource::<PerRow>();
        for &x in xs {
            spawn_particle(&mut world, DVec2::new(x, 0.5), DVec2::new(x, 0.0), 1.0, 1.0);
        }
        world.insert_resource(PerRow(xs.to_vec()));
        world
    }

    fn particles<T: Component + Copy>(world: &mut World) -> Vec<T> {
        let mut query = world.query_filtered::<&T, With<Particle>>();
        query.iter(world).copied().collect()
    }

    /// Particles saved from two worlds are put, picked in another order, into a third, rows
    /// and row state alike; with `same_rows` the row state is left as it is.
    #[test]
    fn particles_picked_from_blocks_fill_the_rows_in_order() {
        let state = world_of(&[]).resource::<CheckpointState>().clone();
        let mut blocks = Vec::new();
        for xs in [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]] {
            let mut source = world_of(&xs);
            let (entities, _) = particles_in_order(&mut source);
            let saved = state.save_particles(&mut source, &entities[1..], &[1, 2]);
            blocks.push(saved.unwrap());
        }
        let mut target = world_of(&[0.0, 0.0, 0.0]);
        // Row 0 gets particle 1 of block 1 (x = 6), row 1 particle 0 of block 0 (x = 2), row 2
        // particle 0 of block 1 (x = 5).
        let picks = [(1, 1), (0, 0), (1, 0)];
        state
            .load_picked_rows(&mut target, &blocks, &picks, false)
            .unwrap();
        let xs: Vec<f64> = particles::<Position<Two>>(&mut target)
            .iter()
            .map(|p| p.0.x)
            .collect();
        assert_eq!(xs, [6.0, 2.0, 5.0]);
        let vs: Vec<f64> = particles::<Velocity<Two>>(&mut target)
            .iter()
            .map(|v| v.0.x)
            .collect();
        assert_eq!(vs, [6.0, 2.0, 5.0]);
        assert_eq!(target.resource::<PerRow>().0, [6.0, 2.0, 5.0]);
        target.resource_mut::<PerRow>().0 = vec![9.0; 3];
        state
            .load_picked_rows(&mut target, &blocks, &[(0, 1), (0, 0), (1, 0)], true)
            .unwrap();
        assert_eq!(target.resource::<PerRow>().0, [9.0; 3]);
        // A pick with no particle behind it is refused, not read out of bounds.
        let missing =
            state.load_picked_rows(&mut target, &blocks, &[(0, 5), (0, 0), (1, 0)], false);
        assert!(missing.is_err());
    }
}
