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
    installer.add_systems(newmark_advection);
    Ok(())
}

/// The `advection/newmark` system.
pub fn newmark_advection(
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
            *x += dt * v_grid + 0.5 * dt * dt * a_grid;
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::linear::linear_basis;
    use fractum_engine::testing::*;

    #[test]
    fn uniform_acceleration_moves_particles_by_the_newmark_update() {
        let mut world = tiny_world(2, 0.5, 0.1);
        spawn_particle(
            &mut world,
            Vector::new(0.3, 0.7),
            Vector::new(1.0, 0.0),
            1.0,
            0.1,
        );
        let mut query = world.query::<(&mut NodeVelocity, &mut NodeAcceleration)>();
        for (mut v, mut a) in query.iter_mut(&mut world) {
            v.0[0] = Vector::new(2.0, 0.0);
            a.0[0] = Vector::new(0.0, -10.0);
        }
        run_system(&mut world, (linear_basis, newmark_advection).chain());
        let x = particle_values::<Position>(&mut world)[0].0;
        let v = particle_values::<Velocity>(&mut world)[0].0;
        assert!(
            (x - Vector::new(0.3 + 0.2, 0.7 - 0.05)).length() < 1e-14,
            "{x}"
        );
        assert!((v - Vector::new(1.0, -1.0)).length() < 1e-14, "{v}");
    }
}
