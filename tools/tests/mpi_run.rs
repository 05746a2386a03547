//! `fractum` built with the `mpi` feature under a real `mpirun` on loopback (`.ci/run`
//! installs Open MPI and runs this with `--features mpi`): several ranks are refused together,
//! with the message once and no rank left waiting; one rank runs as a plain process.

mod support;

use std::process::Output;
use std::time::Duration;
use support::{root, text};

/// `mpirun -np ranks fractum args…` from the workspace root.
fn mpirun(ranks: usize, args: &[&str]) -> Output {
    let fractum = env!("CARGO_BIN_EXE_fractum");
    support::mpirun::mpirun(ranks, fractum, args, &root(), Duration::from_secs(120))
}

#[test]
fn under_mpirun_several_ranks_are_refused_together_and_one_rank_runs() {
    let out_dir = std::env::temp_dir().join(format!("fractum-mpi-run-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out_dir);
    let args = [
        "run",
        "scenes/two_disks.ron",
        "--out",
        out_dir.to_str().unwrap(),
        "--steps",
        "3",
        "--quiet",
    ];
    let several = mpirun(3, &args);
    assert_eq!(several.status.code(), Some(2), "{}", text(&several.stderr));
    let error = text(&several.stderr);
    assert_eq!(
        error.matches("started as 3 ranks").count(),
        1,
        "the refusal is printed by rank 0 alone: {error}"
    );
    assert!(!out_dir.exists());
    let one = mpirun(1, &args);
    assert!(one.status.success(), "{}", text(&one.stderr));
    assert!(
        text(&one.stdout).contains("steps 3"),
        "{}",
        text(&one.stdout)
    );
    let _ = std::fs::remove_dir_all(&out_dir);
}
