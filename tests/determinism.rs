//! The same scene gives bitwise-identical results with 1 and 2 threads, in 2D and in 3D.

use fractum_engine::prelude::*;
use fractum_engine::simulation::End;
use fractum_scene::{PipelineEntry, SceneFile, Spec};
use fractum_suite::repo_root;

/// Basis, integrator and stress: LME + Newmark + neo-Hookean.
fn lme_newmark() -> Vec<PipelineEntry> {
    vec![
        PipelineEntry::with_params("basis/lme", "(gamma: 3.5)"),
        PipelineEntry::new("predictor/newmark"),
        PipelineEntry::new("stress/neo_hookean"),
        PipelineEntry::new("corrector/newmark"),
        PipelineEntry::new("advection/newmark"),
    ]
}

/// The spec of a shipped scene, with its pipeline replaced when `pipeline` is given.
fn spec<D: Dim>(scene: &str, pipeline: Option<Vec<PipelineEntry>>) -> Spec<D> {
    let file =
        SceneFile::read(&repo_root().join("scenes").join(scene)).unwrap_or_else(|e| panic!("{e}"));
    let spec = Spec::<D>::from_file(&file).unwrap_or_else(|e| panic!("{e}"));
    match pipeline {
        Some(entries) => spec.with_pipeline(entries),
        None => spec,
    }
}

/// The bits of every particle's position, velocity, stress and volume after `steps` steps.
fn state_after<D: Dim>(spec: Spec<D>, threads: usize, steps: u64) -> Vec<u64> {
    let mut built = spec
        .build(&fractum_systems::stock_registry())
        .unwrap_or_else(|e| panic!("{e}"));
    let sim = &mut built.simulation;
    // Really on `threads` threads, however small the scene.
    sim.set_serial_below(0);
    sim.set_threads(threads).unwrap();
    sim.set_end(End::Steps(steps));
    while !sim.finished() {
        sim.step().unwrap();
    }
    let mut query = sim.world.query_filtered::<(
        &ParticleId,
        &Position<D>,
        &Velocity<D>,
        &Stress<D>,
        &Volume,
    ), With<Particle>>();
    let mut rows: Vec<_> = query.iter(&sim.world).collect();
    rows.sort_by_key(|r| r.0.0);
    rows.iter()
        .flat_map(|(_, x, v, s, vol)| {
            let mut values: Vec<f64> = x.0.to_3d().into();
            values.extend(v.0.to_3d());
            values.extend(s.0.as_3x3());
            values.push(vol.0);
            values.into_iter().map(f64::to_bits)
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
    let run = |threads| state_after(spec::<Two>("two_disks.ron", None), threads, 1700);
    assert_same(&run(1), &run(2));
}

#[test]
fn lme_newmark_neo_hookean_one_and_two_threads_give_identical_bits() {
    let run = |threads| {
        state_after(
            spec::<Two>("two_disks.ron", Some(lme_newmark())),
            threads,
            1700,
        )
    };
    assert_same(&run(1), &run(2));
}

#[test]
fn three_dimensions_one_and_two_threads_give_identical_bits() {
    // 2000 steps of 1 ms take the spheres through first contact (about t = 1.85 s).
    let run = |threads| state_after(spec::<Three>("two_spheres.ron", None), threads, 2000);
    assert_same(&run(1), &run(2));
    // LME + Newmark + neo-Hookean, 50 steps: the 3D kd-tree, λ solves and transposed gathers.
    let run = |threads| {
        state_after(
            spec::<Three>("two_spheres.ron", Some(lme_newmark())),
            threads,
            50,
        )
    };
    assert_same(&run(1), &run(2));
}

#[test]
fn dfg_partition_and_contact_one_and_two_threads_give_identical_bits() {
    // The contact disks with the damage-field-gradient partition and surface detection on top
    // of the two contact groups: up to four fields per node, contact through impact.
    let mut spec = spec::<Two>("two_disks_contact.ron", None);
    let partition = spec
        .pipeline
        .iter()
        .position(|e| e.system == "partition/bodies")
        .unwrap();
    spec.pipeline[partition] = PipelineEntry::with_params("partition/dfg", "(surface: 0.8)");
    let run = |threads| state_after(spec.clone(), threads, 1700);
    assert_same(&run(1), &run(2));
}

#[test]
fn penalty_contact_one_and_two_threads_give_identical_bits() {
    // The disks through their impact (surfaces touch at t = 1.55 s) with friction, so that
    // both the normal and the tangential pair forces act.
    let mut spec = spec::<Two>("two_disks_penalty.ron", None);
    let contact = spec
        .pipeline
        .iter()
        .position(|e| e.system == "contact/penalty")
        .unwrap();
    spec.pipeline[contact] = PipelineEntry::with_params("contact/penalty", "(friction: 0.3)");
    let run = |threads| state_after(spec.clone(), threads, 1700);
    assert_same(&run(1), &run(2));
}

#[test]
fn usl_contact_in_the_grid_update_one_and_two_threads_give_identical_bits() {
    // GIMP shape functions, frictional contact correcting the USL grid update: the block slides
    // for 0.17 s; 1000 steps cover a third of it.
    let spec = spec::<Two>("sliding_block.ron", None);
    let run = |threads| state_after(spec.clone(), threads, 1000);
    assert_same(&run(1), &run(2));
}

#[test]
fn a_small_scene_steps_on_one_thread_unless_told_otherwise() {
    let mut built = spec::<Two>("two_disks.ron", None)
        .build(&fractum_systems::stock_registry())
        .unwrap_or_else(|e| panic!("{e}"));
    let sim = &mut built.simulation;
    assert!(sim.particle_count() < sim.serial_below());
    // No thread count set (rayon's global pool): the small scene steps on the calling thread.
    assert_eq!(sim.threads(), 1);
    sim.set_threads(2).unwrap();
    assert_eq!((sim.threads(), sim.threads_asked()), (1, 2));
    sim.set_serial_below(0);
    assert_eq!(sim.threads(), 2);
}

#[test]
fn time_to_failure_with_weibull_strength_one_and_two_threads_give_identical_bits() {
    // The strip's crack running (steps 250-400), with strengths drawn per particle: damage in
    // the stress (eqs. 26-27) and the transfer without the 1 - D scaling.
    let mut spec = spec::<Two>("time_to_failure_strip.ron", None);
    let damage = spec
        .pipeline
        .iter()
        .position(|e| e.system == "damage/time_to_failure")
        .unwrap();
    spec.pipeline[damage] = PipelineEntry::with_params(
        "damage/time_to_failure",
        "(tensile_strength: 100.0, crack_speed: 200.0, weibull: (modulus: 6.0, \
         reference_volume: 1.0e-7, seed: 3, thickness: 1.0e-3))",
    );
    let run = |threads| state_after(spec.clone(), threads, 400);
    assert_same(&run(1), &run(2));
}
