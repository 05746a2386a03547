//! Update-stress-last explicit scheme, particle part: grid-to-particle transfer and motion.
//!
//! - Stage: advection. Registration name: `advection/usl`. Pairs with `predictor/usl`.
//! - Implements eqs. (9)–(10) of Homel & Herbold (dfg-partitioning-mpm.md §1.1):
//!   `v_p ← v_p + Δt Σ N_Ip a_I` and `x_p ← x_p + Δt Σ N_Ip v̄_I`, reading field 0 of the
//!   nodes. The particle acceleration `Σ N_Ip a_I` is stored for output and for integrators
//!   that need it.

use crate::transfer::{AdvectedQuery, NodeMotionQuery, advect_particles};
use fractum_engine::prelude::*;

/// Registration of `advection/usl`.
pub const REGISTRATION: Registration = Registration {
    name: "advection/usl",
    summary: "USL particle update: v += Δt Σ N a_I, x += Δt Σ N v_I (eqs. 9-10)",
    params: &[],
    requires: &["predictor/usl"],
    install,
};

fn install(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    crate::no_params(params)?;
    installer.add_systems(usl_advection);
    Ok(())
}

/// The `advection/usl` system.
pub fn usl_advection(
    clock: Res<SimClock>,
    connectivity: Res<Connectivity>,
    nodes: NodeMotionQuery,
    mut particles: AdvectedQuery,
) {
    let dt = clock.dt;
    advect_particles(
        &connectivity,
        &nodes,
        &mut particles,
        |x, v, a_grid, v_grid| {
            *v += dt * a_grid;
            *x += dt * v_grid;
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::linear::linear_basis;
    use fractum_engine::testing::*;

    #[test]
    fn uniform_grid_motion_moves_particles_rigidly() {
        let mut world = tiny_world(2, 0.5, 0.1);
        spawn_particle(
            &mut world,
            Vector::new(0.3, 0.7),
            Vector::new(1.0, 0.0),
            1.0,
            0.1,
        );
        spawn_particle(
            &mut world,
            Vector::new(0.9, 0.1),
            Vector::new(1.0, 0.0),
            1.0,
            0.1,
        );
        let mut query = world.query::<(&mut NodeVelocity, &mut NodeAcceleration)>();
        for (mut v, mut a) in query.iter_mut(&mut world) {
            v.0[0] = Vector::new(1.5, -0.5);
            a.0[0] = Vector::new(5.0, -5.0);
        }
        run_system(&mut world, (linear_basis, usl_advection).chain());
        let x = particle_values::<Position>(&mut world);
        let v = particle_values::<Velocity>(&mut world);
        assert!((x[0].0 - Vector::new(0.45, 0.65)).length() < 1e-14);
        assert!((x[1].0 - Vector::new(1.05, 0.05)).length() < 1e-14);
        assert!((v[0].0 - Vector::new(1.5, -0.5)).length() < 1e-14);
        assert_eq!(
            particle_values::<Acceleration>(&mut world)[1].0,
            Vector::new(5.0, -5.0)
        );
    }
}
