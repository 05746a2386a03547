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
//!   form [`dissipated_density`](crate::damage::rankine_law::dissipated_density)
//!   (`σ_f² (1 + H_s) D / (2 E (1 + H_s − D))`); under any other
//!   stress it is what the particle's stored energy lost to the damage, so the energy account
//!   of `series.csv` closes (docs/design/damage.md).
use super::degrading_update::{DegradingLaw, DegradingParticles, degrade_particles};
use super::rankine_law::{RankineSoftening, install_softening};
use super::tensile_degradation::{
    DEGRADATION_PARAM, Degradation, TENSILE_STRENGTH_PARAM, TensileDegradation, WEIBULL_PARAM,
    characteristic_length, require_stress_degrading_pipeline,
};
use super::weibull::WeibullOption;
use fractum_engine::decomposition::OwnedRows;
use fractum_engine::prelude::*;
use serde::Deserialize;

/// Registration of `damage/rankine`.
pub const REGISTRATION: Registration = Registration {
    name: "damage/rankine",
    summary: "Rankine damage, linear strain softening tied to G_f over l_ch (eq. 23), tensile \
              principal stresses degraded (eqs. 26-27); needs a hyperelastic stress \
              (stress/neo_hookean)",
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
    /// Eq. (23) with G_f spent over l_ch.
    pub softening: RankineSoftening,
    /// Slots of the published columns: damaged, failed, dissipated energy.
    pub columns: [usize; 3],
    /// Which materials this entry damages.
    pub materials: MaterialFilter,
    /// How the damage degrades the stress.
    pub degradation: TensileDegradation,
}

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let raw: RawParams = params.parse()?;
    require_stress_degrading_pipeline(installer, params, "damage/rankine")?;
    let length = characteristic_length::<D>(installer, params, raw.characteristic_length)?;
    let (softening, columns) = install_softening(
        (installer, "damage/rankine"),
        params,
        (raw.tensile_strength, raw.weibull),
        raw.fracture_energy,
        (length, raw.characteristic_length.is_some()),
    )?;
    let materials = installer.materials().clone();
    installer.insert_resource(RankineParams {
        softening,
        columns,
        materials,
        degradation: TensileDegradation::new(installer, raw.degradation),
    });
    installer.add_systems(rankine::<D>);
    Ok(())
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
    let softening = |material, previous, largest, strength| {
        p.softening.damage(material, previous, largest, strength)
    };
    degrade_particles(&law, &mut columns, owned.get(), &mut particles, softening);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::damage::rankine_law::{rankine_damage, softening_modulus};

    /// `fractum systems` documents exactly the fields its parameters read.
    #[test]
    fn parameter_docs_match_the_parameters() {
        fractum_engine::testing::assert_documented::<RawParams>(&REGISTRATION);
    }
    use fractum_engine::testing::*;

    fn insert_params(world: &mut World) -> [usize; 3] {
        let mut columns = SeriesColumns::default();
        let slots = [
            columns.declare("damaged_particles"),
            columns.declare("failed_particles"),
            columns.declare("dissipated_energy"),
        ];
        world.insert_resource(columns);
        world.insert_resource(RankineParams {
            softening: RankineSoftening {
                fracture_energy: 0.01,
                characteristic_length: 0.05,
                youngs_modulus: vec![test_material().youngs_modulus],
            },
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
