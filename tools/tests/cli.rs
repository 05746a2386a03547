//! The `fractum` binary as a user runs it: exit codes, messages, and files written.

use crate::support::{command, fractum, root, text};

#[test]
fn systems_lists_every_stock_system_with_its_stage() {
    let out = fractum(&["systems"]);
    assert!(out.status.success());
    let listing = text(&out.stdout);
    for registration in fractum_systems::ALL {
        assert!(listing.contains(registration.name), "{listing}");
    }
    assert!(listing.contains("[basis]") && listing.contains("[advection]"));
    assert!(
        listing.contains("min_node_mass: f64 (default 0.0)"),
        "{listing}"
    );
}

#[test]
fn check_summarises_a_valid_scene() {
    let out = fractum(&["check", "scenes/two_disks.ron"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let summary = text(&out.stdout);
    assert!(summary.contains("particles  416"), "{summary}");
    assert!(summary.contains("441 nodes"), "{summary}");
    assert!(summary.contains("basis      basis/linear"), "{summary}");
    assert!(summary.trim_end().ends_with("ok"));
}

#[test]
fn check_splits_a_body_of_several_materials_by_material() {
    // The picture's two grey windows make one body of epoxy and steel: 2 × 2 particles in each
    // of 3 200 pixels, 208 of them steel.
    let out = fractum(&["check", "scenes/stiff_inclusion_image.ron"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let summary = text(&out.stdout);
    assert!(
        summary.contains("particles  12800 (specimen: 12800 = 11968 epoxy + 832 steel)"),
        "{summary}"
    );
}

#[test]
fn check_gives_a_graded_grid_its_range_of_cell_widths() {
    let out = fractum(&["check", "scenes/bar_vibration_graded.ron"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let summary = text(&out.stdout);
    // 48 cells of 0.25 and 15 of 1 along x, one of 1 across.
    assert!(
        summary.contains("63 x 1 cells, graded, h = 0.25 to 1 m, 128 nodes"),
        "{summary}"
    );
}

#[test]
fn check_summarises_a_3d_scene_with_its_dimension() {
    let out = fractum(&["check", "scenes/two_spheres.ron"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let summary = text(&out.stdout);
    assert!(summary.contains("dimension  3D\n"), "{summary}");
    assert!(
        summary.contains("20 x 20 x 20 cells, h = 0.05 m, 9261 nodes, box (0, 0, 0) to (1, 1, 1)"),
        "{summary}"
    );
    assert!(summary.contains("momentum_z,com_velocity_x,com_velocity_y,com_velocity_z"));
    let two = text(&fractum(&["check", "scenes/drop_weight_881.ron"]).stdout);
    assert!(
        two.contains("dimension  2D plane strain, thickness 0.1 m"),
        "{two}"
    );
}

#[test]
fn check_rejects_a_bad_scene_with_its_location_and_exit_code_1() {
    let out = fractum(&["check", "tests/bad_scenes/unknown_material.ron"]);
    assert_eq!(out.status.code(), Some(1));
    let error = text(&out.stderr);
    assert!(
        error.starts_with(
            "error: tests/bad_scenes/unknown_material.ron:9:72: `bodies[0].material`:"
        ),
        "{error}"
    );
    assert!(
        !error.contains("panicked") && !error.contains("backtrace"),
        "{error}"
    );
}

#[test]
fn a_missing_scene_file_is_reported_not_panicked() {
    let out = fractum(&["check", "scenes/no_such_scene.ron"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out.stderr).contains("cannot read the scene file"));
}

#[test]
fn run_writes_frames_collection_and_series_and_prints_a_summary() {
    let out_dir = std::env::temp_dir().join(format!("fractum-cli-run-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out_dir);
    let out = fractum(&[
        "run",
        "scenes/block_compression.ron",
        "--out",
        out_dir.to_str().unwrap(),
        "--steps",
        "60",
        "--threads",
        "2",
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let summary = text(&out.stdout);
    assert!(
        summary.contains("steps 60") && summary.contains("particles 400"),
        "{summary}"
    );
    assert!(
        summary.contains("particle-steps/s")
            && summary.contains("threads 1 (2 asked: a scene this small steps faster on one)"),
        "{summary}"
    );
    let csv = std::fs::read_to_string(out_dir.join("series.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    assert_eq!(
        header,
        "step,time,kinetic_energy,strain_energy,total_energy,momentum_x,momentum_y,\
         reaction_base_x,reaction_base_y,reaction_top_x,reaction_top_y,external_work,\
         energy_residual"
    );
    // Rows at steps 0, 5, ..., 60.
    assert_eq!(csv.lines().count(), 1 + 13);
    for frame in [
        "particles_00000000.vtu",
        "particles_00000050.vtu",
        "particles_00000060.vtu",
    ] {
        assert!(out_dir.join("frames").join(frame).is_file(), "{frame}");
    }
    assert!(out_dir.join("particles.pvd").is_file());
    let leftovers: Vec<_> = std::fs::read_dir(&out_dir)
        .unwrap()
        .chain(std::fs::read_dir(out_dir.join("frames")).unwrap())
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(
        leftovers.is_empty(),
        "temporary files left behind: {leftovers:?}"
    );
    std::fs::remove_dir_all(&out_dir).unwrap();
}

#[test]
fn bad_usage_exits_with_2() {
    let out = fractum(&["run"]);
    assert_eq!(out.status.code(), Some(2));
}

/// `grid_every` writes grid-node frames with each velocity field's key, mass, velocity and
/// normal, and their collection `grid.pvd`.
#[test]
fn run_writes_grid_frames_with_the_velocity_fields() {
    let out_dir = std::env::temp_dir().join(format!("fractum-cli-grid-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out_dir);
    // The disks share grid nodes from t = 1.13 s (step 1127).
    let out = fractum(&[
        "run",
        "scenes/two_disks_contact.ron",
        "--out",
        out_dir.to_str().unwrap(),
        "--steps",
        "1300",
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let pvd = std::fs::read_to_string(out_dir.join("grid.pvd")).unwrap();
    assert!(pvd.contains("frames/grid_00001300.vtu"), "{pvd}");
    let frame = std::fs::read_to_string(out_dir.join("frames/grid_00001300.vtu")).unwrap();
    for array in [
        "\"index\"",
        "\"fields\"",
        "\"key_1\"",
        "\"mass_1\"",
        "\"velocity_1\"",
        "\"normal_1\"",
    ] {
        assert!(frame.contains(array), "{array} missing");
    }
    let _ = std::fs::remove_dir_all(&out_dir);
}

#[test]
fn fragments_finds_the_two_halves_of_a_bar_broken_by_a_rankine_band() {
    let out_dir =
        std::env::temp_dir().join(format!("fractum-cli-fragments-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out_dir);
    // The bar 2 cm thick: the frames record it, so the spacing (0.025 m) and the link (1.5
    // spacings) come out right without `--thickness`.
    std::fs::create_dir_all(&out_dir).unwrap();
    let scene = std::fs::read_to_string(root().join("scenes/tension_rankine.ron")).unwrap();
    let thin = scene.replacen("    title:", "    thickness: 0.02,\n    title:", 1);
    assert_ne!(thin, scene);
    let scene_path = out_dir.join("thin_bar.ron");
    std::fs::write(&scene_path, thin).unwrap();
    let run_dir = out_dir.join("run");
    let dir = run_dir.to_str().unwrap();
    let run = fractum(&["run", scene_path.to_str().unwrap(), "--out", dir, "--quiet"]);
    assert!(run.status.success(), "{}", text(&run.stderr));
    // The band has failed by 2.5 ms: the left and the right piece, 20 × 8 = 160 and 18 × 8 = 144
    // particles (the band's 16 failed ones are in neither).
    let out = fractum(&["fragments", dir, "--time", "4.0e-3"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let summary = text(&out.stdout);
    assert!(summary.contains("2 fragments"), "{summary}");
    let link: f64 = summary
        .split("link ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|value| value.parse().ok())
        .unwrap_or_else(|| panic!("no link in {summary}"));
    // Current volumes: the stretched bar's spacing is a little above 0.025 m.
    assert!((link / 0.0375 - 1.0).abs() < 1e-3, "{summary}");
    let table = std::fs::read_to_string(run_dir.join("fragments.csv")).unwrap();
    let particles: Vec<usize> = table
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    assert_eq!(particles, vec![160, 144]);
    assert!(run_dir.join("fragment_sizes.csv").exists());
    assert!(run_dir.join("fragment_sizes.png").exists());
    // A folder that holds no run is an error with exit code 4, not a panic.
    let missing = fractum(&["fragments", "scenes"]);
    assert_eq!(missing.status.code(), Some(4));
    assert!(text(&missing.stderr).contains("particles.pvd"));
    let _ = std::fs::remove_dir_all(&out_dir);
}

#[test]
fn crack_follows_the_tip_from_the_notch_and_compares_its_speed_with_rayleigh() {
    let out_dir = std::env::temp_dir().join(format!("fractum-cli-crack-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out_dir);
    let dir = out_dir.to_str().unwrap();
    let run = fractum(&[
        "run",
        "scenes/time_to_failure_strip.ron",
        "--out",
        dir,
        "--quiet",
    ]);
    assert!(run.status.success(), "{}", text(&run.stderr));
    let scene = "scenes/time_to_failure_strip.ron";
    let out = fractum(&["crack", dir, "--notch", "0.1,0.2", "--scene", scene]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report = text(&out.stdout);
    assert!(report.contains("initial angle"), "{report}");
    assert!(
        report.contains("Rayleigh speed of strip: 588 m/s"),
        "{report}"
    );
    // The crack crosses the strip (0.9 m from the notch tip), below the Rayleigh speed.
    let table = std::fs::read_to_string(out_dir.join("crack.csv")).unwrap();
    let rows: Vec<Vec<f64>> = table
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let last = rows.last().unwrap();
    assert!(last[1] > 0.95 && last[4] > 0.85, "{last:?}");
    let lengths: Vec<f64> = rows.iter().map(|r| r[4]).collect();
    assert!(lengths.windows(2).all(|w| w[1] >= w[0]), "{lengths:?}");
    let fastest = rows
        .windows(2)
        .map(|w| (w[1][4] - w[0][4]) / (w[1][0] - w[0][0]))
        .fold(0.0, f64::max);
    assert!(fastest < 588.0, "{fastest} m/s");
    // Over a window of the growth: the least-squares speed there, which a crack that never
    // outruns 588 m/s between frames cannot exceed.
    let (from, to) = (rows[rows.len() / 4][0], rows[3 * rows.len() / 4][0]);
    let window = format!("{from},{to}");
    let out = fractum(&["crack", dir, "--notch", "0.1,0.2", "--window", &window]);
    let report = text(&out.stdout);
    let line = report
        .lines()
        .find(|l| l.contains("s (least squares over the frames in the window)"))
        .unwrap_or_else(|| panic!("{report}"));
    let speed: f64 = line.split_whitespace().nth(2).unwrap().parse().unwrap();
    assert!(speed > 0.0 && speed <= fastest, "{line}");
    let backwards = fractum(&["crack", dir, "--notch", "0.1,0.2", "--window", "2,1"]);
    assert_eq!(backwards.status.code(), Some(4));
    assert!(text(&backwards.stderr).contains("TO must come after FROM"));
    let bad = fractum(&["crack", dir, "--notch", "0.1"]);
    assert_eq!(bad.status.code(), Some(4));
    assert!(text(&bad.stderr).contains("--notch takes 2 or 3"));
    let _ = std::fs::remove_dir_all(&out_dir);
}

/// A reader that stops reading (`fractum systems | head -1`) is not a crash.
#[test]
fn a_closed_stdout_is_not_a_panic() {
    let mut child = command(&["systems"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("the fractum binary runs");
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
}

/// A DFG run in which no particle failed says that its partition never split a node; one that
/// starts from a seeded crack does not.
#[test]
fn a_run_whose_partition_never_split_says_so() {
    let base = std::env::temp_dir().join(format!("fractum-cli-split-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    // Three steps of a scene, its summary.
    let summary = |scene: &str, out: &str| {
        let dir = base.join(out);
        let run = fractum(&["run", scene, "--steps", "3", "--out", dir.to_str().unwrap()]);
        assert!(run.status.success(), "{}", text(&run.stderr));
        text(&run.stdout)
    };
    let intact = summary("scenes/brazilian_dfg.ron", "intact");
    assert!(intact.contains("no node was split in this run"), "{intact}");
    let cracked = summary("scenes/edge_cracked_panel_lme.ron", "cracked");
    assert!(!cracked.contains("no node was split"), "{cracked}");
    let _ = std::fs::remove_dir_all(&base);
}

/// `fractum run` as rank `rank` of `size` by an Open MPI launcher's environment.
fn run_as_rank(rank: usize, size: usize, out_dir: &std::path::Path) -> std::process::Output {
    command(&[
        "run",
        "scenes/block_compression.ron",
        "--out",
        out_dir.to_str().unwrap(),
        "--steps",
        "2",
        "--quiet",
    ])
    .env("OMPI_COMM_WORLD_RANK", rank.to_string())
    .env("OMPI_COMM_WORLD_SIZE", size.to_string())
    .output()
    .unwrap()
}

#[test]
fn a_run_started_as_several_ranks_is_refused_once_and_one_rank_runs() {
    let out_dir = std::env::temp_dir().join(format!("fractum-cli-ranks-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out_dir);
    let first = run_as_rank(0, 3, &out_dir);
    assert_eq!(first.status.code(), Some(2));
    let error = text(&first.stderr);
    assert!(
        error.contains("started as 3 ranks (mpirun -np 3)")
            && error.contains("built without MPI")
            && error.contains("--features mpi")
            && error.contains("--threads N"),
        "{error}"
    );
    // The other ranks end with the same code and say nothing, so the message is printed once.
    let second = run_as_rank(1, 3, &out_dir);
    assert_eq!(second.status.code(), Some(2));
    assert!(second.stderr.is_empty(), "{}", text(&second.stderr));
    assert!(
        !out_dir.exists(),
        "a refused run wrote {}",
        out_dir.display()
    );
    // One rank is a plain run.
    let alone = run_as_rank(0, 1, &out_dir);
    assert!(alone.status.success(), "{}", text(&alone.stderr));
    assert!(out_dir.join("series.csv").exists());
    let _ = std::fs::remove_dir_all(&out_dir);
}

#[test]
fn a_command_other_than_run_started_as_several_ranks_is_refused_once() {
    let as_rank = |rank: usize| {
        command(&["verify", "--list"])
            .env("OMPI_COMM_WORLD_RANK", rank.to_string())
            .env("OMPI_COMM_WORLD_SIZE", "2")
            .output()
            .unwrap()
    };
    let first = as_rank(0);
    assert_eq!(first.status.code(), Some(2));
    let error = text(&first.stderr);
    assert!(
        error.contains("started as 2 ranks")
            && error.contains("runs as one process")
            && error.contains("only `fractum run` and `fractum resume`"),
        "{error}"
    );
    assert!(first.stdout.is_empty(), "{}", text(&first.stdout));
    let second = as_rank(1);
    assert_eq!(second.status.code(), Some(2));
    assert!(second.stderr.is_empty(), "{}", text(&second.stderr));
    // One rank is a plain process.
    let alone = command(&["verify", "--list"])
        .env("OMPI_COMM_WORLD_RANK", "0")
        .env("OMPI_COMM_WORLD_SIZE", "1")
        .output()
        .unwrap();
    assert!(alone.status.success(), "{}", text(&alone.stderr));
}

#[test]
fn check_estimate_divides_a_scene_over_ranks_in_balanced_slabs() {
    let out = fractum(&[
        "check",
        "--estimate",
        "--ranks",
        "4",
        "scenes/kalthoff_winkler_dfg_tents.ron",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report = text(&out.stdout);
    assert!(
        report.contains("ranks      4 slabs along x, cut at cell faces; imbalance 0.7%"),
        "{report}"
    );
    // "…: 9600 particles, 12344 with ghosts, 12075 nodes, 51.7 MiB": owned, held, nodes.
    let counts: Vec<(u64, u64)> = report
        .lines()
        .filter(|l| l.trim_start().starts_with("rank "))
        .map(|l| {
            let words: Vec<&str> = l.rsplit(": ").next().unwrap().split(' ').collect();
            (words[0].parse().unwrap(), words[2].parse().unwrap())
        })
        .collect();
    let nodes: Vec<usize> = report
        .lines()
        .filter(|l| l.trim_start().starts_with("rank "))
        .map(|l| {
            l.split(", ")
                .nth(2)
                .unwrap()
                .trim_end_matches(" nodes")
                .parse()
                .unwrap()
        })
        .collect();
    // A rank holds the nodes its held cell layers reach and 3 node layers more each way (linear
    // basis: a cell of support, a step's motion, the cut), of 105 nodes each; the grid has 209.
    // Rank 1 holds cell layers 97..145, so node layers 94..149.
    assert!(report.contains("grid       21945 nodes"), "{report}");
    assert_eq!(nodes[1], 55 * 105, "{report}");
    assert!(nodes.iter().all(|&n| n < 21945), "{report}");
    let owned: Vec<u64> = counts.iter().map(|c| c.0).collect();
    // The slabs balance particles and nodes (a node at half a particle): rank 0, whose layers
    // hold the impactor and the empty space above it, owns fewer particles.
    assert_eq!(owned, vec![9600, 13328, 13072, 13200], "{report}");
    // DFG with its kernel reaches 6 layers, and a layer more for the particles a rank takes
    // over: 7; an inner rank holds ghosts on both sides.
    assert!(
        report.contains("within 7 cell layers of its slab"),
        "{report}"
    );
    assert!(counts.iter().all(|(own, held)| held > own), "{report}");
    assert!(
        counts[1].1 - counts[1].0 > counts[0].1 - counts[0].0,
        "{report}"
    );
    // The face at the origin is printed as 0, not as the round-off of its node coordinates.
    assert!(
        report.contains("rank 1    x 0 to 0.034 m (cell layers 104..138)"),
        "{report}"
    );
    // More ranks than cell layers: a rank must own one.
    let out = fractum(&[
        "check",
        "--estimate",
        "--ranks",
        "500",
        "scenes/two_disks.ron",
    ]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        text(&out.stderr).contains("20 cell layers along the x axis, fewer than the 500 ranks"),
        "{}",
        text(&out.stderr)
    );
    // `--ranks` belongs to `--estimate`.
    let out = fractum(&["check", "--ranks", "2", "scenes/two_disks.ron"]);
    assert_eq!(out.status.code(), Some(2));
}

/// A quasi-static scene: `check` shows the scaling and the scaled density, and a bar jerked
/// into motion is reported as dynamic at the end of its run.
#[test]
fn a_quasi_static_run_shows_its_scaling_and_reports_a_jerk() {
    let dir = std::env::temp_dir().join(format!("fractum-cli-quasi-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("jerk.ron");
    std::fs::write(
        &scene,
        r#"(
    time: (step: Cfl(0.5), end: Steps(80), quasi_static: (mass_scaling: 4.0)),
    grid: (min: (-0.01, -0.01), max: (0.12, 0.03), spacing: 0.01),
    materials: { "steel": (density: 7800.0, youngs_modulus: 2.0e11, poisson_ratio: 0.3) },
    bodies: [(shape: Rectangle(min: (0.0, 0.0), max: (0.1, 0.02)), material: "steel")],
    boundaries: [
        (name: "clamp", nodes: Box(min: (0.0, 0.0), max: (0.0, 0.02)), condition: Fixed),
        (name: "pull", nodes: Box(min: (0.1, 0.0), max: (0.1, 0.02)),
         condition: Velocity(x: [(0.0, 1.0)])),
    ],
    output: (csv_every: 5),
    pipeline: [(system: "basis/linear"), (system: "predictor/usl"),
               (system: "stress/linear_elastic"), (system: "advection/usl")],
)"#,
    )
    .unwrap();
    let out = fractum(&["check", scene.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let summary = text(&out.stdout);
    assert!(
        summary.contains("density 31200 kg/m3 (7800 scaled 4 times)")
            && summary.contains("quasi-static mass scaled 4 times")
            && summary.contains("kinetic_fraction,external_work"),
        "{summary}"
    );
    let out_dir = dir.join("out");
    let out = fractum(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let summary = text(&out.stdout);
    assert!(
        summary.contains("quasi-static: the kinetic energy reached"),
        "{summary}"
    );
    // The last row's energy account: an elastic bar dissipates nothing by its laws.
    assert!(
        summary.contains("energy     at t = ") && summary.contains("+ dissipated 0.0000e0 J"),
        "{summary}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Time-to-failure damage reads the scene's real time: mass scaling its scene is warned of by
/// `check` and by the run, and the unscaled scene is not.
#[test]
fn mass_scaling_a_law_with_a_time_of_its_own_is_warned_of() {
    let dir = std::env::temp_dir().join(format!("fractum-cli-real-time-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let strip = std::fs::read_to_string(root().join("scenes/time_to_failure_strip.ron")).unwrap();
    let from = "end: Time(8.0e-3))";
    assert!(strip.contains(from));
    for (scaling, warned) in [("1.0", false), ("4.0", true)] {
        let scene = dir.join(format!("strip_{scaling}.ron"));
        let time = format!("end: Time(8.0e-3), quasi_static: (mass_scaling: {scaling}))");
        std::fs::write(&scene, strip.replace(from, &time)).unwrap();
        let check = fractum(&["check", scene.to_str().unwrap()]);
        assert!(check.status.success(), "{}", text(&check.stderr));
        let out_dir = dir.join(format!("out_{scaling}"));
        let run = fractum(&[
            "run",
            scene.to_str().unwrap(),
            "--steps",
            "3",
            "--quiet",
            "--out",
            out_dir.to_str().unwrap(),
        ]);
        assert!(run.status.success(), "{}", text(&run.stderr));
        let (check, run) = (text(&check.stdout), text(&run.stderr));
        let named = "damage/time_to_failure (its time to failure";
        assert_eq!(check.contains(named), warned, "{check}");
        assert_eq!(run.contains(named), warned, "{run}");
        if warned {
            assert!(
                check.contains("warning    the run is mass scaled 4"),
                "{check}"
            );
            assert!(run.contains("warning: the run is mass scaled 4"), "{run}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An overlay that does not read is refused before any frame is drawn, with the file, the line
/// and the column that is wrong.
#[test]
fn snapshot_refuses_an_overlay_that_does_not_read() {
    let dir = std::env::temp_dir().join(format!("fractum-overlay-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let lines = dir.join("lines.csv");
    std::fs::write(&lines, "line,x,y\n0,0.0,0.0\n0,0.1,north\n").unwrap();
    let out = fractum(&[
        "snapshot",
        "no_frame.vtu",
        "--overlay",
        lines.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let message = text(&out.stderr);
    assert!(
        message.contains("--overlay") && message.contains("lines.csv:3: column `y`"),
        "{message}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
