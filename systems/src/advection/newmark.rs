//! Explicit Newmark predictor-corrector, particle part.
//!
//! - Stage: advection. Registration name: `advection/newmark`. Pairs with `predictor/newmark`.
//! - Implements eigensoftening-lme-mpm.md Appendix A (Algorithm 1), step 9, eqs. (3)–(5):
//!   `a_p = Σ N_Ip f_I / m_I`, `v_p ← v_p + Δt a_p`,
//!   `x_p ← x_p + Δt Σ N_Ip v_I + ½ Δt² a_p`, with `v_I` the corrected nodal velocity (as in the
//!   authors' implementation, where the particle update follows the corrector).

use crate::transfer::{AdvectedQuery, NodeMotionQuery, advect_particles};
use fractum_engine::prelude::*;

/// Registration of `advection/newmark`.
pub const REGISTRATION: Registration = Registration {
    name: "advection/newmark",
    summary: "Newmark particle update: a = Σ N f/m, v += Δt a, x += Δt Σ N v_I + ½Δt² a (eqs. 3-5)",
    params: &[],
    requires: &["predictor/newmark"],
    install,
};

fn install(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    crate::no_params(params)?;
    with_dim!(installer.dimension(), D => installer.add_systems(newmark_advection::<D>));
    Ok(())
}

/// The `advection/newmark` system.
pub fn newmark_advection<D: Dim>(
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
            *x += v_grid * dt + a_grid * (0.5 * dt * dt);
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::linear::linear_basis;
    use fractum_engine::testing::*;

    /// A particle in a uniform grid motion moves by `Δt v_I + ½ Δt² a` and speeds up by `Δt a`.
    fn newmark_update<D: Dim>(x: D::Vector, v: D::Vector, a: D::Vector)
    where
        D::Vector: SpaceVector,
    {
        let mut world = tiny_world::<D>(2, 0.5, 0.1);
        spawn_particle(&mut world, x, D::Vector::ONE, 1.0, 0.1);
        let mut query = world.query::<(&mut NodeVelocity<D>, &mut NodeAcceleration<D>)>();
        for (mut nv, mut na) in query.iter_mut(&mut world) {
            nv.0[0] = v;
            na.0[0] = a;
        }
        run_system(
            &mut world,
            (linear_basis::<D>, newmark_advection::<D>).chain(),
        );
        let moved = particle_values::<Position<D>>(&mut world)[0].0;
        let speed = particle_values::<Velocity<D>>(&mut world)[0].0;
        assert!(
            (moved - (x + v * 0.1 + a * 0.005)).length() < 1e-14,
            "{moved:?}"
        );
        assert!(
            (speed - (D::Vector::ONE + a * 0.1)).length() < 1e-14,
            "{speed:?}"
        );
    }

    #[test]
    fn uniform_acceleration_moves_particles_by_the_newmark_update() {
        newmark_update::<Two>(
            DVec2::new(0.3, 0.7),
            DVec2::new(2.0, 0.0),
            DVec2::new(0.0, -10.0),
        );
        newmark_update::<Three>(
            DVec3::new(0.3, 0.7, 0.4),
            DVec3::new(2.0, 0.0, 1.0),
            DVec3::new(0.0, -10.0, 3.0),
        );
    }
}
