//! What the ECS costs: one step of the linear + update-stress-last pipeline on 100k particles
//! (2D), run as the engine runs it (a bevy schedule over the world's tables, with the stage
//! health checks) and as a plain function over `Vec`s calling the same kernels in the same
//! order. Both start from the same state, and the setup checks that a few steps of each give
//! bitwise the same particles, so the two measure the same arithmetic. Run with
//! `cargo bench -p fractum-systems --features bench --bench ecs_overhead`.

use criterion::{Criterion, criterion_group, criterion_main};
use fractum_engine::connectivity::Connectivity;
use fractum_engine::prelude::*;
use fractum_engine::simulation::{End, Simulation, TimeStep};
use fractum_scene::{Body, InitialVelocity, Output, Shape, Spec};
use fractum_systems::basis::linear::{fill_multilinear_row, nodes_per_particle};
use fractum_systems::predictor::usl::{NodeColumns, StepContext, grid_update};
use fractum_systems::stress::linear_elastic::{ElasticState, update_elastic};
use fractum_systems::transfer::{
    NodeSums, ParticleSlices, add_contribution, interpolate, velocity_gradient,
};
use rayon::prelude::*;
use std::time::Duration;

const CELLS: usize = 158;
const H: f64 = 0.01;
/// Small enough that the particles cross no cell during the thousands of steps criterion takes.
const DT: f64 = 1.0e-5;

/// The `fractum bench` block: 158 × 158 cells of 2 × 2 particles (99 856), a margin of four
/// cells, vibrating in a sine velocity profile.
fn simulation() -> Simulation {
    let margin = 4.0 * H;
    let side = CELLS as f64 * H;
    let grid = Grid::<Two> {
        min: DVec2::ZERO,
        spacing: H,
        cells: [CELLS + 8; 2],
        graded: None,
        window: None,
    };
    let spec = Spec::new(grid)
        .named("<ecs overhead>")
        .time(TimeStep::Fixed(DT), End::Steps(1_000_000))
        .material(Material::new("elastic", 1000.0, 1.0e6, 0.3))
        .body(
            Body::new(
                Shape::Rectangle {
                    min: DVec2::splat(margin),
                    max: DVec2::splat(margin + side),
                },
                "elastic",
            )
            .velocity(InitialVelocity::Sine {
                amplitude: DVec2::new(0.1, 0.05),
                axis: 0,
                wavelength: 2.0 * side,
                origin: margin,
            }),
        )
        .output(Output {
            vtu_every: 0,
            csv_every: 0,
            ..Output::default()
        })
        .system("basis/linear")
        .system("predictor/usl")
        .system("stress/linear_elastic")
        .system("advection/usl");
    let mut simulation = spec
        .build(&fractum_systems::stock_registry())
        .unwrap_or_else(|e| panic!("{e}"))
        .simulation;
    simulation
        .set_threads(rayon::current_num_threads())
        .unwrap();
    simulation
}

/// The same state as plain columns, and the step as a function over them.
struct Plain {
    grid: Grid<Two>,
    lame: (f64, f64),
    position: Vec<Position<Two>>,
    velocity: Vec<Velocity<Two>>,
    acceleration: Vec<Acceleration<Two>>,
    mass: Vec<Mass>,
    volume: Vec<Volume>,
    initial_volume: Vec<InitialVolume>,
    stress: Vec<Stress<Two>>,
    strain: Vec<Strain<Two>>,
    deformation_gradient: Vec<DeformationGradient<Two>>,
    energy: Vec<StrainEnergyDensity>,
    damage: Vec<Damage>,
    external: Vec<ExternalForce<Two>>,
    node_mass: Vec<NodeMass>,
    node_momentum: Vec<NodeMomentum<Two>>,
    node_velocity: Vec<NodeVelocity<Two>>,
    node_acceleration: Vec<NodeAcceleration<Two>>,
    node_force: Vec<NodeForce<Two>>,
    connectivity: Connectivity<Two>,
    sums: Vec<NodeSums<Two>>,
    bcs: BoundaryConditions,
    reactions: Reactions<Two>,
    time: f64,
}

fn column<T: Component + Clone>(world: &mut World) -> Vec<T> {
    let mut query = world.query_filtered::<&T, With<Particle>>();
    query.iter(world).cloned().collect()
}

impl Plain {
    fn from(simulation: &mut Simulation) -> Self {
        let world = &mut simulation.world;
        let grid = world.resource::<Grid<Two>>().clone();
        let lame = world.resource::<Materials>().0[0].lame();
        let nodes = grid.node_count();
        Self {
            grid,
            lame,
            position: column(world),
            velocity: column(world),
            acceleration: column(world),
            mass: column(world),
            volume: column(world),
            initial_volume: column(world),
            stress: column(world),
            strain: column(world),
            deformation_gradient: column(world),
            energy: column(world),
            damage: column(world),
            external: column(world),
            node_mass: vec![NodeMass::default(); nodes],
            node_momentum: vec![NodeMomentum::default(); nodes],
            node_velocity: vec![NodeVelocity::default(); nodes],
            node_acceleration: vec![NodeAcceleration::default(); nodes],
            node_force: vec![NodeForce::default(); nodes],
            connectivity: Connectivity::default(),
            sums: Vec::new(),
            bcs: BoundaryConditions::default(),
            reactions: Reactions(Vec::new()),
            time: 0.0,
        }
    }

    /// Basis, predictor, stress and advection of the four stock systems, on plain slices.
    fn step(&mut self) {
        let grid = &self.grid;
        let positions = &self.position;
        self.connectivity.fill_fixed_width(
            positions.len(),
            nodes_per_particle::<Two>(),
            grid.node_count(),
            |p, nodes, weights, gradients| {
                fill_multilinear_row(grid, positions[p].0, nodes, weights, gradients);
            },
        );
        let c = &self.connectivity;
        let slices = ParticleSlices {
            mass: &self.mass,
            velocity: &self.velocity,
            volume: &self.volume,
            stress: &self.stress,
            damage: &self.damage,
            external: &self.external,
            viscous: None,
            damage_scales_force: true,
        };
        self.sums.resize(grid.node_count(), NodeSums::default());
        c.accumulate_to_nodes(&mut self.sums, |sum, e, p| {
            add_contribution(sum, c, &slices, DVec2::ZERO, e, p)
        });
        let context = StepContext {
            bcs: &self.bcs,
            time: self.time,
            dt: DT,
            min_node_mass: 0.0,
        };
        let columns = NodeColumns {
            mass: &mut self.node_mass,
            momentum: &mut self.node_momentum,
            velocity: &mut self.node_velocity,
            acceleration: &mut self.node_acceleration,
            force: &mut self.node_force,
        };
        grid_update(&self.sums, &context, columns, &mut self.reactions);
        let (node_velocity, lame, v0) = (&self.node_velocity, self.lame, &self.initial_volume);
        self.stress
            .par_iter_mut()
            .zip(self.strain.par_iter_mut())
            .zip(self.deformation_gradient.par_iter_mut())
            .zip(self.volume.par_iter_mut())
            .zip(self.energy.par_iter_mut())
            .enumerate()
            .for_each(|(p, ((((s, e), f), v), w))| {
                let l = velocity_gradient(c, node_velocity, p);
                let before = ElasticState::<Two> {
                    stress: s.0,
                    strain: e.0,
                    deformation_gradient: f.0,
                    volume: v.0,
                    energy_density: w.0,
                };
                let after = update_elastic(&before, l, DT, lame, v0[p].0);
                (s.0, e.0, f.0, v.0, w.0) = (
                    after.stress,
                    after.strain,
                    after.deformation_gradient,
                    after.volume,
                    after.energy_density,
                );
            });
        let node_acceleration = &self.node_acceleration;
        self.position
            .par_iter_mut()
            .zip(self.velocity.par_iter_mut())
            .zip(self.acceleration.par_iter_mut())
            .enumerate()
            .for_each(|(p, ((x, v), a))| {
                let (a_grid, v_grid) = interpolate(c, node_acceleration, node_velocity, p);
                a.0 = a_grid;
                v.0 += a_grid * DT;
                x.0 += v_grid * DT;
            });
        self.time += DT;
    }
}

fn ecs_against_slices(c: &mut Criterion) {
    let mut engine = simulation();
    let mut plain = Plain::from(&mut engine);
    for _ in 0..3 {
        engine.step().unwrap();
        plain.step();
    }
    assert_eq!(
        column::<Position<Two>>(&mut engine.world),
        plain.position,
        "the plain step must compute what the engine computes"
    );
    let particles = plain.position.len();
    let mut group = c.benchmark_group(format!("linear+usl step, {particles} particles (2D)"));
    group.sample_size(20);
    group.measurement_time(Duration::from_secs(8));
    group.bench_function("ECS schedule with health checks", |b| {
        b.iter(|| engine.step().unwrap())
    });
    group.bench_function("plain slices, same kernels", |b| b.iter(|| plain.step()));
    group.finish();
}

// The macro generates an undocumented function.
#[allow(missing_docs)]
mod group {
    use super::*;
    criterion_group!(benches, ecs_against_slices);
}
use group::benches;
criterion_main!(benches);
