//! `fractum` built with the `mpi` feature under a real `mpirun` on loopback (`.ci/run`
//! installs Open MPI and runs this with `--features mpi`): a run over three ranks and its resume
//! write the single process's series and frames, a resume on another rank count is refused
//! once, a SIGTERM to the launcher ends the ranks with a checkpoint, and `fractum-mpi-step`
//! steps scenes over two to four ranks as the single process does.

mod support;

use std::process::Output;
use std::time::Duration;
use support::{root, text};

/// `mpirun -np ranks fractum args…` from the workspace root.
fn mpirun(ranks: usize, args: &[&str]) -> Output {
    let fractum = env!("CARGO_BIN_EXE_fractum");
    support::mpirun::mpirun(ranks, fractum, args, &root(), Duration::from_secs(120))
}

/// The header and rows of `dir/series.csv`.
fn series(dir: &std::path::Path) -> (String, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(dir.join("series.csv")).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

/// Particle ids and positions of a frame (a `.vtu`, or a `.pvtu` and its pieces), by id.
fn positions(path: &std::path::Path) -> Vec<(u32, [f64; 3])> {
    let frame = fractum_io::output::read_particle_frame(path).unwrap();
    let mut rows: Vec<_> = frame.id.into_iter().zip(frame.position).collect();
    rows.sort_by_key(|r| r.0);
    rows
}

#[test]
fn under_mpirun_three_ranks_run_and_resume_a_scene_as_the_single_process_does() {
    let scratch = std::env::temp_dir().join(format!("fractum-mpi-run-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&scratch);
    let (serial_dir, ranks_dir) = (scratch.join("serial"), scratch.join("ranks"));
    let run = |dir: &std::path::Path, steps: &str| {
        let dir = dir.to_str().unwrap().to_string();
        let scene = "scenes/two_disks_contact.ron";
        let args = [
            "run",
            scene,
            "--out",
            &dir,
            "--steps",
            steps,
            "--quiet",
            "--threads",
            "1",
        ];
        args.map(String::from)
    };
    // The disks meet at about step 1600, across the slabs.
    let serial = support::command(&run(&serial_dir, "1700").each_ref().map(String::as_str))
        .current_dir(root())
        .output()
        .unwrap();
    assert!(serial.status.success(), "{}", text(&serial.stderr));
    // Three ranks to step 900 with a checkpoint there, then resumed to 1700.
    let mut first = run(&ranks_dir, "900").to_vec();
    first.extend(["--checkpoint-every".to_string(), "900".to_string()]);
    let first: Vec<&str> = first.iter().map(String::as_str).collect();
    let ran = mpirun(3, &first);
    assert!(ran.status.success(), "{}", text(&ran.stderr));
    // The ranks watch the run's energy, not their parts of it: as one process, no warning.
    assert_eq!(
        text(&ran.stderr).matches("warning:").count(),
        text(&serial.stderr).matches("warning:").count(),
        "{}",
        text(&ran.stderr)
    );
    assert_eq!(
        text(&ran.stdout).matches("steps 900").count(),
        1,
        "rank 0 alone reports: {}",
        text(&ran.stdout)
    );
    assert!(
        text(&ran.stdout).contains("ranks 3: slabs re-cut"),
        "{}",
        text(&ran.stdout)
    );
    // Where a rank's time went, phase by phase (`fractum_io::run::rank_clock`), with the
    // fastest and the slowest rank's pipeline.
    let summary = text(&ran.stdout);
    let phases = summary
        .lines()
        .find(|l| l.starts_with("a rank's time, the mean over ranks: pipeline"))
        .unwrap_or_else(|| panic!("no phases in {summary}"));
    let spread = phases
        .split("; ranks ")
        .nth(1)
        .and_then(|rest| rest.split(" s)").next())
        .and_then(|range| range.split_once('-'))
        .map(|(least, most)| (least.parse::<f64>(), most.parse::<f64>()));
    let Some((Ok(least), Ok(most))) = spread else {
        panic!("no spread of the pipeline over the ranks in {phases}")
    };
    assert!(0.0 <= least && least <= most, "{phases}");
    assert!(
        text(&ran.stdout).contains("x the grid's;"),
        "{}",
        text(&ran.stdout)
    );
    let checkpoints = ranks_dir.join("checkpoints");
    let mut files: Vec<String> = std::fs::read_dir(&checkpoints)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    assert_eq!(
        files,
        [
            "checkpoint_000000000900.bin",
            "checkpoint_000000000900.rank0.bin",
            "checkpoint_000000000900.rank1.bin",
            "checkpoint_000000000900.rank2.bin",
        ]
    );
    let dir = ranks_dir.to_str().unwrap();
    // Another rank count, or one process, is refused with the reason, said once.
    for (ranks, words) in [
        (2, "run over 3 ranks, and this resume has 2"),
        (1, "mpirun -np 3"),
    ] {
        let refused = mpirun(ranks, &["resume", dir, "--quiet"]);
        assert_eq!(refused.status.code(), Some(2), "{}", text(&refused.stderr));
        assert_eq!(
            text(&refused.stderr).matches(words).count(),
            1,
            "{}",
            text(&refused.stderr)
        );
    }
    let resumed = mpirun(
        3,
        &[
            "resume",
            dir,
            "--steps",
            "1700",
            "--quiet",
            "--threads",
            "1",
        ],
    );
    assert!(resumed.status.success(), "{}", text(&resumed.stderr));
    // One series, equal to the single process's to 1e-12 of each column's scale (the ranks'
    // sums add in another order); step and time exactly. A column's scale is its largest
    // magnitude, but the disks' momenta cancel to round-off: the scale of the momentum is then
    // that of the sum's terms, Σ m|v| ≤ √(2MK) with M the disks' mass (2 × π 0.2² × 1000 kg per
    // metre of thickness) and K the kinetic energy, and the centre-of-mass velocity's √(2K/M).
    let ((header, reference), (rank_header, rows)) = (series(&serial_dir), series(&ranks_dir));
    assert_eq!(rank_header, header);
    assert_eq!(rows.len(), reference.len());
    let names: Vec<&str> = header.split(',').collect();
    let mass = 2.0 * std::f64::consts::PI * 0.04 * 1000.0;
    let kinetic = reference.iter().map(|r| r[2]).fold(0.0, f64::max);
    for c in 0..reference[0].len() {
        let largest = reference.iter().map(|r| r[c].abs()).fold(0.0, f64::max);
        let scale = match names[c] {
            n if n.starts_with("momentum_") => (2.0 * mass * kinetic).sqrt(),
            n if n.starts_with("com_velocity_") => (2.0 * kinetic / mass).sqrt(),
            _ => largest,
        };
        let tolerance = if c < 2 { 0.0 } else { 1e-12 * scale };
        for (a, b) in reference.iter().zip(&rows) {
            let name = names[c];
            assert!(
                (a[c] - b[c]).abs() <= tolerance,
                "{name}: {} against {}",
                b[c],
                a[c]
            );
        }
    }
    // The last frame: three pieces behind its index, the single process's particles.
    let index = ranks_dir.join("frames/particles_00001700.pvtu");
    assert_eq!(
        fractum_io::output::read_pvtu_pieces(&index).unwrap().len(),
        3
    );
    let whole = positions(&serial_dir.join("frames/particles_00001700.vtu"));
    assert_eq!(positions(&index), whole);
    let _ = std::fs::remove_dir_all(&scratch);
}

/// Starts `scenes/kalthoff_winkler_dfg_tents.ron` under `mpirun -np ranks`, sends the launcher a
/// SIGTERM once steps are under way, and resumes the run three steps further from the
/// checkpoint every rank wrote on the way out.
fn sigterm_ends_the_ranks_with_a_checkpoint_that_resumes(ranks: usize) {
    let out_dir =
        std::env::temp_dir().join(format!("fractum-mpi-term-{ranks}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out_dir);
    let mut child = std::process::Command::new("mpirun")
        .args(["--allow-run-as-root", "--oversubscribe", "-np"])
        .arg(ranks.to_string())
        .arg(env!("CARGO_BIN_EXE_fractum"))
        .args([
            "run",
            "scenes/kalthoff_winkler_dfg_tents.ron",
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
    assert_eq!(error.matches("interrupted at step").count(), 1, "{error}");
    let manifests = fractum_io::checkpoint::list_checkpoints(&out_dir);
    assert_eq!(manifests.len(), 1, "{error}");
    let files = std::fs::read_dir(out_dir.join("checkpoints"))
        .unwrap()
        .count();
    // The manifest and one piece per rank, or one file of one process.
    assert_eq!(files, if ranks == 1 { 1 } else { 1 + ranks }, "{error}");
    let target = (manifests[0].0 + 3).to_string();
    let args = [
        "resume",
        out_dir.to_str().unwrap(),
        "--steps",
        &target,
        "--quiet",
    ];
    let resumed = mpirun(ranks, &args);
    assert!(resumed.status.success(), "{}", text(&resumed.stderr));
    let series = std::fs::read_to_string(out_dir.join("series.csv")).unwrap();
    let last = series.lines().last().unwrap().split(',').next().unwrap();
    assert_eq!(last, target, "the resumed run ends at step {target}");
    let _ = std::fs::remove_dir_all(&out_dir);
}

#[test]
fn sigterm_to_mpirun_ends_a_one_rank_run_with_a_checkpoint_that_resumes() {
    sigterm_ends_the_ranks_with_a_checkpoint_that_resumes(1);
}

#[test]
fn sigterm_to_mpirun_ends_three_ranks_with_a_checkpoint_that_resumes() {
    sigterm_ends_the_ranks_with_a_checkpoint_that_resumes(3);
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
        ("scenes/kalthoff_winkler_dfg_tents.ron", "6"),
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

#[test]
fn under_mpirun_a_scene_too_large_for_one_process_runs_on_ranks_whose_parts_fit() {
    // Kalthoff–Winkler's plate needs about 160 MiB as one process and at most 61 MiB on each of
    // four ranks (`fractum check --estimate --ranks 4`), each holding the nodes its particles
    // reach (every node, as ranks held before, made the largest part 85 MiB); with 72 MB to
    // each process, one process is refused and four ranks run.
    let out_dir = std::env::temp_dir().join(format!("fractum-mpi-fit-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out_dir);
    let dir = out_dir.to_str().unwrap();
    let args = [
        "run",
        "scenes/kalthoff_winkler_dfg_tents.ron",
        "--out",
        dir,
        "--steps",
        "2",
        "--quiet",
        "--threads",
        "1",
    ];
    let limited = |ranks: usize| {
        std::process::Command::new("mpirun")
            .args(["--allow-run-as-root", "--oversubscribe", "-np"])
            .arg(ranks.to_string())
            .arg(env!("CARGO_BIN_EXE_fractum"))
            .args(args)
            .env("FRACTUM_MEMORY_LIMIT", "72e6")
            .current_dir(root())
            .output()
            .unwrap()
    };
    let alone = limited(1);
    assert_eq!(alone.status.code(), Some(1), "{}", text(&alone.stderr));
    assert!(
        text(&alone.stderr).contains("FRACTUM_MEMORY_LIMIT"),
        "{}",
        text(&alone.stderr)
    );
    let ranks = limited(4);
    assert!(ranks.status.success(), "{}", text(&ranks.stderr));
    assert!(out_dir.join("frames/particles_00000002.pvtu").exists());
    let _ = std::fs::remove_dir_all(&out_dir);
}
