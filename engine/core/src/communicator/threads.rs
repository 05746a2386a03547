//! Ranks as threads of one process: a [`Communicator`] over channels, so that a distributed
//! run's every step can be tested against the single process by `cargo test`, with no MPI
//! library and no launcher. Each ordered pair of ranks has its own channel; every rank makes
//! the same collective calls in the same order, so the messages of one call never meet those
//! of another.

use super::{Communicator, RankFailure};
use std::sync::mpsc::{Receiver, Sender, channel};

/// One rank of [`thread_ranks`]: move it into the thread that plays the rank.
pub struct ThreadRank {
    rank: usize,
    /// `to[r]` sends to rank `r` (`None` for this rank).
    to: Vec<Option<Sender<Vec<u8>>>>,
    /// `from[r]` receives from rank `r` (`None` for this rank).
    from: Vec<Option<Receiver<Vec<u8>>>>,
}

/// `size` ranks connected to one another, rank `k` at index `k`.
pub fn thread_ranks(size: usize) -> Vec<ThreadRank> {
    let mut to: Vec<Vec<Option<Sender<Vec<u8>>>>> = (0..size)
        .map(|_| (0..size).map(|_| None).collect())
        .collect();
    let mut from: Vec<Vec<Option<Receiver<Vec<u8>>>>> = (0..size)
        .map(|_| (0..size).map(|_| None).collect())
        .collect();
    for sender in 0..size {
        for receiver in (0..size).filter(|&r| r != sender) {
            let (tx, rx) = channel();
            to[sender][receiver] = Some(tx);
            from[receiver][sender] = Some(rx);
        }
    }
    to.into_iter()
        .zip(from)
        .enumerate()
        .map(|(rank, (to, from))| ThreadRank { rank, to, from })
        .collect()
}

impl ThreadRank {
    fn send(&self, peer: usize, bytes: Vec<u8>) {
        let sender = self.to[peer]
            .as_ref()
            .expect("no channel to this rank itself");
        // A peer that has gone (its thread panicked) shows as a failed receive below.
        let _ = sender.send(bytes);
    }

    fn receive(&self, peer: usize) -> Vec<u8> {
        let receiver = self.from[peer]
            .as_ref()
            .expect("no channel from this rank itself");
        match receiver.recv() {
            Ok(bytes) => bytes,
            Err(_) => panic!("rank {} stopped without answering rank {}", peer, self.rank),
        }
    }

    /// Every rank's `bytes`, in rank order.
    fn gather_bytes(&self, bytes: &[u8]) -> Vec<Vec<u8>> {
        for peer in (0..self.size()).filter(|&r| r != self.rank) {
            self.send(peer, bytes.to_vec());
        }
        (0..self.size())
            .map(|peer| {
                if peer == self.rank {
                    bytes.to_vec()
                } else {
                    self.receive(peer)
                }
            })
            .collect()
    }
}

impl Communicator for ThreadRank {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.to.len()
    }

    fn all_gather(&self, values: &[f64]) -> Vec<f64> {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.gather_bytes(&bytes)
            .into_iter()
            .flat_map(|b| {
                b.chunks_exact(8)
                    .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
                    .collect::<Vec<_>>()
            })
            .collect()
    }

    fn exchange(&self, outgoing: &[(usize, Vec<u8>)]) -> Vec<Vec<u8>> {
        for (peer, bytes) in outgoing {
            self.send(*peer, bytes.clone());
        }
        outgoing
            .iter()
            .map(|(peer, _)| self.receive(*peer))
            .collect()
    }

    fn agree(&self, failure: Option<&str>) -> Result<(), RankFailure> {
        // One byte for "failed", then the message.
        let mine: Vec<u8> = match failure {
            None => vec![0],
            Some(message) => std::iter::once(1).chain(message.bytes()).collect(),
        };
        let first = self
            .gather_bytes(&mine)
            .into_iter()
            .enumerate()
            .find(|(_, b)| b.first() == Some(&1));
        match first {
            None => Ok(()),
            Some((rank, bytes)) => Err(RankFailure {
                rank,
                message: String::from_utf8_lossy(&bytes[1..]).into_owned(),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn on_ranks<R: Send + 'static>(
        size: usize,
        f: impl Fn(ThreadRank) -> R + Send + Sync + Copy + 'static,
    ) -> Vec<R> {
        let threads: Vec<_> = thread_ranks(size)
            .into_iter()
            .map(|rank| std::thread::spawn(move || f(rank)))
            .collect();
        threads.into_iter().map(|t| t.join().unwrap()).collect()
    }

    #[test]
    fn thread_ranks_gather_sum_exchange_and_agree_like_separate_processes() {
        let results = on_ranks(3, |comm| {
            let r = comm.rank() as f64;
            let sum = comm.sum(&[1e16 * (r == 0.0) as u8 as f64 + 1.0, r]);
            let least = comm.min(10.0 - r);
            let right = (comm.rank() + 1) % 3;
            let left = (comm.rank() + 2) % 3;
            let got = comm.exchange(&[
                (left, vec![comm.rank() as u8; 2]),
                (right, vec![comm.rank() as u8]),
            ]);
            let failure = comm.agree((comm.rank() >= 1).then_some("bad particle 4"));
            (sum, least, got, failure)
        });
        for (rank, (sum, least, got, failure)) in results.into_iter().enumerate() {
            // Added from rank 0 up: 1e16 + 1 + 1 loses both ones.
            assert_eq!(sum, vec![1e16, 3.0]);
            assert_eq!(least, 8.0);
            let right = (rank + 1) % 3;
            let left = (rank + 2) % 3;
            // From the left neighbour its one-byte buffer (sent right), from the right its two.
            assert_eq!(got, vec![vec![left as u8], vec![right as u8; 2]]);
            let failure = failure.unwrap_err();
            assert_eq!(
                (failure.rank, failure.message.as_str()),
                (1, "bad particle 4")
            );
        }
    }
}
