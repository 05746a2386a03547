//! Output: VTU particle frames with a PVD collection for ParaView, and the `series.csv` time
//! series. Every file is written to a temporary name and renamed, so no reader ever sees a
//! half-written file.

mod atomic;
mod csv;
mod pvd;
mod vtu;

pub use atomic::write_atomically;
pub use csv::SeriesWriter;
pub use pvd::write_pvd;
pub use vtu::{ParticleFrame, write_particle_frame};

/// What a run writes, from the scene's `output` section.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OutputPlan {
    /// VTU frame every this many steps (0: none).
    pub vtu_every: u64,
    /// CSV row every this many steps (0: first and last only).
    pub csv_every: u64,
    /// Extra CSV columns.
    pub probes: Vec<ProbeKind>,
    /// Keep the state at the start of each step to write it if the step blows up.
    pub last_good_frame: bool,
    /// Columns published by systems, after the probes.
    pub system_columns: Vec<String>,
}

/// A resolved probe.
#[derive(Clone, Debug, PartialEq)]
pub enum ProbeKind {
    /// Reaction force of boundary region `index` (named `name`).
    Reaction {
        /// Region name.
        name: String,
        /// Region index in [`crate::boundary::BoundaryConditions::regions`].
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
}

/// The columns every `series.csv` starts with.
pub const BASE_COLUMNS: [&str; 7] = [
    "step",
    "time",
    "kinetic_energy",
    "strain_energy",
    "total_energy",
    "momentum_x",
    "momentum_y",
];

impl OutputPlan {
    /// All CSV column names, base columns first, then two per probe.
    pub fn columns(&self) -> Vec<String> {
        let mut columns: Vec<String> = BASE_COLUMNS.iter().map(|c| c.to_string()).collect();
        for probe in &self.probes {
            match probe {
                ProbeKind::Reaction { name, .. } => {
                    columns.push(format!("reaction_{name}_x"));
                    columns.push(format!("reaction_{name}_y"));
                }
                ProbeKind::CentreOfMassVelocity => {
                    columns.push("com_velocity_x".into());
                    columns.push("com_velocity_y".into());
                }
                ProbeKind::Force { name, .. } => {
                    columns.push(format!("force_{name}_x"));
                    columns.push(format!("force_{name}_y"));
                }
                ProbeKind::Displacement { name, .. } => {
                    columns.push(format!("displacement_{name}_x"));
                    columns.push(format!("displacement_{name}_y"));
                }
            }
        }
        columns.extend(self.system_columns.iter().cloned());
        columns
    }
}
