//! The MPI communicator under `mpirun` on loopback, 1 to 4 ranks (`.ci/run` installs Open MPI
//! and runs these with `cargo test -p fractum-mpi`): reductions are the same bits on every rank
//! and equal the rank-order sum, neighbours exchange, a failure on one rank stops every rank
//! with its message, and a panic on one ends them all instead of hanging.

#[path = "../../tests/support/mpirun.rs"]
mod launch;

use std::process::Output;
use std::time::Duration;

/// `mpirun -np ranks fractum-mpi-check args…`, ended after a minute if it hangs.
fn mpirun(ranks: usize, args: &[&str]) -> Output {
    let check = env!("CARGO_BIN_EXE_fractum-mpi-check");
    let here = std::env::current_dir().unwrap();
    launch::mpirun(ranks, check, args, &here, Duration::from_secs(60))
}

fn lines(output: &Output) -> Vec<String> {
    let mut lines: Vec<String> = String::from_utf8_lossy(&output.stdout)
        .lines()
        .filter(|l| l.starts_with("rank "))
        .map(str::to_string)
        .collect();
    lines.sort();
    lines
}

/// The sum the ranks' values make added in rank order, as `fractum-mpi-check` forms them.
fn rank_order_sum(ranks: usize) -> f64 {
    (1..ranks).fold(1e16, |sum, rank| sum + (1.0 + rank as f64 * 0.1))
}

#[test]
fn every_rank_gets_the_same_reductions_and_its_neighbours_buffers() {
    for ranks in 1..=4 {
        let output = mpirun(ranks, &[]);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(output.status.success(), "{ranks} ranks: {stderr}");
        let lines = lines(&output);
        assert_eq!(lines.len(), ranks, "{lines:?} {stderr}");
        let sum = format!("sum {:016x}", rank_order_sum(ranks).to_bits());
        let greatest = 1e16;
        let least = if ranks == 1 { 1e16 } else { 1.1 };
        for (rank, line) in lines.iter().enumerate() {
            assert!(
                line.starts_with(&format!("rank {rank} of {ranks}:")),
                "{line}"
            );
            assert!(line.contains(&sum), "{line}, expected {sum}");
            assert!(
                line.contains(&format!("min {least} max {greatest}")),
                "{line}"
            );
            assert!(line.ends_with("agreed"), "{line}");
            if ranks > 1 {
                let previous = (rank + ranks - 1) % ranks;
                assert!(line.contains(&format!("{previous}->{rank}")), "{line}");
            }
        }
        // Bitwise the same run to run.
        assert_eq!(lines, self::lines(&mpirun(ranks, &[])), "{ranks} ranks");
    }
}

#[test]
fn a_failure_on_one_rank_stops_every_rank_with_its_message() {
    let output = mpirun(3, &["fail", "1"]);
    assert!(!output.status.success());
    let lines = lines(&output);
    assert_eq!(lines.len(), 3, "{lines:?}");
    for line in &lines {
        assert!(
            line.ends_with("failed: rank 1: rank 1 could not go on"),
            "{line}"
        );
    }
}

#[test]
fn a_panic_on_one_rank_ends_the_run_instead_of_hanging() {
    let output = mpirun(3, &["panic", "2"]);
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("rank 2 panicked; ending every rank"),
        "{stderr}"
    );
    assert!(lines(&output).is_empty(), "{:?}", lines(&output));
}
