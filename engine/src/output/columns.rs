//! Frame columns that algorithms register beside their components.
//!
//! A system that gives particles a component of its own (a damage gradient, a strength, a
//! crack opening) registers the frame column that shows it, with `Installer::add_frame_scalar`
//! or `Installer::add_frame_vector`, as it registers its `series.csv` columns. The engine
//! writes every registered column into each particle frame, in the order the columns were
//! registered, and names no algorithm's component itself.

use crate::components::Particle;
use bevy_ecs::prelude::{Component, Resource, With, World};
use std::sync::Arc;

/// One column's values, one per particle in storage order.
#[derive(Clone, Debug, PartialEq)]
pub enum ColumnValues {
    /// A scalar per particle.
    Scalar(Vec<f64>),
    /// A vector per particle (zero beyond the dimension).
    Vector(Vec<[f64; 3]>),
}

/// Reads a column from the world; `None` when some particle lacks the component.
type ColumnReader = Arc<dyn Fn(&mut World) -> Option<ColumnValues> + Send + Sync>;

/// The particle frame columns the installed systems registered, in registration order.
#[derive(Resource, Clone, Default)]
pub struct FrameColumns {
    columns: Vec<(String, ColumnReader)>,
}

impl FrameColumns {
    /// Registers a scalar column `name` with `value` of each particle's `C`. A name already
    /// registered (by another entry of the same law) keeps its first reader.
    pub fn scalar<C: Component>(&mut self, name: &str, value: fn(&C) -> f64) {
        self.add(name, move |world| {
            column_of::<C, f64>(world, value).map(ColumnValues::Scalar)
        });
    }

    /// Registers a vector column `name` with `value` of each particle's `C` (three components,
    /// zero beyond the dimension).
    pub fn vector<C: Component>(&mut self, name: &str, value: fn(&C) -> [f64; 3]) {
        self.add(name, move |world| {
            column_of::<C, [f64; 3]>(world, value).map(ColumnValues::Vector)
        });
    }

    fn add(
        &mut self,
        name: &str,
        reader: impl Fn(&mut World) -> Option<ColumnValues> + Send + Sync + 'static,
    ) {
        if !self.columns.iter().any(|(n, _)| n == name) {
            self.columns.push((name.to_string(), Arc::new(reader)));
        }
    }

    /// Every registered column's values.
    pub fn read(&self, world: &mut World) -> Vec<(String, ColumnValues)> {
        self.columns
            .iter()
            .filter_map(|(name, reader)| reader(world).map(|values| (name.clone(), values)))
            .collect()
    }

    /// The registered names, in order.
    pub fn names(&self) -> Vec<&str> {
        self.columns.iter().map(|(n, _)| n.as_str()).collect()
    }
}

/// `value` of every particle's `C`, or `None` when some particle has none.
fn column_of<C: Component, T>(world: &mut World, value: fn(&C) -> T) -> Option<Vec<T>> {
    let particles = world
        .query_filtered::<(), With<Particle>>()
        .iter(world)
        .count();
    let mut query = world.query_filtered::<&C, With<Particle>>();
    let values: Vec<T> = query.iter(world).map(value).collect();
    (values.len() == particles).then_some(values)
}
