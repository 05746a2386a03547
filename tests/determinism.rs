//! The same scene gives bitwise-identical results with 1 and 2 threads.

use fractum_engine::prelude::*;
use fractum_engine::scene::{End, SceneFile, build_simulation};
use fractum_suite::repo_root;

const LME_NEWMARK: &str = r#"(system: "basis/lme", params: (gamma: 3.5)), (system: "predictor/newmark"),
    (system: "stress/neo_hookean"), (system: "corrector/newmark"), (system: "advection/newmark")"#;

/// The two-disk scene, with its pipeline replaced when `pipeline` is given.
fn two_disks(pipeline: Option<&str>) -> SceneFile {
    let mut text = std::fs::read_to_string(repo_root().join("scenes/two_disks.ron")).unwrap();
    if let Some(pipeline) = pipeline {
        let start = text.find("    pipeline: [").unwrap();
        text = format!("{}    pipeline: [{pipeline}],\n)\n", &text[..start]);
    }
    SceneFile::parse("two_disks.ron", text).unwrap_or_else(|e| panic!("{e}"))
}

fn state_after(pipeline: Option<&str>, threads: usize, steps: u64) -> Vec<u64> {
    let mut built =
        build_simulation(&two_disks(pipeline), &fractum_systems::stock_registry()).unwrap();
    let sim = &mut built.simulation;
    sim.set_threads(threads).unwrap();
    sim.set_end(End::Steps(steps));
    while !sim.finished() {
        sim.step().unwrap();
    }
    let mut query = sim
        .world
        .query_filtered::<(&ParticleId, &Position, &Velocity, &Stress, &Volume), With<Particle>>();
    let mut rows: Vec<_> = query.iter(&sim.world).collect();
    rows.sort_by_key(|r| r.0.0);
    rows.iter()
        .flat_map(|(_, x, v, s, vol)| {
            [
                x.0.x, x.0.y, v.0.x, v.0.y, s.0.xx, s.0.yy, s.0.zz, s.0.xy, vol.0,
            ]
            .map(f64::to_bits)
        })
        .collect()
}

fn assert_same(one: &[u64], two: &[u64]) {
    assert_eq!(one.len(), two.len());
    let differing = one.iter().zip(two).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "{differing} of {} values differ", one.len());
}

#[test]
fn linear_usl_one_and_two_threads_give_identical_bits() {
    // 1700 steps of 1 ms take the disks through first contact (about t = 1.6 s).
    assert_same(&state_after(None, 1, 1700), &state_after(None, 2, 1700));
}

#[test]
fn lme_newmark_neo_hookean_one_and_two_threads_give_identical_bits() {
    assert_same(
        &state_after(Some(LME_NEWMARK), 1, 1700),
        &state_after(Some(LME_NEWMARK), 2, 1700),
    );
}
