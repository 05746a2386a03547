//! Patch tests of every pipeline the documentation shows (`scenes/two_disks.ron`, SCENES.md's
//! minimal scene, the guide's LME swap, SCENES.md's impact pipeline): an elastic disk
//! falling freely five cells under gravity, translating rigidly five cells, and spinning
//! rigidly, with no boundary. Each must run to its end and create no energy; the centre of mass
//! falls at `g t` exactly, a translation keeps every particle's velocity, a rotation keeps most
//! of its angular velocity.
//!
//! `scenes/two_disks.ron` runs the tents with modified update-stress-last (`predictor/usl`,
//! `scheme: Musl`). With eq. 5's grid velocity instead (`scheme: Usl`) the tents pass the free
//! fall only: translating or spinning rigidly across cells, their cell-crossing term (a node a
//! particle has just reached gets `N ≈ 0` of its mass but its full `∇N`, `predictor/usl`'s
//! header) amplifies round-off at every crossing, the translating disk's strain energy grows
//! from 1e-31 J to 8.8 J by step 280, and the run stops at step 379 with an inverted volume
//! (step 87 spinning).

use fractum_engine::prelude::*;
use fractum_engine::simulation::{End, TimeStep};
use fractum_io::output::series_row;
use fractum_scene::{Body, InitialVelocity, PipelineEntry, Shape, Spec};

/// A documented pipeline.
struct Pipeline {
    /// Its name in messages.
    name: &'static str,
    /// Its entries, `(system, params)`.
    entries: &'static [(&'static str, Option<&'static str>)],
}

const PIPELINES: &[Pipeline] = &[
    Pipeline {
        name: "tents + MUSL (scenes/two_disks.ron)",
        entries: &[
            ("basis/linear", None),
            ("predictor/usl", Some("(scheme: Musl)")),
            ("stress/linear_elastic", None),
            ("advection/usl", None),
        ],
    },
    Pipeline {
        name: "B-splines + USL (SCENES.md's minimal scene)",
        entries: &[
            ("basis/bspline", None),
            ("predictor/usl", None),
            ("stress/linear_elastic", None),
            ("advection/usl", None),
        ],
    },
    Pipeline {
        name: "LME + Newmark (the guide's swap)",
        entries: &[
            ("basis/lme", Some("(gamma: 3.5)")),
            ("predictor/newmark", None),
            ("stress/linear_elastic", None),
            ("corrector/newmark", None),
            ("advection/newmark", None),
        ],
    },
    Pipeline {
        name: "B-splines + Newmark + neo-Hookean + shock viscosity (SCENES.md, impact)",
        entries: &[
            ("basis/bspline", None),
            ("predictor/newmark", None),
            ("stress/neo_hookean", None),
            ("stress/shock_viscosity", None),
            ("corrector/newmark", None),
            ("advection/newmark", None),
        ],
    },
    Pipeline {
        name: "MLS-MPM (SCENES.md)",
        entries: &[
            ("basis/mls", None),
            ("predictor/mls", None),
            ("stress/linear_elastic", None),
            ("advection/mls", None),
        ],
    },
];

const GRAVITY: f64 = 9.81;
const SPACING: f64 = 0.05;

/// The rubber disk of SCENES.md's minimal scene (radius 0.2 m on 0.05 m cells), centred at
/// (0.5, 0.7) in a 1 × 1 m grid, with `velocity`, `gravity` and the pipeline, to `end`.
fn disk(pipeline: &Pipeline, velocity: InitialVelocity<Two>, gravity: f64, end: f64) -> Spec<Two> {
    let entries = pipeline
        .entries
        .iter()
        .map(|(name, params)| match params {
            Some(p) => PipelineEntry::with_params(name, p),
            None => PipelineEntry::new(name),
        })
        .collect();
    Spec::<Two>::new(Grid::uniform(DVec2::ZERO, SPACING, [20, 20]))
        .time(TimeStep::Cfl(0.5), End::Time(end))
        .thickness(0.1)
        .body_force(DVec2::new(0.0, -gravity))
        .material(Material::new("rubber", 1000.0, 1.0e6, 0.3))
        .body(
            Body::new(
                Shape::Disk {
                    center: DVec2::new(0.5, 0.7),
                    radius: 0.2,
                },
                "rubber",
            )
            .velocity(velocity),
        )
        .with_pipeline(entries)
}

/// What a patch test looks at over a run: the largest energy created (`E − E₀ − W_ext`, J),
/// the initial energy and the work done, and the world at the end.
struct Outcome {
    created: f64,
    initial: f64,
    work: f64,
    world: World,
}

/// Runs `spec` to its end (a stop is a failure of the test) and follows its energy account.
fn run(label: &str, spec: Spec<Two>) -> Outcome {
    let registry = fractum_systems::stock_registry();
    let mut built = spec
        .build(&registry)
        .unwrap_or_else(|e| panic!("{label}: {e}"));
    let names = built.output.columns();
    let column = |c: &str| names.iter().position(|n| n == c).expect(c) - 1;
    let (total, work) = (column("total_energy"), column("external_work"));
    let sim = &mut built.simulation;
    let first = series_row(&mut sim.world, &built.output);
    let mut created: f64 = 0.0;
    let mut last_work = 0.0;
    while !sim.finished() {
        sim.step().unwrap_or_else(|e| panic!("{label}: {e}"));
        let row = series_row(&mut sim.world, &built.output);
        created = created.max(row[total] - first[total] - row[work]);
        last_work = row[work];
    }
    Outcome {
        created,
        initial: first[total],
        work: last_work,
        world: std::mem::take(&mut sim.world),
    }
}

/// Mass, position and velocity of every particle.
fn particles(world: &mut World) -> Vec<(f64, DVec2, DVec2)> {
    let mut q = world.query::<(&Mass, &Position<Two>, &Velocity<Two>)>();
    q.iter(world).map(|(m, x, v)| (m.0, x.0, v.0)).collect()
}

#[test]
fn every_documented_pipeline_falls_freely_five_cells() {
    // Five cells, 0.25 m, in √(2 · 0.25 / g) s.
    let end = (2.0 * 5.0 * SPACING / GRAVITY).sqrt();
    for pipeline in PIPELINES {
        let spec = disk(
            pipeline,
            InitialVelocity::Uniform(DVec2::ZERO),
            GRAVITY,
            end,
        );
        let mut outcome = run(pipeline.name, spec);
        let state = particles(&mut outcome.world);
        let mass: f64 = state.iter().map(|p| p.0).sum();
        let momentum: DVec2 = state.iter().map(|p| p.2 * p.0).sum();
        let time = outcome.world.resource::<SimClock>().time;
        let fall = -GRAVITY * time;
        eprintln!(
            "{}: centre-of-mass velocity {:.12} against g t = {fall:.12}, energy created {:.3e} \
             J of {:.3e} J of work",
            pipeline.name,
            momentum.y / mass,
            outcome.created,
            outcome.work
        );
        // The body force's nodal shares sum to m g (a partition of unity) and nothing else acts
        // on the body as a whole: its centre of mass falls as a free particle's, to round-off.
        assert!(
            (momentum.y / mass - fall).abs() < 1e-9 * fall.abs(),
            "{}",
            pipeline.name
        );
        assert!(momentum.x.abs() < 1e-12, "{}", pipeline.name);
        assert!(outcome.created <= 1e-6 * outcome.work, "{}", pipeline.name);
    }
}

#[test]
fn every_documented_pipeline_translates_rigidly_five_cells() {
    let velocity = DVec2::new(1.0, -0.5);
    let end = 5.0 * SPACING / velocity.length();
    for pipeline in PIPELINES {
        let spec = disk(pipeline, InitialVelocity::Uniform(velocity), 0.0, end);
        let mut outcome = run(pipeline.name, spec);
        let state = particles(&mut outcome.world);
        let worst = state
            .iter()
            .map(|p| (p.2 - velocity).length())
            .fold(0.0, f64::max);
        eprintln!(
            "{}: largest velocity error {worst:.2e} m/s, energy created {:.2e} J of {:.3e} J",
            pipeline.name, outcome.created, outcome.initial
        );
        // A uniform velocity field is reproduced by every basis (partition of unity) and
        // strains nothing: each particle keeps its velocity, the energy its value.
        assert!(worst < 1e-12, "{}: {worst}", pipeline.name);
        assert!(
            outcome.created <= 1e-12 * outcome.initial,
            "{}",
            pipeline.name
        );
    }
}

#[test]
fn every_documented_pipeline_spins_rigidly_without_creating_energy() {
    // ω = 2 rad/s: the rim at 0.4 m/s, a cell in 0.125 s; a quarter turn, 1.6 cells of rim
    // travel.
    let omega = 2.0;
    let spin = InitialVelocity::Linear {
        gradient: DMat2::from_cols(DVec2::new(0.0, omega), DVec2::new(-omega, 0.0)),
        origin: DVec2::new(0.5, 0.7),
    };
    let end = std::f64::consts::FRAC_PI_2 / omega;
    for pipeline in PIPELINES {
        let mut outcome = run(pipeline.name, disk(pipeline, spin.clone(), 0.0, end));
        let state = particles(&mut outcome.world);
        let mass: f64 = state.iter().map(|p| p.0).sum();
        let centre: DVec2 = state.iter().map(|p| p.1 * p.0).sum::<DVec2>() / mass;
        let angular: f64 = state
            .iter()
            .map(|(m, x, v)| m * (x - centre).perp_dot(*v))
            .sum();
        let inertia: f64 = state
            .iter()
            .map(|(m, x, _)| m * (x - centre).length_squared())
            .sum();
        let rate = angular / inertia;
        eprintln!(
            "{}: angular velocity {rate:.6} against {omega}, energy created {:.2e} J of {:.3e} J",
            pipeline.name, outcome.created, outcome.initial
        );
        // No energy created beyond what the schemes exchange with the grid (+0.09% on the two
        // disks with Newmark). Measured: 0.05% (B-splines + USL), 0.08% (LME + Newmark), 0.003%
        // (B-splines, Newmark and the viscosity).
        assert!(
            outcome.created <= 1e-3 * outcome.initial,
            "{}",
            pipeline.name
        );
        // The particle updates here are not angular-momentum conserving (APIC is a later
        // issue's): over the quarter turn the spin falls to 1.840 rad/s (B-splines + USL),
        // 1.831 rad/s (LME + Newmark) and 1.709 rad/s (B-splines, Newmark and the viscosity).
        // The bound catches a breakdown, not that loss.
        assert!(rate > 0.8 * omega, "{}: {rate}", pipeline.name);
    }
}
