//! The scene's memory estimate: what a system will allocate per particle.

use super::Installer;

impl Installer<'_> {
    /// Declares storage this system will allocate per particle during the run (`bytes` per
    /// particle, described by `what`, e.g. "basis/lme: support of about 40 nodes"), so that
    /// building the scene refuses, with the estimate, a scene that cannot fit in memory
    /// instead of aborting in the first step ([`crate::budget`]).
    pub fn declare_particle_memory(&mut self, what: impl Into<String>, bytes: f64) {
        let field = self
            .entry
            .map_or("pipeline".to_string(), |k| format!("pipeline[{k}]"));
        self.world
            .get_resource_or_init::<crate::budget::ParticleMemory>()
            .0
            .push((field, what.into(), bytes));
    }

    /// The mean number of particles per cell of the smallest width, as built (for a
    /// neighbour list's [`Installer::declare_particle_memory`]).
    pub fn particles_per_cell(&mut self) -> f64 {
        crate::with_dim!(self.dimension(), D => crate::budget::particles_per_cell::<D>(self.world))
    }
}
