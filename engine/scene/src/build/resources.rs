//! The resources every world of a scene has, the probe's and the built one's alike: the grid,
//! dimension, thickness, loads, materials, body force, boundary regions and their reactions,
//! the clock, the policy for escaped particles, a quasi-static run's settings, and the state the
//! engine carries.

use super::regions;
use crate::SceneError;
use crate::spec::Spec;
use bevy_ecs::prelude::World;
use fractum_engine::boundary::Reactions;
use fractum_engine::connectivity::Connectivity;
use fractum_engine::dim::{Dim, VectorOps};
use fractum_engine::loads::ParticleLoads;
use fractum_engine::resources::{BodyForce, Materials, SimClock, Thickness};

/// The resources every world of the scene has, its particles' `loads` among them.
pub(crate) fn insert_scene_resources<D: Dim>(
    spec: &Spec<D>,
    world: &mut World,
    loads: ParticleLoads<D>,
) -> Result<(), SceneError> {
    let boundaries = regions::boundary_conditions(spec)?;
    world.insert_resource(spec.grid.clone());
    world.insert_resource(D::DIMENSION);
    world.insert_resource(Thickness(spec.thickness));
    world.insert_resource(loads);
    // A quasi-static run's world steps with the scaled densities and the body force per unit of
    // the scaled mass (`fractum_engine::quasi_static`).
    world.insert_resource(Materials(spec.inertial_materials()));
    world.insert_resource(BodyForce::<D>(spec.inertial_body_force()));
    if let Some(quasi_static) = spec.quasi_static {
        world.insert_resource(quasi_static);
    }
    world.insert_resource(Reactions::<D>(vec![
        D::Vector::ZERO;
        boundaries.regions.len()
    ]));
    world.insert_resource(boundaries);
    world.insert_resource(SimClock::default());
    world.insert_resource(spec.on_leave_grid);
    world.init_resource::<Connectivity<D>>();
    fractum_io::checkpoint::carry_engine_state::<D>(world);
    Ok(())
}
