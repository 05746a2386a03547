//! Explicit Newmark predictor-corrector, particle part.
//!
//! - Stage: advection. Registration name: `advection/newmark`. Pairs with `predictor/newmark`.
//! - Implements eigensoftening-lme-mpm.md Appendix A (Algorithm 1), step 9, eqs. (3)–(5):
//!   `a_p = Σ N_Ip f_I / m_I`, `v_p ← v_p + Δt a_p`,
//!   `x_p ← x_p + Δt Σ N_Ip v_I + ½ Δt² a_p`, with `v_I` the corrected nodal velocity (as in the
//!   authors' implementation, where the particle update follows the corrector).
//! - Contact: the particles also take the contact stage's collision impulse as a velocity kick,
//!   `v_p += Σ N_Ip Δp_I / m_I`, outside `a_p`, as the node velocities took it (see
//!   `contact/frictional`).

use crate::transfer::{AdvectedQuery, NodeMotionQuery, advect_particles_with_kicks};
use fractum_engine::prelude::*;
use rayon::prelude::*;

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

/// Node columns for the contact kicks: field masses and the contact stage's impulses.
pub type NodeKickQuery<'w, 's, D> =
    Query<'w, 's, (&'static NodeMass, &'static NodeContactImpulse<D>), With<Node>>;

/// The `advection/newmark` system.
pub fn newmark_advection<D: Dim>(
    clock: Res<SimClock>,
    connectivity: Res<Connectivity<D>>,
    nodes: NodeMotionQuery<D>,
    impulses: NodeKickQuery<D>,
    mut particles: AdvectedQuery<D>,
    mut kicks: Local<Vec<[D::Vector; MAX_FIELDS]>>,
) {
    let dt = clock.dt;
    contact_kicks(&impulses, &mut kicks);
    advect_particles_with_kicks(
        &connectivity,
        &nodes,
        &kicks,
        &mut particles,
        |x, v, a_grid, v_grid, kick| {
            *v += a_grid * dt + kick;
            *x += v_grid * dt + a_grid * (0.5 * dt * dt);
        },
    );
}

/// The velocity kick `Δp/m` of every node field from the contact stage's impulses, into
/// `kicks`; left empty when no field has one (no contact system, or no collision this step),
/// so the particles skip its interpolation.
pub fn contact_kicks<D: Dim>(
    impulses: &NodeKickQuery<D>,
    kicks: &mut Vec<[D::Vector; MAX_FIELDS]>,
) {
    kicks.clear();
    let Some((mass, impulse)) = single_table(impulses.contiguous_iter(), "nodes") else {
        return;
    };
    if impulse
        .par_iter()
        .any(|j| j.0.iter().any(|j| *j != D::Vector::ZERO))
    {
        mass.par_iter()
            .zip(impulse.par_iter())
            .map(|(m, j)| {
                std::array::from_fn(|k| {
                    if m.0[k] > 0.0 {
                        j.0[k] / m.0[k]
                    } else {
                        D::Vector::ZERO
                    }
                })
            })
            .collect_into_vec(kicks);
    }
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

    /// A contact kick `J` on the node fields reaches the particle as `Σ N J/m` in velocity, and
    /// stays out of its acceleration and position update.
    #[test]
    fn contact_kicks_change_the_velocity_only() {
        let mut world = tiny_world::<Two>(2, 0.5, 0.1);
        let x = DVec2::new(0.3, 0.7);
        spawn_particle(&mut world, x, DVec2::ZERO, 1.0, 0.1);
        give_nodes(&mut world, NodeContactImpulse::<Two>::default());
        let mut query = world.query::<(&mut NodeMass, &mut NodeContactImpulse<Two>)>();
        for (mut m, mut j) in query.iter_mut(&mut world) {
            m.0[0] = 2.0;
            j.0[0] = DVec2::new(0.5, -1.0);
        }
        run_system(
            &mut world,
            (linear_basis::<Two>, newmark_advection::<Two>).chain(),
        );
        let speed = particle_values::<Velocity<Two>>(&mut world)[0].0;
        assert!(
            (speed - DVec2::new(0.25, -0.5)).length() < 1e-14,
            "{speed:?}"
        );
        assert_eq!(particle_values::<Position<Two>>(&mut world)[0].0, x);
        assert_eq!(
            particle_values::<Acceleration<Two>>(&mut world)[0].0,
            DVec2::ZERO
        );
    }
}
