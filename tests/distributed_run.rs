//! A run over several ranks (threads of this process, `ThreadRank`) through the run loop
//! (`fractum_io::run::run_with` with a communicator): one `series.csv`, written by rank 0,
//! equal to the single process's to 1e-12 of each column's largest magnitude and the same bits
//! run to run; particle frames as per-rank pieces whose `.pvtu` index reads back as the single
//! process's frame; a blow-up on one rank stops every rank with its message; an interrupt seen
//! by one rank stops them all after the same step; per-rank checkpoints with a manifest, from
//! which the same rank count resumes bit for bit. The same run under `mpirun`:
//! `tools/tests/mpi_run.rs`.

use fractum_engine::communicator::thread_ranks;
use fractum_io::checkpoint::{
    CheckpointEvery, RankCheckpoint, SceneRecord, list_checkpoints, read_checkpoint,
};
use fractum_io::output::{ParticleFrame, read_particle_frame, read_pvd, read_pvtu_pieces};
use fractum_io::run::distributed::restore_rank_piece;
use fractum_io::run::{
    CheckpointPlan, RunError, RunOptions, RunSummary, resumed_outputs, rewind_outputs, run_with,
};
use fractum_scene::{SceneFile, build_rank_simulation, build_simulation};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// Two disks thrown at each other, with Kalthoff–Winkler's pipeline (Rankine damage, DFG
/// partitioning, frictional contact), gravity, a line of nodes pushed sideways through the lower
/// disk (reactions and external work) and every probe a distributed run supports.
fn scene(end_steps: u64, speed: f64) -> String {
    format!(
        r#"(
    title: "two disks, pushed",
    units: SI,
    time: (step: Fixed(1.0e-3), end: Steps({end_steps})),
    grid: (min: (0.0, 0.0), max: (1.0, 1.0), spacing: 0.05),
    body_force: (0.0, -1.0),
    materials: {{
        "elastic": (density: 1000.0, youngs_modulus: 1000.0, poisson_ratio: 0.3),
    }},
    bodies: [
        (name: "lower-left", shape: Disk(center: (0.25, 0.3), radius: 0.2), material: "elastic",
         particles_per_cell: 2, velocity: Uniform(({speed}, 0.1)), contact_group: 0),
        (name: "upper-right", shape: Disk(center: (0.75, 0.7), radius: 0.2), material: "elastic",
         particles_per_cell: 2, velocity: Uniform((-0.4, -0.1)), contact_group: 1),
    ],
    boundaries: [
        (name: "pusher", nodes: Box(min: (0.0, 0.3), max: (1.0, 0.3)),
         condition: Velocity(x: [(0.0, 0.0), (0.2, 0.05)])),
    ],
    output: (vtu_every: 100, grid_every: 100, csv_every: 10,
             probes: [CentreOfMassVelocity, Reaction("pusher"), Force("lower-left"),
                      Displacement("pusher")]),
    pipeline: [
        (system: "basis/linear"), (system: "predictor/newmark"),
        (system: "stress/neo_hookean"),
        (system: "damage/rankine", params: (tensile_strength: 20.0, fracture_energy: 0.05)),
        (system: "partition/dfg"),
        (system: "contact/frictional", params: (friction: 0.0, separability: 0.25)),
        (system: "corrector/newmark"), (system: "advection/newmark"),
    ],
)"#
    )
}

fn parse(text: &str) -> SceneFile {
    SceneFile::parse("two_disks_pushed.ron", text.to_string()).unwrap()
}

/// Two spheres meeting along x, cracking where they meet (LME, eigensoftening), in 3D.
const SPHERES: &str = include_str!("fixtures/two_spheres_lme_3d.ron");

/// The shipped scene at `path` with each `(text, replacement)` made, each text found once.
fn shipped_scene_with(path: &str, edits: &[(&str, &str)]) -> String {
    let mut text = std::fs::read_to_string(path).unwrap();
    for (from, to) in edits {
        assert_eq!(text.matches(from).count(), 1, "{path} no longer has {from}");
        text = text.replace(from, to);
    }
    text
}

fn out_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "fractum-distributed-run-{}-{name}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn run_serial(text: &str, dir: &Path) -> Result<RunSummary, RunError> {
    let mut built = build_simulation(&parse(text), &fractum_systems::stock_registry()).unwrap();
    run_with(
        &mut built.simulation,
        &built.output,
        dir,
        RunOptions::default(),
        |_| {},
    )
}

/// Runs `text` as `ranks` ranks into `dir`, each rank seeing `interrupt[rank]` as its signal
/// flag; every rank's outcome, by rank.
fn run_ranks(
    text: &str,
    ranks: usize,
    dir: &Path,
    interrupt: Vec<bool>,
) -> Vec<Result<RunSummary, RunError>> {
    run_ranks_with(text, ranks, dir, interrupt, None, false)
}

/// [`run_ranks`], stopping at step `cap` when given, with a checkpoint every 100 steps when
/// `checkpoints`.
fn run_ranks_with(
    text: &str,
    ranks: usize,
    dir: &Path,
    interrupt: Vec<bool>,
    cap: Option<u64>,
    checkpoints: bool,
) -> Vec<Result<RunSummary, RunError>> {
    let threads: Vec<_> = thread_ranks(ranks)
        .into_iter()
        .zip(interrupt)
        .map(|(comm, interrupted)| {
            let file = parse(text);
            let dir = dir.to_path_buf();
            std::thread::spawn(move || {
                use fractum_engine::communicator::Communicator;
                let registry = fractum_systems::stock_registry();
                let mut built =
                    build_rank_simulation(&file, &registry, comm.rank(), comm.size()).unwrap();
                built.simulation.set_step_cap(cap);
                let flag = AtomicBool::new(interrupted);
                let options = RunOptions {
                    interrupt: Some(&flag),
                    communicator: Some(&comm),
                    checkpoints: checkpoints.then_some(CheckpointPlan {
                        every: CheckpointEvery::Steps(100),
                        keep: 2,
                    }),
                    scene: Some(SceneRecord {
                        path: "two_disks_pushed.ron".into(),
                        text: file.text.clone(),
                    }),
                    ..RunOptions::default()
                };
                run_with(&mut built.simulation, &built.output, &dir, options, |_| {})
            })
        })
        .collect();
    threads.into_iter().map(|t| t.join().unwrap()).collect()
}

/// The header and rows of a `series.csv`.
fn series(dir: &Path) -> (String, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(dir.join("series.csv")).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().to_string();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    (header, rows)
}

/// Every value of `rows` within 1e-12 of its column's scale in `reference` (sums over ranks add
/// in another order than the single process's sums); the step and time columns exactly. A
/// column's scale is its largest magnitude, of every axis for a vector's component (a force
/// along the impact is the scale of the force across it); where a column is a sum whose terms
/// cancel, the terms' scale: the energy residual's is the largest total energy or work; the
/// momentum's (of bodies moving against each other, a sum that cancels to round-off) is
/// `Σ m|v| ≤ √(2MK)`, with `mass` M and the largest kinetic energy K, and the centre-of-mass
/// velocity's `√(2K/M)`.
fn assert_series_close(
    header: &str,
    reference: &[Vec<f64>],
    rows: &[Vec<f64>],
    mass: f64,
    what: &str,
) {
    assert_eq!(reference.len(), rows.len(), "{what}: rows");
    let names: Vec<&str> = header.split(',').collect();
    let at = |name: &str| names.iter().position(|n| *n == name).unwrap();
    let largest = |c: usize| reference.iter().map(|r| r[c].abs()).fold(0.0, f64::max);
    let (total, work) = (at("total_energy"), at("external_work"));
    let energy = largest(total).max(largest(work));
    let kinetic = largest(at("kinetic_energy"));
    // The columns of a vector: those with the same stem before `_x`, `_y`, `_z`.
    let stem = |name: &str| {
        let axis = ["_x", "_y", "_z"].iter().find(|a| name.ends_with(*a));
        axis.map_or(name.to_string(), |a| {
            name[..name.len() - a.len()].to_string()
        })
    };
    let vector = |c: usize| {
        (0..names.len())
            .filter(|&k| stem(names[k]) == stem(names[c]))
            .map(largest)
            .fold(0.0, f64::max)
    };
    for (c, name) in names.iter().enumerate() {
        let scale = match *name {
            "energy_residual" => energy,
            n if n.starts_with("momentum_") => (2.0 * mass * kinetic).sqrt(),
            n if n.starts_with("com_velocity_") => (2.0 * kinetic / mass).sqrt(),
            _ => vector(c),
        };
        for (k, (a, b)) in reference.iter().zip(rows).enumerate() {
            let tolerance = if c < 2 { 0.0 } else { 1e-12 * scale };
            assert!(
                (a[c] - b[c]).abs() <= tolerance,
                "{what}: row {k}, {name}: {} against the single process's {}",
                b[c],
                a[c]
            );
        }
    }
}

/// The frame sorted by particle id.
fn by_id(mut frame: ParticleFrame) -> Vec<(u32, [f64; 3], [f64; 3], f64)> {
    let mut rows: Vec<_> = (0..frame.id.len())
        .map(|i| {
            (
                frame.id[i],
                frame.position[i],
                frame.velocity[i],
                frame.damage[i],
            )
        })
        .collect();
    rows.sort_by_key(|r| r.0);
    frame.id.clear();
    rows
}

/// Runs `text` (`steps` steps, a particle frame at the end) as one process and on 1 to 4
/// ranks: the ranks' series is the single process's ([`assert_series_close`]) and the same
/// bits run to run, and their last frame, read back from its pieces, the single process's.
/// Returns the single process's header and rows.
fn assert_run_matches_serial(name: &str, text: &str, steps: u64) -> (String, Vec<Vec<f64>>) {
    let serial_dir = out_dir(&format!("{name}-serial"));
    let serial = run_serial(text, &serial_dir).unwrap();
    assert_eq!(serial.ranks, None);
    let (header, reference) = series(&serial_dir);
    let last = format!("frames/particles_{steps:08}");
    let serial_frame = read_particle_frame(&serial_dir.join(format!("{last}.vtu"))).unwrap();
    let mass: f64 = serial_frame.mass.iter().sum();
    for ranks in 1..=4 {
        let dir = out_dir(&format!("{name}-ranks-{ranks}"));
        let outcomes = run_ranks(text, ranks, &dir, vec![false; ranks]);
        for outcome in &outcomes {
            let summary = outcome.as_ref().unwrap();
            assert_eq!(
                (summary.steps, summary.particles),
                (steps, serial.particles)
            );
            assert_eq!(summary.frames, serial.frames);
            // How the work divided: the same report on every rank.
            let report = summary.ranks.expect("a distributed run reports its ranks");
            assert_eq!(Some(report), outcomes[0].as_ref().unwrap().ranks);
            assert_eq!(report.ranks, ranks);
            if ranks > 1 {
                assert!(report.held_over_owned > 1.0 && report.sent_per_step > 0.0);
                // Each node is held by a rank at least; where ranks' reaches overlap, by more.
                assert!(report.held_nodes_over_grid >= 1.0, "{report:?}");
            } else {
                assert_eq!(report.held_nodes_over_grid, 1.0);
            }
            // The energy watch judges the run's energy, not a rank's part of it.
            assert_eq!(
                summary.energy_created.map(|c| c.step),
                serial.energy_created.map(|c| c.step),
                "{ranks} ranks"
            );
        }
        let (rank_header, rows) = series(&dir);
        assert_eq!(rank_header, header);
        let what = format!("{name}, {ranks} ranks");
        assert_series_close(&header, &reference, &rows, mass, &what);
        // Frames: one piece per rank behind each index, which reads back as the single
        // process's frame (the particles' states are the single process's, bit for bit).
        let frames = read_pvd(&dir.join("particles.pvd")).unwrap();
        assert_eq!(frames.len(), serial.frames);
        let (_, index) = frames.last().unwrap();
        assert_eq!(index, &format!("{last}.pvtu"));
        let pieces = read_pvtu_pieces(&dir.join(index)).unwrap();
        assert_eq!(pieces.len(), ranks);
        let frame = read_particle_frame(&dir.join(index)).unwrap();
        assert_eq!(by_id(frame), by_id(serial_frame.clone()), "{ranks} ranks");
        if ranks == 3 {
            // Each rank count repeats its own series bit for bit.
            let again = out_dir(&format!("{name}-ranks-3-again"));
            run_ranks(text, ranks, &again, vec![false; ranks]);
            let read = |d: &Path| std::fs::read(d.join("series.csv")).unwrap();
            assert_eq!(read(&again), read(&dir));
            std::fs::remove_dir_all(&again).unwrap();
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
    std::fs::remove_dir_all(&serial_dir).unwrap();
    (header, reference)
}

#[test]
fn a_run_over_one_to_four_ranks_writes_the_single_process_series_and_frames() {
    let (header, reference) = assert_run_matches_serial("disks", &scene(300, 0.4), 300);
    assert_eq!(reference.len(), 31);
    let column = |name: &str| header.split(',').position(|c| c == name).unwrap();
    // The run exercises what the ranks add up: reactions and work at the pushed nodes, damage,
    // and the grid frames' pieces.
    let last = reference.last().unwrap();
    assert!(
        last[column("reaction_pusher_x")].abs() > 0.0,
        "{header}\n{last:?}"
    );
    assert!(
        last[column("external_work")].abs() > 0.0,
        "{header}\n{last:?}"
    );
    assert!(last[column("failed_particles")] > 0.0, "{header}\n{last:?}");
}

#[test]
fn a_3d_run_with_lme_and_eigensoftening_over_ranks_writes_the_single_process_series() {
    let (header, reference) = assert_run_matches_serial("spheres", SPHERES, 320);
    let column = |name: &str| header.split(',').position(|c| c == name).unwrap();
    let last = reference.last().unwrap();
    assert!(
        last[column("damaged_particles")] > 0.0,
        "{header}\n{last:?}"
    );
    assert!(last[column("force_left_x")] != 0.0, "{header}\n{last:?}");
}

#[test]
fn kalthoff_winkler_over_ranks_writes_the_single_process_series() {
    // The shipped plate (49 200 particles) for a short window, a frame at its end.
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/kalthoff_winkler_dfg.ron"
    );
    let text = shipped_scene_with(
        path,
        &[
            ("end: Time(90.0e-6)", "end: Steps(20)"),
            ("vtu_every: 40", "vtu_every: 20"),
        ],
    );
    assert_run_matches_serial("kalthoff", &text, 20);
}

#[test]
fn the_billet_with_surface_detection_and_self_contact_over_ranks_writes_the_single_process_series()
{
    // The shipped billet under its platen for the first 200 steps: the surfaces detected from
    // the whole scene's largest kernel sum, agreed over ranks; Track probes on particles that
    // may be owned by different ranks.
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/billet_self_contact.ron"
    );
    let text = shipped_scene_with(
        path,
        &[
            ("end: Time(2.0e-6)", "end: Steps(200)"),
            ("vtu_every: 200", "vtu_every: 100"),
        ],
    );
    let (header, reference) = assert_run_matches_serial("billet", &text, 200);
    let column = |name: &str| header.split(',').position(|c| c == name).unwrap();
    let last = reference.last().unwrap();
    assert!(
        last[column("track_slip_x")].is_finite(),
        "{header}\n{last:?}"
    );
    assert!(
        last[column("reaction_mid-plane_y")] != 0.0,
        "{header}\n{last:?}"
    );
}

#[test]
fn a_particle_leaving_the_grid_on_one_rank_stops_every_rank_with_its_message() {
    // The lower disk flies out through the right side: only the rank that owns the right of the
    // grid sees it go.
    let text = scene(400, 6.0);
    let serial_dir = out_dir("leaving-serial");
    let Err(RunError::Blowup(blowup, _)) = run_serial(&text, &serial_dir) else {
        panic!("the single process did not stop");
    };
    let dir = out_dir("leaving-ranks");
    let outcomes = run_ranks(&text, 3, &dir, vec![false; 3]);
    let failures: Vec<_> = outcomes
        .into_iter()
        .map(|o| match o {
            Err(RunError::Rank(failure, last_good)) => (failure, last_good),
            other => panic!("a rank did not stop with the others: {other:?}"),
        })
        .collect();
    for (failure, last_good) in &failures {
        assert_eq!(failure, &failures[0].0);
        assert_eq!(failure.message, blowup.to_string());
        let index = last_good.as_ref().unwrap();
        assert_eq!(read_pvtu_pieces(index).unwrap().len(), 3);
    }
    assert_eq!(failures[0].0.rank, 2, "{}", failures[0].0);
    std::fs::remove_dir_all(&dir).unwrap();
    std::fs::remove_dir_all(&serial_dir).unwrap();
}

#[test]
fn particles_removed_on_leaving_the_grid_are_the_single_process_removals_on_any_rank_count() {
    // The lower disk flies out through the right side, where the last rank's slab is, and the
    // run goes on without it.
    let text = scene(400, 6.0).replace(
        "    units: SI,",
        "    units: SI,\n    safety: (on_leave_grid: Remove),",
    );
    let serial_dir = out_dir("removed-serial");
    let serial = run_serial(&text, &serial_dir).unwrap();
    let (header, reference) = series(&serial_dir);
    let first = read_particle_frame(&serial_dir.join("frames/particles_00000000.vtu")).unwrap();
    let last = read_particle_frame(&serial_dir.join("frames/particles_00000400.vtu")).unwrap();
    let mass: f64 = first.mass.iter().sum();
    assert!(
        serial.removed > 100 && !last.id.is_empty(),
        "{} removed, {} left",
        serial.removed,
        last.id.len()
    );
    for ranks in [2, 3] {
        let dir = out_dir(&format!("removed-ranks-{ranks}"));
        for outcome in run_ranks(&text, ranks, &dir, vec![false; ranks]) {
            let summary = outcome.unwrap();
            assert_eq!((summary.steps, summary.removed), (400, serial.removed));
        }
        // One process moves its last rows into the removed ones' places, and its sums add in
        // that order from then on; the series agree to the tolerance of sums in another order.
        let (rank_header, rows) = series(&dir);
        assert_eq!(rank_header, header);
        assert_series_close(&header, &reference, &rows, mass, &format!("{ranks} ranks"));
        let frame = read_particle_frame(&dir.join("frames/particles_00000400.pvtu")).unwrap();
        let ids = |f: &ParticleFrame| {
            by_id(f.clone())
                .into_iter()
                .map(|r| r.0)
                .collect::<Vec<_>>()
        };
        assert_eq!(ids(&frame), ids(&last), "{ranks} ranks");
        std::fs::remove_dir_all(&dir).unwrap();
    }
    std::fs::remove_dir_all(&serial_dir).unwrap();
}

/// Every frame `dir`'s collections list, with each of its pieces on disk: how many.
fn listed_with_every_piece(dir: &Path) -> usize {
    let mut listed = 0;
    for collection in ["particles.pvd", "grid.pvd"] {
        let Ok(frames) = read_pvd(&dir.join(collection)) else {
            continue;
        };
        for (_, index) in frames {
            let index = dir.join(index);
            let pieces = read_pvtu_pieces(&index)
                .unwrap_or_else(|e| panic!("{collection} lists {}: {e}", index.display()));
            for piece in pieces {
                let piece = index.parent().unwrap().join(piece);
                assert!(
                    piece.exists(),
                    "{collection} lists {} before its piece {} is on disk",
                    index.display(),
                    piece.display()
                );
            }
            listed += 1;
        }
    }
    listed
}

#[test]
fn the_collections_list_a_distributed_frame_only_once_every_piece_is_on_disk() {
    // A particle and a grid frame at every step, so that the ranks' writers are still writing
    // their pieces when rank 0 would list them; rank 0 looks after every step.
    let steps = 40;
    let text = scene(steps, 0.4).replace(
        "output: (vtu_every: 100, grid_every: 100,",
        "output: (vtu_every: 1, grid_every: 1,",
    );
    let dir = out_dir("collections");
    let ranks = 3;
    let threads: Vec<_> = thread_ranks(ranks)
        .into_iter()
        .map(|comm| {
            let file = parse(&text);
            let dir = dir.clone();
            std::thread::spawn(move || {
                use fractum_engine::communicator::Communicator;
                let registry = fractum_systems::stock_registry();
                let mut built =
                    build_rank_simulation(&file, &registry, comm.rank(), comm.size()).unwrap();
                let rank = comm.rank();
                let options = RunOptions {
                    communicator: Some(&comm),
                    ..RunOptions::default()
                };
                let mut seen = 0;
                run_with(&mut built.simulation, &built.output, &dir, options, |_| {
                    if rank == 0 {
                        seen = seen.max(listed_with_every_piece(&dir));
                    }
                })
                .unwrap();
                seen
            })
        })
        .collect();
    let seen: Vec<usize> = threads.into_iter().map(|t| t.join().unwrap()).collect();
    // Frames were listed while the run went on, and at its end every frame is.
    assert!(seen[0] > steps as usize, "rank 0 saw {} listed", seen[0]);
    let every = 2 * (steps as usize + 1);
    assert_eq!(listed_with_every_piece(&dir), every);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_interrupt_seen_by_one_rank_stops_every_rank_after_the_same_step() {
    let text = scene(300, 0.4);
    let dir = out_dir("interrupted");
    let outcomes = run_ranks(&text, 3, &dir, vec![false, true, false]);
    for outcome in outcomes {
        let summary = outcome.unwrap();
        assert!(summary.interrupted);
        assert_eq!(summary.steps, 1);
        assert!(summary.checkpoint.is_some());
    }
    // And a checkpoint to resume from: the manifest and the ranks' pieces.
    let steps: Vec<u64> = list_checkpoints(&dir).iter().map(|c| c.0).collect();
    assert_eq!(steps, [1]);
    let files = std::fs::read_dir(dir.join("checkpoints")).unwrap().count();
    assert_eq!(files, 4);
    // The outputs are whole: the first row, and the row and frame of the step it stopped at.
    let (_, rows) = series(&dir);
    assert_eq!(rows.iter().map(|r| r[0]).collect::<Vec<_>>(), [0.0, 1.0]);
    let frames = read_pvd(&dir.join("particles.pvd")).unwrap();
    assert_eq!(frames.len(), 2);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Resumes the run in `dir` as `ranks` ranks from its newest checkpoint, to its end, as
/// `fractum resume` does under `mpirun`.
fn resume_ranks(ranks: usize, dir: &Path) -> Vec<Result<RunSummary, RunError>> {
    let (_, manifest_path) = list_checkpoints(dir).pop().unwrap();
    let manifest = read_checkpoint(&manifest_path).unwrap();
    let Some(RankCheckpoint::Manifest {
        ranks: saved,
        pieces,
    }) = &manifest.ranks
    else {
        panic!("the newest checkpoint is not a distributed run's manifest");
    };
    assert_eq!((*saved, pieces.len()), (ranks, ranks));
    let threads: Vec<_> = thread_ranks(ranks)
        .into_iter()
        .map(|comm| {
            use fractum_engine::communicator::Communicator;
            let piece_path = manifest_path.with_file_name(&pieces[comm.rank()]);
            let manifest = manifest.clone();
            let dir = dir.to_path_buf();
            std::thread::spawn(move || {
                let piece = read_checkpoint(&piece_path).unwrap();
                let file = parse(&manifest.scene.text);
                let registry = fractum_systems::stock_registry();
                let (rank, size) = (comm.rank(), comm.size());
                let mut built = build_rank_simulation(&file, &registry, rank, size).unwrap();
                restore_rank_piece(&mut built.simulation, &piece, (rank, size)).unwrap();
                assert_holds_the_nodes_of_its_slabs(&built.simulation.world);
                let step = built.simulation.clock().step;
                let outputs = if rank == 0 {
                    rewind_outputs(&dir, &manifest, step)
                } else {
                    resumed_outputs(&dir, &manifest, step)
                };
                let options = RunOptions {
                    communicator: Some(&comm),
                    resume: Some(outputs.unwrap()),
                    scene: Some(manifest.scene.clone()),
                    ..RunOptions::default()
                };
                run_with(&mut built.simulation, &built.output, &dir, options, |_| {})
            })
        })
        .collect();
    threads.into_iter().map(|t| t.join().unwrap()).collect()
}

/// The rank's world holds the nodes of the slabs it owns now, which the run may have re-cut.
fn assert_holds_the_nodes_of_its_slabs(world: &bevy_ecs::world::World) {
    use fractum_engine::decomposition::{Ownership, RankRebuild, rank_grid};
    use fractum_engine::resources::Grid;
    let grid = world.resource::<Grid<fractum_engine::dim::Two>>();
    let ownership = world.resource::<Ownership>();
    let reach = world.resource::<RankRebuild>().node_reach;
    let wanted = rank_grid(grid, &ownership.layout, ownership.rank, reach);
    assert_eq!(wanted.window, grid.window, "rank {}", ownership.rank);
    assert!(!ownership.nodes_pending);
}

#[test]
fn a_run_over_ranks_resumes_from_its_checkpoint_on_as_many_ranks_bit_for_bit() {
    let text = scene(300, 0.4);
    let whole = out_dir("whole");
    for outcome in run_ranks_with(&text, 3, &whole, vec![false; 3], None, true) {
        outcome.unwrap();
    }
    let stopped = out_dir("stopped");
    for outcome in run_ranks_with(&text, 3, &stopped, vec![false; 3], Some(150), true) {
        assert_eq!(outcome.unwrap().steps, 150);
    }
    // Checkpoints at steps 100 and 150 (the end of the capped run), each a manifest and one
    // piece per rank; an older one would have been pruned with its pieces.
    let steps: Vec<u64> = list_checkpoints(&stopped).iter().map(|c| c.0).collect();
    assert_eq!(steps, [100, 150]);
    let files = std::fs::read_dir(stopped.join("checkpoints"))
        .unwrap()
        .count();
    assert_eq!(files, 2 * 4);
    // The slabs were re-cut before the checkpoint, and moved some rank's nodes: the resume
    // builds each rank's world for the checkpoint's slabs, not the seeds' cut.
    let (_, newest) = list_checkpoints(&stopped).pop().unwrap();
    let manifest = read_checkpoint(&newest).unwrap();
    let Some(RankCheckpoint::Manifest { pieces, .. }) = &manifest.ranks else {
        panic!("not a manifest");
    };
    let recut: Vec<(u64, u64)> = pieces
        .iter()
        .map(|name| {
            let piece = read_checkpoint(&newest.with_file_name(name)).unwrap();
            let Some(RankCheckpoint::Piece { ownership, .. }) = &piece.ranks else {
                panic!("not a piece");
            };
            let ownership: fractum_engine::decomposition::Ownership =
                postcard::from_bytes(ownership).unwrap();
            (ownership.rebalances, ownership.rebuilds)
        })
        .collect();
    assert!(
        recut
            .iter()
            .any(|&(cuts, rebuilds)| cuts > 0 && rebuilds > 0),
        "{recut:?}"
    );
    for outcome in resume_ranks(3, &stopped) {
        assert_eq!(outcome.unwrap().steps, 150);
    }
    let read = |d: &Path, f: &str| std::fs::read(d.join(f)).unwrap();
    assert_eq!(
        String::from_utf8(read(&stopped, "series.csv")).unwrap(),
        String::from_utf8(read(&whole, "series.csv")).unwrap()
    );
    assert_eq!(
        read(&stopped, "particles.pvd"),
        read(&whole, "particles.pvd")
    );
    let last = "frames/particles_00000300.pvtu";
    let frame = |d: &Path| by_id(read_particle_frame(&d.join(last)).unwrap());
    assert_eq!(frame(&stopped), frame(&whole));
    std::fs::remove_dir_all(&whole).unwrap();
    std::fs::remove_dir_all(&stopped).unwrap();
}
