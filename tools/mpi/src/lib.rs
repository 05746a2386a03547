//! # fractum-mpi
//!
//! The engine's [`Communicator`] over MPI: rsmpi bound to the system's MPI library (Open MPI
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

use fractum_engine::communicator::{Communicator, RankFailure};
use mpi::point_to_point::send_receive_into;
use mpi::topology::SimpleCommunicator;
use mpi::traits::{Communicator as _, CommunicatorCollectives as _, Root as _};

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

/// The world communicator of an MPI run. MPI is finalised when it is dropped.
pub struct Mpi {
    world: SimpleCommunicator,
    // Dropped last: finalises MPI.
    _universe: mpi::environment::Universe,
}

impl Mpi {
    /// Initialises MPI (once per process; `None` if it was already) and installs the panic hook
    /// that aborts every rank when one panics.
    pub fn initialize() -> Option<Mpi> {
        let universe = mpi::initialize()?;
        let world = universe.world();
        install_abort_on_panic(world.rank());
        Some(Mpi {
            world,
            _universe: universe,
        })
    }

    /// Ends every rank of the run with `code` (`MPI_Abort`).
    pub fn abort(&self, code: i32) -> ! {
        self.world.abort(code)
    }
}

/// Prints a panic with its rank, then aborts the whole run: the other ranks may be waiting for
/// this one in a collective, and would wait forever.
fn install_abort_on_panic(rank: i32) {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        eprintln!("rank {rank} panicked; ending every rank");
        default(info);
        SimpleCommunicator::world().abort(101);
    }));
}

impl Communicator for Mpi {
    fn rank(&self) -> usize {
        self.world.rank() as usize
    }

    fn size(&self) -> usize {
        self.world.size() as usize
    }

    fn all_gather(&self, values: &[f64]) -> Vec<f64> {
        let mut gathered = vec![0.0; values.len() * self.size()];
        self.world.all_gather_into(values, &mut gathered[..]);
        gathered
    }

    fn exchange(&self, outgoing: &[(usize, Vec<u8>)]) -> Vec<Vec<u8>> {
        let mut order: Vec<usize> = (0..outgoing.len()).collect();
        order.sort_by_key(|&k| outgoing[k].0);
        let mut incoming = vec![Vec::new(); outgoing.len()];
        for k in order {
            let (peer, bytes) = &outgoing[k];
            assert!(
                *peer != self.rank() && *peer < self.size(),
                "rank {} cannot exchange with rank {peer} of {}",
                self.rank(),
                self.size()
            );
            let process = self.world.process_at_rank(*peer as i32);
            let mut length = 0u64;
            send_receive_into(&(bytes.len() as u64), &process, &mut length, &process);
            let mut received = vec![0u8; length as usize];
            send_receive_into(&bytes[..], &process, &mut received[..], &process);
            incoming[k] = received;
        }
        incoming
    }

    fn agree(&self, failure: Option<&str>) -> Result<(), RankFailure> {
        let flag = i32::from(failure.is_some());
        let mut flags = vec![0i32; self.size()];
        self.world.all_gather_into(&flag, &mut flags[..]);
        let Some(failing) = flags.iter().position(|&f| f != 0) else {
            return Ok(());
        };
        let root = self.world.process_at_rank(failing as i32);
        let mine = failure.unwrap_or_default().as_bytes();
        let mut length = mine.len() as u64;
        root.broadcast_into(&mut length);
        let mut message = if self.rank() == failing {
            mine.to_vec()
        } else {
            vec![0u8; length as usize]
        };
        root.broadcast_into(&mut message[..]);
        Err(RankFailure {
            rank: failing,
            message: String::from_utf8_lossy(&message).into_owned(),
        })
    }
}
