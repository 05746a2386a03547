//! Helpers for testing one system alone on a tiny world, in either dimension.
//!
//! ```
//! use fractum_engine::prelude::*;
//! use fractum_engine::testing::*;
//!
//! // A 2×2-cell grid of spacing 0.5, one particle, one step of 1 ms.
//! let mut world = tiny_world::<Two>(2, 0.5, 1e-3);
//! spawn_particle(&mut world, DVec2::new(0.3, 0.6), DVec2::new(1.0, 0.0), 2.0, 0.25);
//! run_system(&mut world, |mut q: Query<&mut Velocity<Two>, With<Particle>>| {
//!     for mut v in &mut q {
//!         v.0 *= 2.0;
//!     }
//! });
//! assert_eq!(particle_values::<Velocity<Two>>(&mut world)[0].0, DVec2::new(2.0, 0.0));
//! ```
//!
//! The same test in 3D is `tiny_world::<Three>` with `DVec3` positions.
//!
//! [`assert_defaults`] holds a registration's documented parameters against the serde type its
//! installer parses.

mod params;

pub use params::{assert_defaults, assert_documented, serde_fields};

use crate::boundary::{BoundaryConditions, Reactions};
use crate::components::{Node, NodeBundle, NodeIndex, Particle, ParticleBundle, ParticleId};
use crate::connectivity::Connectivity;
use crate::dim::{Dim, Lattice, Three, Two, VectorOps};
use crate::health::Health;
use crate::resources::{BodyForce, Grid, Material, Materials, SimClock, Thickness};
use bevy_ecs::prelude::*;
use bevy_ecs::schedule::ScheduleConfigs;
use bevy_ecs::system::ScheduleSystem;
use glam::{DVec2, DVec3};

/// The material of [`tiny_world`]: E = 100 Pa, ν = 0.25, ρ = 1 kg/m³.
pub fn test_material() -> Material {
    Material::new("test", 1.0, 100.0, 0.25)
}

/// A world with an `n × n` (× `n`)-cell grid of spacing `h` at the origin in dimension `D`, its
/// nodes, one material ([`test_material`]), a clock with step `dt`, no body force and no
/// boundary conditions.
pub fn tiny_world<D: Dim>(n: usize, h: f64, dt: f64) -> World {
    world_on_grid(
        Grid::<D>::uniform(D::Vector::ZERO, h, D::Cell::from_fn(|_| n)),
        dt,
    )
}

/// As [`tiny_world`], on any grid (a graded one, say).
pub fn world_on_grid<D: Dim>(grid: Grid<D>, dt: f64) -> World {
    let mut world = World::new();
    world.insert_resource(grid.clone());
    world.insert_resource(D::DIMENSION);
    world.insert_resource(SimClock {
        step: 0,
        time: 0.0,
        dt,
    });
    world.insert_resource(Materials(vec![test_material()]));
    world.insert_resource(Thickness::default());
    world.insert_resource(BodyForce::<D>::default());
    world.insert_resource(BoundaryConditions::default());
    world.insert_resource(Reactions::<D>::default());
    world.insert_resource(Connectivity::<D>::default());
    world.insert_resource(Health::default());
    let nodes: Vec<_> = (0..grid.node_count())
        .map(|i| NodeBundle::<D>::new(i as u32, grid.node_position(i)))
        .collect();
    world.spawn_batch(nodes);
    world
}

/// A vector type that says which dimension it belongs to, so that test helpers can infer it.
pub trait SpaceVector: Copy {
    /// The dimension whose vectors these are.
    type D: Dim<Vector = Self>;
}

impl SpaceVector for DVec2 {
    type D = Two;
}

impl SpaceVector for DVec3 {
    type D = Three;
}

/// Spawns a particle of material 0 with the next free id at `x` with velocity `v`.
pub fn spawn_particle<V: SpaceVector>(
    world: &mut World,
    x: V,
    v: V,
    mass: f64,
    volume: f64,
) -> Entity {
    let id = world
        .query_filtered::<(), With<Particle>>()
        .iter(world)
        .count() as u32;
    let mut bundle = ParticleBundle::<V::D>::new(id, x, mass, volume, 0);
    bundle.velocity.0 = v;
    world.spawn(bundle).id()
}

/// Runs `systems` once in a schedule of their own.
pub fn run_system<M>(world: &mut World, systems: impl IntoScheduleConfigs<ScheduleSystem, M>) {
    let configs: ScheduleConfigs<ScheduleSystem> = systems.into_configs();
    let mut schedule = Schedule::default();
    schedule.add_systems(configs);
    schedule.run(world);
}

/// A component of every particle, in id order.
pub fn particle_values<T: Component + Copy>(world: &mut World) -> Vec<T> {
    let mut rows: Vec<(u32, T)> = world
        .query_filtered::<(&ParticleId, &T), With<Particle>>()
        .iter(world)
        .map(|(id, t)| (id.0, *t))
        .collect();
    rows.sort_by_key(|r| r.0);
    rows.into_iter().map(|r| r.1).collect()
}

/// Gives every node a component a system's installer would add
/// (`Installer::add_node_component`), e.g. a contact law's normals and forces.
pub fn give_nodes<C: Component + Clone>(world: &mut World, value: C) {
    let nodes: Vec<Entity> = world
        .query_filtered::<Entity, With<Node>>()
        .iter(world)
        .collect();
    for node in nodes {
        world.entity_mut(node).insert(value.clone());
    }
}

/// A component of every node, in node-index order.
pub fn node_values<T: Component + Copy>(world: &mut World) -> Vec<T> {
    let mut rows: Vec<(u32, T)> = world
        .query::<(&NodeIndex, &T)>()
        .iter(world)
        .map(|(i, t)| (i.0, *t))
        .collect();
    rows.sort_by_key(|r| r.0);
    rows.into_iter().map(|r| r.1).collect()
}
