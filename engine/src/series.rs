//! Extra `series.csv` columns published by systems (e.g. the number of failed particles).
//!
//! A system declares its columns at install time with
//! [`crate::registry::Installer::add_series_column`], which returns the column's slot, and
//! writes the current value into that slot whenever it runs. The run loop appends the columns
//! after the scene's probes.

use bevy_ecs::prelude::Resource;

/// Names and current values of the system-published columns.
#[derive(Resource, Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SeriesColumns {
    /// Column names, in the order they were declared.
    pub names: Vec<String>,
    /// Current values, one per name.
    pub values: Vec<f64>,
}

impl SeriesColumns {
    /// Declares a column (or finds it, if declared already) and returns its slot.
    pub fn declare(&mut self, name: &str) -> usize {
        if let Some(i) = self.names.iter().position(|n| n == name) {
            return i;
        }
        self.names.push(name.to_string());
        self.values.push(0.0);
        self.names.len() - 1
    }
}
