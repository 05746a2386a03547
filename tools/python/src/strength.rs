//! Strength scales set from numpy before the first step: each particle's tensile strength
//! becomes what its damage law gave it (`tensile_strength`, or the Weibull draw) times the
//! scale, as a particle file's `strength_scale` column would give it, and the strengths meet
//! the checks the laws put the scene's own strengths to at install (the Rankine laws' `H̄_s l_ch
//! < 1`, registered as `fractum_engine::strength::StrengthChecks`).

use fractum_engine::components::{MaterialId, Particle, Strength, StrengthScale};
use fractum_engine::prelude::{With, World};
use fractum_engine::strength::StrengthChecks;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Scales every particle's strength by `scales` (in particle order). `unscaled` holds the
/// strengths before any scale: taken from the world on the first call (a particle file's scale
/// divided out), kept for the next, so that scales replace each other rather than compound.
pub fn set_strength_scale(
    world: &mut World,
    scales: &[f64],
    unscaled: &mut Vec<f64>,
) -> PyResult<()> {
    if let Some(bad) = scales.iter().find(|s| !(s.is_finite() && **s > 0.0)) {
        return Err(PyValueError::new_err(format!(
            "strength_scale must be finite and positive; got {bad}"
        )));
    }
    let particles = world
        .query_filtered::<(), With<Particle>>()
        .iter(world)
        .count();
    let mut query = world
        .query_filtered::<(&MaterialId, &mut Strength, Option<&mut StrengthScale>), With<Particle>>(
        );
    if query.iter(world).count() != particles || particles == 0 {
        return Err(PyValueError::new_err(
            "no damage law of the pipeline gives the particles a tensile strength to scale \
             (damage/rankine, damage/nonlocal_rankine and damage/time_to_failure do)",
        ));
    }
    if scales.len() != particles {
        return Err(PyValueError::new_err(format!(
            "`strength_scale` needs one value per particle ({particles}); got {}",
            scales.len()
        )));
    }
    if unscaled.is_empty() {
        *unscaled = query
            .iter(world)
            .map(|(_, s, file)| s.0 / file.map_or(1.0, |f| f.0))
            .collect();
    }
    let strengths: Vec<(MaterialId, f64)> = query
        .iter(world)
        .zip(unscaled.iter().zip(scales))
        .map(|((m, _, _), (base, scale))| (*m, base * scale))
        .collect();
    check(world, &strengths)?;
    for ((_, mut strength, file), ((_, value), scale)) in
        query.iter_mut(world).zip(strengths.iter().zip(scales))
    {
        strength.0 = *value;
        if let Some(mut file) = file {
            file.0 = *scale;
        }
    }
    Ok(())
}

/// Runs the laws' checks on the finite strengths (a particle no law governs keeps an infinite
/// one, whatever its scale).
fn check(world: &World, strengths: &[(MaterialId, f64)]) -> PyResult<()> {
    let Some(checks) = world.get_resource::<StrengthChecks>() else {
        return Ok(());
    };
    let finite: Vec<(MaterialId, f64)> = strengths
        .iter()
        .copied()
        .filter(|(_, s)| s.is_finite())
        .collect();
    checks
        .check(&finite)
        .map_err(|message| PyValueError::new_err(format!("strength_scale: {message}")))
}
