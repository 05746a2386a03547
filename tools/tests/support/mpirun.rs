//! Runs a program under `mpirun` on loopback, for the MPI tests of `tools` and `tools/mpi`
//! (the latter includes this file by path: it has no `fractum` binary to build the rest of
//! `support` with).

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// `mpirun --allow-run-as-root --oversubscribe -np ranks program args…` run in `dir`, killed
/// with a failed test after `limit` if it has not ended (a rank left waiting is the failure
/// these tests look for).
pub fn mpirun(ranks: usize, program: &str, args: &[&str], dir: &Path, limit: Duration) -> Output {
    let mut child = Command::new("mpirun")
        .args(["--allow-run-as-root", "--oversubscribe", "-np"])
        .arg(ranks.to_string())
        .arg(program)
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("mpirun runs (Debian: openmpi-bin)");
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            child.kill().unwrap();
            panic!("mpirun -np {ranks} {program} {args:?} did not end in {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.wait_with_output().unwrap()
}
