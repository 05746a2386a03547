//! Update-stress-last explicit scheme, particle part: grid-to-particle transfer and motion.
//!
//! - Stage: advection. Registration name: `advection/usl`. Pairs with `predictor/usl`.
//! - Implements eqs. (9)–(10) of Homel & Herbold (dfg-partitioning-mpm.md §1.1):
//!   `v_p ← v_p + Δt Σ N_Ip a_I` and `x_p ← x_p + Δt Σ N_Ip v̄_I`, reading each particle's own field of the
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
    install: generic_install!(install),
};

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    crate::no_params(params)?;
    installer.add_systems(usl_advection::<D>);
    Ok(())
}

/// The `advection/usl` system.
pub fn usl_advection<D: Dim>(
    clock: Res<SimClock>,
    connectivity: Res<Connectivity<D>>,
    nodes: NodeMotionQuery<D>,
    mut particles: AdvectedQuery<D>,
) {
    let dt = clock.dt;
    advect_particles(
        &connectivity,
        &nodes,
        &mut particles,
        |x, v, a_grid, v_grid| {
            *v += a_grid * dt;
            *x += v_grid * dt;
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::linear::linear_basis;
    use fractum_engine::testing::*;

    /// Particles in a uniform grid motion (node velocity `v`, acceleration `a`) move rigidly.
    fn rigid_motion<D: Dim>(xs: [D::Vector; 2], v: D::Vector, a: D::Vector)
    where
        D::Vector: SpaceVector,
    {
        let mut world = tiny_world::<D>(2, 0.5, 0.1);
        for x in xs {
            spawn_particle(&mut world, x, D::Vector::ONE, 1.0, 0.1);
        }
        let mut query = world.query::<(&mut NodeVelocity<D>, &mut NodeAcceleration<D>)>();
        for (mut nv, mut na) in query.iter_mut(&mut world) {
            nv.0[0] = v;
            na.0[0] = a;
        }
        run_system(&mut world, (linear_basis::<D>, usl_advection::<D>).chain());
        let positions = particle_values::<Position<D>>(&mut world);
        let velocities = particle_values::<Velocity<D>>(&mut world);
        for (k, x) in xs.iter().enumerate() {
            assert!((positions[k].0 - (*x + v * 0.1)).length() < 1e-14);
            assert!((velocities[k].0 - (D::Vector::ONE + a * 0.1)).length() < 1e-14);
        }
        assert!((particle_values::<Acceleration<D>>(&mut world)[1].0 - a).length() < 1e-14);
    }

    #[test]
    fn uniform_grid_motion_moves_particles_rigidly() {
        rigid_motion::<Two>(
            [DVec2::new(0.3, 0.7), DVec2::new(0.9, 0.1)],
            DVec2::new(1.5, -0.5),
            DVec2::new(5.0, -5.0),
        );
        rigid_motion::<Three>(
            [DVec3::new(0.3, 0.7, 0.2), DVec3::new(0.9, 0.1, 0.6)],
            DVec3::new(1.5, -0.5, 0.25),
            DVec3::new(5.0, -5.0, 2.0),
        );
    }
}
