//! Frame columns that algorithms register beside their components.
//!
//! A system that gives particles a component of its own (a damage gradient, a strength, a
//! crack opening) registers the frame column that shows it, with `Installer::add_frame_scalar`
//! or `Installer::add_frame_vector`, as it registers its `series.csv` columns. The engine
//! writes every registered column into each particle frame, in the order the columns were
//! registered, and names no algorithm's component itself.

use crate::components::Particle;
use bevy_ecs::prelude::{Component, Resource, With, World};
use rayon::prelude::*;
use std::sync::Arc;

/// One column's values, one per particle in storage order.
#[derive(Clone, Debug, PartialEq)]
pub enum ColumnValues {
    /// A scalar per particle.
    Scalar(Vec<f64>),
    /// A vector per particle (zero beyond the dimension).
    Vector(Vec<[f64; 3]>),
}

/// Reads a column from the world into the given values (of the column's kind), reusing their
/// allocation; `false` when some particle lacks the component.
type ColumnReader = Arc<dyn Fn(&mut World, &mut ColumnValues) -> bool + Send + Sync>;

/// The particle frame columns the installed systems registered, in registration order.
#[derive(Resource, Clone, Default)]
pub struct FrameColumns {
    columns: Vec<(String, ColumnReader)>,
}

impl FrameColumns {
    /// Registers a scalar column `name` with `value` of each particle's `C`. A name already
    /// registered (by another entry of the same law) keeps its first reader.
    pub fn scalar<C: Component>(&mut self, name: &str, value: fn(&C) -> f64) {
        self.add(name, move |world, values| {
            if !matches!(values, ColumnValues::Scalar(_)) {
                *values = ColumnValues::Scalar(Vec::new());
            }
            match values {
                ColumnValues::Scalar(out) => column_into::<C, f64>(world, value, out),
                ColumnValues::Vector(_) => false,
            }
        });
    }

    /// Registers a vector column `name` with `value` of each particle's `C` (three components,
    /// zero beyond the dimension).
    pub fn vector<C: Component>(&mut self, name: &str, value: fn(&C) -> [f64; 3]) {
        self.add(name, move |world, values| {
            if !matches!(values, ColumnValues::Vector(_)) {
                *values = ColumnValues::Vector(Vec::new());
            }
            match values {
                ColumnValues::Vector(out) => column_into::<C, [f64; 3]>(world, value, out),
                ColumnValues::Scalar(_) => false,
            }
        });
    }

    fn add(
        &mut self,
        name: &str,
        reader: impl Fn(&mut World, &mut ColumnValues) -> bool + Send + Sync + 'static,
    ) {
        if !self.columns.iter().any(|(n, _)| n == name) {
            self.columns.push((name.to_string(), Arc::new(reader)));
        }
    }

    /// Every registered column's values.
    pub fn read(&self, world: &mut World) -> Vec<(String, ColumnValues)> {
        let mut columns = Vec::new();
        self.read_into(world, &mut columns);
        columns
    }

    /// [`FrameColumns::read`] into `columns`, reusing the arrays of the values it holds under
    /// the same names (a frame refilled every step allocates nothing).
    pub fn read_into(&self, world: &mut World, columns: &mut Vec<(String, ColumnValues)>) {
        let mut previous = std::mem::take(columns);
        for (name, reader) in &self.columns {
            let mut values = match previous.iter().position(|(n, _)| n == name) {
                Some(k) => previous.swap_remove(k).1,
                None => ColumnValues::Scalar(Vec::new()),
            };
            if reader(world, &mut values) {
                columns.push((name.clone(), values));
            }
        }
    }

    /// The registered names, in order.
    pub fn names(&self) -> Vec<&str> {
        self.columns.iter().map(|(n, _)| n.as_str()).collect()
    }
}

/// `out[p] = value` of every particle's `C`, in row order, into `out`'s own allocation; `false`
/// when some particle has none. One table (the engine's rule) is read in parallel.
fn column_into<C: Component, T: Send>(
    world: &mut World,
    value: fn(&C) -> T,
    out: &mut Vec<T>,
) -> bool {
    let particles = world
        .query_filtered::<(), With<Particle>>()
        .iter(world)
        .len();
    let mut state = world.query_filtered::<&C, With<Particle>>();
    let query = state.query(world);
    match query.contiguous_iter() {
        Ok(tables) => {
            let tables: Vec<&[C]> = tables.collect();
            match tables.as_slice() {
                [table] => table.par_iter().map(value).collect_into_vec(out),
                _ => {
                    out.clear();
                    out.extend(tables.into_iter().flatten().map(value));
                }
            }
        }
        Err(_) => {
            out.clear();
            out.extend(query.iter().map(value));
        }
    }
    out.len() == particles
}
