//! Long runs that survive, as a user drives them from the command line: the output folder's
//! policy, checkpoints and `resume`, interruption by signals, the exit codes, and the inputs
//! that used to get through `check` and abort or hang a run.

use crate::support::{command, fractum, root, text};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Starts `fractum run SCENE --out OUT --quiet --threads 1` in the background, its stderr
/// captured.
fn start_run(scene: &str, out: &Path, stdout: Stdio) -> Child {
    command(&[
        "run",
        scene,
        "--out",
        out.to_str().unwrap(),
        "--quiet",
        "--threads",
        "1",
    ])
    .stdout(stdout)
    .stderr(Stdio::piped())
    .spawn()
    .unwrap()
}

/// A fresh temporary folder for one test.
fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("fractum-long-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Every file under `dir` with its bytes, sorted by path.
fn folder_bytes(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files = Vec::new();
    let mut pending = vec![dir.to_path_buf()];
    while let Some(folder) = pending.pop() {
        for entry in std::fs::read_dir(&folder).unwrap().flatten() {
            let path = entry.path();
            if path.is_dir() {
                pending.push(path);
            } else {
                files.push((path.clone(), std::fs::read(&path).unwrap()));
            }
        }
    }
    files.sort();
    files
}

/// A shipped scene with edits, written into `dir`.
fn edited_scene(dir: &Path, scene: &str, edits: &[(&str, &str)]) -> PathBuf {
    let mut text = std::fs::read_to_string(root().join("scenes").join(scene)).unwrap();
    for (from, to) in edits {
        assert!(text.contains(from), "{scene} has no `{from}`");
        text = text.replacen(from, to, 1);
    }
    let path = dir.join(scene);
    std::fs::write(&path, text).unwrap();
    path
}

/// `fractum run SCENE --out OUT --steps 30 --checkpoint-every 10 --quiet`.
fn run_30_steps_checkpointed(scene: &str, out: &str) -> std::process::Output {
    fractum(&[
        "run",
        scene,
        "--out",
        out,
        "--steps",
        "30",
        "--checkpoint-every",
        "10",
        "--quiet",
    ])
}

fn series_steps(dir: &Path) -> Vec<u64> {
    std::fs::read_to_string(dir.join("series.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect()
}

fn temporaries(dir: &Path) -> Vec<String> {
    ["", "frames", "checkpoints"]
        .iter()
        .filter_map(|sub| std::fs::read_dir(dir.join(sub)).ok())
        .flatten()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

#[test]
fn an_output_folder_holding_a_run_is_refused_unless_forced() {
    let dir = temp("force");
    let out = dir.join("run");
    let out_arg = out.to_str().unwrap();
    let first = fractum(&[
        "run",
        "scenes/two_disks.ron",
        "--out",
        out_arg,
        "--steps",
        "20",
        "--quiet",
    ]);
    assert!(first.status.success(), "{}", text(&first.stderr));
    let again = fractum(&[
        "run",
        "scenes/two_disks.ron",
        "--out",
        out_arg,
        "--steps",
        "20",
        "--quiet",
    ]);
    assert_eq!(again.status.code(), Some(4));
    assert!(
        text(&again.stderr).contains("holds a previous run"),
        "{}",
        text(&again.stderr)
    );
    // The first run wrote no checkpoint: resuming it is no way out, so it is not offered.
    assert!(
        !text(&again.stderr).contains("fractum resume"),
        "{}",
        text(&again.stderr)
    );
    let checkpointed = dir.join("checkpointed");
    let checkpointed_arg = checkpointed.to_str().unwrap();
    let with_checkpoint = [
        "run",
        "scenes/two_disks.ron",
        "--out",
        checkpointed_arg,
        "--steps",
        "20",
        "--checkpoint-every",
        "10",
        "--quiet",
    ];
    assert!(fractum(&with_checkpoint).status.success());
    let occupied = fractum(&with_checkpoint);
    assert_eq!(occupied.status.code(), Some(4));
    assert!(
        text(&occupied.stderr).contains(&format!("`fractum resume {checkpointed_arg}`")),
        "{}",
        text(&occupied.stderr)
    );
    // --force clears the previous run's outputs, and only those.
    std::fs::write(out.join("frames/particles_99999999.vtu"), "stale").unwrap();
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let forced = fractum(&[
        "run",
        "scenes/two_disks.ron",
        "--out",
        out_arg,
        "--steps",
        "20",
        "--quiet",
        "--force",
    ]);
    assert!(forced.status.success(), "{}", text(&forced.stderr));
    assert!(!out.join("frames/particles_99999999.vtu").exists());
    assert!(out.join("notes.txt").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_resumed_run_appends_to_its_outputs_as_if_it_had_never_stopped() {
    let dir = temp("resume");
    let (straight, split) = (dir.join("straight"), dir.join("split"));
    let scene = "scenes/two_disks_contact.ron";
    let run = |out: &Path, extra: &[&str]| {
        let mut args = vec!["run", scene, "--out", out.to_str().unwrap(), "--quiet"];
        args.extend_from_slice(extra);
        fractum(&args)
    };
    let whole = run(&straight, &["--steps", "1800"]);
    assert!(whole.status.success(), "{}", text(&whole.stderr));
    let first = run(
        &split,
        &[
            "--steps",
            "1650",
            "--checkpoint-every",
            "500",
            "--keep-checkpoints",
            "2",
        ],
    );
    assert!(first.status.success(), "{}", text(&first.stderr));
    let kept: Vec<String> = std::fs::read_dir(split.join("checkpoints"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(kept.len(), 2, "{kept:?}");
    assert!(kept.iter().all(|n| n.ends_with(".bin")));
    let resumed = fractum(&[
        "resume",
        split.to_str().unwrap(),
        "--steps",
        "1800",
        "--quiet",
    ]);
    assert!(resumed.status.success(), "{}", text(&resumed.stderr));
    assert!(
        text(&resumed.stderr).contains("resuming"),
        "{}",
        text(&resumed.stderr)
    );
    for file in [
        "series.csv",
        "particles.pvd",
        "frames/particles_00001800.vtu",
    ] {
        assert!(
            std::fs::read(straight.join(file)).unwrap() == std::fs::read(split.join(file)).unwrap(),
            "{file} differs"
        );
    }
    // The first run's forced frame at its end is not part of the continued run.
    assert!(!split.join("frames/particles_00001650.vtu").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn resume_refuses_a_changed_scene_and_a_damaged_checkpoint() {
    let dir = temp("mismatch");
    let scene = edited_scene(&dir, "two_disks.ron", &[]);
    let out = dir.join("run");
    let (scene_arg, out_arg) = (scene.to_str().unwrap(), out.to_str().unwrap());
    let first = run_30_steps_checkpointed(scene_arg, out_arg);
    assert!(first.status.success(), "{}", text(&first.stderr));
    // A resume to the step the run is at already is a usage error, and leaves every output
    // as it was (the final frame of step 30 was written after the checkpoint: a rewind would
    // delete it).
    let before = folder_bytes(&out);
    for steps in [&["--steps", "30"][..], &["--steps", "10"]] {
        let at_end = fractum(&[&["resume", out_arg, "--quiet"][..], steps].concat());
        assert_eq!(at_end.status.code(), Some(2), "{steps:?}");
        assert!(
            text(&at_end.stderr).contains("already at step 30, where --steps stops it"),
            "{}",
            text(&at_end.stderr)
        );
        assert!(
            folder_bytes(&out) == before,
            "{steps:?} changed the outputs"
        );
    }
    // So is a forced run that would take no step: the run it was to replace stays.
    let no_step = fractum(&[
        "run", scene_arg, "--out", out_arg, "--force", "--steps", "0", "--quiet",
    ]);
    assert_eq!(no_step.status.code(), Some(2), "{}", text(&no_step.stderr));
    assert!(
        folder_bytes(&out) == before,
        "run --force --steps 0 changed the outputs"
    );
    let original = std::fs::read_to_string(&scene).unwrap();
    std::fs::write(
        &scene,
        original.replace("poisson_ratio: 0.3", "poisson_ratio: 0.25"),
    )
    .unwrap();
    let changed = fractum(&["resume", out_arg, "--steps", "60", "--quiet"]);
    assert_eq!(changed.status.code(), Some(1));
    assert!(
        text(&changed.stderr).contains("changed since the checkpoint"),
        "{}",
        text(&changed.stderr)
    );
    std::fs::write(&scene, &original).unwrap();
    let newest = out.join("checkpoints/checkpoint_000000000030.bin");
    let mut bytes = std::fs::read(&newest).unwrap();
    // One bit of the particle data: it still decodes, and would resume with an altered number.
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0x01;
    std::fs::write(&newest, bytes).unwrap();
    let damaged = fractum(&["resume", out_arg, "--steps", "60", "--quiet"]);
    assert_eq!(damaged.status.code(), Some(4));
    assert!(
        text(&damaged.stderr).contains("is damaged"),
        "{}",
        text(&damaged.stderr)
    );
    let nothing = fractum(&["resume", dir.to_str().unwrap()]);
    assert_eq!(nothing.status.code(), Some(4));
    assert!(
        text(&nothing.stderr).contains("no checkpoint"),
        "{}",
        text(&nothing.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Waits until the run writing into `out` has written at least one row after step 0.
fn wait_for_steps(child: &mut Child, out: &Path) {
    let started = Instant::now();
    loop {
        let rows = std::fs::read_to_string(out.join("series.csv")).map_or(0, |t| t.lines().count());
        if rows >= 3 {
            return;
        }
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before the signal"
        );
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "the run wrote no rows"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn signal(child: &Child, name: &str) {
    let status = Command::new("kill")
        .args([&format!("-{name}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
}

#[test]
fn an_interrupted_run_finishes_its_step_writes_a_checkpoint_and_resumes() {
    let dir = temp("sigint");
    let out = dir.join("run");
    let out_arg = out.to_str().unwrap();
    let mut child = start_run("scenes/edge_cracked_panel_lme.ron", &out, Stdio::piped());
    wait_for_steps(&mut child, &out);
    signal(&child, "INT");
    let output = child.wait_with_output().unwrap();
    assert_eq!(output.status.code(), Some(130), "{}", text(&output.stderr));
    assert!(
        text(&output.stderr).contains("fractum resume"),
        "{}",
        text(&output.stderr)
    );
    let checkpoints: Vec<String> = std::fs::read_dir(out.join("checkpoints"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(checkpoints.len(), 1, "{checkpoints:?}");
    let stopped: u64 = checkpoints[0]
        .trim_start_matches("checkpoint_")
        .trim_end_matches(".bin")
        .parse()
        .unwrap();
    // The final row and frame are of the step the run stopped after.
    assert_eq!(series_steps(&out).last(), Some(&stopped));
    let pvd = std::fs::read_to_string(out.join("particles.pvd")).unwrap();
    assert!(
        pvd.contains(&format!("particles_{stopped:08}.vtu")),
        "{pvd}"
    );
    assert!(temporaries(&out).is_empty(), "{:?}", temporaries(&out));
    let target = (stopped + 25).to_string();
    let resumed = fractum(&["resume", out_arg, "--steps", &target, "--quiet"]);
    assert!(resumed.status.success(), "{}", text(&resumed.stderr));
    let steps = series_steps(&out);
    assert_eq!(steps.last(), Some(&(stopped + 25)));
    assert!(
        steps.windows(2).all(|w| w[0] < w[1]),
        "rows out of order: {steps:?}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_second_interrupt_exits_at_once() {
    let dir = temp("sigint2");
    let out = dir.join("run");
    // Steps of about a tenth of a second, so both signals land inside one step.
    let child = start_run("scenes/drop_weight_881_graded.ron", &out, Stdio::null());
    let started = Instant::now();
    while !out.join("series.csv").exists() {
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "the run never started"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    signal(&child, "INT");
    std::thread::sleep(Duration::from_millis(30));
    signal(&child, "TERM");
    let output = child.wait_with_output().unwrap();
    assert_eq!(output.status.code(), Some(131), "{}", text(&output.stderr));
    assert!(text(&output.stderr).contains("second interrupt"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn thread_counts_beyond_the_bound_are_a_usage_error() {
    let out = fractum(&["run", "scenes/two_disks.ron", "--threads", "100000000"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("--threads"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn a_run_whose_particles_all_leave_the_grid_stops_with_exit_3() {
    let dir = temp("escape");
    let scene = edited_scene(
        &dir,
        "two_disks.ron",
        &[
            ("Fixed(1.0e-3)", "Cfl(0.5)"),
            ("Uniform((0.1, 0.1))", "Uniform((-5.0, -5.0))"),
            ("Uniform((-0.1, -0.1))", "Uniform((5.0, 5.0))"),
            (
                "output: (",
                "safety: (on_leave_grid: Remove),\n    output: (",
            ),
        ],
    );
    let out = dir.join("run");
    let run = fractum(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(run.status.code(), Some(3), "{}", text(&run.stderr));
    let error = text(&run.stderr);
    assert!(
        error.contains("every particle has left the grid: 416 removed"),
        "{error}"
    );
    let series = std::fs::read_to_string(out.join("series.csv")).unwrap();
    assert!(
        !series.contains("inf") && !series.contains("NaN"),
        "{series}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A particle that leaves the grid stops the run with the particle named and the usual cures;
/// the linear tents' own cure is named because the scene uses them.
#[test]
fn a_particle_leaving_the_grid_is_reported_with_the_usual_cures() {
    let dir = temp("cures");
    let scene = edited_scene(
        &dir,
        "two_disks.ron",
        &[
            ("Fixed(1.0e-3)", "Cfl(0.5)"),
            ("Uniform((0.1, 0.1))", "Uniform((-5.0, -5.0))"),
        ],
    );
    let out = dir.join("run");
    let run = fractum(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(run.status.code(), Some(3), "{}", text(&run.stderr));
    let error = text(&run.stderr);
    assert!(
        error.contains("left the grid")
            && error.contains("`safety: (on_leave_grid: Remove)`")
            && error.contains("`basis/gimp` in place of `basis/linear`"),
        "{error}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn scenes_that_cannot_fit_in_memory_are_refused_before_anything_is_allocated() {
    let dir = temp("memory");
    let grid = edited_scene(
        &dir,
        "two_disks.ron",
        &[(
            "max: (1.0, 1.0), spacing: 0.05",
            "max: (450.0, 450.0), spacing: 0.05",
        )],
    );
    let out = command(&["check", grid.to_str().unwrap()])
        .env("FRACTUM_MEMORY_LIMIT", "1e9")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let error = text(&out.stderr);
    assert!(
        error.contains("grid nodes") && error.contains("953.7 MiB is available"),
        "{error}"
    );
    assert!(error.contains("`grid.spacing`"), "{error}");
    let particles = edited_scene(
        &dir,
        "block_compression.ron",
        &[("particles_per_cell: 2", "particles_per_cell: 16")],
    );
    let out = command(&["check", particles.to_str().unwrap()])
        .env("FRACTUM_MEMORY_LIMIT", "1e6")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    let error = text(&out.stderr);
    assert!(error.contains("particles_per_cell"), "{error}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A 3D GIMP scene of 753 571 nodes and 200 000 particles: about 1.9 GiB by its estimate,
/// more than half a gigabyte to spawn.
const GIMP_BLOCK: &str = r#"(
    title: "GIMP block",
    units: SI,
    time: (step: Cfl(0.4), end: Steps(1)),
    grid: (min: (0.0, 0.0, 0.0), max: (0.9, 0.9, 0.9), spacing: 0.01),
    materials: { "stiff": (density: 1000.0, youngs_modulus: 2.0e7, poisson_ratio: 0.25) },
    bodies: [(shape: Box(min: (0.2, 0.2, 0.2), max: (0.7, 0.7, 0.3)), material: "stiff")],
    pipeline: [
        (system: "basis/gimp"),
        (system: "predictor/newmark"),
        (system: "stress/linear_elastic"),
        (system: "corrector/newmark"),
        (system: "advection/newmark"),
    ],
)"#;

/// `fractum ARGS` under an address-space limit of `kib` KiB (`ulimit -v`, as batch systems
/// set it).
fn under_address_space_limit(kib: u64, args: &[&str]) -> Command {
    let mut command = Command::new("sh");
    command
        .arg("-c")
        .arg(format!("ulimit -v {kib} && exec \"$0\" \"$@\""))
        .arg(env!("CARGO_BIN_EXE_fractum"))
        .args(args)
        .current_dir(root());
    command
}

#[test]
fn an_address_space_limit_refuses_a_scene_instead_of_aborting_and_check_estimate_spawns_nothing() {
    let dir = temp("address-space");
    let scene = dir.join("gimp_block.ron");
    std::fs::write(&scene, GIMP_BLOCK).unwrap();
    let scene = scene.to_str().unwrap();
    // About 586 MiB of address space: the estimate is held against it, not against the
    // machine's free memory, and the scene is refused before anything is spawned.
    let out = under_address_space_limit(600_000, &["check", scene])
        .output()
        .unwrap();
    let error = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{error}");
    assert!(
        error.contains("the scene needs about 1.9 GiB")
            && error.contains("address-space limit (ulimit -v)"),
        "{error}"
    );
    // `check --estimate` with the limit to check against raised past the scene: it reports the
    // estimate from counts within the same 586 MiB, which spawning the scene would exceed.
    let out = under_address_space_limit(600_000, &["check", "--estimate", scene])
        .env("FRACTUM_MEMORY_LIMIT", "1e12")
        .output()
        .unwrap();
    let report = text(&out.stdout);
    assert!(out.status.success(), "{}{report}", text(&out.stderr));
    assert!(
        report.contains("particles  200000")
            && report.contains("basis/gimp: a support of about 27 nodes per particle")
            && report.contains("1.9 GiB  in all")
            && report.ends_with("fits\n"),
        "{report}"
    );
    // Against the limit itself it does not fit, and says so with exit 1.
    let out = under_address_space_limit(600_000, &["check", "--estimate", scene])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stdout).contains("does not fit"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_image_s_particles_are_counted_by_its_voxels_before_any_is_seeded() {
    // Cells 8 pixels wide and 8 × 8 particles per pixel: the image seeds 3 200 × 64 = 204 800
    // particles, 50 times what its box's cells would hold at 64 per cell.
    let dir = temp("image-memory");
    let picture = root().join("scenes/geometry/stiff_inclusion.png");
    let scene = edited_scene(
        &dir,
        "stiff_inclusion_image.ron",
        &[
            (
                "\"geometry/stiff_inclusion.png\"",
                &format!("{:?}", picture),
            ),
            (
                "max: (0.205, 0.1), spacing: 0.0025",
                "max: (0.22, 0.1), spacing: 0.02",
            ),
            ("particles_per_cell: 2", "particles_per_cell: 8"),
        ],
    );
    let out = command(&["check", scene.to_str().unwrap()])
        .env("FRACTUM_MEMORY_LIMIT", "2e7")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stdout));
    let error = text(&out.stderr);
    assert!(
        error.contains("`bodies[0].particles_per_cell`")
            && error.contains("up to 204800 particles of bodies[0]"),
        "{error}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_scene_saved_with_a_byte_order_mark_reads_as_without() {
    let dir = temp("bom");
    let path = dir.join("bom.ron");
    let mut bytes = vec![0xef, 0xbb, 0xbf];
    bytes.extend(std::fs::read(root().join("scenes/two_disks.ron")).unwrap());
    std::fs::write(&path, bytes).unwrap();
    let out = fractum(&["check", path.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The last `(step, time)` row of a run's series.
fn last_row(dir: &Path) -> (u64, f64) {
    let series = std::fs::read_to_string(dir.join("series.csv")).unwrap();
    let last = series.lines().last().unwrap().to_string();
    let mut cells = last.split(',');
    let step = cells.next().unwrap().parse().unwrap();
    (step, cells.next().unwrap().parse().unwrap())
}

/// `--steps` caps a run without replacing the scene's end: a plain `resume` goes on to that
/// end, whose last step is shortened to land on it exactly, and no `--steps` passes it.
#[test]
fn steps_cap_a_run_and_a_plain_resume_goes_on_to_the_scenes_end() {
    let dir = temp("cap");
    // 40.5 steps of 1 ms: the 41st is half a step.
    let scene = edited_scene(
        &dir,
        "two_disks.ron",
        &[("end: Time(3.0)", "end: Time(0.0405)")],
    );
    let out = dir.join("run");
    let (scene_arg, out_arg) = (scene.to_str().unwrap(), out.to_str().unwrap());
    let capped = run_30_steps_checkpointed(scene_arg, out_arg);
    assert!(capped.status.success(), "{}", text(&capped.stderr));
    assert_eq!(last_row(&out).0, 30);
    let resumed = fractum(&["resume", out_arg, "--checkpoint-every", "10", "--quiet"]);
    assert!(resumed.status.success(), "{}", text(&resumed.stderr));
    assert_eq!(last_row(&out), (41, 0.0405));
    // Its checkpoint at the end holds the scene's end: no cap takes the run past it.
    let past = fractum(&["resume", out_arg, "--steps", "100000", "--quiet"]);
    assert_eq!(past.status.code(), Some(2), "{}", text(&past.stderr));
    assert!(
        text(&past.stderr).contains("already at the scene's end (step 41"),
        "{}",
        text(&past.stderr)
    );
    // A fresh run with a cap beyond the end stops at the end too, on the same bytes.
    let again = dir.join("again");
    let uncapped = fractum(&[
        "run",
        scene_arg,
        "--out",
        again.to_str().unwrap(),
        "--steps",
        "100000",
        "--quiet",
    ]);
    assert!(uncapped.status.success(), "{}", text(&uncapped.stderr));
    assert!(
        std::fs::read(out.join("series.csv")).unwrap()
            == std::fs::read(again.join("series.csv")).unwrap(),
        "the capped-and-resumed run differs from the straight one"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// SCENES.md's minimal disk on the tents with update-stress-last, translating rigidly: the
/// cell-crossing term amplifies round-off at every crossing until the run creates energy and
/// stops with an inverted volume. The energy watch's warning names cell crossing, with how far
/// the particles had moved.
#[test]
fn the_energy_warning_names_cell_crossing_under_the_tents() {
    let dir = temp("crossing");
    let scene = dir.join("translating_disk.ron");
    std::fs::write(
        &scene,
        r#"(
    time: (step: Cfl(0.5), end: Time(0.2236)),
    grid: (min: (0.0, 0.0), max: (1.0, 1.0), spacing: 0.05),
    thickness: 0.1,
    materials: { "rubber": (density: 1000.0, youngs_modulus: 1.0e6, poisson_ratio: 0.3) },
    bodies: [(shape: Disk(center: (0.5, 0.7), radius: 0.2), material: "rubber",
              velocity: Uniform((1.0, -0.5)))],
    output: (csv_every: 10, vtu_every: 1000),
    pipeline: [(system: "basis/linear"), (system: "predictor/usl"),
               (system: "stress/linear_elastic"), (system: "advection/usl")],
)"#,
    )
    .unwrap();
    let out = dir.join("out");
    let run = fractum(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
        "--threads",
        "1",
    ]);
    let stderr = text(&run.stderr);
    let _ = std::fs::remove_dir_all(&dir);
    assert_ne!(run.status.code(), Some(0), "{stderr}");
    assert!(
        stderr.contains(
            "Likely cause here: cell crossing. Under basis/linear particles have moved up to"
        ),
        "{stderr}"
    );
}
