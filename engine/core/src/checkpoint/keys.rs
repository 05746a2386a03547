//! What a checkpoint can carry: the [`State`] and [`RowState`] traits, the keys of the
//! engine's own state, and the errors of capturing and restoring it.

use crate::dim::Numbers;
use bevy_ecs::prelude::Resource;
use serde::Serialize;
use serde::de::DeserializeOwned;

/// Data a checkpoint can carry: serde both ways, safe to share between threads, and stored
/// under an explicit [`State::KEY`].
pub trait State: Serialize + DeserializeOwned + Send + Sync + 'static {
    /// The name the value is stored under: stable across builds and compilers (never derived
    /// from the type's Rust path), unique among everything a run carries. Stock keys are
    /// `particle/…`, `engine/…` and `<system>/…`; a user's crate should prefix its own.
    const KEY: &'static str;

    /// How many `f64`s a value is made of, when it is made of nothing else (a scalar, a vector,
    /// a tensor), with [`Self::write_numbers`] and [`Self::read_numbers`] taking it apart and
    /// putting it back bit for bit; `0`, the default, otherwise. A distributed run sends a
    /// carried particle component of numbers between ranks as its numbers, and encodes the
    /// others value by value (what a checkpoint file holds is encoded either way).
    const NUMBERS: usize = 0;

    /// Writes the value's [`Self::NUMBERS`] numbers into `out` (which holds as many).
    fn write_numbers(&self, out: &mut [f64]) {
        let _ = out;
    }

    /// The value [`Self::write_numbers`] wrote as `numbers`; `None` for a type that is not
    /// numbers.
    fn read_numbers(numbers: &[f64]) -> Option<Self> {
        let _ = numbers;
        None
    }
}

/// A carried resource that keeps a value per particle row (a Newton warm start, a cached
/// neighbour list): in a distributed run, each row's value goes with its particle to the ranks
/// that hold it ([`CheckpointState::row_resource`](super::CheckpointState::row_resource)). Rows are storage rows, the rows of every
/// particle slice.
pub trait RowState: Resource<Mutability = bevy_ecs::component::Mutable> + State {
    /// What one row carries to another rank (`()` for a cache that is simply rebuilt).
    type Row: Serialize + DeserializeOwned;

    /// Row `row`'s value.
    fn row(&self, row: usize) -> Self::Row;

    /// Makes `rows` the rows, in order: the particles' rows after they were rebuilt. Cached
    /// data that is not carried must be marked for rebuilding here.
    fn set_rows(&mut self, rows: Vec<Self::Row>);
}

/// Implements [`State`] for types with explicit keys: `checkpoint_keys! { MyTotal => "my/total" }`.
/// A generic type is written out by hand (`impl<D: Dim> State for MyState<D> { … }`).
#[macro_export]
macro_rules! checkpoint_keys {
    ($($ty:ty => $key:literal),* $(,)?) => {
        $(impl $crate::checkpoint::State for $ty {
            const KEY: &'static str = $key;
        })*
    };
}

/// Implements [`State`] for generic-over-`D` engine types, newtypes of `D`'s vector, matrix or
/// symmetric tensor: numbers ([`State::NUMBERS`]).
macro_rules! dim_keys {
    ($($ty:ident($inner:ident) => $key:literal),* $(,)?) => {
        $(impl<D: crate::dim::Dim> State for crate::components::$ty<D> {
            const KEY: &'static str = $key;
            const NUMBERS: usize = <D::$inner as Numbers>::COUNT;

            #[inline]
            fn write_numbers(&self, out: &mut [f64]) {
                self.0.write_numbers(out);
            }

            #[inline]
            fn read_numbers(numbers: &[f64]) -> Option<Self> {
                Some(Self(Numbers::from_numbers(numbers)))
            }
        })*
    };
}

/// Implements [`State`] for newtypes of one `f64`: numbers ([`State::NUMBERS`]).
macro_rules! scalar_keys {
    ($($ty:ty => $key:literal),* $(,)?) => {
        $(impl State for $ty {
            const KEY: &'static str = $key;
            const NUMBERS: usize = 1;

            #[inline]
            fn write_numbers(&self, out: &mut [f64]) {
                out[0] = self.0;
            }

            #[inline]
            fn read_numbers(numbers: &[f64]) -> Option<Self> {
                Some(Self(numbers[0]))
            }
        })*
    };
}

dim_keys! {
    Position(Vector) => "particle/position",
    Velocity(Vector) => "particle/velocity",
    Acceleration(Vector) => "particle/acceleration",
    DeformationGradient(Matrix) => "particle/deformation_gradient",
    Stress(Sym) => "particle/stress",
    Strain(Sym) => "particle/strain",
    ExternalForce(Vector) => "particle/external_force",
    DamageGradient(Vector) => "particle/damage_gradient",
    AffineVelocity(Matrix) => "particle/affine_velocity",
    ReferencePosition(Vector) => "particle/reference_position",
}

scalar_keys! {
    crate::components::Mass => "particle/mass",
    crate::components::Volume => "particle/volume",
    crate::components::InitialVolume => "particle/initial_volume",
    crate::components::StrainEnergyDensity => "particle/strain_energy_density",
    crate::components::WaveSpeed => "particle/wave_speed",
    crate::components::Damage => "particle/damage",
    crate::components::DamageHistory => "particle/damage_history",
    crate::components::Strength => "particle/strength",
    crate::components::CrackOpening => "particle/crack_opening",
    crate::components::ViscousPressure => "particle/viscous_pressure",
    crate::components::ViscousDissipation => "particle/viscous_dissipation",
    crate::components::DamageDissipation => "particle/damage_dissipation",
    crate::components::SurfaceFlag => "particle/surface_flag",
}

checkpoint_keys! {
    crate::components::MaterialId => "particle/material",
    crate::components::BodyId => "particle/body",
    crate::components::ContactGroup => "particle/contact_group",
    crate::loads::LoadShare => "particle/load_share",
    crate::resources::SimClock => "engine/clock",
    crate::energy::EnergyAccount => "engine/energy_account",
    crate::energy::EnergyWatch => "engine/energy_watch",
    crate::series::ForceProbeMemory => "engine/force_probes",
    crate::health::EscapedParticles => "engine/escaped_particles",
    crate::series::SeriesColumns => "engine/series_columns",
}

/// Why a checkpoint could not be written or restored.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    /// A value could not be encoded or decoded.
    #[error("cannot encode or decode {what}: {source}")]
    Codec {
        /// The component or resource.
        what: String,
        /// The cause.
        source: postcard::Error,
    },
    /// The checkpoint does not fit the world rebuilt from the scene.
    #[error("{0}")]
    Mismatch(String),
}

/// A pick ([`CheckpointState::load_picked_rows`](super::CheckpointState::load_picked_rows)) that leaves its row as it is.
pub const KEEP_ROW: (u32, u32) = (u32::MAX, u32::MAX);
