//! Output: VTU particle frames with a PVD collection for ParaView, and the `series.csv` time
//! series. Every file is written to a temporary name and renamed, so no reader ever sees a
//! half-written file. A run writes its frames on a thread of their own ([`FrameWriter`]).

mod atomic;
mod csv;
mod frame_reader;
mod frames;
mod last_good;
mod probes;
mod pvd;
mod pvtu;
mod vtu;
mod writer;

pub use atomic::write_atomically;
pub use csv::SeriesWriter;
pub use fractum_engine::columns::{ColumnValues, FrameColumns};
pub use frame_reader::read_particle_frame;
pub use frames::{grid_frame, particle_frame, refill_particle_frame};
pub use last_good::LastGoodState;
pub use probes::{
    initial_energy_part, largest_energy_particle, must_be_finite, series_parts, series_row,
    series_row_from,
};
pub use pvd::{read_pvd, write_pvd};
pub use pvtu::{piece_name, read_pvtu_pieces, write_pvtu};
pub(crate) use vtu::particle_frame_file;
pub use vtu::{
    ENGINE_FRAME_FIELDS, FrameCompression, GridFrame, ParticleFrame, PieceArrays, write_grid_frame,
    write_particle_frame,
};
pub use writer::{FrameWriter, PieceIndex, WriteFailure};

use fractum_engine::dim::Dimension;

/// What a run writes, from the scene's `output` section.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputPlan {
    /// The scene's dimension: vector columns get one column per axis.
    pub dimension: Dimension,
    /// VTU frame every this many steps (0: none).
    pub vtu_every: u64,
    /// Grid-node VTU frame every this many steps (0: none).
    pub grid_every: u64,
    /// CSV row every this many steps (0: first and last only).
    pub csv_every: u64,
    /// Extra CSV columns.
    pub probes: Vec<ProbeKind>,
    /// Keep the state at the start of each step to write it if the step blows up.
    pub last_good_frame: bool,
    /// Columns published by systems, after the probes.
    pub system_columns: Vec<String>,
    /// How frame arrays are encoded.
    pub compression: FrameCompression,
    /// The arrays a particle frame carries beside positions; `None`: every one there is.
    pub frame_fields: Option<Vec<String>>,
    /// A quasi-static run's [`KINETIC_FRACTION_COLUMN`], before the energy account's columns.
    pub kinetic_fraction: bool,
}

impl OutputPlan {
    /// A plan with no frames, a CSV row every step, no probes and no system columns.
    pub fn new(dimension: Dimension) -> Self {
        Self {
            dimension,
            vtu_every: 0,
            grid_every: 0,
            csv_every: 1,
            probes: Vec::new(),
            last_good_frame: true,
            system_columns: Vec::new(),
            compression: FrameCompression::default(),
            frame_fields: None,
            kinetic_fraction: false,
        }
    }
}

/// A resolved probe.
#[derive(Clone, Debug, PartialEq)]
pub enum ProbeKind {
    /// Reaction force of boundary region `index` (named `name`).
    Reaction {
        /// Region name.
        name: String,
        /// Region index in [`fractum_engine::boundary::BoundaryConditions::regions`].
        index: usize,
    },
    /// Centre-of-mass velocity of all particles.
    CentreOfMassVelocity,
    /// Net force on body `index` (named `name`).
    Force {
        /// Body name.
        name: String,
        /// Body index.
        index: u16,
    },
    /// Displacement imposed by boundary region `index` (named `name`).
    Displacement {
        /// Region name.
        name: String,
        /// Region index.
        index: usize,
    },
    /// Displacement of one particle, optionally relative to another's.
    Track {
        /// Column name.
        name: String,
        /// The particle's id and its position at the start (x, y, z; unused axes zero);
        /// `None` when the body has no particle. By id, not entity: a distributed run moves
        /// particles between ranks and rows.
        particle: Option<(u32, [f64; 3])>,
        /// The particle whose displacement is subtracted, when the probe is relative.
        reference: Option<(u32, [f64; 3])>,
    },
}

impl ProbeKind {
    /// The column-name stem; one column per axis follows it (`reaction_base` → `reaction_base_x`).
    pub fn stem(&self) -> String {
        match self {
            ProbeKind::Reaction { name, .. } => format!("reaction_{name}"),
            ProbeKind::CentreOfMassVelocity => "com_velocity".into(),
            ProbeKind::Force { name, .. } => format!("force_{name}"),
            ProbeKind::Displacement { name, .. } => format!("displacement_{name}"),
            ProbeKind::Track { name, .. } => format!("track_{name}"),
        }
    }
}

/// The columns every `series.csv` starts with, in 2D; 3D adds `momentum_z` (see
/// [`base_columns`]).
pub const BASE_COLUMNS: [&str; 7] = [
    "step",
    "time",
    "kinetic_energy",
    "strain_energy",
    "total_energy",
    "momentum_x",
    "momentum_y",
];

/// The energy balance's columns, last in every `series.csv`: the work of the loads since the
/// start and the residual `W_ext − (E − E₀) − D` (`fractum_engine::energy`).
pub const ACCOUNT_COLUMNS: [&str; 2] = ["external_work", "energy_residual"];

/// A quasi-static run's column: the kinetic energy over the stored energy, `K / U`
/// (`fractum_engine::quasi_static`).
pub const KINETIC_FRACTION_COLUMN: &str = "kinetic_fraction";

/// One column per axis: `stem_x`, `stem_y` (and `stem_z` in 3D).
pub fn axis_columns(stem: &str, dimension: Dimension) -> Vec<String> {
    dimension
        .axes()
        .iter()
        .map(|axis| format!("{stem}_{axis}"))
        .collect()
}

/// The columns every `series.csv` of a scene of `dimension` starts with.
pub fn base_columns(dimension: Dimension) -> Vec<String> {
    let mut columns: Vec<String> = BASE_COLUMNS[..5].iter().map(|c| c.to_string()).collect();
    columns.extend(axis_columns("momentum", dimension));
    columns
}

impl OutputPlan {
    /// All CSV column names: base columns, then one per axis for each probe, then the system
    /// columns, a quasi-static run's [`KINETIC_FRACTION_COLUMN`], then the energy account's
    /// [`ACCOUNT_COLUMNS`].
    pub fn columns(&self) -> Vec<String> {
        let mut columns = base_columns(self.dimension);
        for probe in &self.probes {
            columns.extend(axis_columns(&probe.stem(), self.dimension));
        }
        columns.extend(self.system_columns.iter().cloned());
        if self.kinetic_fraction {
            columns.push(KINETIC_FRACTION_COLUMN.into());
        }
        columns.extend(ACCOUNT_COLUMNS.iter().map(|c| c.to_string()));
        columns
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_have_one_entry_per_axis() {
        let mut plan = OutputPlan::new(Dimension::Two);
        plan.probes.push(ProbeKind::Reaction {
            name: "base".into(),
            index: 0,
        });
        plan.system_columns.push("failed_particles".into());
        assert_eq!(
            plan.columns().join(","),
            "step,time,kinetic_energy,strain_energy,total_energy,momentum_x,momentum_y,\
             reaction_base_x,reaction_base_y,failed_particles,external_work,energy_residual"
        );
        plan.dimension = Dimension::Three;
        let columns = plan.columns();
        assert_eq!(columns[7], "momentum_z");
        assert_eq!(
            &columns[8..11],
            ["reaction_base_x", "reaction_base_y", "reaction_base_z"]
        );
        assert_eq!(base_columns(Dimension::Two), BASE_COLUMNS);
    }
}
