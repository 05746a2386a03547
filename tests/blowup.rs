//! A run that goes wrong stops at once with a message naming the step, the stage and the
//! particle.

use fractum_engine::health::EscapedParticles;
use fractum_engine::prelude::*;
use fractum_io::run::{RunError, run};
use fractum_scene::{SceneFile, build_simulation};
use fractum_suite::temp_dir;

fn scene(velocity: &str, extra_system: &str) -> SceneFile {
    scene_with_safety(velocity, extra_system, "")
}

fn scene_with_safety(velocity: &str, extra_system: &str, safety: &str) -> SceneFile {
    let text = format!(
        r#"(
    time: (step: Fixed(1.0e-3), end: Steps(100)),{safety}
    grid: (min: (0.0, 0.0), max: (1.0, 1.0), spacing: 0.1),
    materials: {{ "m": (density: 1.0, youngs_modulus: 1.0, poisson_ratio: 0.0) }},
    bodies: [(shape: Rectangle(min: (0.8, 0.4), max: (1.0, 0.6)), material: "m",
              velocity: Uniform({velocity}))],
    pipeline: [(system: "basis/linear"), (system: "predictor/usl"),
               (system: "stress/linear_elastic"), (system: "advection/usl") {extra_system}],
)"#
    );
    SceneFile::parse("inline.ron", text).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_particle_leaving_the_grid_stops_the_run_naming_it() {
    // The right column of particles sits 0.025 from the edge and moves at 10 m/s: it leaves
    // during step 3 (x = 0.975 + 0.03 > 1).
    let file = scene("(10.0, 0.0)", "");
    let mut sim = build_simulation(&file, &fractum_systems::stock_registry())
        .unwrap()
        .simulation;
    let failure = loop {
        if let Err(e) = sim.step() {
            break e;
        }
        assert!(
            !sim.finished(),
            "the run finished although particles left the grid"
        );
    };
    assert_eq!(failure.step, 3);
    assert_eq!(failure.stage, Stage::Advection);
    assert!(failure.message.contains("left the grid"), "{failure}");
    assert_eq!(failure.cause, fractum_engine::health::Cause::LeftGrid);
    let text = failure.to_string();
    assert!(
        text.starts_with("step 3, stage advection: particle "),
        "{text}"
    );
}

fn poison(
    mut particles: Query<(&ParticleId, &mut Stress<Two>), With<Particle>>,
    clock: Res<SimClock>,
) {
    if clock.step == 4 {
        for (id, mut s) in &mut particles {
            if id.0 == 7 {
                s.0.xy = f64::NAN;
            }
        }
    }
}

fn poison_install(installer: &mut Installer, _: &Params) -> Result<(), SceneError> {
    installer.add_systems(poison);
    Ok(())
}

/// The stock systems plus `damage/poison`.
fn registry_with_poison() -> Registry {
    let mut registry = fractum_systems::stock_registry();
    registry
        .register(Registration {
            name: "damage/poison",
            summary: "writes NaN into particle 7's stress at step 5",
            params: &[],
            requires: &[],
            install: poison_install,
        })
        .unwrap();
    registry
}

#[test]
fn a_non_finite_stress_stops_the_run_in_the_stage_that_produced_it() {
    let registry = registry_with_poison();
    let file = scene("(0.0, 0.0)", r#", (system: "damage/poison")"#);
    let mut sim = build_simulation(&file, &registry).unwrap().simulation;
    let failure = loop {
        if let Err(e) = sim.step() {
            break e;
        }
    };
    assert_eq!((failure.step, failure.stage), (5, Stage::Damage));
    assert!(failure.message.starts_with("particle 7 at "), "{failure}");
    assert!(failure.message.contains("non-finite stress"), "{failure}");
    assert_eq!(failure.cause, fractum_engine::health::Cause::Inverted);
    // The clock stays at the last completed step.
    assert_eq!(sim.clock().step, 4);
}

#[test]
fn under_the_remove_policy_escaping_particles_are_removed_and_the_run_goes_on() {
    let file = scene_with_safety("(10.0, 0.0)", "", "\n    safety: (on_leave_grid: Remove),");
    let mut sim = build_simulation(&file, &fractum_systems::stock_registry())
        .unwrap()
        .simulation;
    let before = sim.particle_count();
    for _ in 0..10 {
        sim.step().unwrap_or_else(|e| panic!("{e}"));
    }
    let escaped = sim.world.resource::<EscapedParticles>().clone();
    assert!(escaped.count > 0);
    assert_eq!(sim.particle_count() as u64, before as u64 - escaped.count);
    let (_, x) = escaped.first.unwrap();
    assert!(x[0] > 1.0, "{x:?}");
}

#[test]
fn a_blown_up_run_writes_the_state_at_the_start_of_the_failing_step() {
    let registry = registry_with_poison();
    let file = scene("(0.0, 0.0)", r#", (system: "damage/poison")"#);
    let mut built = build_simulation(&file, &registry).unwrap();
    let particles = built.simulation.particle_count();
    let out = temp_dir("last-good");
    // Uncompressed, for vtkio (which does not take compressed inline arrays).
    let mut plan = built.output.clone();
    plan.compression = fractum_io::output::FrameCompression::None;
    let error = run(&mut built.simulation, &plan, &out, |_| {}).unwrap_err();
    let RunError::Blowup(blowup, Some(path)) = error else {
        panic!("expected a blow-up with a last good frame");
    };
    assert_eq!(blowup.step, 5);
    assert_eq!(path, out.join("frames/particles_last_good_00000004.vtu"));
    let vtk = vtkio::Vtk::import(&path).unwrap();
    let vtkio::model::DataSet::UnstructuredGrid { pieces, .. } = vtk.data else {
        panic!("not an unstructured grid");
    };
    let piece = pieces[0].load_piece_data(Some(&path)).unwrap();
    assert_eq!(piece.num_points(), particles);
    let stress = piece
        .data
        .point
        .iter()
        .find(|a| a.name() == "stress")
        .unwrap();
    let vtkio::model::Attribute::DataArray(array) = stress else {
        panic!("stress is not a data array");
    };
    let values: Vec<f64> = array.data.clone().cast_into().unwrap();
    assert_eq!(values.len(), 9 * particles);
    assert!(
        values.iter().all(|v| v.is_finite()),
        "the saved state is the good one"
    );
    std::fs::remove_dir_all(&out).unwrap();
}

/// Each check looks at what the systems since the previous check may write (their bevy access),
/// and a damage system that writes stresses gets a stress check.
#[test]
fn each_check_looks_at_what_its_stage_can_write() {
    use fractum_engine::health::{CheckPlan, Columns};
    let file = scene("(0.0, 0.0)", r#", (system: "damage/poison")"#);
    let sim = build_simulation(&file, &registry_with_poison())
        .unwrap()
        .simulation;
    let plan = sim.world.resource::<CheckPlan>();
    let expected = [
        (Stage::Basis, Columns::NONE),
        (Stage::Predictor, Columns::NODES),
        (Stage::Stress, Columns::STRESS | Columns::VOLUME),
        (Stage::Damage, Columns::STRESS),
        (Stage::Advection, Columns::POSITION | Columns::VELOCITY),
    ];
    for (stage, columns) in expected {
        assert_eq!(plan.of(stage), columns, "{stage:?}");
    }
    // Under the remove policy a system with deferred commands shares the advection check's
    // set: that check then looks at everything.
    let file = scene_with_safety("(0.0, 0.0)", "", "\n    safety: (on_leave_grid: Remove),");
    let sim = build_simulation(&file, &fractum_systems::stock_registry())
        .unwrap()
        .simulation;
    let plan = sim.world.resource::<CheckPlan>();
    assert_eq!(plan.of(Stage::Advection), Columns::ALL);
    assert_eq!(plan.of(Stage::Stress), Columns::STRESS | Columns::VOLUME);
}

/// A step too small to move the clock (here: a clock so far along that 1 ms is below its
/// resolution) stops the run instead of looping for ever.
#[test]
fn a_step_that_cannot_advance_the_clock_stops_the_run() {
    let file = scene("(0.0, 0.0)", "");
    let mut sim = build_simulation(&file, &fractum_systems::stock_registry())
        .unwrap()
        .simulation;
    sim.world.resource_mut::<SimClock>().time = 1.0e20;
    let failure = sim.step().unwrap_err();
    assert_eq!(failure.stage, Stage::PreStep);
    assert!(
        failure
            .message
            .contains("cannot advance the clock from t = 1e20 s"),
        "{failure}"
    );
}

/// Finite velocities whose energy overflows stop the run at the series row, naming the most
/// energetic particle, instead of writing `inf` into the series.
#[test]
fn energies_that_overflow_stop_the_run_naming_the_particle() {
    let file = scene("(0.0, 0.0)", "");
    let mut built = build_simulation(&file, &fractum_systems::stock_registry()).unwrap();
    let world = &mut built.simulation.world;
    let mut query = world.query_filtered::<&mut Velocity<Two>, With<Particle>>();
    if let Some(mut v) = query.iter_mut(world).next() {
        v.0 = DVec2::new(0.0, 1.0e200);
    }
    let out = temp_dir("overflow");
    let error = run(&mut built.simulation, &built.output, &out, |_| {}).unwrap_err();
    let RunError::Blowup(blowup, _) = error else {
        panic!("expected a blow-up, got {error}");
    };
    assert_eq!(blowup.stage, Stage::PostStep);
    assert!(
        blowup.message.contains("kinetic_energy is inf")
            && blowup.message.contains("has velocity [0.0, 1e200]"),
        "{blowup}"
    );
    let series = std::fs::read_to_string(out.join("series.csv")).unwrap();
    assert!(!series.contains("inf"), "{series}");
    let _ = std::fs::remove_dir_all(&out);
}

/// Publishes `broken_column`, which turns NaN in step 4 (the clock still reads 3; as a damage law's energy account does
/// when it divides by a vanishing softening modulus).
fn broken_column(
    slot: Res<BrokenColumnSlot>,
    mut columns: ResMut<SeriesColumns>,
    clock: Res<SimClock>,
) {
    columns.values[slot.0] = if clock.step >= 3 { f64::NAN } else { 1.0 };
}

/// The slot `damage/broken_column` publishes into.
#[derive(Resource)]
struct BrokenColumnSlot(usize);

fn broken_column_install(installer: &mut Installer, _: &Params) -> Result<(), SceneError> {
    let slot = installer.add_series_column("broken_column");
    installer.insert_resource(BrokenColumnSlot(slot));
    installer.add_systems(broken_column);
    Ok(())
}

/// A system's series column that turns NaN stops the run (its particles all finite) instead
/// of writing NaN into `series.csv`; the rows before it are kept.
#[test]
fn a_non_finite_series_column_stops_the_run_naming_the_column() {
    let mut registry = fractum_systems::stock_registry();
    registry
        .register(Registration {
            name: "damage/broken_column",
            summary: "publishes a column that is NaN from step 4",
            params: &[],
            requires: &[],
            install: broken_column_install,
        })
        .unwrap();
    let file = scene("(0.0, 0.0)", r#", (system: "damage/broken_column")"#);
    let mut built = build_simulation(&file, &registry).unwrap();
    built.output.csv_every = 1;
    let out = temp_dir("nan-column");
    let error = run(&mut built.simulation, &built.output, &out, |_| {}).unwrap_err();
    let RunError::Blowup(blowup, _) = error else {
        panic!("expected a blow-up, got {error}");
    };
    assert_eq!((blowup.step, blowup.stage), (4, Stage::PostStep));
    assert!(
        blowup
            .message
            .starts_with("the series column broken_column is NaN after the step: particle "),
        "{blowup}"
    );
    let series = std::fs::read_to_string(out.join("series.csv")).unwrap();
    assert!(!series.contains("NaN"), "{series}");
    // The header and the rows of steps 0 to 3.
    assert_eq!(series.lines().count(), 5, "{series}");
    let _ = std::fs::remove_dir_all(&out);
}

/// A `Track` probe whose particle has left the grid under `Remove` reads NaN, by design: that
/// is the one non-finite value a series may hold, and the run goes on.
#[test]
fn a_track_probe_of_a_removed_particle_reads_nan_and_the_run_goes_on() {
    let text = r#"(
    time: (step: Fixed(1.0e-3), end: Steps(10)),
    safety: (on_leave_grid: Remove),
    grid: (min: (0.0, 0.0), max: (1.0, 1.0), spacing: 0.1),
    materials: { "m": (density: 1.0, youngs_modulus: 1.0, poisson_ratio: 0.0) },
    bodies: [
        (name: "still", shape: Rectangle(min: (0.1, 0.4), max: (0.3, 0.6)), material: "m"),
        (name: "leaving", shape: Rectangle(min: (0.8, 0.4), max: (1.0, 0.6)), material: "m",
         velocity: Uniform((10.0, 0.0))),
    ],
    output: (csv_every: 1, probes: [Track(name: "edge", body: "leaving", at: (0.975, 0.425))]),
    pipeline: [(system: "basis/linear"), (system: "predictor/usl"),
               (system: "stress/linear_elastic"), (system: "advection/usl")],
)"#;
    let file = SceneFile::parse("inline.ron", text.to_string()).unwrap_or_else(|e| panic!("{e}"));
    let mut built = build_simulation(&file, &fractum_systems::stock_registry()).unwrap();
    let out = temp_dir("track-nan");
    run(&mut built.simulation, &built.output, &out, |_| {}).unwrap_or_else(|e| panic!("{e}"));
    let series = std::fs::read_to_string(out.join("series.csv")).unwrap();
    let header: Vec<&str> = series.lines().next().unwrap().split(',').collect();
    let last: Vec<&str> = series.lines().last().unwrap().split(',').collect();
    assert_eq!(last[0], "10", "{series}");
    for (name, value) in header.iter().zip(&last) {
        let finite = value.parse::<f64>().unwrap().is_finite();
        assert_eq!(finite, !name.starts_with("track_edge"), "{name} = {value}");
    }
    let _ = std::fs::remove_dir_all(&out);
}

/// A frame that cannot be written stops the run with an error naming the file, and the rows
/// taken before it are on disk, not lost in the series' buffer. Frames are written behind the
/// steps, so the failure surfaces when the run next hands over a frame (or waits for them): by
/// the next frame's step at the latest.
#[test]
fn a_failed_frame_write_keeps_the_rows_before_it() {
    let file = scene("(0.0, 0.0)", "");
    let mut built = build_simulation(&file, &fractum_systems::stock_registry()).unwrap();
    built.output.vtu_every = 40;
    built.output.csv_every = 1;
    let out = temp_dir("failed-write");
    // A folder where the frame of step 40 should go makes that write fail.
    let blocked = out.join("frames/particles_00000040.vtu");
    std::fs::create_dir_all(&blocked).unwrap();
    let error = run(&mut built.simulation, &built.output, &out, |_| {}).unwrap_err();
    let RunError::Io { path, .. } = &error else {
        panic!("expected a write error, got {error}");
    };
    assert_eq!(path, &blocked, "{error}");
    let series = std::fs::read_to_string(out.join("series.csv")).unwrap();
    let steps: Vec<u64> = series
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    // Every row up to the failed frame's step, in order, and none past the next frame's.
    assert_eq!(steps[..41], (0..=40).collect::<Vec<u64>>()[..], "{series}");
    let last = *steps.last().unwrap();
    assert!((40..=80).contains(&last), "{series}");
    assert!(steps.windows(2).all(|w| w[1] == w[0] + 1), "{series}");
    let _ = std::fs::remove_dir_all(&out);
}
