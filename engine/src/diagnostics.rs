//! Whole-system quantities for the time series: energies, momentum, centre-of-mass velocity.
//!
//! Sums run sequentially in particle order, so they are bitwise reproducible for any number of
//! threads; they are only evaluated on output steps.

use crate::components::{InitialVolume, Mass, Particle, StrainEnergyDensity, Velocity};
use crate::dim::Vector;
use bevy_ecs::prelude::*;

/// Totals over all particles.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Totals {
    /// Σ ½ m |v|².
    pub kinetic_energy: f64,
    /// Σ W V₀ (stored energy density times reference volume).
    pub strain_energy: f64,
    /// Σ m v.
    pub momentum: Vector,
    /// Σ m.
    pub mass: f64,
}

impl Totals {
    /// Kinetic plus strain energy.
    pub fn total_energy(&self) -> f64 {
        self.kinetic_energy + self.strain_energy
    }

    /// Centre-of-mass velocity (zero for an empty system).
    pub fn centre_of_mass_velocity(&self) -> Vector {
        if self.mass > 0.0 {
            self.momentum / self.mass
        } else {
            Vector::ZERO
        }
    }
}

/// Computes the totals of the current state.
pub fn totals(world: &mut World) -> Totals {
    let mut query = world
        .query_filtered::<(&Mass, &Velocity, &StrainEnergyDensity, &InitialVolume), With<Particle>>(
        );
    let mut t = Totals::default();
    for (m, v, w, v0) in query.iter(world) {
        t.kinetic_energy += 0.5 * m.0 * v.0.length_squared();
        t.strain_energy += w.0 * v0.0;
        t.momentum += m.0 * v.0;
        t.mass += m.0;
    }
    t
}
