//! What the engine needs from the processes of a distributed run: who it is (`rank` of
//! `size`), reductions whose result is the same bits on every rank and every run, a neighbour
//! exchange of byte buffers, and agreement on a failure so that no rank waits on one that has
//! stopped.
//!
//! [`Serial`] is the one-process implementation every run uses without MPI. The MPI one lives
//! in its own crate (`tools/mpi`, the `fractum` binary's `mpi` feature), the only code that
//! knows MPI: the engine, the systems and their tests build and run without an MPI library.
//!
//! Reductions are defined as the values of every rank gathered in rank order and combined in
//! that order on every rank, not as MPI's own reductions, whose order of addition the standard
//! leaves to the implementation: a sum is then the same bits on every rank, run to run.

/// A failure one rank met and every rank agreed on ([`Communicator::agree`]): the first
/// failing rank, by rank order, and its message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RankFailure {
    /// The failing rank.
    pub rank: usize,
    /// What it reported.
    pub message: String,
}

impl std::fmt::Display for RankFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "rank {}: {}", self.rank, self.message)
    }
}

impl std::error::Error for RankFailure {}

/// The processes of a run, as the engine sees them. Every rank must make the same collective
/// calls in the same order ([`Communicator::all_gather`], [`Communicator::exchange`],
/// [`Communicator::agree`] and what is built on them). Not `Send`: an MPI communicator is a
/// handle the library ties to the thread that made it, so the run loop, not the systems' worker
/// threads, talks to other ranks.
pub trait Communicator {
    /// This process's rank, `0..size`.
    fn rank(&self) -> usize;

    /// How many ranks the run has.
    fn size(&self) -> usize;

    /// Every rank's `values`, rank after rank, on every rank. Each rank gives the same count.
    fn all_gather(&self, values: &[f64]) -> Vec<f64>;

    /// Sends `outgoing[k].1` to rank `outgoing[k].0` and returns what each of those ranks sent
    /// back, in the order of `outgoing`. Exchanges are symmetric: a rank lists a peer exactly
    /// when the peer lists it (a buffer may be empty), and no rank lists itself.
    fn exchange(&self, outgoing: &[(usize, Vec<u8>)]) -> Vec<Vec<u8>>;

    /// Whether every rank got through a section: each rank passes its own failure, if any, and
    /// every rank returns the same answer, the failure of the lowest failing rank. Called at
    /// the same point by every rank, so that a failure on one stops all of them together.
    fn agree(&self, failure: Option<&str>) -> Result<(), RankFailure>;

    /// The sums over ranks of each of `values`, added in rank order: the same bits on every
    /// rank, run to run.
    fn sum(&self, values: &[f64]) -> Vec<f64> {
        let gathered = self.all_gather(values);
        sum_in_rank_order(&gathered, values.len())
    }

    /// The least of `value` over ranks (exact in any order).
    fn min(&self, value: f64) -> f64 {
        self.all_gather(&[value]).into_iter().fold(value, f64::min)
    }

    /// The greatest of `value` over ranks (exact in any order).
    fn max(&self, value: f64) -> f64 {
        self.all_gather(&[value]).into_iter().fold(value, f64::max)
    }
}

/// Column sums of `gathered`, rows of `width` values rank after rank, each column added from
/// rank 0 up, starting from rank 0's value (so one rank's sum is its value, bit for bit).
pub fn sum_in_rank_order(gathered: &[f64], width: usize) -> Vec<f64> {
    if width == 0 {
        return Vec::new();
    }
    let mut rows = gathered.chunks_exact(width);
    let Some(first) = rows.next() else {
        return vec![0.0; width];
    };
    let mut sums = first.to_vec();
    for row in rows {
        for (s, v) in sums.iter_mut().zip(row) {
            *s += v;
        }
    }
    sums
}

mod threads;
pub use threads::{ThreadRank, thread_ranks};

/// The one-process communicator: rank 0 of 1. A gather returns the values, an exchange has no
/// peer, and a failure is this rank's own.
#[derive(Clone, Copy, Debug, Default)]
pub struct Serial;

impl Communicator for Serial {
    fn rank(&self) -> usize {
        0
    }

    fn size(&self) -> usize {
        1
    }

    fn all_gather(&self, values: &[f64]) -> Vec<f64> {
        values.to_vec()
    }

    fn exchange(&self, outgoing: &[(usize, Vec<u8>)]) -> Vec<Vec<u8>> {
        assert!(
            outgoing.is_empty(),
            "a one-process run has no rank to exchange with"
        );
        Vec::new()
    }

    fn agree(&self, failure: Option<&str>) -> Result<(), RankFailure> {
        match failure {
            None => Ok(()),
            Some(message) => Err(RankFailure {
                rank: 0,
                message: message.to_string(),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_serial_run_is_rank_0_of_1_and_its_reductions_are_its_values() {
        let one = Serial;
        assert_eq!((one.rank(), one.size()), (0, 1));
        assert_eq!(one.sum(&[0.1, 0.2]), vec![0.1, 0.2]);
        assert_eq!(one.min(-3.0), -3.0);
        assert_eq!(one.max(f64::INFINITY), f64::INFINITY);
        assert!(one.exchange(&[]).is_empty());
        assert_eq!(one.agree(None), Ok(()));
        let failure = one
            .agree(Some("step 3, stage stress: particle 7"))
            .unwrap_err();
        assert_eq!(
            failure.to_string(),
            "rank 0: step 3, stage stress: particle 7"
        );
    }

    #[test]
    fn sums_add_in_rank_order_from_rank_0() {
        // Three ranks of two values: (1e16 + 1) + 1 loses both ones; the order is rank order.
        let gathered = [1e16, 1.0, 1.0, 2.0, 1.0, 3.0];
        assert_eq!(sum_in_rank_order(&gathered, 2), vec![1e16, 6.0]);
        assert_eq!(sum_in_rank_order(&[], 2), vec![0.0, 0.0]);
        assert!(sum_in_rank_order(&[], 0).is_empty());
        assert_eq!(
            sum_in_rank_order(&[-0.0], 1)[0].to_bits(),
            (-0.0f64).to_bits()
        );
    }
}
