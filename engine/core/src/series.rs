//! Extra `series.csv` columns published by systems (e.g. the number of failed particles).
//!
//! A system declares its columns at install time with
//! [`crate::registry::Installer::add_series_column`], which returns the column's slot, and
//! writes the current value into that slot whenever it runs. The run loop appends the columns
//! after the scene's probes.
//!
//! Each pipeline entry gets its own slots, so two entries of one stage, each limited to its
//! own materials (say `damage/rankine` on the concrete and `damage/time_to_failure` on the
//! mortar), can both publish `dissipated_energy`: the published column is the sum of their
//! slots, the scene's total, not whichever entry ran last.

use bevy_ecs::prelude::Resource;

/// Names and current values of the system-published columns, one slot per declaring entry.
#[derive(Resource, Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SeriesColumns {
    /// Column name of each slot, in the order the slots were declared.
    pub names: Vec<String>,
    /// Current value of each slot.
    pub values: Vec<f64>,
    /// The pipeline entry that declared each slot (`None` outside a scene, in tests).
    pub owners: Vec<Option<usize>>,
    /// Whether each slot is a sum over the particles and nodes a rank owns
    /// ([`crate::decomposition::Ownership`]; all of them in one process), so that a
    /// distributed run's column is the sum of its ranks' slots.
    #[serde(default)]
    pub owned_sums: Vec<bool>,
}

impl SeriesColumns {
    /// Declares a column with no owning entry (or finds it) and returns its slot.
    pub fn declare(&mut self, name: &str) -> usize {
        self.declare_for(None, name)
    }

    /// Declares column `name` for pipeline entry `owner` (or finds the slot that entry
    /// declared already) and returns its slot.
    pub fn declare_for(&mut self, owner: Option<usize>, name: &str) -> usize {
        if let Some(i) =
            (0..self.names.len()).find(|&i| self.names[i] == name && self.owners[i] == owner)
        {
            return i;
        }
        self.names.push(name.to_string());
        self.values.push(0.0);
        self.owners.push(owner);
        self.owned_sums.push(false);
        self.names.len() - 1
    }

    /// The first column some slot of which is not a sum over owned particles and nodes: one a
    /// distributed run cannot add up over its ranks.
    pub fn not_summed_over_ranks(&self) -> Option<&str> {
        (0..self.names.len())
            .find(|&i| !self.owned_sums.get(i).copied().unwrap_or(false))
            .map(|i| self.names[i].as_str())
    }

    /// The published column names: each once, in the order first declared.
    pub fn published(&self) -> Vec<String> {
        let mut names: Vec<String> = Vec::new();
        for name in &self.names {
            if !names.contains(name) {
                names.push(name.clone());
            }
        }
        names
    }

    /// The published value of column `name`, the sum of its slots (in declaration order);
    /// `None` when no slot has that name.
    pub fn value(&self, name: &str) -> Option<f64> {
        let mut slots = (0..self.names.len()).filter(|&i| self.names[i] == name);
        let first = slots.next()?;
        Some(slots.fold(self.values[first], |sum, i| sum + self.values[i]))
    }
}

/// What the `Force` probes remember between series rows, per probe slot.
#[derive(Resource, Default, Debug, serde::Serialize, serde::Deserialize)]
pub struct ForceProbeMemory(Vec<Option<ForceProbeRow>>);

/// One `Force` probe's last row.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
struct ForceProbeRow {
    time: f64,
    momentum: [f64; 3],
    reported: Option<[f64; 3]>,
}

impl ForceProbeMemory {
    /// The mean net force `(P − P₀)/(t − t₀)` on a body over the interval since the previous
    /// row, from its momentum `P` now; `None` at the first row (no interval yet, reported as
    /// zero). A second row at the same time repeats the first row's value.
    pub fn mean_force(&mut self, slot: usize, time: f64, momentum: [f64; 3]) -> Option<[f64; 3]> {
        if self.0.len() <= slot {
            self.0.resize(slot + 1, None);
        }
        let force = match self.0[slot] {
            Some(row) if row.time == time => return row.reported,
            Some(row) => Some(std::array::from_fn(|a| {
                (momentum[a] - row.momentum[a]) / (time - row.time)
            })),
            None => None,
        };
        self.0[slot] = Some(ForceProbeRow {
            time,
            momentum,
            reported: force,
        });
        force
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_publishing_one_column_are_summed_and_listed_once() {
        let mut columns = SeriesColumns::default();
        let failed_a = columns.declare_for(Some(3), "failed_particles");
        let energy_a = columns.declare_for(Some(3), "dissipated_energy");
        let failed_b = columns.declare_for(Some(4), "failed_particles");
        assert_ne!(failed_a, failed_b);
        assert_eq!(columns.declare_for(Some(3), "failed_particles"), failed_a);
        columns.values[failed_a] = 2.0;
        columns.values[failed_b] = 5.0;
        columns.values[energy_a] = 0.25;
        assert_eq!(
            columns.published(),
            ["failed_particles", "dissipated_energy"]
        );
        assert_eq!(columns.value("failed_particles"), Some(7.0));
        assert_eq!(columns.value("dissipated_energy"), Some(0.25));
        assert_eq!(columns.value("damaged_particles"), None);
    }

    #[test]
    fn a_column_declared_without_an_entry_is_one_slot() {
        let mut columns = SeriesColumns::default();
        assert_eq!(columns.declare("failed_particles"), 0);
        assert_eq!(columns.declare("failed_particles"), 0);
        columns.values[0] = -0.0;
        assert_eq!(
            columns.value("failed_particles").unwrap().to_bits(),
            (-0.0f64).to_bits()
        );
    }
}
