//! A system written once outside the stock crate, generic over the dimension, registered next
//! to the stock systems and used in a 2D and a 3D scene built in code. This is the pattern a
//! user's crate follows (README, "Adding your own system").

use fractum_engine::prelude::*;
use fractum_engine::simulation::{End, TimeStep};
use fractum_scene::{Body, Boundary, Condition, InitialVelocity, Shape, Spec};
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

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let parsed: Overstress = params.parse()?;
    if !(parsed.strength.is_finite() && parsed.strength > 0.0) {
        return Err(params.error("strength", "expected a positive strength (Pa)"));
    }
    installer.insert_resource(parsed);
    installer.add_systems(overstress::<D>);
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
    install: generic_install!(install),
};

/// A bar stretched along x at 0.1 /s, its left end on rollers and its right end pulled at
/// 0.1 m/s (σ_xx = E ε̇ t = 100 t with E = 1000, ν = 0), in `D`.
fn stretched_bar<D: Dim>() -> Spec<D> {
    let grid = Grid::<D> {
        min: D::Vector::ZERO,
        spacing: 0.1,
        cells: D::Cell::from_fn(|a| if a == 0 { 10 } else { 2 }),
        graded: None,
        window: None,
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

/// Parameters of `stress/simo_pister`: none, like `stress/neo_hookean`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct NoParams {}

/// What a hyperelastic stress update reads and writes per particle.
type HyperelasticParticles<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static MaterialId,
        &'static InitialVolume,
        &'static mut DeformationGradient<D>,
        &'static mut Stress<D>,
        &'static mut Volume,
        &'static mut StrainEnergyDensity,
    ),
    With<Particle>,
>;

/// A compressible neo-Hookean solid with the volumetric energy `κ/4 (J² − 1 − 2 ln J)`:
/// `W = μ/2 (tr C − 3) − μ ln J + κ/4 (J² − 1 − 2 ln J)`, so
/// `σ = μ/J (b − I) + κ/2 (J − 1/J) I`, with `F ← (I + Δt L) F` every step. Not a stock model:
/// a user's hyperelastic stress, written once for 2D and 3D.
fn simo_pister<D: Dim>(
    clock: Res<SimClock>,
    materials: Res<Materials>,
    connectivity: Res<Connectivity<D>>,
    nodes: Query<&NodeVelocity<D>, With<Node>>,
    mut particles: HyperelasticParticles<D>,
) {
    let node_velocity: Vec<NodeVelocity<D>> = nodes.iter().copied().collect();
    for (p, (material, v0, mut f, mut stress, mut volume, mut energy)) in
        particles.iter_mut().enumerate()
    {
        let (lambda, mu) = materials.0[material.0 as usize].lame();
        let kappa = lambda + 2.0 * mu / 3.0;
        let l = fractum_systems::transfer::velocity_gradient(&connectivity, &node_velocity, p);
        f.0 = (D::Matrix::IDENTITY + l * clock.dt) * f.0;
        let j = f.0.determinant();
        let pressure = 0.5 * kappa * (j - 1.0 / j) - mu / j;
        stress.0 = D::Sym::isotropic(pressure).add_scaled(&D::left_cauchy_green(f.0), mu / j);
        volume.0 = j * v0.0;
        let ln_j = j.ln();
        energy.0 = 0.5 * mu * (D::cauchy_green_trace(f.0) - 3.0) - mu * ln_j
            + 0.25 * kappa * (j * j - 1.0 - 2.0 * ln_j);
    }
}

fn install_simo_pister<D: Dim>(
    installer: &mut Installer,
    params: &Params,
) -> Result<(), SceneError> {
    params.parse::<NoParams>()?;
    // The promise damage/rankine relies on: a stress from a potential, recomputed every step.
    installer.provide::<HyperelasticStress>();
    installer.add_systems(simo_pister::<D>);
    Ok(())
}

/// The same system, installed without declaring the capability.
fn install_undeclared<D: Dim>(
    installer: &mut Installer,
    params: &Params,
) -> Result<(), SceneError> {
    params.parse::<NoParams>()?;
    installer.add_systems(simo_pister::<D>);
    Ok(())
}

const SIMO_PISTER: Registration = Registration {
    name: "stress/simo_pister",
    summary: "compressible neo-Hookean with the volumetric energy κ/4 (J² − 1 − 2 ln J)",
    params: &[],
    requires: &[],
    install: generic_install!(install_simo_pister),
};

const UNDECLARED: Registration = Registration {
    name: "stress/undeclared",
    summary: "the same stress, without the capability declared",
    params: &[],
    requires: &[],
    install: generic_install!(install_undeclared),
};

/// The stretched bar with `stress` and Rankine damage (σ_f = 2 Pa) in place of the overstress
/// law.
fn stretched_bar_with_rankine<D: Dim>(stress: &str) -> Spec<D> {
    let mut spec = stretched_bar::<D>();
    spec.pipeline.clear();
    spec.system("basis/linear")
        .system("predictor/usl")
        .system(stress)
        .system_with(
            "damage/rankine",
            "(tensile_strength: 2.0, fracture_energy: 1.0)",
        )
        .system("advection/usl")
}

/// A user's hyperelastic stress system qualifies for `damage/rankine` by the capability it
/// declares, not by its name: the bar softens once σ_xx passes the strength, in 2D and 3D. The
/// same system without the declaration, and the rate-form `stress/linear_elastic`, are refused
/// with the capability named.
#[test]
fn a_user_hyperelastic_stress_satisfies_rankine_by_its_capability() {
    let mut registry = fractum_systems::stock_registry();
    registry.register(SIMO_PISTER).unwrap();
    registry.register(UNDECLARED).unwrap();
    fn damaged<D: Dim>(registry: &Registry) -> usize {
        let mut sim = stretched_bar_with_rankine::<D>("stress/simo_pister")
            .build(registry)
            .unwrap_or_else(|e| panic!("{e}"))
            .simulation;
        while !sim.finished() {
            sim.step().unwrap_or_else(|e| panic!("{e}"));
        }
        let mut damage = sim.world.query_filtered::<&Damage, With<Particle>>();
        damage.iter(&sim.world).filter(|d| d.0 > 0.0).count()
    }
    // σ_xx ≈ E ε reaches 4 Pa by step 40, twice the strength: every particle softens.
    let (two, three) = (damaged::<Two>(&registry), damaged::<Three>(&registry));
    assert!(two > 0 && three > 0, "2D: {two}, 3D: {three} damaged");
    for refused in ["stress/undeclared", "stress/linear_elastic"] {
        let message = match stretched_bar_with_rankine::<Two>(refused).build(&registry) {
            Ok(_) => panic!("{refused} was accepted"),
            Err(e) => e.to_string(),
        };
        assert!(
            message.contains(
                "damage/rankine needs every stress system to provide a stress derived from a \
                 hyperelastic potential"
            ) && message.contains(&format!("; {refused} does not")),
            "{message}"
        );
    }
}

/// Under MLS-MPM (`basis/mls`, `predictor/mls`, `advection/mls`) the velocity gradient is the
/// particles' `C_p`, which a stress system reads through `transfer::VelocityGradients`. The
/// stock neo-Hookean stress declares so (`ReadsTransferGradient`), and with `damage/rankine`
/// the stretched bar softens as under USL; the user's stress above reads the connectivity, which
/// MLS does not build, and is refused with the capability named rather than given no gradient.
#[test]
fn under_mls_a_stress_system_reads_the_transfers_gradient() {
    let mut registry = fractum_systems::stock_registry();
    registry.register(SIMO_PISTER).unwrap();
    let mls = |stress: &str| {
        let mut spec = stretched_bar::<Two>();
        spec.pipeline.clear();
        spec.system("basis/mls")
            .system("predictor/mls")
            .system(stress)
            .system_with(
                "damage/rankine",
                "(tensile_strength: 2.0, fracture_energy: 1.0)",
            )
            .system("advection/mls")
    };
    let mut sim = mls("stress/neo_hookean")
        .build(&registry)
        .unwrap_or_else(|e| panic!("{e}"))
        .simulation;
    while !sim.finished() {
        sim.step().unwrap_or_else(|e| panic!("{e}"));
    }
    let mut damage = sim.world.query_filtered::<&Damage, With<Particle>>();
    let damaged = damage.iter(&sim.world).filter(|d| d.0 > 0.0).count();
    assert!(damaged > 0, "no particle softened under MLS");
    let message = match mls("stress/simo_pister").build(&registry) {
        Ok(_) => panic!("stress/simo_pister was accepted beside predictor/mls"),
        Err(e) => e.to_string(),
    };
    assert!(
        message.contains("advection/mls needs every stress system to provide a velocity gradient")
            && message.contains("; stress/simo_pister does not"),
        "{message}"
    );
}

/// Installs nothing from its params, as README's first example does.
fn install_ignoring_params(_: &mut Installer, _: &Params) -> Result<(), SceneError> {
    Ok(())
}

/// A user's system that never parses its params still has every field it does not declare
/// refused, at the field: the engine checks params against the registration's `params`.
#[test]
fn undeclared_params_are_refused_for_a_users_system_too() {
    let mut registry = fractum_systems::stock_registry();
    registry
        .register(Registration {
            name: "damage/silent",
            summary: "takes no parameters and reads none",
            params: &[],
            requires: &[],
            install: install_ignoring_params,
        })
        .unwrap();
    registry.register(OVERSTRESS).unwrap();
    let spec = |system: &str, params: &str| {
        let mut spec = stretched_bar::<Two>();
        spec.pipeline.retain(|e| !e.system.starts_with("damage/"));
        spec.system_with(system, params)
    };
    let message = match spec("damage/silent", "(strength: 2.0)").build(&registry) {
        Ok(_) => panic!("an undeclared parameter was accepted"),
        Err(e) => e.to_string(),
    };
    assert!(
        message.contains("unknown field `strength`; damage/silent takes no parameters"),
        "{message}"
    );
    let message = match spec("damage/overstress", "(strenght: 2.0)").build(&registry) {
        Ok(_) => panic!("a misspelt parameter was accepted"),
        Err(e) => e.to_string(),
    };
    assert!(
        message.contains("unknown field `strenght`; expected `strength`"),
        "{message}"
    );
}
