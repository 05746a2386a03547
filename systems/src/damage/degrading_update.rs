//! The step the stress-degrading damage laws share (not a system): `damage/rankine`,
//! `damage/nonlocal_rankine` and `damage/time_to_failure` each give a damage law, and this
//! loop updates every particle of their materials with it, degrades the stress
//! (`damage::tensile_degradation`), accumulates the energy the growth released in
//! `DamageDissipation`, and publishes the three columns `damaged_particles`,
//! `failed_particles` and `dissipated_energy`.

use super::tensile_degradation::{TensileDegradation, damage_counts, largest_trial_principal};
use fractum_engine::decomposition::Owned;
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// The particles a stress-degrading damage law updates.
pub type DegradingParticles<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static MaterialId,
        &'static InitialVolume,
        &'static Strength,
        &'static Strain<D>,
        &'static DeformationGradient<D>,
        &'static mut Stress<D>,
        &'static mut StrainEnergyDensity,
        &'static mut Damage,
        &'static mut DamageDissipation,
    ),
    With<Particle>,
>;

/// What a law's system hands the shared step.
pub struct DegradingLaw<'a> {
    /// The materials the entry damages.
    pub materials: &'a MaterialFilter,
    /// How the damage degrades the stress.
    pub degradation: &'a TensileDegradation,
    /// Slots of the damaged, failed and dissipated-energy columns.
    pub columns: [usize; 3],
    /// The stress that drives each row's damage, in place of the row's own largest principal
    /// trial stress: a non-local law's average (`damage::nonlocal_rankine`).
    pub driving: Option<&'a [f64]>,
}

/// Updates every particle of the law's materials with `damage_law` (from the particle's
/// material, previous damage, driving stress and strength, its new damage; the driving stress
/// is the particle's largest principal trial stress unless the law gives its own),
/// degrades its stress and energy, adds the energy the growth released to its
/// `DamageDissipation`, and publishes the columns over the rows `owned` marks.
pub fn degrade_particles<D: Dim>(
    law: &DegradingLaw,
    columns: &mut SeriesColumns,
    owned: Owned,
    particles: &mut DegradingParticles<D>,
    damage_law: impl Fn(MaterialId, f64, f64, f64) -> f64 + Sync,
) {
    let Some((material, v0, strength, strain, deformation, stress, energy, damage, dissipation)) =
        single_table_mut(particles.contiguous_iter_mut(), "particles")
    else {
        return;
    };
    stress
        .par_iter_mut()
        .zip(energy.par_iter_mut())
        .zip(damage.par_iter_mut())
        .zip(dissipation.par_iter_mut())
        .enumerate()
        .for_each(|(i, (((s, w), d), dissipated))| {
            if !law.materials.applies(material[i]) {
                return;
            }
            let previous = d.0;
            let driving = match law.driving {
                Some(driving) => driving[i],
                None => largest_trial_principal(&s.0),
            };
            d.0 = damage_law(material[i], previous, driving, strength[i].0);
            if d.0 > 0.0 {
                let released = law.degradation.apply_and_release::<D>(
                    material[i],
                    (previous, d.0),
                    (&mut s.0, &mut w.0),
                    &strain[i].0,
                    &deformation[i].0,
                );
                dissipated.0 += v0[i].0 * released;
            }
        });
    let (damaged, failed) = damage_counts(material, damage, law.materials, owned);
    let [cd, cf, ce] = law.columns;
    columns.values[cd] = damaged as f64;
    columns.values[cf] = failed as f64;
    // Summed in row order over the rows this rank owns: the same bits for any thread count.
    columns.values[ce] = owned.particles(dissipation.iter().map(|d| d.0)).sum();
}
