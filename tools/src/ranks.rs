//! The ranks an MPI launcher (`mpirun`, `mpiexec`, `srun`) started this process as one of, and
//! the communicator of the run.
//!
//! The engine steps a scene over ranks (`fractum_engine::run::distributed`), but the run
//! command does not yet write a distributed run's series, frames and checkpoints. A `run` or
//! `resume` started as one of several ranks is therefore refused before it reads its scene, by every
//! rank with the same exit code and the message printed once, by rank 0: otherwise each rank
//! would run the whole scene into the same output folder. One rank (`mpirun -np 1`) runs as a
//! plain process. Built with the `mpi` feature, the ranks initialise MPI and agree on the
//! refusal through the communicator ([`communicator`]); without it, the launcher's
//! environment says how many ranks there are.

use fractum_engine::communicator::{Communicator, Serial};

/// This process's rank and the run's size as the launcher's environment gives them: Open
/// MPI's `OMPI_COMM_WORLD_RANK`/`_SIZE`, or the PMI `PMI_RANK`/`PMI_SIZE` of MPICH's Hydra and
/// of Slurm's `srun --mpi=pmi2`. `None` when no launcher started the process.
pub fn launched_ranks() -> Option<(usize, usize)> {
    let read = |name: &str| std::env::var(name).ok()?.trim().parse::<usize>().ok();
    [
        ("OMPI_COMM_WORLD_RANK", "OMPI_COMM_WORLD_SIZE"),
        ("PMI_RANK", "PMI_SIZE"),
    ]
    .iter()
    .find_map(|(rank, size)| Some((read(rank)?, read(size)?)))
}

/// The communicator of this process: MPI's when the binary has the `mpi` feature and a
/// launcher started it, else [`Serial`].
pub fn communicator() -> Box<dyn Communicator> {
    #[cfg(feature = "mpi")]
    if launched_ranks().is_some()
        && let Some(mpi) = fractum_mpi::Mpi::initialize()
    {
        return Box::new(mpi);
    }
    Box::new(Serial)
}

/// Why a run of `size` ranks is refused.
pub fn distributed_refusal(size: usize) -> String {
    format!(
        "this run was started as {size} ranks (mpirun -np {size}), but `fractum run` does not \
         yet write the series, frames and checkpoints of a run over ranks: each rank would run \
         the whole scene into the same output folder. Run it as one process, with `--threads N` for the cores of one machine \
         (`fractum check --estimate SCENE` tells whether the scene fits one machine's memory)"
    )
}

/// `None` for a run of one rank or none; for several, the exit code every rank ends with, the
/// refusal printed once by rank 0.
pub fn refuse_several_ranks() -> Option<i32> {
    let (_, launched) = launched_ranks()?;
    if launched <= 1 {
        return None;
    }
    let communicator = communicator();
    let (rank, size) = if communicator.size() > 1 {
        (communicator.rank(), communicator.size())
    } else {
        launched_ranks().unwrap_or((0, launched))
    };
    if rank == 0 {
        eprintln!("error: {}", distributed_refusal(size));
    }
    Some(crate::EXIT_USAGE)
}
