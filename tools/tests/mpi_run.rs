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

#[test]
fn sigterm_to_mpirun_ends_a_one_rank_run_with_a_checkpoint_that_resumes() {
    let out_dir = std::env::temp_dir().join(format!("fractum-mpi-term-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out_dir);
    let mut child = std::process::Command::new("mpirun")
        .args(["--allow-run-as-root", "--oversubscribe", "-np", "1"])
        .arg(env!("CARGO_BIN_EXE_fractum"))
        .args([
            "run",
            "scenes/kalthoff_winkler_dfg.ron",
            "--quiet",
            "--threads",
            "1",
        ])
        .arg("--out")
        .arg(&out_dir)
        .current_dir(root())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Wait for steps to be under way (a few rows of the series), then signal the launcher.
    let started = std::time::Instant::now();
    while std::fs::read_to_string(out_dir.join("series.csv")).map_or(0, |t| t.lines().count()) < 3 {
        assert!(started.elapsed() < Duration::from_secs(120), "no rows");
        assert!(child.try_wait().unwrap().is_none(), "the run ended early");
        std::thread::sleep(Duration::from_millis(20));
    }
    let kill = std::process::Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let ended = child.wait_with_output().unwrap();
    let error = text(&ended.stderr);
    assert!(error.contains("interrupted at step"), "{error}");
    let checkpoints: Vec<String> = std::fs::read_dir(out_dir.join("checkpoints"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(checkpoints.len(), 1, "{error}");
    // checkpoint_000000000254.bin: the step it was written at.
    let step: u64 = checkpoints[0]
        .trim_start_matches("checkpoint_")
        .trim_end_matches(".bin")
        .parse()
        .unwrap();
    let target = (step + 3).to_string();
    let resumed = support::command(&["resume", out_dir.to_str().unwrap(), "--steps", &target])
        .output()
        .unwrap();
    assert!(resumed.status.success(), "{}", text(&resumed.stderr));
    let series = std::fs::read_to_string(out_dir.join("series.csv")).unwrap();
    let last = series.lines().last().unwrap().split(',').next().unwrap();
    assert_eq!(last, target, "the resumed run ends at step {target}");
    let _ = std::fs::remove_dir_all(&out_dir);
}
