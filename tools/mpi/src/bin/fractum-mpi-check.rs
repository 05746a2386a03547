//! `mpirun -np N fractum-mpi-check [fail RANK | panic RANK]`: checks that this machine's MPI
//! carries Fractum's communicator. Each rank prints one line: its rank and size, a sum over
//! ranks (its bits), the least and greatest value, what its ring neighbours sent it, and
//! whether every rank agreed. With `fail RANK` that rank reports a failure and every rank must
//! print the same one and exit 1; with `panic RANK` that rank panics and the launcher must end
//! every rank.

use fractum_engine::communicator::Communicator;
use fractum_mpi::Mpi;

fn main() {
    let Some(mpi) = Mpi::initialize() else {
        eprintln!("MPI was initialised already");
        std::process::exit(2);
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let chosen = |what: &str| -> Option<usize> {
        let at = args.iter().position(|a| a == what)?;
        args.get(at + 1)?.parse().ok()
    };
    let (rank, size) = (mpi.rank(), mpi.size());
    if chosen("panic") == Some(rank) {
        panic!("rank {rank} was asked to panic");
    }
    // Values whose sum depends on the order of addition: 1e16 then ones.
    let value = if rank == 0 {
        1e16
    } else {
        1.0 + rank as f64 * 0.1
    };
    let sum = mpi.sum(&[value])[0];
    let least = mpi.min(value);
    let greatest = mpi.max(value);
    let ring = if size > 1 {
        let next = (rank + 1) % size;
        let previous = (rank + size - 1) % size;
        let mut peers = vec![next];
        if previous != next {
            peers.push(previous);
        }
        let outgoing: Vec<(usize, Vec<u8>)> = peers
            .iter()
            .map(|&peer| (peer, format!("{rank}->{peer}").into_bytes()))
            .collect();
        let incoming = mpi.exchange(&outgoing);
        incoming
            .iter()
            .map(|bytes| String::from_utf8_lossy(bytes).into_owned())
            .collect::<Vec<_>>()
            .join(" ")
    } else {
        String::new()
    };
    let failure = (chosen("fail") == Some(rank)).then(|| format!("rank {rank} could not go on"));
    let agreed = mpi.agree(failure.as_deref());
    println!(
        "rank {rank} of {size}: sum {:016x} min {least} max {greatest} ring [{ring}] {}",
        sum.to_bits(),
        match &agreed {
            Ok(()) => "agreed".to_string(),
            Err(failure) => format!("failed: {failure}"),
        }
    );
    if agreed.is_err() {
        drop(mpi);
        std::process::exit(1);
    }
}
