//! Eq. (23)'s kernels, shared by `damage/rankine` and `damage/nonlocal_rankine` (not a system):
//! the brittleness `H̄_s = σ_f² / (2 E G_f)`, the softening modulus `H_s` that spends `G_f`
//! over a length `l`, the damage law `D = (1 + H_s)(1 − σ_f / r̂)`, the closed form of the
//! uniaxial softening work, and the install check that a length leaves the law a softening
//! branch. dfg-partitioning-mpm.md §2.7, eq. (23) (Cervera et al.'s model).
use super::tensile_degradation::install_strength;
use super::weibull::WeibullOption;
use fractum_engine::prelude::*;
use fractum_engine::text::readable;

/// Eq. (23) with the parameters a law installs: what turns a driving stress into damage.
#[derive(Clone, Debug, PartialEq)]
pub struct RankineSoftening {
    /// G_f (J/m²).
    pub fracture_energy: f64,
    /// The width over which the law spends G_f (m).
    pub characteristic_length: f64,
    /// Young's modulus of each material (the scene's material table order).
    pub youngs_modulus: Vec<f64>,
}

impl RankineSoftening {
    /// The damage of a particle of `material` with strength `strength` after a step whose
    /// driving stress is `driving`, from `previous`.
    pub fn damage(&self, material: MaterialId, previous: f64, driving: f64, strength: f64) -> f64 {
        let e = self.youngs_modulus[material.0 as usize];
        let h = softening_modulus(
            strength,
            e,
            self.fracture_energy,
            self.characteristic_length,
        );
        rankine_damage(previous, driving, strength, h)
    }
}

/// What a Rankine law's install (of the system `system`) shares: `G_f > 0`, the particles'
/// strengths (`tensile_strength` and its Weibull draw), the check that `length` leaves every
/// strength a softening branch (`length_given`: the scene wrote it), registered again for
/// strengths changed after the build, the particles' `DamageDissipation`, and the three
/// published columns (damaged, failed, dissipated energy) with their slots.
pub fn install_softening(
    (installer, system): (&mut Installer, &'static str),
    params: &Params,
    (tensile_strength, weibull): (f64, Option<WeibullOption>),
    fracture_energy: f64,
    (length, length_given): (f64, bool),
) -> Result<(RankineSoftening, [usize; 3]), SceneError> {
    params.require_positive(
        "fracture_energy",
        fracture_energy,
        "expected G_f > 0 (J/m²)",
    )?;
    let youngs_modulus: Vec<f64> = installer
        .world()
        .resource::<Materials>()
        .0
        .iter()
        .map(|m| m.youngs_modulus)
        .collect();
    let strengths = install_strength(installer, params, tensile_strength, weibull)?;
    let given = (fracture_energy, length_given);
    check_brittleness(params, given, &strengths, &youngs_modulus, length)?;
    installer.add_particle_component(DamageDissipation(0.0));
    let columns = [
        installer.add_owned_sum_column("damaged_particles"),
        installer.add_owned_sum_column("failed_particles"),
        installer.add_owned_sum_column("dissipated_energy"),
    ];
    let softening = RankineSoftening {
        fracture_energy,
        characteristic_length: length,
        youngs_modulus,
    };
    register_brittleness_check(installer, &softening, system);
    Ok((softening, columns))
}

/// A strength a Rankine law cannot take, with its scaled brittleness `H̄_s l_ch`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BrittlenessViolation {
    /// `H̄_s l_ch` is not a normal f64: the law cannot be evaluated.
    TooSmall {
        /// `H̄_s l_ch`.
        scaled: f64,
        /// The particle strength σ_f (Pa).
        strength: f64,
    },
    /// `H̄_s l_ch ≥ 1`: no softening branch.
    SnapBack {
        /// `H̄_s l_ch`.
        scaled: f64,
        /// The particle strength σ_f (Pa).
        strength: f64,
    },
}

impl BrittlenessViolation {
    /// What is wrong and what to change, for the law's length `length`.
    pub fn message(&self, length: f64) -> String {
        match *self {
            Self::TooSmall { scaled, strength } => format!(
                "H̄_s l_ch = σ_f² l_ch / (2 E G_f) = {scaled:e} (σ_f = {strength:e} Pa, l_ch = \
                 {length:e} m) is too small for f64: the softening law cannot be evaluated; a \
                 strength this small is no strength"
            ),
            Self::SnapBack { scaled, strength } => format!(
                "H̄_s l_ch = σ_f² l_ch / (2 E G_f) = {} ≥ 1 (σ_f = {} Pa, l_ch = {} m): the \
                 softening branch would have to snap back; use l_ch < {} m (a finer grid, when \
                 it defaults to the cell diagonal) or a larger G_f",
                readable(scaled),
                readable(strength),
                readable(length),
                readable(length / scaled)
            ),
        }
    }
}

/// The first strength of `strengths` whose scaled brittleness `H̄_s l_ch` is not a normal f64
/// (the weakest) or reaches 1 (the strongest), if any.
pub fn brittleness_violation(
    fracture_energy: f64,
    strengths: &[(MaterialId, f64)],
    youngs_modulus: &[f64],
    length: f64,
) -> Option<BrittlenessViolation> {
    let scaled = strengths.iter().map(|&(m, s)| {
        let e = youngs_modulus[m.0 as usize];
        (brittleness(s, e, fracture_energy) * length, s)
    });
    // The weakest particle has the smallest H̄_s l_ch, the strongest the largest.
    let weakest = scaled.clone().min_by(|a, b| a.0.total_cmp(&b.0));
    let worst = scaled.max_by(|a, b| a.0.total_cmp(&b.0));
    if let Some((scaled, strength)) = weakest
        && !scaled.is_normal()
    {
        return Some(BrittlenessViolation::TooSmall { scaled, strength });
    }
    worst
        .filter(|&(scaled, _)| scaled >= 1.0)
        .map(|(scaled, strength)| BrittlenessViolation::SnapBack { scaled, strength })
}

/// Refuses strengths whose scaled brittleness `H̄_s l_ch` is not a normal f64 (too small to
/// evaluate the law) or reaches 1 (no softening branch), naming the particle strength.
/// `length_given`: the scene wrote `characteristic_length` (else it defaults to the cell
/// diagonal, and the error names `fracture_energy`).
pub fn check_brittleness(
    params: &Params,
    (fracture_energy, length_given): (f64, bool),
    strengths: &[(MaterialId, f64)],
    youngs_modulus: &[f64],
    length: f64,
) -> Result<(), SceneError> {
    let Some(violation) = brittleness_violation(fracture_energy, strengths, youngs_modulus, length)
    else {
        return Ok(());
    };
    let field = match violation {
        BrittlenessViolation::TooSmall { .. } => "tensile_strength",
        BrittlenessViolation::SnapBack { .. } if length_given => "characteristic_length",
        BrittlenessViolation::SnapBack { .. } => "fracture_energy",
    };
    Err(params.error(field, violation.message(length)))
}

/// Registers the brittleness check for strengths changed after the build: those of the
/// particles of `materials` (the law's entry) that `softening` governs.
fn register_brittleness_check(
    installer: &mut Installer,
    softening: &RankineSoftening,
    system: &'static str,
) {
    let materials = installer.materials().clone();
    let softening = softening.clone();
    installer.add_strength_check(move |strengths| {
        let governed: Vec<(MaterialId, f64)> = strengths
            .iter()
            .copied()
            .filter(|&(m, _)| materials.applies(m))
            .collect();
        let RankineSoftening {
            fracture_energy,
            characteristic_length: length,
            youngs_modulus,
        } = &softening;
        match brittleness_violation(*fracture_energy, &governed, youngs_modulus, *length) {
            Some(violation) => Err(format!(
                "{system} refuses it: {}",
                violation.message(*length)
            )),
            None => Ok(()),
        }
    });
}

/// `H̄_s = σ_f² / (2 E G_f)` (1/m).
pub fn brittleness(strength: f64, youngs_modulus: f64, fracture_energy: f64) -> f64 {
    strength * strength / (2.0 * youngs_modulus * fracture_energy)
}

/// The softening modulus `H_s = H̄_s l / (1 − H̄_s l)` for strength `σ_f`, modulus `E`, fracture
/// energy `G_f` and characteristic length `l`.
pub fn softening_modulus(
    strength: f64,
    youngs_modulus: f64,
    fracture_energy: f64,
    length: f64,
) -> f64 {
    let scaled = brittleness(strength, youngs_modulus, fracture_energy) * length;
    scaled / (1.0 - scaled)
}

/// Eq. (23): the damage after a step whose largest principal trial stress is `trial`, from
/// `previous`, for strength `strength` and softening modulus `h`.
pub fn rankine_damage(previous: f64, trial: f64, strength: f64, h: f64) -> f64 {
    if trial <= strength {
        return previous;
    }
    let law = (1.0 + h) * (1.0 - strength / trial);
    law.max(previous).min(1.0)
}

/// Energy per unit volume dissipated in uniaxial tension up to damage `d`:
/// `σ_f² (1 + H) d / (2 E (1 + H − d))`, the closed form the published account reaches in
/// uniaxial tension (the tests hold it to it).
///
/// The denominator is summed as `(1 − d) + H`: at `d = 1` that is `H` exactly, where
/// `1 + H − d` rounds to 0 once `H` is below the f64 epsilon.
pub fn dissipated_density(d: f64, strength: f64, youngs_modulus: f64, h: f64) -> f64 {
    strength * strength * (1.0 + h) * d / (2.0 * youngs_modulus * ((1.0 - d) + h))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::damage::tensile_degradation::{Degradation, TensileDegradation};

    #[test]
    fn softening_is_linear_and_dissipates_the_fracture_energy_over_the_length() {
        let (sigma_f, e, gf, l) = (2.0, 1000.0, 0.01, 0.05);
        let h = softening_modulus(sigma_f, e, gf, l);
        // H̄ = 4 / 20 = 0.2 /m, H̄ l = 0.01, H = 0.01/0.99.
        assert!((h - 0.01 / 0.99).abs() < 1e-15);
        // Uniaxial: σ = (1 − D) E ε falls linearly with slope −H E after σ_f.
        for eps in [0.0025, 0.004, 0.1] {
            let d = rankine_damage(0.0, e * eps, sigma_f, h);
            let sigma = (1.0 - d) * e * eps;
            let linear = (sigma_f - h * e * (eps - sigma_f / e)).max(0.0);
            assert!(
                (sigma - linear).abs() < 1e-12,
                "ε {eps}: {sigma} against {linear}"
            );
        }
        // Below strength nothing; no healing on unloading.
        assert_eq!(rankine_damage(0.0, 1.9, sigma_f, h), 0.0);
        let d = rankine_damage(0.0, 4.0, sigma_f, h);
        assert_eq!(rankine_damage(d, 2.5, sigma_f, h), d);
        // Full failure dissipates G_f / l_ch per unit volume.
        assert!((dissipated_density(1.0, sigma_f, e, h) * l - gf).abs() < 1e-15);
    }

    /// A softening modulus below the f64 epsilon: `1 + H − 1` would round to 0 and the full
    /// failure's dissipation to infinity; it stays `G_f / l_ch`.
    #[test]
    fn full_failure_dissipation_stays_finite_for_a_vanishing_softening_modulus() {
        let (sigma_f, e, gf, l) = (1e-9, 1000.0, 0.01, 0.05);
        let h = softening_modulus(sigma_f, e, gf, l);
        assert!(h > 0.0 && h < f64::EPSILON, "H = {h:e}");
        let g = dissipated_density(1.0, sigma_f, e, h);
        assert!((g * l - gf).abs() < 1e-12 * gf, "g l = {:e}", g * l);
    }

    /// `H̄_s l_ch = σ_f² l / (2 E G_f)`: with E = 1000, G_f = 0.01 and l = 0.05 it is
    /// `σ_f² / 400`: strengths below 20 have a softening branch.
    #[test]
    fn brittleness_refuses_the_weakest_too_small_and_the_strongest_at_or_past_snap_back() {
        let (e, gf, l) = ([1000.0, 1.0e9], 0.01, 0.05);
        let (soft, stiff) = (MaterialId(0), MaterialId(1));
        let violation =
            |strengths: &[(MaterialId, f64)]| brittleness_violation(gf, strengths, &e, l);
        assert_eq!(violation(&[(soft, 2.0), (soft, 19.9)]), None);
        // The same strength on a stiffer material is far from snapping back.
        assert_eq!(violation(&[(stiff, 25.0)]), None);
        assert_eq!(
            violation(&[(soft, 2.0), (soft, 20.0), (soft, 30.0)]),
            Some(BrittlenessViolation::SnapBack {
                scaled: 2.25,
                strength: 30.0
            })
        );
        let Some(BrittlenessViolation::TooSmall { strength, .. }) =
            violation(&[(soft, 1.0e-160), (soft, 30.0)])
        else {
            panic!("a strength whose square underflows is refused first");
        };
        assert_eq!(strength, 1.0e-160);
        let message = violation(&[(soft, 30.0)]).unwrap().message(l);
        assert!(
            message.contains("≥ 1") && message.contains("l_ch < 0.02222 m"),
            "{message}"
        );
    }

    #[test]
    fn the_released_energy_of_a_uniaxial_path_sums_to_the_softening_work() {
        let (sigma_f, e, gf, l) = (1.0, 100.0, 0.01, 0.05);
        let h = softening_modulus(sigma_f, e, gf, l);
        let failure_strain = sigma_f * (1.0 + h) / (h * e);
        let degradation = TensileDegradation {
            kind: Degradation::Published,
            lame: vec![(0.0, 0.5 * e)],
        };
        let released_over = |steps: usize| {
            let (mut d, mut total) = (0.0, 0.0);
            for k in 1..=steps {
                let eps = 1.2 * failure_strain * k as f64 / steps as f64;
                let strain = SymTensor2 {
                    xx: eps,
                    ..SymTensor2::ZERO
                };
                let (mut s, mut w) = (strain.scaled(e), 0.5 * e * eps * eps);
                let previous = d;
                d = rankine_damage(previous, s.principal_values()[0], sigma_f, h);
                if d > 0.0 {
                    total += degradation.apply_and_release::<Two>(
                        MaterialId(0),
                        (previous, d),
                        (&mut s, &mut w),
                        &strain,
                        &DMat2::IDENTITY,
                    );
                }
            }
            assert_eq!(d, 1.0);
            total
        };
        let exact = dissipated_density(1.0, sigma_f, e, h);
        assert!((exact * l - gf).abs() < 1e-12 * gf);
        let errors: Vec<f64> = [2000, 4000]
            .iter()
            .map(|&n| (released_over(n) / exact - 1.0).abs())
            .collect();
        assert!(errors[0] < 2e-2, "{errors:?}");
        assert!((errors[0] / errors[1] - 2.0).abs() < 0.1, "{errors:?}");
    }
}
