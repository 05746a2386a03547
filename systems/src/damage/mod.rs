//! Damage stage: failure and softening of material points.
pub mod degrading_update;
pub mod eigenerosion;
pub mod eigensoftening;
pub mod nonlocal_rankine;
pub mod rankine;
pub mod rankine_law;
pub mod softening;
pub mod spectral_split;
pub mod stress_reach;
pub mod tensile_degradation;
pub mod time_to_failure;
pub mod weibull;

use bevy_ecs::prelude::{Entity, With};
use bevy_ecs::world::{EntityRef, World};
use fractum_engine::decomposition::Owned;
use fractum_engine::prelude::{Damage, InitialVolume, MaterialFilter, MaterialId, Particle};

/// `Σ V₀ g(particle, D)` over the particles of `materials` that the scene seeds as damaged
/// (`D > 0` before the first step): what a damage law's energy account would credit them,
/// so that the published `dissipated_energy` can leave it out. In a distributed run, over the
/// particles this rank owns, as the published column is.
pub fn seeded_sum(
    world: &World,
    materials: &MaterialFilter,
    per_volume: impl Fn(EntityRef, MaterialId, f64) -> f64,
) -> f64 {
    let owned = Owned::in_world(world);
    let Some(mut particles) = world.try_query_filtered::<Entity, With<Particle>>() else {
        return 0.0;
    };
    let mut total = 0.0;
    for (row, particle) in particles.iter(world).enumerate() {
        if !owned.particle(row) {
            continue;
        }
        let entity = world.entity(particle);
        let (Some(m), Some(v0), Some(d)) = (
            entity.get::<MaterialId>(),
            entity.get::<InitialVolume>(),
            entity.get::<Damage>(),
        ) else {
            continue;
        };
        if d.0 > 0.0 && materials.applies(*m) {
            total += v0.0 * per_volume(entity, *m, d.0.min(1.0));
        }
    }
    total
}
