//! Storage rules every system relies on: all particles (and all nodes) live in one table.
//!
//! The engine creates all particles (and all nodes) with one bundle and never adds or removes
//! components per step, so each lives in exactly one storage table, and a slice index from a
//! contiguous query is a row index (for nodes, the node index). This ground-floor module holds
//! the accessor that checks that rule; it depends on nothing else in the engine.
//!
//! Fractum reads no change detection: nothing filters on `Changed` or `Added`, and the run's
//! health checks know which columns a stage may have written from the systems' declared access
//! ([`crate::health`]). Bevy marks every row of a contiguous mutable column changed each time
//! the column is borrowed mutably, a pass over the column's change ticks outside any parallel
//! loop: four bytes a row, on one thread, before the parallel work starts. Systems therefore take
//! their mutable columns through [`single_table_mut`], which leaves the ticks alone
//! ([`Untracked`]).

/// The slices of the one table that holds all particles (or all nodes), from a contiguous query.
///
/// The engine creates all particles (and all nodes) with one bundle and never adds or removes
/// components, so each lives in exactly one table and slice index equals row index (for nodes,
/// the node index). A second table means some code broke that rule, and continuing would
/// silently skip entities, so that is a panic naming the rule. `None` means there are no such
/// entities.
pub fn single_table<I: IntoIterator, E: std::fmt::Debug>(
    tables: Result<I, E>,
    what: &str,
) -> Option<I::Item> {
    let mut tables = tables
        .unwrap_or_else(|e| panic!("{what} components must use table storage: {e:?}"))
        .into_iter();
    let first = tables.next();
    assert!(
        tables.next().is_none(),
        "{what} are stored in more than one table: a component was added to or removed from only \
         some of them. Give every one of them the same components at creation."
    );
    first
}

/// A contiguous query item with bevy's change ticks left alone: mutable columns become plain
/// mutable slices, read-only ones stay as they are (see the module's header for why).
pub trait Untracked {
    /// The item with plain slices for its mutable columns.
    type Rows;

    /// The item's columns, without marking any row changed.
    fn untracked(self) -> Self::Rows;
}

impl<'w, T> Untracked for bevy_ecs::change_detection::ContiguousMut<'w, T> {
    type Rows = &'w mut [T];

    #[inline]
    fn untracked(self) -> &'w mut [T] {
        bevy_ecs::change_detection::ContiguousMut::bypass_change_detection_split(self).0
    }
}

impl<'w, T> Untracked for &'w [T] {
    type Rows = &'w [T];

    #[inline]
    fn untracked(self) -> &'w [T] {
        self
    }
}

impl<U: Untracked> Untracked for Option<U> {
    type Rows = Option<U::Rows>;

    #[inline]
    fn untracked(self) -> Self::Rows {
        self.map(Untracked::untracked)
    }
}

/// `Untracked` for a tuple of columns, element by element.
macro_rules! untracked_tuple {
    ($($name:ident),+) => {
        impl<$($name: Untracked),+> Untracked for ($($name,)+) {
            type Rows = ($($name::Rows,)+);

            #[inline]
            #[allow(non_snake_case)]
            fn untracked(self) -> Self::Rows {
                let ($($name,)+) = self;
                ($($name.untracked(),)+)
            }
        }
    };
}

untracked_tuple!(A);
untracked_tuple!(A, B);
untracked_tuple!(A, B, C);
untracked_tuple!(A, B, C, E);
untracked_tuple!(A, B, C, E, F);
untracked_tuple!(A, B, C, E, F, G);
untracked_tuple!(A, B, C, E, F, G, H);
untracked_tuple!(A, B, C, E, F, G, H, I);
untracked_tuple!(A, B, C, E, F, G, H, I, J);
untracked_tuple!(A, B, C, E, F, G, H, I, J, K);

/// [`single_table`] for a query with mutable columns: the one table's columns as plain slices,
/// without marking their rows changed ([`Untracked`]).
///
/// # Panics
/// As [`single_table`], when the entities are split over more than one table.
pub fn single_table_mut<I, E>(
    tables: Result<I, E>,
    what: &str,
) -> Option<<I::Item as Untracked>::Rows>
where
    I: IntoIterator,
    I::Item: Untracked,
    E: std::fmt::Debug,
{
    single_table(tables, what).map(Untracked::untracked)
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy_ecs::prelude::*;

    #[derive(Component, Debug, PartialEq)]
    struct Level(f64);

    /// Each entity's tick of last change, in entity order.
    fn changed_ticks(world: &mut World) -> Vec<bevy_ecs::change_detection::Tick> {
        let mut query = world.query::<Ref<Level>>();
        query
            .iter(world)
            .map(|level| level.last_changed())
            .collect()
    }

    #[test]
    fn single_table_mut_writes_the_rows_and_leaves_their_change_ticks() {
        let mut world = World::new();
        world.spawn_batch((0..4).map(|i| Level(i as f64)));
        let spawned = changed_ticks(&mut world);
        world.increment_change_tick();
        let mut query = world.query::<(Entity, &mut Level)>();
        let (entities, levels) =
            single_table_mut(query.contiguous_iter_mut(&mut world), "levels").unwrap();
        assert_eq!(entities.len(), 4);
        levels.iter_mut().for_each(|level| level.0 *= 2.0);
        let mut read = world.query::<&Level>();
        let values: Vec<f64> = read.iter(&world).map(|level| level.0).collect();
        assert_eq!(values, [0.0, 2.0, 4.0, 6.0]);
        assert_eq!(changed_ticks(&mut world), spawned);
        // Through bevy's own mutable borrow the same write marks every row changed: the pass
        // `single_table_mut` leaves out.
        world.increment_change_tick();
        let mut query = world.query::<&mut Level>();
        let mut levels = single_table(query.contiguous_iter_mut(&mut world), "levels").unwrap();
        levels.iter_mut().for_each(|level| level.0 += 1.0);
        assert!(
            changed_ticks(&mut world)
                .iter()
                .zip(&spawned)
                .all(|(now, then)| now != then)
        );
    }
}
