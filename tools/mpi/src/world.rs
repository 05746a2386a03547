//! The world communicator over rsmpi (the crate's `mpi` feature).

use fractum_engine::communicator::{Communicator, RankFailure};
use mpi::point_to_point::send_receive_into;
use mpi::topology::SimpleCommunicator;
use mpi::traits::{Communicator as _, CommunicatorCollectives as _, Root as _};

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
