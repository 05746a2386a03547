//! Advection stage: grid-to-particle transfer and particle motion.
pub mod mls;
pub mod newmark;
pub mod usl;

use serde::Deserialize;

/// The grid-to-particle transfer of an advection system (its `transfer` parameter).
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
pub enum Transfer {
    /// The particle velocity takes the grid's change (both papers' update).
    #[default]
    Flip,
    /// The affine particle-in-cell transfer: the particle takes the grid velocity and an affine
    /// velocity ([`fractum_engine::prelude::AffineVelocity`]), and the transfers keep angular
    /// momentum (`transfer::affine_interpolation`).
    Apic,
}

/// What both advection systems' affine round-trip tests share: particles scattered off the
/// node lines, an arbitrary grid velocity field, and the grid's angular momentum.
#[cfg(test)]
pub(crate) mod round_trip {
    use fractum_engine::prelude::*;
    use fractum_engine::testing::spawn_particle;

    /// Twelve particles of unequal masses and volume `volume`, scattered over the tiny world's
    /// interior, each carrying an affine velocity.
    pub(crate) fn scatter_affine_particles(world: &mut World, volume: f64) {
        for k in 0..12 {
            let x = DVec2::new(0.6 + 0.17 * k as f64, 0.7 + 0.13 * ((5 * k) % 11) as f64);
            let p = spawn_particle(world, x, DVec2::ZERO, 1.0 + 0.1 * k as f64, volume);
            world.entity_mut(p).insert(AffineVelocity::<Two>::default());
        }
    }

    /// Gives every node with mass a velocity from a field that is neither affine nor rigid, and
    /// returns the grid's angular momentum `Σ m_I x_I × v_I`.
    pub(crate) fn set_grid_field(world: &mut World) -> f64 {
        let grid = world.resource::<Grid<Two>>().clone();
        let field = |x: DVec2| DVec2::new((3.0 * x.y).sin(), (2.0 * x.x).cos() + x.x * x.y);
        let mut query = world.query::<(&NodeIndex, &NodeMass, &mut NodeVelocity<Two>)>();
        let mut angular_momentum = 0.0;
        for (i, m, mut v) in query.iter_mut(world) {
            let x = grid.node_position(i.0 as usize);
            v.0[0] = if m.0[0] > 0.0 { field(x) } else { DVec2::ZERO };
            angular_momentum += m.0[0] * x.perp_dot(v.0[0]);
        }
        angular_momentum
    }

    /// The angular momentum `Σ x_I × p_I` of the node momenta a predictor transferred.
    pub(crate) fn grid_angular_momentum(world: &mut World) -> f64 {
        let grid = world.resource::<Grid<Two>>().clone();
        let mut query = world.query::<(&NodeIndex, &NodeMomentum<Two>)>();
        query
            .iter(world)
            .map(|(i, p)| grid.node_position(i.0 as usize).perp_dot(p.0[0]))
            .sum()
    }
}
