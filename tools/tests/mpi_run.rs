//! `fractum` built with the `mpi` feature under a real `mpirun` on loopback (`.ci/run`
//! installs Open MPI and runs this with `--features mpi`): several ranks are refused together,
//! with the message once and no rank left waiting; one rank runs as a plain process.

mod support;

use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};
use support::{root, text};

/// `mpirun -np ranks fractum args…` from the workspace root, ended after two minutes if it
/// hangs.
fn mpirun(ranks: usize, args: &[&str]) -> Output {
    let mut child = Command::new("mpirun")
        .args(["--allow-run-as-root", "--oversubscribe", "-np"])
        .arg(ranks.to_string())
        .arg(env!("CARGO_BIN_EXE_fractum"))
        .args(args)
        .current_dir(root())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("mpirun runs (Debian: openmpi-bin)");
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(120) {
            child.kill().unwrap();
            panic!("mpirun -np {ranks} fractum {args:?} hung");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.wait_with_output().unwrap()
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
