//! The ranks an MPI launcher (`mpirun`, `mpiexec`, `srun`) started this process as one of, and
//! the communicator of the run.
//!
//! `fractum run` and `fractum resume` started as one of several ranks run the scene over them
//! ([`crate::running::run_ranks`], [`crate::resuming::resume_ranks`]): built with the `mpi`
//! feature, the ranks initialise MPI and step together through its communicator
//! ([`communicator`]). A binary without the feature is refused before the scene is read, by
//! every rank with the same exit code and the message printed once, by rank 0: otherwise each
//! rank would run the whole scene into the same output folder. One rank (`mpirun -np 1`) runs
//! as a plain process. Every other command started as several ranks is refused the same way
//! ([`one_process_only`]).

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

/// The communicator of a run started as several ranks; `None` for one rank or none. Where
/// several were started but this binary cannot join them (built without the `mpi` feature),
/// the exit code every rank ends with, the reason printed once, by rank 0.
pub fn several_ranks() -> Option<Result<Box<dyn Communicator>, i32>> {
    let (launched_rank, launched) = launched_ranks()?;
    if launched <= 1 {
        return None;
    }
    let communicator = communicator();
    if communicator.size() > 1 {
        return Some(Ok(communicator));
    }
    if launched_rank == 0 {
        eprintln!(
            "error: this run was started as {launched} ranks (mpirun -np {launched}), but this \
             fractum was built without MPI: each rank would run the whole scene into the same \
             output folder. Build it with `cargo build --release -p fractum-cli --features mpi` \
             to run over ranks, or run it as one process, with `--threads N` for the cores of \
             one machine"
        );
    }
    Some(Err(crate::EXIT_USAGE))
}

/// Refuses a command other than `run` and `resume` started as several ranks: it runs as one
/// process, and every rank would run it whole, each writing the same files. The exit code every
/// rank ends with, the reason printed once, by rank 0; `None` for one rank or none.
pub fn one_process_only() -> Option<i32> {
    let (rank, launched) = launched_ranks()?;
    if launched <= 1 {
        return None;
    }
    if rank == 0 {
        eprintln!(
            "error: this command was started as {launched} ranks (mpirun -np {launched}), but \
             it runs as one process, and each rank would run it whole, writing the same files: \
             only `fractum run` and `fractum resume` divide their work over ranks. Run it \
             without mpirun"
        );
    }
    Some(crate::EXIT_USAGE)
}

/// What a distributed run of a scene left after some steps, in a form ranks can add up: the
/// owned particles, a digest of their carried state that adds over particles (so the ranks'
/// digests add to the single process's whatever the split), and the published series
/// columns (each rank's part). `fractum-mpi-step` prints it per rank.
#[derive(Clone, Debug, PartialEq)]
pub struct StepDigest {
    /// Particles owned.
    pub particles: u64,
    /// The wrapping sum over owned particles of a 64-bit FNV-1a hash of the particle's id and
    /// carried state.
    pub digest: u64,
    /// Each published series column and this rank's value of it.
    pub columns: Vec<(String, f64)>,
    /// How often the slabs were re-cut, and how far the most loaded rank was over the mean
    /// after the last step (0 in one process).
    pub rebalanced: (u64, f64),
    /// The particles this rank held (owned and ghosts) after the last step, and the bytes it
    /// sent to other ranks over the steps (0 in one process).
    pub traffic: (u64, u64),
}

/// Steps `file` `steps` times, as rank `comm.rank()` of a distributed run when `comm` is given
/// (`fractum_io::run::distributed`), as one process otherwise, and digests what this
/// process owns.
pub fn step_digest(
    file: &fractum_scene::SceneFile,
    steps: u64,
    comm: Option<&dyn Communicator>,
) -> Result<StepDigest, String> {
    use fractum_scene::{build_rank_simulation, build_simulation};
    let registry = fractum_systems::stock_registry();
    let mut built = match comm {
        Some(comm) => build_rank_simulation(file, &registry, comm.rank(), comm.size()),
        None => build_simulation(file, &registry),
    }
    .map_err(|e| e.to_string())?;
    let sim = &mut built.simulation;
    for _ in 0..steps {
        match comm {
            Some(comm) => {
                fractum_io::run::distributed::step(sim, comm).map_err(|e| e.to_string())?
            }
            None => sim.step().map_err(|e| e.to_string())?,
        }
    }
    let dimension = file.dimension().map_err(|e| e.to_string())?;
    let states = fractum_engine::with_dim!(dimension, D =>
        fractum_io::run::distributed::state_of_particles::<D>(&mut sim.world))?;
    let digest = states
        .iter()
        .map(|(id, parts)| {
            fnv1a(std::iter::once(&id.to_le_bytes()[..]).chain(parts.iter().map(Vec::as_slice)))
        })
        .fold(0u64, u64::wrapping_add);
    let columns = sim
        .world
        .get_resource::<fractum_engine::series::SeriesColumns>()
        .map(|c| {
            c.published()
                .into_iter()
                .map(|name| {
                    let value = c.value(&name).unwrap_or(f64::NAN);
                    (name, value)
                })
                .collect()
        })
        .unwrap_or_default();
    let ownership = sim
        .world
        .get_resource::<fractum_engine::decomposition::Ownership>();
    let rebalanced = ownership.map_or((0, 0.0), |o| (o.rebalances, o.imbalance));
    let traffic = ownership.map_or((0, 0), |o| (o.particles.len() as u64, o.sent_bytes));
    Ok(StepDigest {
        particles: states.len() as u64,
        digest,
        columns,
        rebalanced,
        traffic,
    })
}

/// 64-bit FNV-1a over `parts`, one after another.
fn fnv1a<'a>(parts: impl Iterator<Item = &'a [u8]>) -> u64 {
    parts.flatten().fold(0xcbf2_9ce4_8422_2325, |hash, &byte| {
        (hash ^ u64::from(byte)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_ranks_digests_add_up_to_the_single_process_digest() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../scenes/two_disks_contact.ron"
        );
        let read = || fractum_scene::SceneFile::read(std::path::Path::new(path)).unwrap();
        let serial = step_digest(&read(), 40, None).unwrap();
        let threads: Vec<_> = fractum_engine::communicator::thread_ranks(3)
            .into_iter()
            .map(|comm| {
                let file = read();
                std::thread::spawn(move || step_digest(&file, 40, Some(&comm)).unwrap())
            })
            .collect();
        let ranks: Vec<StepDigest> = threads.into_iter().map(|t| t.join().unwrap()).collect();
        let particles: u64 = ranks.iter().map(|r| r.particles).sum();
        let digest = ranks.iter().map(|r| r.digest).fold(0, u64::wrapping_add);
        assert_eq!((particles, digest), (serial.particles, serial.digest));
        assert!(
            ranks
                .iter()
                .all(|r| r.particles > 0 && r.particles < particles)
        );
    }
}
