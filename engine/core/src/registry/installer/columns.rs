//! Output columns a system fills: `series.csv` columns and frame columns.

use super::Installer;
use crate::series::SeriesColumns;
use bevy_ecs::prelude::Component;

impl Installer<'_> {
    /// Declares a `series.csv` column this system will fill, returning its slot in
    /// [`SeriesColumns::values`]. The slot is this entry's own: another entry publishing the
    /// same column (for other materials) adds to it.
    pub fn add_series_column(&mut self, name: &str) -> usize {
        let entry = self.entry;
        self.world
            .get_resource_or_init::<SeriesColumns>()
            .declare_for(entry, name)
    }

    /// [`Installer::add_series_column`] for a column whose value is a sum over the particles
    /// and nodes this rank owns (`Option<Res<Ownership>>` in the system; every one in a single
    /// process), accumulated or not: a distributed run publishes the sum of its ranks' values.
    /// A column declared with `add_series_column` keeps the pipeline to one process.
    pub fn add_owned_sum_column(&mut self, name: &str) -> usize {
        let slot = self.add_series_column(name);
        let mut columns = self.world.resource_mut::<SeriesColumns>();
        columns.owned_sums.resize(slot + 1, false);
        columns.owned_sums[slot] = true;
        slot
    }

    /// Registers a per-particle scalar column of the VTU frames, `value` of each particle's
    /// `C` (a component this system added), e.g.
    /// `installer.add_frame_scalar::<CrackOpening>("crack_opening", |w| w.0)`. A column name
    /// registered before keeps its first reader. Write NaN where the law defines no value.
    pub fn add_frame_scalar<C: Component>(&mut self, name: &str, value: fn(&C) -> f64) {
        self.world
            .get_resource_or_init::<crate::columns::FrameColumns>()
            .scalar(name, value);
    }

    /// Registers a per-particle vector column of the VTU frames (three components, zero beyond
    /// the dimension), `value` of each particle's `C`.
    pub fn add_frame_vector<C: Component>(&mut self, name: &str, value: fn(&C) -> [f64; 3]) {
        self.world
            .get_resource_or_init::<crate::columns::FrameColumns>()
            .vector(name, value);
    }
}
