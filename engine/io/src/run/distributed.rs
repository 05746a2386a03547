//! A step of a distributed run on one rank: the stable step agreed by every rank, the scene's
//! step on the rank's particles, and then [`redistribute`]: every particle's owner sends its
//! state to the ranks that hold it, and each rank rebuilds its particles from what it kept and
//! received, sorted by id. What each rank holds and why: [`fractum_engine::decomposition::Ownership`].

use super::rank_clock::{Phase, RankClock, record};
use crate::checkpoint::CheckpointState;
use bevy_ecs::prelude::*;
use fractum_engine::communicator::{Communicator, RankFailure};
use fractum_engine::components::{Particle, ParticleBundle, ParticleId};
use fractum_engine::decomposition::{Layout, Ownership, RankRebuild};
use fractum_engine::dim::{Dim, VectorOps};
use fractum_engine::health::{EscapedParticles, LeaveGrid};
use fractum_engine::resources::Grid;
use fractum_engine::resources::SimClock;
use fractum_engine::with_dim;
use std::time::Instant;

mod rows;
mod wire;
use rows::{for_each_row, rebuild, rows};

/// Takes one step of a distributed run on this rank: the least stable step over ranks, the
/// step, and [`redistribute`]. Every rank calls it for the same step; a failure on any rank
/// (a blow-up it found, an exchange it could not decode) is returned by every rank, naming the
/// first failing one.
pub fn step(
    sim: &mut fractum_engine::Simulation,
    comm: &dyn Communicator,
) -> Result<(), RankFailure> {
    // The clock stays out of the world while a re-cut may replace the world.
    let clock = sim.world.remove_resource::<RankClock>().unwrap_or_default();
    let started = Instant::now();
    let followed = with_dim!(sim.dimension(), D => follow_layout::<D>(sim));
    sim.world.insert_resource(clock);
    record(&mut sim.world, Phase::NewWorld, started.elapsed());
    let started = Instant::now();
    comm.agree(followed.err().as_deref())?;
    agree_maxima(&mut sim.world, comm);
    let dt = comm.min(sim.planned_time_step());
    record(&mut sim.world, Phase::Collectives, started.elapsed());
    let started = Instant::now();
    let stepped = sim.step_with_time_step(dt).map_err(|e| e.to_string());
    record(&mut sim.world, Phase::Pipeline, started.elapsed());
    let started = Instant::now();
    let agreed = comm.agree(stepped.err().as_deref());
    record(&mut sim.world, Phase::Collectives, started.elapsed());
    agreed?;
    let moved = with_dim!(sim.dimension(), D => redistribute::<D>(&mut sim.world, comm));
    let started = Instant::now();
    let agreed = comm.agree(moved.err().as_deref());
    record(&mut sim.world, Phase::Collectives, started.elapsed());
    agreed
}

/// Moves this rank onto the nodes of its slabs, when they were re-cut after the last step
/// ([`Ownership::nodes_pending`]). Until then the world kept the nodes the last step computed
/// and owned, for what is read after a step (reactions, grid frames, a checkpoint). When the
/// new slabs reach nodes the world does not hold, or no longer reach some it holds, the world
/// is built afresh from the scene for them ([`RankRebuild`]) and the rank's particles, their
/// carried state and the run's are put into it, as a resume puts a checkpoint into a fresh
/// world; else only the nodes it owns change. A world built without a [`RankRebuild`] (one made
/// by hand) keeps its nodes.
fn follow_layout<D: Dim>(sim: &mut fractum_engine::Simulation) -> Result<(), String> {
    let world = &mut sim.world;
    let Some(mut ownership) = world
        .get_resource::<Ownership>()
        .filter(|o| o.nodes_pending)
        .cloned()
    else {
        return Ok(());
    };
    ownership.nodes_pending = false;
    let grid = world.resource::<Grid<D>>();
    let wanted = world.get_resource::<RankRebuild>().map(|rebuild| {
        let grid = fractum_engine::decomposition::rank_grid(
            grid,
            &ownership.layout,
            ownership.rank,
            rebuild.node_reach,
        );
        (grid, rebuild.clone())
    });
    let rebuild = match wanted {
        Some((wanted, rebuild)) if wanted.window != grid.window => rebuild,
        _ => {
            // The same nodes: those owned here follow the slabs.
            own_nodes::<D>(world, ownership);
            return Ok(());
        }
    };
    let saved = crate::checkpoint::capture(world).map_err(|e| e.to_string())?;
    ownership.rebuilds += 1;
    let mut fresh = rebuild.build(&ownership.layout).map_err(|e| {
        format!(
            "rank {} cannot build its world for the re-cut slabs: {e}",
            ownership.rank
        )
    })?;
    put_particles::<D>(&mut fresh.world, &saved.particles, ownership)?;
    crate::checkpoint::restore(&mut fresh.world, &saved).map_err(|e| {
        format!("the rank's state does not fit its world built for the re-cut slabs: {e}")
    })?;
    sim.adopt_world(fresh)
}

/// Gives `world`, a rank's world freshly built from the scene, the particles `ids` in that row
/// order (rows spawned or despawned at the end of its table) and `ownership`; the particles'
/// state is then to be restored.
fn put_particles<D: Dim>(
    world: &mut World,
    ids: &[u32],
    ownership: Ownership,
) -> Result<(), String> {
    resize_particles::<D>(world, ids.len())?;
    let mut slots = world.query_filtered::<&mut ParticleId, With<Particle>>();
    for (mut slot, &id) in slots.iter_mut(world).zip(ids) {
        slot.0 = id;
    }
    own_nodes::<D>(world, ownership);
    Ok(())
}

/// Gives `world` `ownership`, with the nodes it owns those of its slab among the nodes of the
/// world's grid, and measures the reactions at them.
fn own_nodes<D: Dim>(world: &mut World, mut ownership: Ownership) {
    let grid = world.resource::<Grid<D>>();
    let axis = ownership.layout.axis;
    let layers = (0..grid.node_count()).map(|n| grid.node_lattice(n)[axis]);
    ownership.nodes = ownership.node_flags(layers);
    ownership.nodes_pending = false;
    if let Some(mut bcs) = world.get_resource_mut::<fractum_engine::boundary::BoundaryConditions>()
    {
        bcs.measured_nodes = Some(ownership.nodes.clone());
    }
    world.insert_resource(ownership);
}

/// Gives the world each scene-wide maximum the pipeline wants before this step
/// ([`fractum_engine::decomposition::RankMaximum`]): the greatest of the ranks' own. A maximum any rank
/// wants is found by all: a rank whose world was built afresh for re-cut slabs
/// ([`follow_layout`]) wants again what the others hold already.
fn agree_maxima(world: &mut World, comm: &dyn Communicator) {
    let Some(maxima) = world.get_resource::<fractum_engine::decomposition::RankMaxima>() else {
        return;
    };
    for maximum in maxima.0.clone() {
        let wanted = if (maximum.wanted)(world) { 1.0 } else { 0.0 };
        if comm.max(wanted) > 0.0 {
            let local = (maximum.local)(world);
            (maximum.apply)(world, comm.max(local));
        }
    }
}

/// The cell layer along the slabs' axis of a particle at `x`, clamped into the grid.
#[inline]
fn layer_of<D: Dim>(layout: &Layout, grid: &Grid<D>, x: D::Vector) -> usize {
    grid.clamped_axis_cell(layout.axis, x[layout.axis])
}

/// One rank's particles on the wire: their ids, ascending, and their carried components as
/// [`CheckpointState::save_particles`] encodes them.
type Block = (Vec<u32>, Vec<Vec<u8>>);

/// The particles `rows` (storage row, entity, id) on the wire.
fn block(
    world: &mut World,
    state: &CheckpointState,
    rows: &[(usize, Entity, u32)],
) -> Result<Block, String> {
    let entities: Vec<Entity> = rows.iter().map(|r| r.1).collect();
    let storage: Vec<usize> = rows.iter().map(|r| r.0).collect();
    let components = state
        .save_particles(world, &entities, &storage)
        .map_err(|e| e.to_string())?;
    Ok((rows.iter().map(|r| r.2).collect(), components))
}

/// Ends a step of a distributed run on this rank: sends the state of each particle this rank
/// now owns to every other rank that holds its layer, and replaces this rank's particles with
/// the ones it owns and the ones it received, in id order, each with its owner's state. Every
/// rank calls it after the same step.
pub fn redistribute<D: Dim>(world: &mut World, comm: &dyn Communicator) -> Result<(), String> {
    let mut ownership = world
        .remove_resource::<Ownership>()
        .ok_or("a distributed step needs the rank's Ownership")?;
    let result = exchange_and_rebuild::<D>(world, comm, &mut ownership);
    world.insert_resource(ownership);
    result
}

fn exchange_and_rebuild<D: Dim>(
    world: &mut World,
    comm: &dyn Communicator,
    ownership: &mut Ownership,
) -> Result<(), String> {
    let started = Instant::now();
    let grid = world.resource::<Grid<D>>().clone();
    let state = world
        .get_resource::<CheckpointState>()
        .cloned()
        .unwrap_or_default();
    let layout = ownership.layout.clone();
    let (claimed, per_layer, escaped) = claim::<D>(world, &grid, ownership);
    // Every rank takes part in the sums and the exchange, whatever it found, so that none
    // waits for another; the failures are reported after them.
    let (per_layer, mut failure) = count(world, comm, ownership, &per_layer, &escaped);
    let nodes_per_layer = grid.nodes_per_layer(layout.axis);
    let (next, peers) = next_layout(&layout, (&per_layer, nodes_per_layer), ownership);
    let started = lap(world, Phase::Counting, started);
    let (kept, sends) = send(world, &state, (&claimed, ownership.rank), (&next, &peers));
    let sends: Vec<(usize, Vec<u8>)> = sends
        .into_iter()
        .map(|(peer, encoded)| {
            let bytes = encoded.unwrap_or_else(|e| {
                failure.get_or_insert(e);
                Vec::new()
            });
            (peer, bytes)
        })
        .collect();
    ownership.sent_bytes += sends.iter().map(|(_, b)| b.len() as u64).sum::<u64>();
    let started = lap(world, Phase::Encoding, started);
    let received = comm.exchange(&sends);
    let started = lap(world, Phase::Exchange, started);
    if let Some(failure) = failure {
        return Err(failure);
    }
    let arrived = receive(&peers, received)?;
    let started = lap(world, Phase::Decoding, started);
    rebuild::<D>(world, &state, &kept, arrived)?;
    let loads = fractum_engine::decomposition::layer_loads(&per_layer, nodes_per_layer);
    settle::<D>(world, &grid, ownership, (layout, next), &loads);
    lap(world, Phase::Rebuilding, started);
    Ok(())
}

/// Adds the time since `started` to `phase` of the world's [`RankClock`]; the next phase's
/// start.
fn lap(world: &mut World, phase: Phase, started: Instant) -> Instant {
    let now = Instant::now();
    record(world, phase, now - started);
    now
}

/// A particle this rank takes over after the step: its row, entity, id and cell layer.
type Claimed = (usize, Entity, u32, usize);

/// A particle this rank removed on leaving the grid: its id and position (`Ownership::escaped`).
type Escaped = (u32, [f64; 3]);

/// The particles this rank takes over: those whose step here was exact (they began near the
/// slab) and that ended it in the slab. Under `LeaveGrid::Remove` a particle that ended the
/// step outside the grid is taken over by none, and counted by its owner. Also the claimed
/// particles per cell layer, with the particles this rank removed in a last slot, and those
/// removed ones.
fn claim<D: Dim>(
    world: &mut World,
    grid: &Grid<D>,
    ownership: &mut Ownership,
) -> (Vec<Claimed>, Vec<f64>, Vec<Escaped>) {
    let removing = world.get_resource::<LeaveGrid>() == Some(&LeaveGrid::Remove);
    let escaped = std::mem::take(&mut ownership.escaped);
    let (layout, claimable) = (&ownership.layout, &ownership.claimable);
    // The layers of this rank's slab are the ones it owns (`Layout::owner`).
    let slab = layout.slabs[ownership.rank].clone();
    let mut claimed = Vec::with_capacity(claimable.len());
    let mut per_layer = vec![0.0; layout.cells() + 1];
    per_layer[layout.cells()] = escaped.len() as f64;
    for_each_row::<D>(world, |row, entity, id, x| {
        let skipped = removing && x.is_finite() && !grid.contains(x);
        if skipped || !claimable.get(row).copied().unwrap_or(false) {
            return;
        }
        let layer = layer_of::<D>(layout, grid, x);
        if slab.contains(&layer) {
            claimed.push((row, entity, id, layer));
            per_layer[layer] += 1.0;
        }
    });
    (claimed, per_layer, escaped)
}

/// The particles per cell layer over every rank (a collective), the particles removed in the
/// step recorded, and why the step cannot go on, if it cannot: particles lost between slabs,
/// or none left.
fn count(
    world: &mut World,
    comm: &dyn Communicator,
    ownership: &mut Ownership,
    per_layer: &[f64],
    escaped: &[Escaped],
) -> (Vec<u64>, Option<String>) {
    let mut per_layer: Vec<u64> = comm.sum(per_layer).iter().map(|&n| n as u64).collect();
    let removed = per_layer.pop().unwrap_or(0);
    if removed > 0 {
        record_removed(world, comm, escaped, removed);
        ownership.total -= removed.min(ownership.total);
    }
    let owned: u64 = per_layer.iter().sum();
    let mut failure = (owned != ownership.total).then(|| {
        format!(
            "the ranks own {owned} particles after the step, not the run's {}: a particle moved \
             further in one step than the halo of {} layers allows",
            ownership.total, ownership.layout.halo
        )
    });
    if ownership.total == 0 && failure.is_none() {
        let escaped = world.resource::<EscapedParticles>();
        failure = Some(
            escaped
                .nothing_left(world.resource::<SimClock>().step)
                .to_string(),
        );
    }
    (per_layer, failure)
}

/// The slabs after the step (re-cut when the load is out of balance) and the ranks this rank
/// exchanges particles with: its neighbours, or every rank when the slabs move. `per_layer`:
/// the particles in each cell layer and the nodes in every layer.
fn next_layout(
    layout: &Layout,
    per_layer: (&[u64], u64),
    ownership: &Ownership,
) -> (Layout, Vec<usize>) {
    let me = ownership.rank;
    match rebalanced(layout, per_layer, ownership.rebalance_above) {
        // The slabs move: any rank may hold what another owned.
        Some(next) => {
            let peers = (0..layout.slabs.len()).filter(|&r| r != me).collect();
            (next, peers)
        }
        None => (layout.clone(), layout.peers(me)),
    }
}

/// A particle kept on this rank or sent to a peer: its row, entity and id.
type Moved = (usize, Entity, u32);

/// A peer and the block of particles encoded for it (or why it could not be encoded).
type Encoded = (usize, Result<Vec<u8>, String>);

/// The claimed particles this rank keeps (it holds their layer in the `next` slabs), and each
/// peer's encoded block of those it holds: the send half of the exchange.
fn send(
    world: &mut World,
    state: &CheckpointState,
    (claimed, me): (&[Claimed], usize),
    (next, peers): (&Layout, &[usize]),
) -> (Vec<Moved>, Vec<Encoded>) {
    let mut kept = Vec::with_capacity(claimed.len());
    let mut outgoing: Vec<Vec<Moved>> = vec![Vec::new(); peers.len()];
    // Where each layer's particles go, found once per layer rather than once per particle:
    // `None` for this rank, the peer's place in `peers` otherwise (every holder of a layer of
    // this slab is a peer, `Layout::peers`).
    let destinations: Vec<Vec<Option<usize>>> = (0..next.cells())
        .map(|layer| {
            (next.holders(layer))
                .filter_map(|holder| match peers.iter().position(|&p| p == holder) {
                    _ if holder == me => Some(None),
                    Some(k) => Some(Some(k)),
                    None => None,
                })
                .collect()
        })
        .collect();
    for &(row, entity, id, layer) in claimed {
        for destination in destinations.get(layer).into_iter().flatten() {
            match destination {
                None => kept.push((row, entity, id)),
                Some(k) => outgoing[*k].push((row, entity, id)),
            }
        }
    }
    let sends = peers
        .iter()
        .zip(&outgoing)
        .map(|(peer, rows)| {
            let encoded = block(world, state, rows)
                .map(|(ids, parts)| wire::encode(&ids, &parts))
                .map_err(|e| format!("cannot encode particles for rank {peer}: {e}"));
            (*peer, encoded)
        })
        .collect();
    (kept, sends)
}

/// The blocks the peers sent, decoded: the receive half of the exchange.
fn receive(peers: &[usize], received: Vec<Vec<u8>>) -> Result<Vec<Block>, String> {
    peers
        .iter()
        .zip(received)
        .map(|(peer, bytes)| {
            wire::decode(&bytes)
                .map_err(|e| format!("cannot decode the particles rank {peer} sent: {e}"))
        })
        .collect()
}

/// After the rebuild: the ownership follows the `next` slabs (its nodes when the next step
/// begins), and records the imbalance (of the cell layers' `loads`) and which particles this
/// rank owns.
fn settle<D: Dim>(
    world: &mut World,
    grid: &Grid<D>,
    ownership: &mut Ownership,
    (layout, next): (Layout, Layout),
    loads: &[u64],
) {
    if next != layout {
        // The nodes this step computed stay owned (and held) until the next step begins
        // (`follow_layout`): what is read after the step reads them.
        let nodes = std::mem::take(&mut ownership.nodes);
        ownership.relayout(next, std::iter::empty());
        ownership.nodes = nodes;
        ownership.nodes_pending = true;
    }
    ownership.imbalance =
        fractum_engine::decomposition::imbalance(&slab_loads(&ownership.layout, loads));
    let mut layers = Vec::with_capacity(ownership.particles.len());
    let layout = &ownership.layout;
    for_each_row::<D>(world, |_, _, _, x| {
        layers.push(layer_of::<D>(layout, grid, x))
    });
    ownership.mark(layers.into_iter());
}

/// Adds the `removed` particles that left the grid in this step, over every rank, to the
/// run's [`EscapedParticles`], which every rank holds alike: the count, and the first removed
/// when none was before (the lowest id, as one process, which removes a step's particles in
/// row order and keeps its rows in id order until it first removes one). `escaped` are the ones
/// this rank owned (`Ownership::escaped`). Every rank calls it after the same step.
fn record_removed(
    world: &mut World,
    comm: &dyn Communicator,
    escaped: &[(u32, [f64; 3])],
    removed: u64,
) {
    let mut record = world.resource_mut::<EscapedParticles>();
    record.count += removed;
    if record.first.is_none() {
        let lowest = escaped.iter().min_by_key(|e| e.0);
        let id = comm.min(lowest.map_or(f64::INFINITY, |e| f64::from(e.0)));
        // The owner of the lowest id gives its position; the others add zeros.
        let mine = lowest.filter(|e| f64::from(e.0) == id);
        let position = comm.sum(&mine.map_or([0.0; 3], |e| e.1));
        record.first = Some((id as u32, [position[0], position[1], position[2]]));
    }
}

/// Each slab's load, from the loads per layer.
fn slab_loads(layout: &Layout, loads: &[u64]) -> Vec<u64> {
    layout
        .slabs
        .iter()
        .map(|slab| loads[slab.clone()].iter().sum())
        .collect()
}

/// The slabs re-cut to the particles per layer and the nodes in every layer
/// ([`fractum_engine::decomposition::layer_loads`]) when the most loaded rank is more than
/// `above` over the mean and the new cut is better balanced; `None` to keep them.
fn rebalanced(
    layout: &Layout,
    (per_layer, nodes_per_layer): (&[u64], u64),
    above: Option<f64>,
) -> Option<Layout> {
    use fractum_engine::decomposition::{cut_slabs, imbalance, layer_loads};
    let above = above?;
    let now = imbalance(&slab_loads(
        layout,
        &layer_loads(per_layer, nodes_per_layer),
    ));
    if now <= above {
        return None;
    }
    let cut = cut_slabs(layout.axis, per_layer, nodes_per_layer, layout.slabs.len()).ok()?;
    (cut.imbalance() < now).then(|| Layout {
        slabs: cut.layers,
        ..layout.clone()
    })
}

/// Spawns or despawns particles at the end of storage until there are `count`: the rows that
/// stay keep their places.
fn resize_particles<D: Dim>(world: &mut World, count: usize) -> Result<(), String> {
    let entities: Vec<Entity> = rows::<D>(world).into_iter().map(|r| r.0).collect();
    if count < entities.len() {
        for &entity in entities[count..].iter().rev() {
            world.despawn(entity);
        }
    } else if count > entities.len() {
        let templates = world
            .remove_resource::<fractum_engine::registry::templates::RankParticles>()
            .ok_or("a distributed step needs the rank's particle templates")?;
        let fresh = ParticleBundle::<D>::new(0, D::Vector::ZERO, 0.0, 0.0, 0);
        templates
            .0
            .spawn(world, vec![fresh; count - entities.len()]);
        world.insert_resource(templates);
    }
    Ok(())
}

/// The ids of this rank's owned particles in a distributed run (every particle's otherwise),
/// ascending: which particles a rank holds, without encoding their state as
/// [`state_of_particles`] does (one query for the whole table, where that encodes each particle's
/// components one query at a time).
pub fn owned_particle_ids<D: Dim>(world: &mut World) -> Vec<u32> {
    let owned = world
        .get_resource::<Ownership>()
        .map(|o| o.particles.clone());
    let mut ids: Vec<u32> = rows::<D>(world)
        .into_iter()
        .enumerate()
        .filter(|(row, _)| owned.as_ref().is_none_or(|o| o[*row]))
        .map(|(_, (_, id, _))| id)
        .collect();
    ids.sort_unstable();
    ids
}

/// Each particle's carried state, encoded one particle at a time, by id: this rank's owned
/// particles in a distributed run, every particle otherwise. What tests compare between a
/// distributed run and the single process.
pub fn state_of_particles<D: Dim>(
    world: &mut World,
) -> Result<std::collections::BTreeMap<u32, Vec<Vec<u8>>>, String> {
    let state = world
        .get_resource::<CheckpointState>()
        .cloned()
        .unwrap_or_default();
    let owned = world
        .get_resource::<Ownership>()
        .map(|o| o.particles.clone());
    let mut states = std::collections::BTreeMap::new();
    for (row, (entity, id, _)) in rows::<D>(world).into_iter().enumerate() {
        if owned.as_ref().is_some_and(|o| !o[row]) {
            continue;
        }
        let encoded = state
            .save_particles(world, &[entity], &[row])
            .map_err(|e| e.to_string())?;
        states.insert(id, encoded);
    }
    Ok(states)
}

/// Puts this rank's piece of the checkpoint of a distributed run ([`crate::checkpoint::RankCheckpoint::Piece`])
/// into `sim`, a rank's simulation freshly built from the checkpoint's scene for the same rank
/// of as many ranks: the particles the rank held then (rows spawned or despawned at the end of
/// its table and given their ids), what it owned, and every carried component and resource.
/// The outputs are not touched.
pub fn restore_rank_piece(
    sim: &mut fractum_engine::Simulation,
    file: &crate::checkpoint::CheckpointFile,
    (rank, ranks): (usize, usize),
) -> Result<(), String> {
    use crate::checkpoint::RankCheckpoint;
    let Some(RankCheckpoint::Piece {
        rank: saved_rank,
        ranks: saved_ranks,
        ownership,
    }) = &file.ranks
    else {
        return Err("this file is not a rank's piece of a checkpoint".into());
    };
    if (*saved_rank, *saved_ranks) != (rank, ranks) {
        return Err(format!(
            "this is the piece of rank {saved_rank} of {saved_ranks}, not of rank {rank} of \
             {ranks}"
        ));
    }
    let ownership: Ownership = postcard::from_bytes(ownership)
        .map_err(|e| format!("the piece's ownership cannot be read: {e}"))?;
    // The slabs may have been re-cut before the checkpoint: the rank's world holds the nodes
    // of the piece's slabs.
    let built_for = sim
        .world
        .get_resource::<Ownership>()
        .map(|o| o.layout.clone());
    if built_for.as_ref() != Some(&ownership.layout)
        && let Some(rebuild) = sim.world.get_resource::<RankRebuild>().cloned()
    {
        sim.adopt_world(rebuild.build(&ownership.layout)?)?;
    }
    let dimension = sim.dimension();
    let world = &mut sim.world;
    with_dim!(dimension, D => put_particles::<D>(world, &file.world.particles, ownership))?;
    super::restore_checkpoint(sim, file)
}
