//! Loads on particles: a ramped total force shared by the particles of a body (or of a region of
//! it) in proportion to their initial volume, e.g. the platen traction of
//! dfg-partitioning-mpm.md §3.1. The engine refreshes each loaded particle's [`ExternalForce`]
//! at the start of every step; the particle-to-grid force transfer adds `N_Ip f_p` to the nodes.

use crate::boundary::PiecewiseLinear;
pub use crate::components::LoadShare;
use crate::components::{ExternalForce, Particle};
use crate::dim::{Dim, VectorOps};
use crate::resources::SimClock;
use crate::storage::single_table_mut;
use bevy_ecs::prelude::*;
use rayon::prelude::*;

/// Every load of the scene: total force at factor 1 and its time factor.
#[derive(Resource, Clone, Debug)]
pub struct ParticleLoads<D: Dim>(pub Vec<(D::Vector, PiecewiseLinear)>);

impl<D: Dim> Default for ParticleLoads<D> {
    fn default() -> Self {
        Self(Vec::new())
    }
}

impl<D: Dim> ParticleLoads<D> {
    /// Force on a particle with `share` of load `load` at time `t`.
    pub fn force(&self, share: &LoadShare, t: f64) -> D::Vector {
        match self.0.get(share.load as usize) {
            Some((total, ramp)) => *total * (ramp.eval(t) * share.share),
            None => D::Vector::ZERO,
        }
    }
}

/// Sets every particle's external force for the step starting at the clock's time.
pub fn apply_loads<D: Dim>(
    clock: Res<SimClock>,
    loads: Res<ParticleLoads<D>>,
    mut particles: Query<(&LoadShare, &mut ExternalForce<D>), With<Particle>>,
) {
    let Some((shares, forces)) = single_table_mut(particles.contiguous_iter_mut(), "particles")
    else {
        return;
    };
    forces
        .par_iter_mut()
        .zip(shares.par_iter())
        .for_each(|(f, share)| f.0 = loads.force(share, clock.time));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dim::Two;
    use glam::DVec2;

    #[test]
    fn a_share_of_a_ramped_load() {
        let ramp = PiecewiseLinear::new(vec![(0.0, 0.0), (2.0, 1.0)]).unwrap();
        let loads = ParticleLoads::<Two>(vec![(DVec2::new(0.0, -10.0), ramp)]);
        let share = LoadShare {
            load: 0,
            share: 0.25,
        };
        assert_eq!(loads.force(&share, 1.0), DVec2::new(0.0, -1.25));
        assert_eq!(loads.force(&LoadShare::default(), 1.0), DVec2::ZERO);
    }
}
