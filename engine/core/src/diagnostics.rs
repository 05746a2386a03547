//! Whole-system quantities for the time series: energies, momentum, centre-of-mass velocity.
//!
//! Sums run sequentially in particle order, so they are bitwise reproducible for any number of
//! threads; they are only evaluated on output steps.

use crate::components::{Damage, InitialVolume, Mass, Particle, StrainEnergyDensity, Velocity};
use crate::dim::{Dim, Dimension, VectorOps};
use crate::with_dim;
use bevy_ecs::prelude::*;

/// Totals over all particles. Vectors have three components; the last is 0 in 2D.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Totals {
    /// Σ ½ m |v|².
    pub kinetic_energy: f64,
    /// Σ W V₀ (stored energy density times reference volume).
    pub strain_energy: f64,
    /// Energy held by a contact potential ([`crate::energy::ContactPotential`]).
    pub contact_energy: f64,
    /// Σ m v.
    pub momentum: [f64; 3],
    /// Σ m.
    pub mass: f64,
}

impl Totals {
    /// Kinetic plus stored energy: the particles' strain energy and a contact potential's.
    pub fn total_energy(&self) -> f64 {
        self.kinetic_energy + self.strain_energy + self.contact_energy
    }

    /// Centre-of-mass velocity (zero for an empty system).
    pub fn centre_of_mass_velocity(&self) -> [f64; 3] {
        if self.mass > 0.0 {
            self.momentum.map(|p| p / self.mass)
        } else {
            [0.0; 3]
        }
    }
}

/// Computes the totals of the current state of a world built for dimension `D`.
pub fn totals_of<D: Dim>(world: &mut World) -> Totals {
    // Where damage scales the internal force (eq. 16 of the eigensoftening paper), a particle
    // stores (1 − D) of its undamaged energy (the secant energy); where the damage system
    // degraded the stress itself it has scaled the energy density too.
    let damage_scales_force = !world.contains_resource::<crate::resources::DamageInStress>();
    let mut query = world.query_filtered::<(
        &Mass,
        &Velocity<D>,
        &StrainEnergyDensity,
        &InitialVolume,
        &Damage,
    ), With<Particle>>();
    let (mut kinetic, mut strain, mut momentum, mut mass) = (0.0, 0.0, D::Vector::ZERO, 0.0);
    // A rank of a distributed run sums the particles it owns; the run adds the ranks' sums.
    let ownership = world.get_resource::<crate::decomposition::Ownership>();
    let counted = |row: usize| crate::decomposition::counts_here(ownership, row);
    for (row, (m, v, w, v0, d)) in query.iter(world).enumerate() {
        if !counted(row) {
            continue;
        }
        kinetic += 0.5 * m.0 * v.0.length_squared();
        let stored = w.0 * v0.0;
        strain += if damage_scales_force && d.0 > 0.0 {
            (1.0 - d.0) * stored
        } else {
            stored
        };
        momentum += v.0 * m.0;
        mass += m.0;
    }
    let contact_energy = world
        .get_resource::<crate::energy::ContactPotential>()
        .map_or(0.0, |c| c.0);
    Totals {
        kinetic_energy: kinetic,
        strain_energy: strain,
        contact_energy,
        momentum: momentum.to_3d(),
        mass,
    }
}

/// Computes the totals of the current state (the world's [`Dimension`] says which).
pub fn totals(world: &mut World) -> Totals {
    let dimension = *world.resource::<Dimension>();
    with_dim!(dimension, D => totals_of::<D>(world))
}
