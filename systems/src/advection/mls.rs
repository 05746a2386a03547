//! Moving-least-squares MPM, particle part: the particles move with the velocity the grid gave
//! them.
//!
//! - Stage: advection. Registration name: `advection/mls`. Pairs with `predictor/mls`.
//! - `x_p ← x_p + Δt v_p`, with `v_p = Σ N_Ip v̄_I` already set by `predictor/mls`'s
//!   grid-to-particle half (dfg-partitioning-mpm.md eq. 10, the position update, with the
//!   particle's own interpolated velocity).
//! - The install checks that every stress system reads its velocity gradient through the
//!   transfer's reader (capability `ReadsTransferGradient`): under `predictor/mls` that
//!   gradient is `C_p`, and a system reading the connectivity would see none.

use fractum_engine::capability::ReadsTransferGradient;
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// Registration of `advection/mls`.
pub const REGISTRATION: Registration = Registration {
    name: "advection/mls",
    summary: "MLS-MPM particle update: x += Δt v_p with the velocity predictor/mls gave",
    params: &[],
    requires: &["predictor/mls"],
    install: generic_install!(install),
};

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    crate::no_params(params)?;
    installer
        .require_from::<ReadsTransferGradient>(Stage::Stress)
        .map_err(|message| params.error("", &message))?;
    installer.add_systems(mls_advection::<D>);
    Ok(())
}

/// The `advection/mls` system.
pub fn mls_advection<D: Dim>(
    clock: Res<SimClock>,
    mut particles: Query<(&mut Position<D>, &Velocity<D>), With<Particle>>,
) {
    let Some((position, velocity)) = single_table_mut(particles.contiguous_iter_mut(), "particles")
    else {
        return;
    };
    let dt = clock.dt;
    position
        .par_chunks_mut(BLOCK_ROWS)
        .zip(velocity.par_chunks(BLOCK_ROWS))
        .for_each(|(x, v)| {
            vectorised(
                #[inline(always)]
                || {
                    for (x, v) in x.iter_mut().zip(v) {
                        x.0 += v.0 * dt;
                    }
                },
            )
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use fractum_engine::testing::*;

    #[test]
    fn particles_move_with_their_velocity() {
        let mut world = tiny_world::<Two>(2, 0.5, 0.1);
        spawn_particle(
            &mut world,
            DVec2::new(0.3, 0.7),
            DVec2::new(1.0, -2.0),
            1.0,
            0.1,
        );
        spawn_particle(
            &mut world,
            DVec2::new(0.6, 0.2),
            DVec2::new(0.0, 0.5),
            1.0,
            0.1,
        );
        run_system(&mut world, mls_advection::<Two>);
        let x = particle_values::<Position<Two>>(&mut world);
        assert!((x[0].0 - DVec2::new(0.4, 0.5)).length() < 1e-15);
        assert!((x[1].0 - DVec2::new(0.6, 0.25)).length() < 1e-15);
    }
}
