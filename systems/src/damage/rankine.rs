//! Rankine damage with linear strain softening tied to the fracture energy.
//!
//! - Stage: damage. Registration name: `damage/rankine`. Needs a stress system that provides
//!   `HyperelasticStress` (the stock one: `stress/neo_hookean`).
//! - dfg-partitioning-mpm.md §2.7, eq. (23) (Cervera et al.'s model): once the largest principal
//!   trial stress `r` (of the three, `σ_zz` included in plane strain) exceeds the particle's
//!   strength `σ_f`, `D = (1 + H_s)(1 − σ_f / r̂)` with `r̂` the largest `r` so far (damage never
//!   heals; kept as `D = max(D_prev, ·)`, which is the same since the law grows with `r̂`), capped
//!   at 1. The brittleness `H̄_s = σ_f² / (2 E G_f)` is scaled by the characteristic length,
//!   `H_s = H̄_s l_ch / (1 − H̄_s l_ch)`, so that a band of width `l_ch` dissipates `G_f` per unit
//!   area: in uniaxial tension the stress then falls linearly from `σ_f` with slope `−H_s E`,
//!   and the energy per unit volume to full failure is `σ_f² (1 + H_s) / (2 E H_s) = G_f / l_ch`.
//!   `l_ch` defaults to the cell diagonal; `H̄_s l_ch ≥ 1` has no softening branch (the stress
//!   would have to snap back) and is refused at install.
//! - The damage scales the tensile principal stresses only (eqs. 26–27,
//!   `damage::tensile_degradation`), written back into `Stress`; or, with
//!   `degradation: Spectral`, the tensile part of the strain energy, the stress derived from it
//!   (`damage::spectral_split`).
//! - Strength per particle: `tensile_strength`, or drawn from a Weibull distribution (eq. 25)
//!   with the `weibull` option (`damage::weibull`).
//! - Publishes `series.csv` columns `damaged_particles` (D > 0), `failed_particles` (D = 1) and
//!   `dissipated_energy`: the stored energy each step's damage growth released at that step's
//!   strain, `Σ_p V₀,p Σ_steps (ψ(D_prev) − ψ(D))` (`TensileDegradation::apply_and_release`),
//!   accumulated per particle in `DamageDissipation`; J per scene thickness in 2D. Damage a
//!   scene seeds (a notch) released nothing and is not counted. In uniaxial tension this is the
//!   work of the softening curve less the elastic energy left on the unloading line, the closed
//!   form [`dissipated_density`] (`σ_f² (1 + H_s) D / (2 E (1 + H_s − D))`); under any other
//!   stress it is what the particle's stored energy lost to the damage, so the energy account
//!   of `series.csv` closes (docs/design/damage.md).
use super::degrading_update::{DegradingLaw, DegradingParticles, degrade_particles};
use super::tensile_degradation::{
    DEGRADATION_PARAM, Degradation, TENSILE_STRENGTH_PARAM, TensileDegradation, WEIBULL_PARAM,
    characteristic_length, install_strength, require_stress_degrading_pipeline,
};
use super::weibull::WeibullOption;
use fractum_engine::decomposition::OwnedRows;
use fractum_engine::prelude::*;
use serde::Deserialize;

/// Registration of `damage/rankine`.
pub const REGISTRATION: Registration = Registration {
    name: "damage/rankine",
    summary: "Rankine damage, linear strain softening tied to G_f over l_ch (eq. 23), tensile \
              principal stresses degraded (eqs. 26-27)",
    params: &[
        TENSILE_STRENGTH_PARAM,
        ParamDoc {
            name: "fracture_energy",
            ty: "f64",
            default: None,
            doc: "G_f (J/m²)",
        },
        ParamDoc {
            name: "characteristic_length",
            ty: "f64",
            default: Some("cell diagonal"),
            doc: "l_ch (m), the width over which a crack dissipates G_f",
        },
        WEIBULL_PARAM,
        DEGRADATION_PARAM,
    ],
    requires: &[],
    install: generic_install!(install),
};

/// Parameters as written in the scene.
#[derive(Deserialize, Clone, Debug)]
#[serde(deny_unknown_fields)]
struct RawParams {
    tensile_strength: f64,
    fracture_energy: f64,
    #[serde(default)]
    characteristic_length: Option<f64>,
    #[serde(default)]
    weibull: Option<WeibullOption>,
    #[serde(default)]
    degradation: Degradation,
}

/// Installed parameters of `damage/rankine`.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct RankineParams {
    /// G_f (J/m²).
    pub fracture_energy: f64,
    /// l_ch (m).
    pub characteristic_length: f64,
    /// Young's modulus of each material (the scene's material table order).
    pub youngs_modulus: Vec<f64>,
    /// Slots of the published columns: damaged, failed, dissipated energy.
    pub columns: [usize; 3],
    /// Which materials this entry damages.
    pub materials: MaterialFilter,
    /// How the damage degrades the stress.
    pub degradation: TensileDegradation,
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
    let scaled: Vec<(f64, f64)> = strengths
        .iter()
        .map(|&(m, s)| {
            (
                brittleness(s, youngs_modulus[m.0 as usize], fracture_energy) * length,
                s,
            )
        })
        .collect();
    // The weakest particle has the smallest H̄_s l_ch, the strongest the largest.
    let weakest = scaled.iter().min_by(|a, b| a.0.total_cmp(&b.0));
    let worst = scaled.iter().max_by(|a, b| a.0.total_cmp(&b.0));
    if let Some(&(scaled, strength)) = weakest
        && !scaled.is_normal()
    {
        return Err(params.error(
            "tensile_strength",
            format!(
                "H̄_s l_ch = σ_f² l_ch / (2 E G_f) = {scaled:e} (σ_f = {strength:e} Pa, l_ch = \
                 {length:e} m) is too small for f64: the softening law cannot be evaluated; a \
                 strength this small is no strength"
            ),
        ));
    }
    if let Some(&(scaled, strength)) = worst
        && scaled >= 1.0
    {
        let field = if length_given {
            "characteristic_length"
        } else {
            "fracture_energy"
        };
        return Err(params.error(
            field,
            format!(
                "H̄_s l_ch = σ_f² l_ch / (2 E G_f) = {scaled:.3} ≥ 1 (σ_f = {strength:e} Pa, l_ch = \
                 {length:e} m): the softening branch would have to snap back; use l_ch < {:e} m \
                 (a finer grid, when it defaults to the cell diagonal) or a larger G_f",
                length / scaled
            ),
        ));
    }
    Ok(())
}

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let raw: RawParams = params.parse()?;
    require_stress_degrading_pipeline(installer, params, "damage/rankine")?;
    params.require_positive(
        "fracture_energy",
        raw.fracture_energy,
        "expected G_f > 0 (J/m²)",
    )?;
    let length = characteristic_length::<D>(installer, params, raw.characteristic_length)?;
    let youngs_modulus: Vec<f64> = installer
        .world()
        .resource::<Materials>()
        .0
        .iter()
        .map(|m| m.youngs_modulus)
        .collect();
    let strengths = install_strength(installer, params, raw.tensile_strength, raw.weibull)?;
    let given = (raw.fracture_energy, raw.characteristic_length.is_some());
    check_brittleness(params, given, &strengths, &youngs_modulus, length)?;
    let materials = installer.materials().clone();
    installer.add_particle_component(DamageDissipation(0.0));
    let columns = [
        installer.add_owned_sum_column("damaged_particles"),
        installer.add_owned_sum_column("failed_particles"),
        installer.add_owned_sum_column("dissipated_energy"),
    ];
    installer.insert_resource(RankineParams {
        fracture_energy: raw.fracture_energy,
        characteristic_length: length,
        youngs_modulus,
        columns,
        materials,
        degradation: TensileDegradation::new(installer, raw.degradation),
    });
    installer.add_systems(rankine::<D>);
    Ok(())
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

/// The `damage/rankine` system.
pub fn rankine<D: Dim>(
    params: Res<RankineParams>,
    mut columns: ResMut<SeriesColumns>,
    owned: OwnedRows,
    mut particles: DegradingParticles<D>,
) {
    let p = &*params;
    let law = DegradingLaw {
        materials: &p.materials,
        degradation: &p.degradation,
        columns: p.columns,
        driving: None,
    };
    let softening = |material: MaterialId, previous: f64, largest: f64, strength: f64| {
        let e = p.youngs_modulus[material.0 as usize];
        let h = softening_modulus(strength, e, p.fracture_energy, p.characteristic_length);
        rankine_damage(previous, largest, strength, h)
    };
    degrade_particles(&law, &mut columns, owned.get(), &mut particles, softening);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `fractum systems` documents exactly the fields its parameters read.
    #[test]
    fn parameter_docs_match_the_parameters() {
        fractum_engine::testing::assert_documented::<RawParams>(&REGISTRATION);
    }
    use fractum_engine::testing::*;

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

    fn insert_params(world: &mut World) -> [usize; 3] {
        let mut columns = SeriesColumns::default();
        let slots = [
            columns.declare("damaged_particles"),
            columns.declare("failed_particles"),
            columns.declare("dissipated_energy"),
        ];
        world.insert_resource(columns);
        world.insert_resource(RankineParams {
            fracture_energy: 0.01,
            characteristic_length: 0.05,
            youngs_modulus: vec![test_material().youngs_modulus],
            columns: slots,
            materials: MaterialFilter::all(),
            degradation: TensileDegradation {
                kind: Degradation::Published,
                lame: vec![test_material().lame()],
            },
        });
        slots
    }

    /// Two particles under the same trial stress, strengths 1 and 10: the weak one damages and
    /// its tensile stress is scaled back, its compression kept; the strong one is untouched.
    fn damages_the_weak_particle<D: Dim>(trial: D::Sym)
    where
        D::Vector: SpaceVector,
    {
        let mut world = tiny_world::<D>(4, 0.25, 1e-3);
        let slots = insert_params(&mut world);
        // A strain along the trial stress, `ε = σ / 100`, and the energy `σ : ε / 2` it stores.
        let strain = trial.scaled(0.01);
        let stored = 0.5 * trial.double_dot(&strain);
        for (k, strength) in [(0, 1.0), (1, 10.0)] {
            let x = D::Vector::from_fn(|a| if a == 0 { 0.3 + 0.3 * k as f64 } else { 0.5 });
            let p = spawn_particle(&mut world, x, D::Vector::ZERO, 1.0, 0.01);
            world
                .entity_mut(p)
                .insert((Strength(strength), DamageDissipation(0.0)));
            world.get_mut::<Stress<D>>(p).unwrap().0 = trial;
            world.get_mut::<Strain<D>>(p).unwrap().0 = strain;
            world.get_mut::<StrainEnergyDensity>(p).unwrap().0 = stored;
        }
        run_system(&mut world, rankine::<D>);
        let damage = particle_values::<Damage>(&mut world);
        let h = softening_modulus(1.0, 100.0, 0.01, 0.05);
        let expected = rankine_damage(0.0, 2.0, 1.0, h);
        assert!(expected > 0.0 && expected < 1.0);
        assert_eq!(damage[0].0, expected);
        assert_eq!(damage[1].0, 0.0);
        let stress = particle_values::<Stress<D>>(&mut world);
        let values = stress[0].0.principal_values();
        // Principal trial values (2, 0, −1): tension scaled, compression kept.
        assert!(
            (values[0] - 2.0 * (1.0 - expected)).abs() < 1e-12,
            "{values:?}"
        );
        assert!((values[2] + 1.0).abs() < 1e-12, "{values:?}");
        assert_eq!(stress[1].0, trial);
        let columns = world.resource::<SeriesColumns>();
        assert_eq!(columns.values[slots[0]], 1.0);
        assert_eq!(columns.values[slots[1]], 0.0);
        // Of σ : ε = (4 + 1) / 100, the tensile 4 / 100 lost D: released `0.8 D` of the stored
        // energy, times V₀ = 0.01, on the particle and in the column.
        let released = 0.01 * 0.8 * expected * stored;
        let dissipation = particle_values::<DamageDissipation>(&mut world);
        assert!((dissipation[0].0 - released).abs() < 1e-15 * released);
        assert_eq!(dissipation[1].0, 0.0);
        let columns = world.resource::<SeriesColumns>();
        assert_eq!(columns.values[slots[2]], dissipation[0].0);
    }

    /// A particle taken along a uniaxial strain path (ν = 0, so σ = E ε alone) through the
    /// whole softening branch: the energy its damage releases, step by step, sums to the closed
    /// form of the work of the softening curve, `G_f / l_ch` at full failure, with an error that
    /// halves as the steps halve (the release is taken at each step's end strain).
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

    #[test]
    fn system_damages_the_particles_above_their_strength() {
        // Plane strain: σ_xx = 2, σ_yy = −1.
        damages_the_weak_particle::<Two>(SymTensor2 {
            xx: 2.0,
            yy: -1.0,
            ..SymTensor2::ZERO
        });
        // 3D, tension along (1, 1, 0)/√2 and compression along z.
        damages_the_weak_particle::<Three>(SymTensor3 {
            xx: 1.0,
            yy: 1.0,
            zz: -1.0,
            xy: 1.0,
            ..SymTensor3::ZERO
        });
    }

    /// With `degradation: Spectral` the system writes the stress and energy of the split
    /// potential for the particle's deformation gradient and damage.
    #[test]
    fn system_degrades_the_split_energy_with_the_spectral_option() {
        use crate::damage::spectral_split::spectral_degraded;
        use crate::stress::neo_hookean::{neo_hookean_energy, neo_hookean_stress_of};
        let mut world = tiny_world::<Two>(4, 0.25, 1e-3);
        insert_params(&mut world);
        world.resource_mut::<RankineParams>().degradation.kind = Degradation::Spectral;
        let (lambda, mu) = test_material().lame();
        // Opened along x, shortened along y: trial σ_xx ≈ 5.8 Pa against a strength of 1.
        let f = DMat2::from_diagonal(DVec2::new(1.05, 0.99));
        let p = spawn_particle(&mut world, DVec2::new(0.5, 0.5), DVec2::ZERO, 1.0, 0.01);
        world
            .entity_mut(p)
            .insert((Strength(1.0), DamageDissipation(0.0)));
        world.get_mut::<DeformationGradient<Two>>(p).unwrap().0 = f;
        let trial = neo_hookean_stress_of::<Two>(f, lambda, mu).unwrap();
        world.get_mut::<Stress<Two>>(p).unwrap().0 = trial;
        world.get_mut::<StrainEnergyDensity>(p).unwrap().0 =
            neo_hookean_energy::<Two>(f, lambda, mu);
        run_system(&mut world, rankine::<Two>);
        let d = particle_values::<Damage>(&mut world)[0].0;
        let h = softening_modulus(1.0, 100.0, 0.01, 0.05);
        assert_eq!(d, rankine_damage(0.0, trial.principal_values()[0], 1.0, h));
        let (stress, energy) = spectral_degraded::<Two>(f, lambda, mu, d).unwrap();
        assert_eq!(particle_values::<Stress<Two>>(&mut world)[0].0, stress);
        assert_eq!(
            particle_values::<StrainEnergyDensity>(&mut world)[0].0,
            energy
        );
        // The shortened axis keeps its compression; the opened one lost (1 − D)'s complement.
        assert!(stress.yy < 0.0 && stress.xx < trial.xx, "{stress:?}");
        // The growth from intact released the split energy's loss, times V₀ = 0.01.
        let released = 0.01 * (neo_hookean_energy::<Two>(f, lambda, mu) - energy);
        assert!(released > 0.0);
        let dissipated = particle_values::<DamageDissipation>(&mut world)[0].0;
        assert!(
            (dissipated - released).abs() < 1e-15,
            "{dissipated:e} {released:e}"
        );
    }
}
