//! Storage rules every system relies on: all particles (and all nodes) live in one table.
//!
//! The engine creates all particles (and all nodes) with one bundle and never adds or removes
//! components per step, so each lives in exactly one storage table, and a slice index from a
//! contiguous query is a row index (for nodes, the node index). This ground-floor module holds
//! the accessor that checks that rule; it depends on nothing else in the engine.

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
