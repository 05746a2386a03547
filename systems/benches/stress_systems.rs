//! The stock stress systems as a step runs them: one system over 100k particles (2D and 3D),
//! each particle with its own velocity gradient (read from its affine velocity, as under
//! `predictor/mls`), in a bevy schedule on one thread.
//!
//! What it measures is the arithmetic of the update and the columns it streams, so it is the
//! benchmark of `fractum_engine::vector_isa`: run it twice, once as is (the widest instruction
//! set the CPU has) and once with `FRACTUM_VECTOR_ISA=baseline`, and compare.
//!
//! `cargo bench -p fractum-systems --features bench --bench stress_systems`

use criterion::{Criterion, criterion_group, criterion_main};
use fractum_engine::prelude::*;
use fractum_engine::testing::tiny_world;
use fractum_engine::vector_isa::VectorIsa;
use fractum_systems::stress::linear_elastic::linear_elastic_stress;
use fractum_systems::stress::neo_hookean::neo_hookean_stress;
use fractum_systems::transfer::GradientInAffineVelocity;
use std::time::Duration;

/// Particles per world.
const PARTICLES: usize = 100_000;

/// A world of `PARTICLES` particles whose velocity gradients differ from row to row, with the
/// resources a stress system reads.
fn world<D: Dim>() -> World {
    let mut world = tiny_world::<D>(2, 1.0, 1e-4);
    world.insert_resource(GradientInAffineVelocity);
    for p in 0..PARTICLES {
        let s = p as f64 / PARTICLES as f64;
        let x = D::Vector::from_fn(|a| 0.5 + 0.5 * s + 0.1 * a as f64);
        let gradient = D::Matrix::from_fn(|i, j| 0.1 * (s + i as f64) - 0.07 * j as f64);
        let id = spawn_particle_in::<D>(&mut world, x);
        world.entity_mut(id).insert(AffineVelocity::<D>(gradient));
    }
    world
}

fn spawn_particle_in<D: Dim>(world: &mut World, x: D::Vector) -> Entity {
    let mut bundle = ParticleBundle::<D>::new(0, x, 1.0, 1e-4, 0);
    bundle.velocity.0 = D::Vector::ZERO;
    world.spawn(bundle).id()
}

fn stress_systems<D: Dim>(c: &mut Criterion) {
    let isa = VectorIsa::selected().describe();
    let mut schedules = [
        ("stress/linear_elastic", Schedule::default()),
        ("stress/neo_hookean", Schedule::default()),
    ];
    schedules[0].1.add_systems(linear_elastic_stress::<D>);
    schedules[1].1.add_systems(neo_hookean_stress::<D>);
    for (name, schedule) in &mut schedules {
        let mut world = world::<D>();
        schedule.run(&mut world);
        c.bench_function(
            &format!("{name}, {PARTICLES} particles, {}D, {isa}", D::N),
            |b| b.iter(|| schedule.run(&mut world)),
        );
    }
}

fn benches(c: &mut Criterion) {
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .ok();
    stress_systems::<Two>(c);
    stress_systems::<Three>(c);
}

// The macro generates an undocumented function.
#[allow(missing_docs)]
mod group {
    use super::*;
    criterion_group! {
        name = stress;
        config = Criterion::default()
            .sample_size(20)
            .measurement_time(Duration::from_secs(3))
            .warm_up_time(Duration::from_secs(1));
        targets = benches
    }
}
use group::stress;
criterion_main!(stress);
