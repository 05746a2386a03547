//! Time-to-failure damage: a failing particle loses its tensile strength over the time a crack
//! takes to cross it.
//!
//! - Stage: damage. Registration name: `damage/time_to_failure`. Needs a stress system that provides
//!   `HyperelasticStress` (the stock one: `stress/neo_hookean`).
//! - dfg-partitioning-mpm.md §2.7, eq. (24): `D ← min(1, D + Δt / τ)` with `τ = l_ch / c_f`, the
//!   transit time of a crack running at the prescribed speed `c_f` across the characteristic
//!   length `l_ch` (default: the cell diagonal, as in the paper). The paper prints `τ = c_f / ℓ`,
//!   which is a rate (1/s), not a time; the transit time it describes is `ℓ / c_f`, used here.
//! - A particle starts failing in the first step its largest principal trial stress (of the
//!   three, `σ_zz` included in plane strain) exceeds its strength `σ_f`, and then keeps failing
//!   at that rate until `D = 1`, whatever its stress does meanwhile: the damage growing means a
//!   crack crossing it, which does not stop half-way. (`D > 0` is the record that it started.)
//! - The damage scales the tensile principal stresses only (eqs. 26–27,
//!   `damage::tensile_degradation`), written back into `Stress`; or, with
//!   `degradation: Spectral`, the tensile part of the strain energy, the stress derived from it
//!   (`damage::spectral_split`).
//! - Strength per particle: `tensile_strength`, or drawn from a Weibull distribution (eq. 25)
//!   with the `weibull` option (`damage::weibull`), as in the paper's Brazilian test.
//! - Publishes `series.csv` columns `damaged_particles` (D > 0), `failed_particles` (D = 1) and
//!   `dissipated_energy`, the stored energy each step's damage growth released at that step's
//!   strain, accumulated per particle in `DamageDissipation` (as `damage/rankine` does; J per
//!   scene thickness in 2D).

use super::degrading_update::{DegradingLaw, DegradingParticles, degrade_particles};
use super::tensile_degradation::{
    DEGRADATION_PARAM, Degradation, TENSILE_STRENGTH_PARAM, TensileDegradation, WEIBULL_PARAM,
    characteristic_length, install_strength, require_stress_degrading_pipeline,
};
use super::weibull::WeibullOption;
use fractum_engine::decomposition::OwnedRows;
use fractum_engine::prelude::*;
use serde::Deserialize;

/// Registration of `damage/time_to_failure`.
pub const REGISTRATION: Registration = Registration {
    name: "damage/time_to_failure",
    summary: "time-to-failure damage: D grows by Δt c_f / l_ch once σ_f is exceeded (eq. 24), \
              tensile principal stresses degraded (eqs. 26-27); needs a hyperelastic stress \
              (stress/neo_hookean)",
    params: &[
        TENSILE_STRENGTH_PARAM,
        ParamDoc {
            name: "crack_speed",
            ty: "f64",
            default: None,
            doc: "c_f (m/s), the speed a crack crosses a particle at",
        },
        ParamDoc {
            name: "characteristic_length",
            ty: "f64",
            default: Some("cell diagonal"),
            doc: "l_ch (m); the time to failure is τ = l_ch / c_f",
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
    crack_speed: f64,
    #[serde(default)]
    characteristic_length: Option<f64>,
    #[serde(default)]
    weibull: Option<WeibullOption>,
    #[serde(default)]
    degradation: Degradation,
}

/// Installed parameters of `damage/time_to_failure`.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct TimeToFailureParams {
    /// τ = l_ch / c_f (s).
    pub time_to_failure: f64,
    /// Slots of the published columns: damaged, failed, dissipated energy.
    pub columns: [usize; 3],
    /// Which materials this entry damages.
    pub materials: MaterialFilter,
    /// How the damage degrades the stress.
    pub degradation: TensileDegradation,
}

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let raw: RawParams = params.parse()?;
    require_stress_degrading_pipeline(installer, params, "damage/time_to_failure")?;
    params.require_positive("crack_speed", raw.crack_speed, "expected c_f > 0 (m/s)")?;
    let length = characteristic_length::<D>(installer, params, raw.characteristic_length)?;
    install_strength(installer, params, raw.tensile_strength, raw.weibull)?;
    let materials = installer.materials().clone();
    installer.add_particle_component(DamageDissipation(0.0));
    installer.declare_real_time(REGISTRATION.name, "its time to failure τ = l_ch / c_f");
    let columns = [
        installer.add_owned_sum_column("damaged_particles"),
        installer.add_owned_sum_column("failed_particles"),
        installer.add_owned_sum_column("dissipated_energy"),
    ];
    installer.insert_resource(TimeToFailureParams {
        time_to_failure: length / raw.crack_speed,
        columns,
        materials,
        degradation: TensileDegradation::new(installer, raw.degradation),
    });
    installer.add_systems(time_to_failure::<D>);
    Ok(())
}

/// Eq. (24): the damage after a step of `dt` from `previous`, for a largest principal trial
/// stress `trial`, strength `strength` and time to failure `tau`.
pub fn time_to_failure_damage(previous: f64, trial: f64, strength: f64, dt: f64, tau: f64) -> f64 {
    if previous > 0.0 || trial > strength {
        (previous + dt / tau).min(1.0)
    } else {
        previous
    }
}

/// The `damage/time_to_failure` system.
pub fn time_to_failure<D: Dim>(
    clock: Res<SimClock>,
    params: Res<TimeToFailureParams>,
    mut columns: ResMut<SeriesColumns>,
    owned: OwnedRows,
    mut particles: DegradingParticles<D>,
) {
    let (p, dt) = (&*params, clock.dt);
    let law = DegradingLaw {
        materials: &p.materials,
        degradation: &p.degradation,
        columns: p.columns,
        driving: None,
    };
    let failing = |_: MaterialId, previous: f64, largest: f64, strength: f64| {
        time_to_failure_damage(previous, largest, strength, dt, p.time_to_failure)
    };
    degrade_particles(&law, &mut columns, owned.get(), &mut particles, failing);
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
    fn damage_starts_above_strength_and_then_grows_at_the_crack_speed() {
        let (dt, tau) = (1.0, 4.0);
        assert_eq!(time_to_failure_damage(0.0, 0.9, 1.0, dt, tau), 0.0);
        let mut d = time_to_failure_damage(0.0, 1.1, 1.0, dt, tau);
        assert_eq!(d, 0.25);
        // Started: it goes on under any stress, to 1 in τ.
        for _ in 0..3 {
            d = time_to_failure_damage(d, -5.0, 1.0, dt, tau);
        }
        assert_eq!(d, 1.0);
        assert_eq!(time_to_failure_damage(d, 5.0, 1.0, dt, tau), 1.0);
    }

    /// Two particles under the same trial stress, strengths 1 and 10, for two steps.
    fn fails_the_weak_particle<D: Dim>(trial: D::Sym)
    where
        D::Vector: SpaceVector,
    {
        let mut world = tiny_world::<D>(4, 0.25, 1e-3);
        let mut columns = SeriesColumns::default();
        let slots = [
            columns.declare("damaged_particles"),
            columns.declare("failed_particles"),
            columns.declare("dissipated_energy"),
        ];
        world.insert_resource(columns);
        world.insert_resource(TimeToFailureParams {
            time_to_failure: 2e-3,
            columns: slots,
            materials: MaterialFilter::all(),
            degradation: TensileDegradation {
                kind: Degradation::Published,
                lame: vec![test_material().lame()],
            },
        });
        for (k, strength) in [(0, 1.0), (1, 10.0)] {
            let x = D::Vector::from_fn(|a| if a == 0 { 0.3 + 0.3 * k as f64 } else { 0.5 });
            let p = spawn_particle(&mut world, x, D::Vector::ZERO, 1.0, 0.01);
            world
                .entity_mut(p)
                .insert((Strength(strength), DamageDissipation(0.0)));
            // A strain along the trial stress, `ε = σ / 100`, storing `σ : ε / 2`.
            world.get_mut::<Strain<D>>(p).unwrap().0 = trial.scaled(0.01);
        }
        let stored = 0.5 * trial.double_dot(&(trial.scaled(0.01)));
        for (step, expected) in [(1, 0.5), (2, 1.0)] {
            // The stress stage would write the trial stress and energy afresh each step.
            let mut q = world.query::<(&mut Stress<D>, &mut StrainEnergyDensity)>();
            for (mut s, mut w) in q.iter_mut(&mut world) {
                s.0 = trial;
                w.0 = stored;
            }
            run_system(&mut world, time_to_failure::<D>);
            let damage = particle_values::<Damage>(&mut world);
            assert_eq!((damage[0].0, damage[1].0), (expected, 0.0), "step {step}");
        }
        let stress = particle_values::<Stress<D>>(&mut world);
        let values = stress[0].0.principal_values();
        // Trial principal values (2, 0, −1): failed in tension, compression kept.
        assert!(
            values[0].abs() < 1e-12 && (values[2] + 1.0).abs() < 1e-12,
            "{values:?}"
        );
        assert_eq!(stress[1].0, trial);
        let columns = world.resource::<SeriesColumns>();
        assert_eq!(
            (columns.values[slots[0]], columns.values[slots[1]]),
            (1.0, 1.0)
        );
        // Failing released the tensile share of the stored energy, 4 of σ : ε's 5 parts, in two
        // halves, times V₀ = 0.01.
        let released = 0.01 * 0.8 * stored;
        assert!((columns.values[slots[2]] - released).abs() < 1e-15 * released);
        let dissipation = particle_values::<DamageDissipation>(&mut world);
        assert_eq!(dissipation[1].0, 0.0);
    }

    #[test]
    fn system_fails_the_particles_above_their_strength_in_two_time_steps() {
        fails_the_weak_particle::<Two>(SymTensor2 {
            xx: 2.0,
            yy: -1.0,
            ..SymTensor2::ZERO
        });
        fails_the_weak_particle::<Three>(SymTensor3 {
            xx: 1.0,
            yy: 1.0,
            zz: -1.0,
            xy: 1.0,
            ..SymTensor3::ZERO
        });
    }
}
