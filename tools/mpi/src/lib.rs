//! # fractum-mpi
//!
//! The engine's [`Communicator`](fractum_engine::communicator::Communicator) over MPI: rsmpi bound to the system's MPI library (Open MPI
//! 4.1 or MPICH). This crate is the only code of Fractum that knows MPI; the `fractum` binary
//! uses it with its `mpi` feature when it runs under `mpirun` (or `srun`).
//!
//! - Gathers are `MPI_Allgather`; sums, minima and maxima are the engine's, computed from the
//!   gathered values in rank order, so they are the same bits on every rank, run to run.
//! - An exchange sends each peer the length of its buffer, then the buffer, with
//!   `MPI_Sendrecv`, peers taken in rank order on every rank: with symmetric peer lists every
//!   pair meets in the same order on both sides and nothing waits forever.
//! - `agree` gathers one flag per rank and, when any is set, broadcasts the lowest failing
//!   rank's message to every rank.
//! - A panic on any rank prints its message with the rank and calls `MPI_Abort`, which ends
//!   every rank: a rank that dies never leaves the others waiting in a collective.
//!
//! Without its `mpi` feature the crate holds only the launcher check ([`launched_by_mpi`]), so
//! that `cargo build --workspace` needs no MPI library; the `fractum` binary's `mpi` feature
//! turns this crate's on.

#[cfg(feature = "mpi")]
mod world;
#[cfg(feature = "mpi")]
pub use world::Mpi;

/// The environment variables by which MPI launchers (`mpirun` of Open MPI, Hydra of MPICH,
/// PMIx under Slurm's `srun`) tell a process it is one rank of several.
pub const LAUNCHER_VARIABLES: [&str; 4] = [
    "OMPI_COMM_WORLD_SIZE",
    "PMI_SIZE",
    "PMIX_RANK",
    "MPI_LOCALNRANKS",
];

/// Whether this process was started by an MPI launcher ([`LAUNCHER_VARIABLES`]): a plain
/// start stays serial and never initialises MPI.
pub fn launched_by_mpi() -> bool {
    LAUNCHER_VARIABLES
        .iter()
        .any(|v| std::env::var_os(v).is_some())
}
