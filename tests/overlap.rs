//! Overlapping bodies: refused unless one body keeps the overlap (`wins_over`), when every place
//! is seeded once. The refusals' places and wording are in the bad-scene corpus.

use bevy_ecs::query::With;
use fractum_engine::components::{BodyId, InitialVolume, Particle};
use fractum_engine::prelude::*;
use fractum_engine::simulation::{End, TimeStep};
use fractum_scene::{Body, Shape, Spec};
use glam::DVec2;

const PLATE_AREA: f64 = 0.5;

fn plate() -> Body<Two> {
    Body::new(
        Shape::Rectangle {
            min: DVec2::ZERO,
            max: DVec2::new(1.0, 0.5),
        },
        "m",
    )
    .named("plate")
}

fn inclusion() -> Body<Two> {
    Body::new(
        Shape::Disk {
            center: DVec2::new(0.5, 0.25),
            radius: 0.1,
        },
        "m",
    )
    .named("inclusion")
}

fn scene(bodies: Vec<Body<Two>>) -> Spec<Two> {
    let grid = Grid::<Two> {
        min: DVec2::ZERO,
        spacing: 0.0125,
        cells: [80, 40],
        graded: None,
        window: None,
    };
    let mut spec = Spec::new(grid)
        .time(TimeStep::Fixed(1e-6), End::Steps(1))
        .material(Material::new("m", 1000.0, 1.0e6, 0.2));
    for body in bodies {
        spec = spec.body(body);
    }
    spec.system("basis/linear")
        .system("predictor/usl")
        .system("stress/linear_elastic")
        .system("advection/usl")
}

/// Each body's total particle volume, by body index.
fn volumes(spec: Spec<Two>) -> Vec<f64> {
    let mut built = spec
        .build(&fractum_systems::stock_registry())
        .unwrap_or_else(|e| panic!("{e}"));
    let world = &mut built.simulation.world;
    let mut totals = vec![0.0; built.body_particles.len()];
    let mut query = world.query_filtered::<(&BodyId, &InitialVolume), With<Particle>>();
    for (body, volume) in query.iter(world) {
        totals[usize::from(body.0)] += volume.0;
    }
    totals
}

#[test]
fn the_winner_keeps_the_overlap_and_every_place_is_seeded_once() {
    let inclusion_alone = volumes(scene(vec![inclusion()]))[0];
    let plate_alone = volumes(scene(vec![plate()]))[0];
    assert!((plate_alone - PLATE_AREA).abs() < 1e-12);
    let together = volumes(scene(vec![plate(), inclusion().wins_over("plate")]));
    assert_eq!(together[1], inclusion_alone, "the winner is seeded whole");
    assert!(
        (together[0] + together[1] - PLATE_AREA).abs() < 1e-12,
        "the plate gives up exactly the inclusion's particles: {together:?}"
    );
    // A body wholly inside one that wins over it would seed nothing: refused.
    let error = scene(vec![inclusion(), plate().wins_over("inclusion")])
        .build(&fractum_systems::stock_registry())
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(
        error.contains(
            "every particle of bodies[0] (\"inclusion\") lies inside bodies that win over it"
        ),
        "{error}"
    );
}

#[test]
fn overlapping_bodies_without_a_winner_are_refused_naming_both() {
    let error = scene(vec![plate(), inclusion()])
        .build(&fractum_systems::stock_registry())
        .map(|_| ())
        .unwrap_err()
        .to_string();
    for expected in [
        "bodies[1] (\"inclusion\") overlaps bodies[0] (\"plate\")",
        "`wins_over: [\"plate\"]` on bodies[1]",
        "`wins_over: [\"inclusion\"]` on bodies[0]",
    ] {
        assert!(error.contains(expected), "{error}");
    }
}

#[test]
fn bodies_that_only_touch_are_accepted() {
    let half = |x0: f64, name: &str| {
        Body::new(
            Shape::Rectangle {
                min: DVec2::new(x0, 0.0),
                max: DVec2::new(x0 + 0.5, 0.5),
            },
            "m",
        )
        .named(name)
    };
    let halves = volumes(scene(vec![half(0.0, "left"), half(0.5, "right")]));
    assert!((halves[0] + halves[1] - PLATE_AREA).abs() < 1e-12);
}
