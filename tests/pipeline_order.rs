//! The pipeline runs in stage order whatever the order of its entries in the scene; systems
//! registered from outside the stock crate (here, this test crate) plug in the same way; and two
//! systems of one stage that touch the same data without an order make the scene fail to load,
//! naming both.

use fractum_engine::prelude::*;
use fractum_scene::{SceneFile, build_simulation};

/// Stages in the order their systems ran.
#[derive(Resource, Default)]
struct Log(Vec<Stage>);

fn log_install(installer: &mut Installer, _: &Params) -> Result<(), SceneError> {
    let stage = installer.stage();
    installer.init_resource::<Log>();
    installer.add_systems(move |mut log: ResMut<Log>| log.0.push(stage));
    Ok(())
}

fn logger(name: &'static str) -> Registration {
    Registration {
        name,
        summary: "records that its stage ran",
        params: &[],
        requires: &[],
        install: log_install,
    }
}

const LOGGERS: [&str; 11] = [
    "pre_step/log",
    "neighbour/log",
    "basis/log",
    "predictor/log",
    "stress/log",
    "damage/log",
    "partition/log",
    "contact/log",
    "corrector/log",
    "advection/log",
    "post_step/log",
];

fn scene_with(pipeline: &str) -> SceneFile {
    let text = format!(
        r#"(
    time: (step: Fixed(1.0e-3), end: Steps(2)),
    grid: (min: (0.0, 0.0), max: (1.0, 1.0), spacing: 0.25),
    materials: {{ "m": (density: 1.0, youngs_modulus: 1.0, poisson_ratio: 0.0) }},
    bodies: [(shape: Disk(center: (0.5, 0.5), radius: 0.2), material: "m")],
    pipeline: [{pipeline}],
)"#
    );
    SceneFile::parse("inline.ron", text).unwrap_or_else(|e| panic!("{e}"))
}

fn stock_plus(name: &'static str, install: fractum_engine::registry::InstallFn) -> Registry {
    let mut registry = fractum_systems::stock_registry();
    registry
        .register(Registration {
            name,
            summary: "a test system",
            params: &[],
            requires: &[],
            install,
        })
        .unwrap();
    registry
}

fn registry_with_loggers() -> Registry {
    let mut registry = fractum_systems::stock_registry();
    for name in LOGGERS {
        registry.register(logger(name)).unwrap();
    }
    registry
}

#[test]
fn systems_run_in_stage_order_whatever_the_order_in_the_file() {
    let mut shuffled = LOGGERS.to_vec();
    // A fixed permutation that moves every entry.
    shuffled.reverse();
    shuffled.swap(0, 5);
    shuffled.swap(3, 9);
    let pipeline: Vec<String> = shuffled
        .iter()
        .map(|n| format!("(system: \"{n}\")"))
        .collect();
    let file = scene_with(&pipeline.join(", "));
    let mut built =
        build_simulation(&file, &registry_with_loggers()).unwrap_or_else(|e| panic!("{e}"));
    built.simulation.step().unwrap();
    built.simulation.step().unwrap();
    let log = &built.simulation.world.resource::<Log>().0;
    let once: Vec<Stage> = Stage::ORDER.to_vec();
    assert_eq!(log[..11], once[..]);
    assert_eq!(log[11..], once[..]);
}

fn first_writer(mut log: ResMut<Log>) {
    log.0.push(Stage::Damage);
}

fn second_writer(mut log: ResMut<Log>) {
    log.0.clear();
}

fn conflicting_install(installer: &mut Installer, _: &Params) -> Result<(), SceneError> {
    installer.init_resource::<Log>();
    installer.add_systems((first_writer, second_writer));
    Ok(())
}

#[test]
fn unordered_conflicting_systems_in_one_stage_fail_to_load_naming_them() {
    let registry = stock_plus("damage/conflicting", conflicting_install);
    let file = scene_with(
        r#"(system: "basis/linear"), (system: "predictor/usl"), (system: "stress/linear_elastic"),
           (system: "damage/conflicting"), (system: "advection/usl")"#,
    );
    let error = match build_simulation(&file, &registry) {
        Ok(_) => panic!("the scene loaded"),
        Err(e) => e.to_string(),
    };
    assert!(error.starts_with("inline.ron:"), "{error}");
    assert!(
        error.contains("first_writer") && error.contains("second_writer"),
        "{error}"
    );
}

#[test]
fn conflicting_systems_load_once_ordered() {
    fn ordered_install(installer: &mut Installer, _: &Params) -> Result<(), SceneError> {
        installer.init_resource::<Log>();
        installer.add_systems((first_writer, second_writer).chain());
        Ok(())
    }
    let registry = stock_plus("damage/ordered", ordered_install);
    let file = scene_with(
        r#"(system: "basis/linear"), (system: "predictor/usl"), (system: "stress/linear_elastic"),
           (system: "damage/ordered"), (system: "advection/usl")"#,
    );
    let mut built = build_simulation(&file, &registry).unwrap_or_else(|e| panic!("{e}"));
    built.simulation.step().unwrap();
    assert!(built.simulation.world.resource::<Log>().0.is_empty());
}

/// A contact registration that corrects the grid update (as `contact/frictional` does with
/// update-stress-last) runs after the predictor stage and before the stress stage.
#[test]
fn grid_update_corrections_run_between_predictor_and_stress() {
    fn early_install(installer: &mut Installer, _: &Params) -> Result<(), SceneError> {
        installer.init_resource::<Log>();
        installer.add_systems_to(StepSet::GridUpdateCorrection, |mut log: ResMut<Log>| {
            log.0.push(Stage::Contact)
        })
    }
    let mut registry = registry_with_loggers();
    registry
        .register(Registration {
            name: "contact/early",
            summary: "records that it ran",
            params: &[],
            requires: &[],
            install: early_install,
        })
        .unwrap();
    let pipeline: Vec<String> = LOGGERS
        .iter()
        .map(|n| n.replace("contact/log", "contact/early"))
        .map(|n| format!("(system: \"{n}\")"))
        .collect();
    let file = scene_with(&pipeline.join(", "));
    let mut built = build_simulation(&file, &registry).unwrap_or_else(|e| panic!("{e}"));
    built.simulation.step().unwrap();
    let log = &built.simulation.world.resource::<Log>().0;
    let mut expected: Vec<Stage> = Stage::ORDER.to_vec();
    expected.retain(|s| *s != Stage::Contact);
    expected.insert(4, Stage::Contact);
    assert_eq!(log[..], expected[..]);
}
