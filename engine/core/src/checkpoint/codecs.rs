//! The codecs behind [`CheckpointState`](super::CheckpointState)'s entries: each carried component, column, row
//! resource and resource saved to postcard bytes and loaded (or picked, row by row, for a
//! rank's arrivals) back into a world.

use super::keys::{CheckpointError, KEEP_ROW, RowState, State};
use crate::components::Particle;
use crate::storage::Untracked;
use bevy_ecs::prelude::*;

fn codec(what: &str) -> impl FnOnce(postcard::Error) -> CheckpointError + '_ {
    move |source| CheckpointError::Codec {
        what: what.to_string(),
        source,
    }
}

pub(super) fn save_component<C: Component + State>(
    world: &mut World,
    particles: &[Entity],
) -> Result<Vec<u8>, CheckpointError> {
    let values: Vec<Option<&C>> = particles.iter().map(|&e| world.get::<C>(e)).collect();
    postcard::to_allocvec(&values).map_err(codec(C::KEY))
}

pub(super) fn load_component<C: Component<Mutability = bevy_ecs::component::Mutable> + State>(
    world: &mut World,
    particles: &[Entity],
    bytes: &[u8],
) -> Result<(), CheckpointError> {
    let name = C::KEY;
    let values: Vec<Option<C>> = postcard::from_bytes(bytes).map_err(codec(name))?;
    if values.len() != particles.len() {
        return Err(CheckpointError::Mismatch(format!(
            "{name}: the checkpoint has {} particles, the scene {}",
            values.len(),
            particles.len()
        )));
    }
    for (&entity, value) in particles.iter().zip(values) {
        match (world.get_mut::<C>(entity), value) {
            (Some(mut slot), Some(value)) => *slot = value,
            (None, None) => {}
            _ => {
                return Err(CheckpointError::Mismatch(format!(
                    "{name}: the particles that have it differ between the checkpoint and the \
                     scene"
                )));
            }
        }
    }
    Ok(())
}

/// `C` of particle rows `rows`, encoded as [`save_component`] encodes them, read from the
/// particles' one table; `None` when the particles (`count` of them) are not all in one table
/// with `C`.
pub(super) fn save_column<C: Component + State>(
    world: &mut World,
    rows: &[usize],
    count: usize,
) -> Option<Result<Vec<u8>, CheckpointError>> {
    let mut query = world.query_filtered::<&C, With<Particle>>();
    let mut tables = query.contiguous_iter(world).ok()?;
    let column: &[C] = tables.next()?;
    if tables.next().is_some() || column.len() < count {
        return None;
    }
    if rows.iter().any(|&r| r >= column.len()) {
        return None;
    }
    if (1..=MOST_NUMBERS).contains(&C::NUMBERS) {
        return Some(Ok(save_numbers(column, rows)));
    }
    // The bytes of a `Vec<Option<&C>>` (a length, then each value tagged as present), written
    // straight from the column into a buffer sized for them: no vector of references between,
    // and no buffer regrown and copied as it fills (a rank encodes its ghosts' columns every
    // step).
    let values = PresentRows { column, rows };
    let room = 11 + rows.len() * (1 + std::mem::size_of::<C>());
    let mut bytes = Vec::with_capacity(room);
    bytes.push(ENCODED);
    let output = Appending(bytes);
    Some(postcard::serialize_with_flavor(&values, output).map_err(codec(C::KEY)))
}

/// A part of a rank's particles ([`CheckpointState::save_particles`](super::CheckpointState::save_particles)) that holds a
/// `Vec<Option<C>>` as postcard encodes it, after this byte.
pub(super) const ENCODED: u8 = 0;

/// A part that holds every value as its numbers ([`State::NUMBERS`]), after this byte: the
/// count of values (a little-endian `u64`), then each value's numbers as little-endian `f64`s.
pub(super) const NUMBERS: u8 = 1;

/// The most numbers a value sent as numbers is made of (a 3×3 tensor has nine); a type made of
/// more is encoded.
const MOST_NUMBERS: usize = 16;

/// Rows `rows` of `column` as a [`NUMBERS`] part: a copy of their numbers, where encoding them
/// value by value cost several times as much (a rank sends its ghosts' columns every step).
fn save_numbers<C: State>(column: &[C], rows: &[usize]) -> Vec<u8> {
    let count = C::NUMBERS;
    // Appended value by value into the room reserved for them: a buffer zeroed first cost as
    // much as the copy.
    let mut bytes = Vec::with_capacity(9 + 8 * count * rows.len());
    bytes.push(NUMBERS);
    bytes.extend_from_slice(&(rows.len() as u64).to_le_bytes());
    let mut numbers = [0.0; MOST_NUMBERS];
    let mut value = [0u8; 8 * MOST_NUMBERS];
    for &row in rows {
        column[row].write_numbers(&mut numbers[..count]);
        // A value's bytes gathered on the stack and appended at once: one check of the room
        // a value instead of one a number.
        for (slot, number) in value.chunks_exact_mut(8).zip(&numbers[..count]) {
            slot.copy_from_slice(&number.to_le_bytes());
        }
        bytes.extend_from_slice(&value[..8 * count]);
    }
    bytes
}

/// The values of a [`NUMBERS`] part's `body` (what follows its first byte), in order; a body
/// that is not whole values of `C`, or a `C` that is not numbers, is a mismatch.
fn numbers_of<C: State>(body: &[u8]) -> Result<impl Iterator<Item = C>, CheckpointError> {
    let mismatch =
        |what: &str| CheckpointError::Mismatch(format!("{}: the numbers sent {what}", C::KEY));
    let count = C::NUMBERS;
    if !(1..=MOST_NUMBERS).contains(&count) {
        return Err(mismatch("are of a value that is not numbers"));
    }
    let (length, values) = body
        .split_at_checked(8)
        .ok_or_else(|| mismatch("have no count"))?;
    let mut length_bytes = [0u8; 8];
    length_bytes.copy_from_slice(length);
    let length = usize::try_from(u64::from_le_bytes(length_bytes)).unwrap_or(usize::MAX);
    let (numbers, rest) = values.as_chunks::<8>();
    if !rest.is_empty() || Some(numbers.len()) != length.checked_mul(count) {
        return Err(mismatch(&format!(
            "are {} bytes, not {length} values of {count}",
            values.len()
        )));
    }
    let numbers: Vec<f64> = numbers.iter().map(|&n| f64::from_le_bytes(n)).collect();
    let values: Vec<C> = (numbers.chunks_exact(count))
        .map(|value| C::read_numbers(value).expect("a type of numbers reads its numbers"))
        .collect();
    Ok(values.into_iter())
}

/// A part's format byte and the bytes after it; an empty part is a mismatch.
fn split_part<'a>(bytes: &'a [u8], what: &str) -> Result<(u8, &'a [u8]), CheckpointError> {
    bytes
        .split_first()
        .map(|(&format, body)| (format, body))
        .ok_or_else(|| CheckpointError::Mismatch(format!("{what}: an empty part was sent")))
}

/// A part's values, in order, as `Option`s (every value of a [`NUMBERS`] part is present).
fn values_of_part<C: State>(bytes: &[u8]) -> Result<Vec<Option<C>>, CheckpointError> {
    match split_part(bytes, C::KEY)? {
        (ENCODED, body) => postcard::from_bytes(body).map_err(codec(C::KEY)),
        (NUMBERS, body) => Ok(numbers_of::<C>(body)?.map(Some).collect()),
        (format, _) => Err(unknown_format::<C>(format)),
    }
}

/// A part of `C` whose format byte is neither [`ENCODED`] nor [`NUMBERS`].
fn unknown_format<C: State>(format: u8) -> CheckpointError {
    CheckpointError::Mismatch(format!(
        "{}: a part of unknown format {format} was sent",
        C::KEY
    ))
}

/// Postcard's output appended to a vector whose room was reserved (here after the part's
/// format byte), a value's bytes (a number's eight) copied at once.
struct Appending(Vec<u8>);

impl postcard::ser_flavors::Flavor for Appending {
    type Output = Vec<u8>;

    #[inline(always)]
    fn try_extend(&mut self, data: &[u8]) -> postcard::Result<()> {
        self.0.extend_from_slice(data);
        Ok(())
    }

    #[inline(always)]
    fn try_push(&mut self, data: u8) -> postcard::Result<()> {
        self.0.push(data);
        Ok(())
    }

    fn finalize(self) -> postcard::Result<Vec<u8>> {
        Ok(self.0)
    }
}

/// Rows `rows` of `column`, serialised as the sequence of `Some(&value)` that
/// [`save_component`] writes for particles that all have the component.
struct PresentRows<'a, C> {
    column: &'a [C],
    rows: &'a [usize],
}

impl<C: serde::Serialize> serde::Serialize for PresentRows<'_, C> {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_seq(self.rows.iter().map(|&r| Some(&self.column[r])))
    }
}

/// A block's particle that no row picks ([`BlockRows`]).
pub(super) const NOT_PICKED: usize = usize::MAX;

/// Where each block's particles go: per block, per particle of the block, the row it fills
/// ([`NOT_PICKED`] for none). Found once from the picks, for every column.
pub(super) type BlockRows = [Vec<usize>];

/// [`pick_component`] into the particles' one table: `block_rows` says the row each block's
/// particle fills (every other row keeps its value, [`KEEP_ROW`]), among `count` rows; `None`
/// when the particles are not all in one table with `C`. Each block's values are decoded
/// straight into their rows, with no vector of decoded values between (a rank picks its
/// ghosts' columns every step).
pub(super) fn pick_column<C: Component<Mutability = bevy_ecs::component::Mutable> + State>(
    world: &mut World,
    sources: &[&[u8]],
    (block_rows, count): (&BlockRows, usize),
) -> Option<Result<(), CheckpointError>> {
    let mut query = world.query_filtered::<&mut C, With<Particle>>();
    let mut tables = query.contiguous_iter_mut(world).ok()?;
    let column = tables.next()?.untracked();
    if tables.next().is_some() || column.len() != count {
        return None;
    }
    for (block, bytes) in sources.iter().enumerate() {
        let rows = block_rows.get(block).map_or(&[][..], Vec::as_slice);
        let bytes = match split_part(bytes, C::KEY) {
            Ok((ENCODED, body)) => body,
            Ok((NUMBERS, body)) => match numbers_into_rows(column, body, rows, block) {
                Ok(()) => continue,
                Err(e) => return Some(Err(e)),
            },
            Ok((format, _)) => return Some(Err(unknown_format::<C>(format))),
            Err(e) => return Some(Err(e)),
        };
        let mut mismatch = None;
        let seed = IntoRows {
            column: &mut *column,
            rows,
            block,
            mismatch: &mut mismatch,
        };
        let decoded = serde::de::DeserializeSeed::deserialize(
            seed,
            &mut postcard::Deserializer::from_bytes(bytes),
        );
        if let Some(mismatch) = mismatch {
            return Some(Err(mismatch));
        }
        if let Err(e) = decoded {
            return Some(Err(codec(C::KEY)(e)));
        }
    }
    Some(Ok(()))
}

/// A [`NUMBERS`] part's values (its `body`) into `column`: the `i`-th into row `rows[i]`, or
/// dropped where no row picks it; a picked value past the part's end is a mismatch.
fn numbers_into_rows<C: State>(
    column: &mut [C],
    body: &[u8],
    rows: &[usize],
    block: usize,
) -> Result<(), CheckpointError> {
    let mut sent = 0;
    for (index, value) in numbers_of::<C>(body)?.enumerate() {
        if let Some(slot) = rows.get(index).and_then(|&row| column.get_mut(row)) {
            *slot = value;
        }
        sent = index + 1;
    }
    let rows = rows.get(sent..).unwrap_or(&[]);
    match rows.iter().position(|&row| row != NOT_PICKED) {
        Some(missing) => Err(CheckpointError::Mismatch(format!(
            "{}: particle {} of block {block} was not sent with it",
            C::KEY,
            sent + missing
        ))),
        None => Ok(()),
    }
}

/// Decodes one block's `Vec<Option<C>>` (as [`save_column`] encodes it) into `column`: the
/// `i`-th value into row `rows[i]`, or dropped where no row picks it. A picked value that was
/// not sent (absent, or past the block's end) is a mismatch, kept in `mismatch`.
struct IntoRows<'a, C> {
    column: &'a mut [C],
    rows: &'a [usize],
    block: usize,
    mismatch: &'a mut Option<CheckpointError>,
}

impl<C: State> IntoRows<'_, C> {
    fn not_sent(&mut self, index: usize) {
        *self.mismatch = Some(CheckpointError::Mismatch(format!(
            "{}: particle {index} of block {} was not sent with it",
            C::KEY,
            self.block
        )));
    }
}

impl<'de, C: State> serde::de::DeserializeSeed<'de> for IntoRows<'_, C> {
    type Value = ();

    fn deserialize<De: serde::Deserializer<'de>>(self, deserializer: De) -> Result<(), De::Error> {
        deserializer.deserialize_seq(self)
    }
}

impl<'de, C: State> serde::de::Visitor<'de> for IntoRows<'_, C> {
    type Value = ();

    fn expecting(&self, formatter: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(formatter, "a sequence of {} values", C::KEY)
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(mut self, mut seq: A) -> Result<(), A::Error> {
        let mut index = 0;
        while let Some(value) = seq.next_element::<Option<C>>()? {
            let row = self.rows.get(index).copied().unwrap_or(NOT_PICKED);
            match (self.column.get_mut(row), value) {
                (Some(slot), Some(value)) => *slot = value,
                (Some(_), None) => {
                    self.not_sent(index);
                    return Err(serde::de::Error::custom("a picked value was not sent"));
                }
                (None, _) => {}
            }
            index += 1;
        }
        let rows = self.rows.get(index..).unwrap_or(&[]);
        if let Some(missing) = rows.iter().position(|&row| row != NOT_PICKED) {
            self.not_sent(index + missing);
        }
        Ok(())
    }
}

pub(super) fn pick_component<C: Component<Mutability = bevy_ecs::component::Mutable> + State>(
    world: &mut World,
    targets: &[Entity],
    sources: &[&[u8]],
    picks: &[(u32, u32)],
) -> Result<(), CheckpointError> {
    let name = C::KEY;
    let mut decoded: Vec<Vec<Option<C>>> = sources
        .iter()
        .map(|bytes| values_of_part::<C>(bytes))
        .collect::<Result<_, _>>()?;
    for (&entity, &(block, index)) in targets.iter().zip(picks) {
        if (block, index) == KEEP_ROW {
            continue;
        }
        // Each particle is picked once: its value is moved out.
        let value = picked(&mut decoded, block, index)
            .map(Option::take)
            .ok_or_else(|| {
                CheckpointError::Mismatch(format!(
                    "{name}: particle {index} of block {block} was not sent"
                ))
            })?;
        match (world.get_mut::<C>(entity), value) {
            (Some(mut slot), Some(value)) => *slot = value,
            (None, None) => {}
            _ => {
                return Err(CheckpointError::Mismatch(format!(
                    "{name}: carried by the particle sent and not by the one it fills, or the \
                     other way round"
                )));
            }
        }
    }
    Ok(())
}

/// The slot of the `index`-th value of block `block`, if it was sent.
fn picked<T>(decoded: &mut [Vec<Option<T>>], block: u32, index: u32) -> Option<&mut Option<T>> {
    decoded.get_mut(block as usize)?.get_mut(index as usize)
}

pub(super) fn save_rows<R: RowState>(
    world: &World,
    rows: &[usize],
) -> Result<Vec<u8>, CheckpointError> {
    let values: Vec<R::Row> = match world.get_resource::<R>() {
        Some(resource) => rows.iter().map(|&r| resource.row(r)).collect(),
        None => Vec::new(),
    };
    postcard::to_allocvec(&values).map_err(codec(R::KEY))
}

/// Moves the values of `C`'s column in the particles' one table so that row `n` holds what row
/// `from[n]` held (`from` a permutation of the rows); `false` when the particles are not all in
/// one table with `C`. A table without `C` has nothing to move.
pub(super) fn permute_column<C: Component<Mutability = bevy_ecs::component::Mutable>>(
    world: &mut World,
    from: &[usize],
) -> bool {
    let mut query = world.query_filtered::<&mut C, With<Particle>>();
    let Ok(mut tables) = query.contiguous_iter_mut(world) else {
        return false;
    };
    let Some(column) = tables.next().map(Untracked::untracked) else {
        return true;
    };
    if tables.next().is_some() || column.len() != from.len() {
        return false;
    }
    apply_permutation(column, from);
    true
}

/// Rearranges `values` so that slot `n` holds what slot `from[n]` held, by swaps along the
/// permutation's cycles (no value is cloned or dropped).
pub(super) fn apply_permutation<T>(values: &mut [T], from: &[usize]) {
    let mut placed = vec![false; values.len()];
    for start in 0..values.len() {
        let mut slot = start;
        while !placed[slot] {
            placed[slot] = true;
            let source = from[slot];
            if source == start {
                break;
            }
            values.swap(slot, source);
            slot = source;
        }
    }
}

/// Picks each row of resource `R` from `sources` as [`pick_component`] picks a component; a row
/// picked as [`KEEP_ROW`] takes the value of row `kept[n]` of the resource as it is.
pub(super) fn pick_rows<R: RowState>(
    world: &mut World,
    sources: &[&[u8]],
    picks: &[(u32, u32)],
    kept: &[Option<usize>],
) -> Result<(), CheckpointError> {
    let name = R::KEY;
    if !world.contains_resource::<R>() {
        return Ok(());
    }
    let mut decoded: Vec<Vec<Option<R::Row>>> = sources
        .iter()
        .map(|bytes| {
            postcard::from_bytes::<Vec<R::Row>>(bytes)
                .map(|rows| rows.into_iter().map(Some).collect())
                .map_err(codec(name))
        })
        .collect::<Result<_, _>>()?;
    let resource = world.resource::<R>();
    let rows = (picks.iter().enumerate())
        .map(|(n, &(block, index))| {
            let old_row = kept.get(n).copied().flatten();
            match old_row {
                Some(row) if (block, index) == KEEP_ROW => Some(resource.row(row)),
                _ => picked(&mut decoded, block, index).and_then(Option::take),
            }
            .ok_or_else(|| {
                CheckpointError::Mismatch(format!(
                    "{name}: row {index} of block {block} was not sent"
                ))
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    if let Some(mut resource) = world.get_resource_mut::<R>() {
        resource.set_rows(rows);
    }
    Ok(())
}

pub(super) fn save_resource<R: Resource + State>(
    world: &World,
) -> Result<Option<Vec<u8>>, CheckpointError> {
    world
        .get_resource::<R>()
        .map(|r| postcard::to_allocvec(r).map_err(codec(R::KEY)))
        .transpose()
}

pub(super) fn load_resource<R: Resource + State>(
    world: &mut World,
    bytes: &[u8],
) -> Result<(), CheckpointError> {
    let value: R = postcard::from_bytes(bytes).map_err(codec(R::KEY))?;
    world.insert_resource(value);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::components::{MaterialId, Position};
    use crate::dim::Two;
    use crate::testing::{spawn_particle, tiny_world};
    use glam::DVec2;

    /// Rows read from the column are the same values as the same particles saved one entity
    /// at a time, in any order and with repeats: as their numbers for a component of numbers,
    /// as the same encoded bytes after the format byte for any other; a row past the table is
    /// no column read.
    #[test]
    fn rows_of_the_column_are_the_values_of_the_particles() {
        let mut world = tiny_world::<Two>(4, 1.0, 1e-3);
        let particles: Vec<Entity> = (0..5)
            .map(|i| {
                let x = 0.1 + 0.15 * i as f64;
                spawn_particle(&mut world, DVec2::new(x, 0.5), DVec2::ZERO, 1.0, 1.0)
            })
            .collect();
        let rows = [3, 0, 4, 4, 1];
        let entities: Vec<Entity> = rows.iter().map(|&r| particles[r]).collect();
        let by_entity = save_component::<Position<Two>>(&mut world, &entities).unwrap();
        let by_column = save_column::<Position<Two>>(&mut world, &rows, 5)
            .unwrap()
            .unwrap();
        assert_eq!(by_column[0], NUMBERS);
        let sent: Vec<Option<Position<Two>>> = postcard::from_bytes(&by_entity).unwrap();
        assert_eq!(values_of_part::<Position<Two>>(&by_column).unwrap(), sent);
        let materials = save_component::<MaterialId>(&mut world, &entities).unwrap();
        let by_column = save_column::<MaterialId>(&mut world, &rows, 5);
        assert_eq!(
            by_column.unwrap().unwrap(),
            [&[ENCODED], &materials[..]].concat()
        );
        assert!(save_column::<Position<Two>>(&mut world, &[0, 5], 5).is_none());
        let none = save_column::<Position<Two>>(&mut world, &[], 5)
            .unwrap()
            .unwrap();
        assert!(values_of_part::<Position<Two>>(&none).unwrap().is_empty());
    }

    /// Values sent as numbers come back bit for bit, signed zeros, infinities, subnormals and
    /// a NaN's payload included, in 2D and 3D, for vectors, tensors and scalars.
    #[test]
    fn numbers_come_back_bit_for_bit() {
        let odd = [
            -0.0,
            f64::from_bits(0x7ff8_0000_dead_beef),
            f64::INFINITY,
            f64::MIN_POSITIVE / 3.0,
            -1.5e300,
            std::f64::consts::PI,
            1.0 / 3.0,
            -7.25,
            f64::NEG_INFINITY,
        ];
        fn round_trip<C: State>(numbers: &[f64]) {
            let value = C::read_numbers(numbers).unwrap();
            let part = save_numbers(&[value], &[0, 0]);
            let back: Vec<C> = numbers_of::<C>(&part[1..]).unwrap().collect();
            assert_eq!(back.len(), 2);
            for value in &back {
                let mut out = [0.0; MOST_NUMBERS];
                value.write_numbers(&mut out);
                let bits = |xs: &[f64]| xs.iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
                assert_eq!(
                    bits(&out[..C::NUMBERS]),
                    bits(&numbers[..C::NUMBERS]),
                    "{}",
                    C::KEY
                );
            }
        }
        use crate::components::{DeformationGradient, Mass, Stress, Velocity};
        use crate::dim::Three;
        round_trip::<Position<Two>>(&odd);
        round_trip::<Velocity<Three>>(&odd);
        round_trip::<Stress<Two>>(&odd);
        round_trip::<Stress<Three>>(&odd);
        round_trip::<DeformationGradient<Two>>(&odd);
        round_trip::<DeformationGradient<Three>>(&odd);
        round_trip::<Mass>(&odd[1..]);
        assert_eq!(<Stress<Three> as State>::NUMBERS, 6);
        assert_eq!(<DeformationGradient<Three> as State>::NUMBERS, 9);
        assert!(MaterialId::read_numbers(&[1.0]).is_none());
    }

    /// A part of numbers fills the rows that pick its values, in the column and entity by
    /// entity alike; a pick past its end, a part cut inside a value or without its count, and
    /// an unknown format byte are mismatches that say so, never a panic.
    #[test]
    fn a_part_of_numbers_fills_its_rows_and_a_damaged_one_is_refused() {
        let mut world = tiny_world::<Two>(4, 1.0, 1e-3);
        let at = |i: usize| DVec2::new(0.1 + 0.15 * i as f64, 0.5);
        let particles: Vec<Entity> = (0..5)
            .map(|i| spawn_particle(&mut world, at(i), DVec2::ZERO, 1.0, 1.0))
            .collect();
        let values = [
            Position::<Two>(DVec2::new(7.0, -7.0)),
            Position(DVec2::new(8.0, -8.0)),
        ];
        let part = save_numbers(&values, &[0, 1]);
        let rows = [vec![NOT_PICKED, 2]];
        let picked = pick_column::<Position<Two>>(&mut world, &[&part], (&rows, 5));
        assert!(matches!(picked, Some(Ok(()))));
        let xs = |world: &mut World| -> Vec<f64> {
            let mut query = world.query::<&Position<Two>>();
            query.iter(world).map(|x| x.0.x).collect()
        };
        assert_eq!(xs(&mut world), [at(0).x, at(1).x, 8.0, at(3).x, at(4).x]);
        let targets = [particles[4], particles[3]];
        pick_component::<Position<Two>>(&mut world, &targets, &[&part], &[(0, 0), KEEP_ROW])
            .unwrap();
        assert_eq!(xs(&mut world), [at(0).x, at(1).x, 8.0, at(3).x, 7.0]);
        let message =
            |picked: Option<Result<(), CheckpointError>>| picked.unwrap().unwrap_err().to_string();
        let past_the_end = [vec![0, 1, 3]];
        let refused = pick_column::<Position<Two>>(&mut world, &[&part], (&past_the_end, 5));
        assert!(message(refused).contains("particle 2 of block 0 was not sent"));
        let cut = &part[..part.len() - 3];
        let refused = pick_column::<Position<Two>>(&mut world, &[cut], (&rows, 5));
        assert!(message(refused).contains("not 2 values of 2"));
        let refused = pick_column::<Position<Two>>(&mut world, &[&part[..5]], (&rows, 5));
        assert!(message(refused).contains("have no count"));
        let unknown = [&[7u8], &part[1..]].concat();
        let refused = pick_column::<Position<Two>>(&mut world, &[&unknown], (&rows, 5));
        assert!(message(refused).contains("unknown format 7"));
        let refused = pick_column::<Position<Two>>(&mut world, &[&[]], (&rows, 5));
        assert!(message(refused).contains("an empty part"));
        assert!(numbers_of::<MaterialId>(&part[1..]).is_err());
    }

    /// Each block's values go straight to the rows that pick them: rows picked from two
    /// blocks take their values, unpicked values of a block are dropped, every other row keeps
    /// its own; a picked value past a block's end, or one sent as absent, is a mismatch that
    /// names the particle and its block.
    #[test]
    fn picked_values_are_decoded_into_their_rows() {
        let mut world = tiny_world::<Two>(4, 1.0, 1e-3);
        let at = |i: usize| DVec2::new(0.1 + 0.15 * i as f64, 0.5);
        for i in 0..5 {
            spawn_particle(&mut world, at(i), DVec2::ZERO, 1.0, 1.0);
        }
        let sent = |xs: &[Option<f64>]| {
            let values: Vec<Option<Position<Two>>> = (xs.iter())
                .map(|x| x.map(|x| Position(DVec2::new(x, -x))))
                .collect();
            [&[ENCODED], &postcard::to_allocvec(&values).unwrap()[..]].concat()
        };
        let (first, second) = (
            sent(&[Some(7.0), Some(8.0)]),
            sent(&[Some(9.0), Some(10.0)]),
        );
        // Row 4 from block 0's second value, rows 1 and 3 from block 1; block 0's first value
        // picked by none.
        let rows = [vec![NOT_PICKED, 4], vec![1, 3]];
        let picked = pick_column::<Position<Two>>(&mut world, &[&first, &second], (&rows, 5));
        assert!(matches!(picked, Some(Ok(()))));
        let mut query = world.query::<&Position<Two>>();
        let xs: Vec<f64> = query.iter(&world).map(|x| x.0.x).collect();
        assert_eq!(xs, [at(0).x, 9.0, at(2).x, 10.0, 8.0]);
        let past_the_end = [vec![0, 1, 2]];
        let picked = pick_column::<Position<Two>>(&mut world, &[&first], (&past_the_end, 5));
        let message = picked.unwrap().unwrap_err().to_string();
        assert!(
            message.contains("particle 2 of block 0 was not sent"),
            "{message}"
        );
        let absent = sent(&[Some(1.0), None]);
        let picked = pick_column::<Position<Two>>(&mut world, &[&absent], (&[vec![0, 1]], 5));
        let message = picked.unwrap().unwrap_err().to_string();
        assert!(
            message.contains("particle 1 of block 0 was not sent"),
            "{message}"
        );
        assert!(pick_column::<Position<Two>>(&mut world, &[], (&[], 4)).is_none());
    }

    /// Slot `n` takes what slot `from[n]` held, through cycles of every length, with values
    /// that can be neither cloned nor defaulted.
    #[test]
    fn a_permutation_moves_each_value_once() {
        struct Opaque(u32);
        let from = [3, 0, 1, 2, 4, 6, 5];
        let mut values: Vec<Opaque> = (0..7).map(Opaque).collect();
        apply_permutation(&mut values, &from);
        let got: Vec<u32> = values.iter().map(|v| v.0).collect();
        let want: Vec<u32> = from.iter().map(|&r| r as u32).collect();
        assert_eq!(got, want);
    }
}
