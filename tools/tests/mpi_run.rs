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

/// Particles, digest and columns summed over the `rank … of …:` lines `fractum-mpi-step`
/// printed.
fn added_up(stdout: &str) -> (u64, u64, Vec<(String, f64)>) {
    let mut total = (0u64, 0u64, Vec::<(String, f64)>::new());
    for line in stdout.lines().filter(|l| l.starts_with("rank ")) {
        let words: Vec<&str> = line.split_whitespace().collect();
        let field = |name: &str| words[words.iter().position(|w| *w == name).unwrap() + 1];
        total.0 += field("particles").parse::<u64>().unwrap();
        total.1 = total
            .1
            .wrapping_add(u64::from_str_radix(field("digest"), 16).unwrap());
        let columns = words.last().unwrap().split(',').filter(|c| c.contains('='));
        for (k, column) in columns.enumerate() {
            let (name, value) = column.split_once('=').unwrap();
            let value: f64 = value.parse().unwrap();
            match total.2.get_mut(k) {
                Some(slot) => slot.1 += value,
                None => total.2.push((name.to_string(), value)),
            }
        }
    }
    total
}

#[test]
fn under_mpirun_two_to_four_ranks_step_scenes_as_the_single_process_does() {
    let program = env!("CARGO_BIN_EXE_fractum-mpi-step");
    // Disks in frictional contact meeting across the slabs, and Kalthoff–Winkler's DFG
    // pipeline on its 49 200 particles for a few steps.
    for (scene, steps) in [
        ("scenes/two_disks_contact.ron", "1800"),
        ("scenes/kalthoff_winkler_dfg.ron", "6"),
    ] {
        let serial = std::process::Command::new(program)
            .args([scene, steps, "--serial"])
            .current_dir(root())
            .output()
            .unwrap();
        assert!(serial.status.success(), "{}", text(&serial.stderr));
        let (particles, digest, columns) = added_up(&text(&serial.stdout));
        assert!(particles > 0);
        for ranks in [2, 3, 4] {
            let out = support::mpirun::mpirun(
                ranks,
                program,
                &[scene, steps],
                &root(),
                Duration::from_secs(300),
            );
            assert!(out.status.success(), "{scene}: {}", text(&out.stderr));
            let stdout = text(&out.stdout);
            assert_eq!(
                stdout.lines().filter(|l| l.starts_with("rank ")).count(),
                ranks
            );
            let (p, d, c) = added_up(&stdout);
            assert_eq!(
                (p, d),
                (particles, digest),
                "{scene}, {ranks} ranks:\n{stdout}"
            );
            for ((name, serial), (_, summed)) in columns.iter().zip(&c) {
                assert!(
                    (summed - serial).abs() <= 1e-12 * serial.abs(),
                    "{scene}, {ranks} ranks: {name} {summed} against {serial}"
                );
            }
        }
    }
}
