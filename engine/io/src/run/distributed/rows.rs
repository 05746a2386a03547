//! A rank's particle rows: visited in storage order ([`for_each_row`]), and rebuilt after a
//! step's exchange ([`super::redistribute`]) from the particles it kept and those that arrived,
//! sorted by id, each with its owner's state.

use super::{Block, Moved, block, resize_particles};
use crate::checkpoint::CheckpointState;
use bevy_ecs::prelude::*;
use fractum_engine::components::{Particle, ParticleId, Position};
use fractum_engine::dim::Dim;

/// Makes the world's particles exactly those it `kept` (storage row, entity, id) and those
/// that `arrived` from other ranks, sorted by id, each with its owner's state. Mostly no
/// particle enters or leaves a rank in a step: every kept particle is then in its row already,
/// with the state this rank computed for it, and only the rows of those that arrived are
/// written. Where rows change, the kept particles' components move to their new rows within
/// their columns ([`CheckpointState::permute_rows`]), and only what arrived is decoded.
pub(super) fn rebuild<D: Dim>(
    world: &mut World,
    state: &CheckpointState,
    kept: &[(usize, Entity, u32)],
    arrived: Vec<Block>,
) -> Result<(), String> {
    let picks = merged_picks(kept, &arrived)?;
    let mut held = Vec::with_capacity(picks.len());
    for_each_row::<D>(world, |_, _, id, _| held.push(id));
    let same_rows = held.len() == picks.len() && held.iter().zip(&picks).all(|(a, b)| *a == b.0);
    let arrived: Vec<Vec<Vec<u8>>> = arrived.into_iter().map(|b| b.1).collect();
    let keep_or_pick = |&(_, b, i): &(u32, u32, u32)| match b {
        0 => crate::checkpoint::KEEP_ROW,
        _ => (b - 1, i),
    };
    let kept_picks: Vec<(u32, u32)> = picks.iter().map(keep_or_pick).collect();
    let codec = |e: fractum_engine::checkpoint::CheckpointError| e.to_string();
    if same_rows {
        // The systems' row caches (neighbour lists) stay valid.
        return (state.load_picked_rows(world, &arrived, &kept_picks, true)).map_err(codec);
    }
    let kept_from: Vec<Option<usize>> = (picks.iter())
        .map(|&(_, b, i)| (b == 0).then(|| kept[i as usize].0))
        .collect();
    if picks.len() > held.len() {
        resize_particles::<D>(world, picks.len())?;
    }
    let from = complete_permutation(&kept_from, held.len().max(picks.len()));
    if state.permute_rows(world, &from).map_err(codec)? {
        resize_particles::<D>(world, picks.len())?;
        set_ids(world, &picks);
        return (state.load_arrived_rows(world, &arrived, &kept_picks, &kept_from)).map_err(codec);
    }
    // Particles in several tables: the kept ones' state is encoded and picked back as block 0.
    let mut components = vec![block(world, state, kept)?.1];
    components.extend(arrived);
    resize_particles::<D>(world, picks.len())?;
    set_ids(world, &picks);
    let picks: Vec<(u32, u32)> = picks.iter().map(|&(_, b, i)| (b, i)).collect();
    (state.load_picked_rows(world, &components, &picks, false)).map_err(codec)
}

/// Every particle the rank holds after the step, sorted by id: (id, block, index), block 0
/// being what this rank `kept` and block `b + 1` the `b`-th that arrived.
fn merged_picks(kept: &[Moved], arrived: &[Block]) -> Result<Vec<(u32, u32, u32)>, String> {
    let kept_ids: Vec<u32> = kept.iter().map(|r| r.2).collect();
    let runs: Vec<&[u32]> = std::iter::once(kept_ids.as_slice())
        .chain(arrived.iter().map(|(ids, _)| ids.as_slice()))
        .collect();
    let picks = merge_ascending_runs(&runs);
    match picks.windows(2).find(|w| w[0].0 == w[1].0) {
        Some(w) => Err(format!("particle {} arrived from two ranks", w[0].0)),
        None => Ok(picks),
    }
}

/// The ids of `runs` in one ascending sequence, each as (id, run, index in the run), equal ids
/// in run order. The kept ids ascend (rows are in id order) and so do each block's, so the
/// runs are merged in one pass: the run with the least head gives every id that still comes
/// before the next run's head (a rank has a few runs, its own and one per peer, whose ids
/// interleave in stretches); a run that does not ascend is sorted with the rest instead.
fn merge_ascending_runs(runs: &[&[u32]]) -> Vec<(u32, u32, u32)> {
    let total = runs.iter().map(|r| r.len()).sum();
    let mut merged = Vec::with_capacity(total);
    if !runs.iter().all(|run| run.is_sorted()) {
        for (b, run) in runs.iter().enumerate() {
            merged.extend((run.iter().enumerate()).map(|(i, &id)| (id, b as u32, i as u32)));
        }
        merged.sort();
        return merged;
    }
    let mut heads = vec![0usize; runs.len()];
    while let Some(((_, b), next)) = two_least_heads(runs, &heads) {
        // Run `b`'s ids up to the next head, a tie going to the lower run, as a sort would.
        let run = runs[b];
        let mut h = heads[b];
        while let Some(&id) = run.get(h) {
            if next.is_some_and(|next| (id, b) > next) {
                break;
            }
            merged.push((id, b as u32, h as u32));
            h += 1;
        }
        heads[b] = h;
    }
    merged
}

/// The least (head id, run) over the runs not yet used up, and the next least, if any.
type Heads = ((u32, usize), Option<(u32, usize)>);

/// [`Heads`] of `runs` at `heads`; `None` when every run is used up.
fn two_least_heads(runs: &[&[u32]], heads: &[usize]) -> Option<Heads> {
    let mut least: Option<(u32, usize)> = None;
    let mut next: Option<(u32, usize)> = None;
    for (b, (run, &h)) in runs.iter().zip(heads).enumerate() {
        let Some(&id) = run.get(h) else { continue };
        let key = (id, b);
        if least.is_none_or(|l| key < l) {
            next = least;
            least = Some(key);
        } else if next.is_none_or(|n| key < n) {
            next = Some(key);
        }
    }
    least.map(|least| (least, next))
}

/// The rows' new order over `len` rows: new row `n` takes old row `kept_from[n]` where a kept
/// particle moves there, and one of the rows no kept particle leaves from otherwise (a row an
/// arrival overwrites, or one despawned at the end).
fn complete_permutation(kept_from: &[Option<usize>], len: usize) -> Vec<usize> {
    let mut left = vec![true; len];
    for &row in kept_from.iter().flatten() {
        left[row] = false;
    }
    let mut spare = (0..len).filter(|&row| left[row]);
    (0..len)
        .map(|n| match kept_from.get(n).copied().flatten() {
            Some(row) => row,
            None => spare.next().unwrap_or(n),
        })
        .collect()
}

/// Writes the particles' ids in storage order from `picks` (id, block, index).
fn set_ids(world: &mut World, picks: &[(u32, u32, u32)]) {
    let mut ids = world.query_filtered::<&mut ParticleId, With<Particle>>();
    for (mut slot, &(id, _, _)) in ids.iter_mut(world).zip(picks) {
        slot.0 = id;
    }
}

/// Rows in storage order: entity, id, position.
pub(super) fn rows<D: Dim>(world: &mut World) -> Vec<(Entity, u32, D::Vector)> {
    let mut rows = Vec::new();
    for_each_row::<D>(world, |_, entity, id, x| rows.push((entity, id, x)));
    rows
}

/// Calls `visit` with every particle row in storage order: its row, entity, id and position.
/// Table by table over the columns' slices, as the query's iterator goes through the tables:
/// that iterator's fetch of each particle cost more than the work a step's exchange does with
/// it, twice over every row (a rank goes through its rows after every step).
pub(super) fn for_each_row<D: Dim>(
    world: &mut World,
    mut visit: impl FnMut(usize, Entity, u32, D::Vector),
) {
    let mut query = world.query_filtered::<(Entity, &ParticleId, &Position<D>), With<Particle>>();
    let mut row = 0;
    let mut next = |entity: Entity, id: &ParticleId, x: &Position<D>| {
        visit(row, entity, id.0, x.0);
        row += 1;
    };
    match query.contiguous_iter(world) {
        Ok(tables) => {
            for (entities, ids, xs) in tables {
                for ((&entity, id), x) in entities.iter().zip(ids).zip(xs) {
                    next(entity, id, x);
                }
            }
        }
        Err(_) => query.iter(world).for_each(|(e, id, x)| next(e, id, x)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fractum_engine::components::ParticleBundle;
    use fractum_engine::dim::Two;
    use glam::DVec2;

    /// Rows 0..5 held particles 10..14; 11 and 13 left, 12 and 14 were kept, and 15 and 16
    /// arrived: the new rows are 12, 14, 15, 16 (the kept ones from old rows 2 and 4), over
    /// five rows until the last is despawned.
    #[test]
    fn kept_rows_take_their_new_places_and_the_rest_fill_in() {
        let kept_from = [Some(2), Some(4), None, None];
        let from = complete_permutation(&kept_from, 5);
        assert_eq!(from, vec![2, 4, 0, 1, 3]);
        let mut sorted = from.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, vec![0, 1, 2, 3, 4]);
        // Growing: two rows kept in place and one moved up past an arrival.
        let grown = complete_permutation(&[Some(0), None, Some(1), Some(2)], 4);
        assert_eq!(grown, vec![0, 3, 1, 2]);
    }

    /// The merge is the sort of the tagged ids, runs that ascend or not, empty ones too.
    #[test]
    fn merged_runs_are_the_sorted_ids() {
        let cases: [&[&[u32]]; 4] = [
            &[&[2, 5, 9], &[1, 3], &[], &[4, 10, 11]],
            &[&[], &[]],
            &[&[7, 7, 8], &[7]],
            &[&[5, 1], &[3]],
        ];
        for runs in cases {
            let mut sorted: Vec<(u32, u32, u32)> = (runs.iter().enumerate())
                .flat_map(|(b, run)| {
                    (run.iter().enumerate()).map(move |(i, &id)| (id, b as u32, i as u32))
                })
                .collect();
            sorted.sort();
            assert_eq!(merge_ascending_runs(runs), sorted, "{runs:?}");
        }
    }

    /// Runs that interleave in stretches of every length, with ids shared between runs, merge
    /// into the sort of their tagged ids.
    #[test]
    fn interleaved_runs_merge_into_the_sorted_ids() {
        let mut state = 0x2545_f491_u64;
        let mut next = |below: u64| {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1);
            (state >> 33) % below
        };
        for case in 0..200 {
            let runs: Vec<Vec<u32>> = (0..1 + next(4))
                .map(|_| {
                    let mut run: Vec<u32> = (0..next(40)).map(|_| next(20 + case) as u32).collect();
                    run.sort_unstable();
                    run
                })
                .collect();
            let runs: Vec<&[u32]> = runs.iter().map(Vec::as_slice).collect();
            let mut sorted: Vec<(u32, u32, u32)> = (runs.iter().enumerate())
                .flat_map(|(b, run)| {
                    (run.iter().enumerate()).map(move |(i, &id)| (id, b as u32, i as u32))
                })
                .collect();
            sorted.sort();
            assert_eq!(merge_ascending_runs(&runs), sorted, "{runs:?}");
        }
    }

    #[test]
    fn merged_picks_sort_by_id_and_refuse_a_particle_sent_twice() {
        let e = Entity::PLACEHOLDER;
        let kept = [(0, e, 3), (1, e, 7)];
        let arrived: Vec<Block> = vec![(vec![1, 5], vec![]), (vec![9], vec![])];
        let picks = merged_picks(&kept, &arrived).unwrap();
        assert_eq!(
            picks,
            vec![(1, 1, 0), (3, 0, 0), (5, 1, 1), (7, 0, 1), (9, 2, 0)]
        );
        let twice: Vec<Block> = vec![(vec![7], vec![])];
        assert!(
            merged_picks(&kept, &twice)
                .unwrap_err()
                .contains("particle 7")
        );
    }

    #[derive(Component)]
    struct Marked;

    /// Rows come in the query's order with their own ids and positions, in one table and when
    /// a component on some particles splits them over two.
    #[test]
    fn rows_are_visited_in_the_querys_order_over_every_table() {
        for split in [false, true] {
            let mut world = fractum_engine::testing::tiny_world::<Two>(4, 0.25, 1e-3);
            for k in 0..6u32 {
                let x = DVec2::new(0.1 * f64::from(k), 0.5);
                let mut entity = world.spawn(ParticleBundle::<Two>::new(10 + k, x, 1.0, 0.01, 0));
                if split && k % 2 == 1 {
                    entity.insert(Marked);
                }
            }
            let mut query =
                world.query_filtered::<(Entity, &ParticleId, &Position<Two>), With<Particle>>();
            let expected: Vec<(usize, Entity, u32, DVec2)> = (query.iter(&world))
                .enumerate()
                .map(|(row, (e, id, x))| (row, e, id.0, x.0))
                .collect();
            let mut visited = Vec::new();
            for_each_row::<Two>(&mut world, |row, e, id, x| visited.push((row, e, id, x)));
            assert_eq!(visited, expected, "split over two tables: {split}");
            let ids: Vec<u32> = visited.iter().map(|v| v.2).collect();
            let mut sorted = ids.clone();
            sorted.sort_unstable();
            assert_eq!(sorted, (10..16).collect::<Vec<u32>>());
            if split {
                assert_ne!(ids, sorted, "the marked particles make a second table");
            }
        }
    }
}
