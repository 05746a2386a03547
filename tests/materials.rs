//! Pipeline entries limited to materials (`materials: [...]`): a steel body under
//! `stress/neo_hookean` and a rubber body under `stress/linear_elastic` in one run.

use fractum_engine::prelude::*;
use fractum_engine::simulation::{End, TimeStep};
use fractum_scene::{Body, InitialVelocity, PipelineEntry, Shape, Spec};

/// Two blocks stretched by their initial velocity, with the stress systems in `stress`.
fn blocks(stress: Vec<PipelineEntry>) -> Spec<Two> {
    blocks_moving(stress, DVec2::new(0.5, -0.2))
}

/// Two blocks with the initial velocity gradient `diag(rates)`, with the stress systems in
/// `stress`.
fn blocks_moving(stress: Vec<PipelineEntry>, rates: DVec2) -> Spec<Two> {
    let stretch = InitialVelocity::Linear {
        gradient: DMat2::from_diagonal(rates),
        origin: DVec2::ZERO,
    };
    let mut pipeline = vec![
        PipelineEntry::new("basis/linear"),
        PipelineEntry::new("predictor/usl"),
    ];
    pipeline.extend(stress);
    pipeline.push(PipelineEntry::new("advection/usl"));
    Spec::<Two>::new(Grid {
        min: DVec2::ZERO,
        spacing: 0.1,
        cells: [12, 6],
        graded: None,
        window: None,
    })
    .time(TimeStep::Fixed(1.0e-5), End::Steps(1))
    .material(Material::new("steel", 7800.0, 2.0e11, 0.3))
    .material(Material::new("rubber", 1000.0, 1.0e6, 0.45))
    .body(
        Body::new(
            Shape::Rectangle {
                min: DVec2::new(0.1, 0.1),
                max: DVec2::new(0.5, 0.5),
            },
            "steel",
        )
        .velocity(stretch.clone()),
    )
    .body(
        Body::new(
            Shape::Rectangle {
                min: DVec2::new(0.7, 0.1),
                max: DVec2::new(1.1, 0.5),
            },
            "rubber",
        )
        .velocity(stretch),
    )
    .with_pipeline(pipeline)
}

/// `(body, stress)` of every particle after one step.
fn stresses(spec: Spec<Two>) -> Vec<(u16, SymTensor2)> {
    let registry = fractum_systems::stock_registry();
    let mut sim = spec
        .build(&registry)
        .unwrap_or_else(|e| panic!("{e}"))
        .simulation;
    sim.step().unwrap_or_else(|e| panic!("{e}"));
    let mut q = sim.world.query::<(&BodyId, &Stress<Two>)>();
    q.iter(&sim.world).map(|(b, s)| (b.0, s.0)).collect()
}

/// Each body gets exactly the stress its own system gives when that system runs alone.
#[test]
fn each_material_is_stressed_by_its_own_system() {
    let mixed = stresses(blocks(vec![
        PipelineEntry::new("stress/neo_hookean").for_materials(&["steel"]),
        PipelineEntry::new("stress/linear_elastic").for_materials(&["rubber"]),
    ]));
    let neo = stresses(blocks(vec![PipelineEntry::new("stress/neo_hookean")]));
    let linear = stresses(blocks(vec![PipelineEntry::new("stress/linear_elastic")]));
    let mut differ = false;
    for ((m, n), l) in mixed.iter().zip(&neo).zip(&linear) {
        let expected = if m.0 == 0 { n.1 } else { l.1 };
        assert_eq!(m.1, expected, "body {}", m.0);
        differ |= n.1 != l.1;
    }
    // The two laws give different stresses here, so the test can tell them apart.
    assert!(differ);
}

/// A shock viscosity over every material beside two limited material laws: it claims no
/// material (it changes no stress), so the laws' coverage holds, and each body keeps its own
/// law's stress; the viscosity acts in the forces alone. Limited to steel, the rubber gets no
/// viscous pressure.
#[test]
fn a_shock_viscosity_claims_no_material_from_the_material_laws() {
    let laws = || {
        vec![
            PipelineEntry::new("stress/neo_hookean").for_materials(&["steel"]),
            PipelineEntry::new("stress/linear_elastic").for_materials(&["rubber"]),
        ]
    };
    // The viscosity's linear term lowers the stable step to 0.82 of the limit.
    let stepped = |mut spec: Spec<Two>| {
        spec.time_step = TimeStep::Fixed(8.0e-6);
        spec
    };
    let mut with_viscosity = laws();
    with_viscosity.push(PipelineEntry::new("stress/shock_viscosity"));
    assert_eq!(
        stresses(stepped(blocks(with_viscosity))),
        stresses(stepped(blocks(laws())))
    );
    let mut on_steel = laws();
    on_steel.push(PipelineEntry::new("stress/shock_viscosity").for_materials(&["steel"]));
    let registry = fractum_systems::stock_registry();
    let mut sim = stepped(blocks_moving(on_steel, DVec2::new(-0.5, -0.2)))
        .build(&registry)
        .unwrap_or_else(|e| panic!("{e}"))
        .simulation;
    sim.step().unwrap_or_else(|e| panic!("{e}"));
    let mut q = sim.world.query::<(&BodyId, &ViscousPressure)>();
    for (body, pressure) in q.iter(&sim.world) {
        // Both blocks shorten along both axes; only the steel (body 0) is priced.
        assert_eq!(
            pressure.0 > 0.0,
            body.0 == 0,
            "body {}: q = {}",
            body.0,
            pressure.0
        );
    }
}
