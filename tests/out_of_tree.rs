//! A system written once outside the stock crate, generic over the dimension, registered next
//! to the stock systems and used in a 2D and a 3D scene built in code. This is the pattern a
//! user's crate follows (README, "Adding your own system").

use fractum_engine::prelude::*;
use fractum_engine::scene::{Body, Boundary, Condition, InitialVelocity, Shape, Spec};
use fractum_engine::simulation::{End, TimeStep};
use serde::Deserialize;

/// Parameters of `damage/overstress`.
#[derive(Resource, Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
struct Overstress {
    strength: f64,
}

/// A particle fails outright once its largest principal stress exceeds the strength. Written
/// once: `D` is 2D plane strain or 3D.
fn overstress<D: Dim>(
    limit: Res<Overstress>,
    mut particles: Query<(&Stress<D>, &mut Damage), With<Particle>>,
) {
    for (stress, mut damage) in &mut particles {
        if stress.0.largest_principal() > limit.strength {
            damage.0 = 1.0;
        }
    }
}

fn install(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let parsed: Overstress = params.parse()?;
    if !(parsed.strength.is_finite() && parsed.strength > 0.0) {
        return Err(params.error("strength", "expected a positive strength (Pa)"));
    }
    installer.insert_resource(parsed);
    with_dim!(installer.dimension(), D => installer.add_systems(overstress::<D>));
    Ok(())
}

const OVERSTRESS: Registration = Registration {
    name: "damage/overstress",
    summary: "a particle fails once its largest principal stress exceeds the strength",
    params: &[ParamDoc {
        name: "strength",
        ty: "f64",
        default: None,
        doc: "tensile strength (Pa)",
    }],
    requires: &[],
    install,
};

/// A bar stretched along x at 0.1 /s, its left end on rollers and its right end pulled at
/// 0.1 m/s (σ_xx = E ε̇ t = 100 t with E = 1000, ν = 0), in `D`.
fn stretched_bar<D: Dim>() -> Spec<D> {
    let grid = Grid::<D> {
        min: D::Vector::ZERO,
        spacing: 0.1,
        cells: D::Cell::from_fn(|a| if a == 0 { 10 } else { 2 }),
        graded: None,
    };
    let shape = match D::N {
        2 => Shape::Rectangle {
            min: DVec2::ZERO,
            max: DVec2::new(1.0, 0.2),
        },
        _ => Shape::Box {
            min: DVec3::ZERO,
            max: DVec3::new(1.0, 0.2, 0.2),
        },
    };
    let stretching = D::Matrix::from_fn(|i, j| if (i, j) == (0, 0) { 0.1 } else { 0.0 });
    let end = |x: f64| {
        (
            D::Vector::from_fn(|a| if a == 0 { x } else { 0.0 }),
            D::Vector::from_fn(|a| if a == 0 { x } else { 0.2 }),
        )
    };
    let (left_min, left_max) = end(0.0);
    let (right_min, right_max) = end(1.0);
    let pulled = Condition::Velocity([Some(vec![(0.0, 0.1)]), None, None]);
    Spec::new(grid)
        .time(TimeStep::Fixed(1e-3), End::Steps(40))
        .material(Material::new("m", 1.0, 1000.0, 0.0))
        .body(Body::new(shape, "m").velocity(InitialVelocity::Linear {
            gradient: stretching,
            origin: D::Vector::ZERO,
        }))
        .boundary(Boundary::new(
            "left",
            left_min,
            left_max,
            Condition::Roller { normal: 0 },
        ))
        .boundary(Boundary::new("right", right_min, right_max, pulled))
        .system("basis/linear")
        .system("predictor/usl")
        .system("stress/linear_elastic")
        .system_with("damage/overstress", "(strength: 2.0)")
        .system("advection/usl")
}

/// Steps until some particle fails and returns that step.
fn first_failure<D: Dim>(registry: &Registry) -> u64 {
    let mut sim = stretched_bar::<D>()
        .build(registry)
        .unwrap_or_else(|e| panic!("{e}"))
        .simulation;
    while !sim.finished() {
        sim.step().unwrap_or_else(|e| panic!("{e}"));
        let mut damage = sim.world.query_filtered::<&Damage, With<Particle>>();
        if damage.iter(&sim.world).any(|d| d.0 == 1.0) {
            return sim.clock().step;
        }
    }
    panic!("no particle failed");
}

#[test]
fn a_user_system_written_once_runs_in_2d_and_3d() {
    let mut registry = fractum_systems::stock_registry();
    registry.register(OVERSTRESS).unwrap();
    // σ_xx grows by 0.1 Pa per step: it passes 2 Pa during step 20 or 21 (round-off decides),
    // the same step in both dimensions.
    let two = first_failure::<Two>(&registry);
    let three = first_failure::<Three>(&registry);
    assert!((20..=21).contains(&two), "2D: step {two}");
    assert_eq!(two, three);
}
