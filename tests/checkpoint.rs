//! Checkpoint and restart: a run of 2N steps, and a run of N steps continued from its
//! checkpoint for N more, end bitwise in the same state with the same `series.csv` and frames.
//! One scene per kind of state a checkpoint must carry: LME warm starts and kd-tree candidate
//! lists with eigensoftening's openings mid-softening; two bodies in contact under Newmark
//! (force-probe memory, energy account); DFG partitioning with surface detection (its
//! neighbour lists and the once-only detection flag); particles removed on leaving the grid.

use fractum_engine::components::{CrackOpening, Damage};
use fractum_engine::simulation::End;
use fractum_io::checkpoint::{SceneRecord, WorldState, capture, list_checkpoints, read_checkpoint};
use fractum_io::run::{CheckpointPlan, RunOptions, resume_from, run_with};
use fractum_scene::{Built, SceneFile, build_simulation};
use fractum_suite::{repo_root, temp_dir};
use std::path::Path;

/// The name scenes are built under: a file in `scenes/`, so that the geometry files shipped
/// scenes name (`geometry/sphere.stl`) are found beside it.
fn scene_name() -> String {
    repo_root()
        .join("scenes/checkpoint-test.ron")
        .display()
        .to_string()
}

fn build(text: &str) -> Built {
    let file = SceneFile::parse(&scene_name(), text.to_string()).expect("scene parses");
    build_simulation(&file, &fractum_systems::stock_registry()).expect("scene builds")
}

fn record(text: &str) -> SceneRecord {
    SceneRecord {
        path: scene_name(),
        text: text.to_string(),
    }
}

/// Runs `text` to step `end` into `dir`, with checkpoints every `every` steps when asked.
fn run_to(text: &str, dir: &Path, end: u64, every: Option<u64>) -> WorldState {
    let mut built = build(text);
    built.simulation.set_end(End::Steps(end));
    let options = RunOptions {
        checkpoints: every.map(|n| CheckpointPlan {
            every: fractum_io::checkpoint::CheckpointEvery::Steps(n),
            keep: 2,
        }),
        scene: Some(record(text)),
        ..RunOptions::default()
    };
    run_with(&mut built.simulation, &built.output, dir, options, |_| {}).expect("run");
    capture(&mut built.simulation.world).expect("capture")
}

/// Continues the run in `dir` from its newest checkpoint to step `end`.
fn resume_to(dir: &Path, end: u64) -> WorldState {
    let (_, newest) = list_checkpoints(dir).pop().expect("a checkpoint");
    let checkpoint = read_checkpoint(&newest).expect("readable checkpoint");
    let mut built = build(&checkpoint.scene.text);
    let outputs = resume_from(&mut built.simulation, dir, &checkpoint).expect("resume");
    built.simulation.set_end(End::Steps(end));
    let options = RunOptions {
        scene: Some(checkpoint.scene.clone()),
        resume: Some(outputs),
        ..RunOptions::default()
    };
    run_with(&mut built.simulation, &built.output, dir, options, |_| {}).expect("resumed run");
    capture(&mut built.simulation.world).expect("capture")
}

/// The outputs of `a` and `b` are the same files with the same bytes.
fn assert_same_outputs(a: &Path, b: &Path) {
    let read = |p: &Path| std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    assert!(
        read(&a.join("series.csv")) == read(&b.join("series.csv")),
        "series.csv differs between {} and {}",
        a.display(),
        b.display()
    );
    let frames = |d: &Path| {
        let mut names: Vec<String> = std::fs::read_dir(d.join("frames"))
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    };
    assert_eq!(frames(a), frames(b));
    for name in frames(a) {
        let path = Path::new("frames").join(&name);
        assert!(
            read(&a.join(&path)) == read(&b.join(&path)),
            "{name} differs"
        );
    }
    assert_eq!(
        read(&a.join("particles.pvd")),
        read(&b.join("particles.pvd"))
    );
}

/// Runs `text` for 2N steps straight, and N + N through a checkpoint, and compares.
fn assert_resume_is_bitwise(name: &str, text: &str, n: u64) -> WorldState {
    let straight = temp_dir(&format!("{name}-straight"));
    let split = temp_dir(&format!("{name}-split"));
    let whole = run_to(text, &straight, 2 * n, None);
    let halfway = run_to(text, &split, n, Some(n / 2));
    assert_ne!(halfway, whole, "{name}: the two halves should differ");
    let resumed = resume_to(&split, 2 * n);
    assert!(
        resumed == whole,
        "{name}: the resumed run's state differs from the straight run's"
    );
    assert_same_outputs(&straight, &split);
    let _ = std::fs::remove_dir_all(&straight);
    let _ = std::fs::remove_dir_all(&split);
    whole
}

fn scene(name: &str) -> String {
    std::fs::read_to_string(repo_root().join("scenes").join(name)).unwrap()
}

/// The values of the carried component `C`, found by its checkpoint key.
fn component<C: fractum_io::checkpoint::State>(state: &WorldState) -> Vec<C> {
    let bytes = &state
        .components
        .iter()
        .find(|(n, _)| n == C::KEY)
        .unwrap_or_else(|| panic!("no component {}", C::KEY))
        .1;
    let values: Vec<Option<C>> = postcard::from_bytes(bytes).unwrap();
    values.into_iter().flatten().collect()
}

/// LME + Newmark + eigensoftening, checkpointed at step 120: softening began at step 101.
#[test]
fn lme_newmark_eigensoftening_resumes_bitwise() {
    let text = scene("tension_softening.ron")
        .replace(
            "(system: \"basis/linear\")",
            "(system: \"basis/lme\", params: (gamma: 1.8))",
        )
        .replace("predictor/usl", "predictor/newmark")
        .replace(
            "(system: \"advection/usl\")",
            "(system: \"corrector/newmark\"), (system: \"advection/newmark\")",
        );
    let state = assert_resume_is_bitwise("softening", &text, 120);
    // The run got into softening: some crack opening is carried.
    let openings: Vec<CrackOpening> = component(&state);
    assert!(openings.iter().any(|w| w.0 > 0.0), "no crack opened");
}

/// Two disks meeting under frictional contact (Newmark), resumed in the middle of the impact,
/// with the force probe of one disk in the series.
#[test]
fn contact_resumes_bitwise_through_an_impact() {
    let text =
        scene("two_disks_contact.ron").replace("probes: [", "probes: [Force(\"lower-left\"), ");
    assert!(text.contains("Force(\"lower-left\")"));
    assert_resume_is_bitwise("contact", &text, 1700);
}

/// DFG partitioning with surface detection (self-contact): its neighbour lists and the
/// detection done once at the start are carried.
#[test]
fn dfg_self_contact_resumes_bitwise() {
    assert_resume_is_bitwise("dfg", &scene("billet_self_contact.ron"), 40);
}

/// Particles removed on leaving the grid are removed again in their order, so the storage
/// order (and every sum over it) is the straight run's.
#[test]
fn removed_particles_resume_bitwise() {
    let text = scene("two_disks.ron")
        .replace("Uniform((0.1, 0.1))", "Uniform((-1.0, -0.5))")
        .replace(
            "output: (",
            "safety: (on_leave_grid: Remove),\n    output: (",
        );
    let state = assert_resume_is_bitwise("removal", &text, 200);
    assert!(state.removed.len() > 10, "too few particles left the grid");
    assert!(state.particles.len() > 100);
}

/// Every shipped scene resumes bitwise over a few steps: a system whose state a checkpoint
/// forgets shows here even before a test of its own exists.
#[test]
fn every_shipped_scene_resumes_bitwise_over_a_few_steps() {
    for path in fractum_suite::ron_files("scenes") {
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_resume_is_bitwise(&name, &text, 4);
    }
}

/// Rankine softening (local and non-local) and time-to-failure damage (with Weibull strengths)
/// carry their history.
#[test]
fn the_damage_laws_of_the_dfg_paper_resume_bitwise() {
    // The non-local bar is damaged from step 260 on.
    for (name, file, n) in [
        ("rankine", "tension_rankine.ron", 150),
        ("ttf", "time_to_failure_strip.ron", 150),
        ("nonlocal", "tension_nonlocal.ron", 300),
    ] {
        let state = assert_resume_is_bitwise(name, &scene(file), n);
        let damage: Vec<Damage> = component(&state);
        assert!(damage.iter().any(|d| d.0 > 0.0), "{file}: nothing damaged");
    }
}

/// A quasi-static run (mass scaled, with its kinetic watch) resumes bitwise: the series'
/// `kinetic_fraction` and the rows the watch judges are carried.
#[test]
fn a_quasi_static_run_resumes_bitwise() {
    let text = scene("tension_softening.ron").replace(
        "end: Time(4.0e-3))",
        "end: Time(4.0e-3), quasi_static: (mass_scaling: 4.0))",
    );
    assert!(text.contains("mass_scaling"));
    let state = assert_resume_is_bitwise("quasi-static", &text, 120);
    let watch = &state
        .resources
        .iter()
        .find(|(key, _)| key == "engine/kinetic_watch")
        .expect("the kinetic watch is carried")
        .1;
    let watch: fractum_engine::quasi_static::KineticWatch = postcard::from_bytes(watch).unwrap();
    assert!(watch.peak_stored > 0.0, "{watch:?}");
}

/// Every key the shipped scenes' checkpoints carry, sorted. The keys are explicit
/// (`checkpoint::State::KEY`), so this list changes only when a key is renamed or state is
/// added: a renamed key makes older checkpoints unreadable, so it must be a decision.
const STOCK_KEYS: &[&str] = &[
    "dfg/neighbours",
    "dfg/surface_detected",
    "eigenerosion/state",
    "engine/clock",
    "engine/contact_potential",
    "engine/energy_account",
    "engine/energy_watch",
    "engine/escaped_particles",
    "engine/field_splits",
    "engine/force_probes",
    "engine/kinetic_watch",
    "engine/series_columns",
    "kdtree/candidates",
    "lme/state",
    "particle/acceleration",
    "particle/affine_velocity",
    "particle/body",
    "particle/contact_group",
    "particle/crack_opening",
    "particle/damage",
    "particle/damage_dissipation",
    "particle/damage_gradient",
    "particle/damage_history",
    "particle/deformation_gradient",
    "particle/external_force",
    "particle/initial_volume",
    "particle/load_share",
    "particle/mass",
    "particle/material",
    "particle/position",
    "particle/reference_position",
    "particle/strain",
    "particle/strain_energy_density",
    "particle/strength",
    "particle/stress",
    "particle/surface_flag",
    "particle/velocity",
    "particle/viscous_dissipation",
    "particle/viscous_pressure",
    "particle/volume",
    "particle/wave_speed",
];

#[test]
fn checkpoint_keys_are_stable_and_unique() {
    let mut keys = std::collections::BTreeSet::new();
    for path in fractum_suite::ron_files("scenes") {
        let mut built = fractum_suite::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let state = built
            .simulation
            .world
            .resource::<fractum_io::checkpoint::CheckpointState>();
        assert!(state.collisions().is_empty(), "{}", path.display());
        let names: Vec<&str> = state
            .component_names()
            .into_iter()
            .chain(state.resource_names())
            .collect();
        let unique: std::collections::BTreeSet<&str> = names.iter().copied().collect();
        assert_eq!(unique.len(), names.len(), "{}: {names:?}", path.display());
        keys.extend(names);
        let _ = capture(&mut built.simulation.world).expect("capture");
    }
    let keys: Vec<&str> = keys.into_iter().collect();
    assert_eq!(keys, STOCK_KEYS);
}

/// Two types asking for one key: the second is not carried silently over the first, and a
/// scene that would do so is refused.
#[test]
fn two_types_under_one_key_are_a_collision() {
    use fractum_io::checkpoint::CheckpointState;
    #[derive(serde::Serialize, serde::Deserialize, bevy_ecs::prelude::Resource)]
    struct First(u8);
    #[derive(serde::Serialize, serde::Deserialize, bevy_ecs::prelude::Resource)]
    struct Second(u8);
    fractum_engine::checkpoint_keys! { First => "test/shared", Second => "test/shared" }
    let mut state = CheckpointState::default();
    state.resource::<First>();
    state.resource::<First>();
    assert!(state.collisions().is_empty());
    state.resource::<Second>();
    assert_eq!(state.collisions(), ["test/shared"]);
    assert_eq!(state.resource_names(), ["test/shared"]);
}
