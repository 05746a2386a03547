//! Non-local Rankine damage: `damage/rankine`'s softening driven by a weighted average of the
//! largest principal stress over a fixed radius, so that the failed band's width, and with it
//! the dissipated energy, is a property of the material and not of the grid.
//!
//! - Stage: damage. Registration name: `damage/nonlocal_rankine`. Needs a `neighbour/*` system
//!   whose lists reach the averaging radius (give it `radius` in metres), and a stress system
//!   that provides `HyperelasticStress` (the stock one: `stress/neo_hookean`).
//! - The local law is dfg-partitioning-mpm.md §2.7, eq. (23), as in `damage/rankine`:
//!   `D = (1 + H_s)(1 − σ_f / r̂)`, `H_s = H̄_s l / (1 − H̄_s l)`, `H̄_s = σ_f² / (2 E G_f)`,
//!   damage never healing. What drives it is not the particle's own largest principal trial
//!   stress but the integral-type non-local average of Pijaudier-Cabot and Bažant (1987) with
//!   Rankine's equivalent stress (Jirásek, 2004):
//!   `r̄_p = Σ_q α(|x_p − x_q|) V₀,q ⟨σ_I,q⟩ / Σ_q α(|x_p − x_q|) V₀,q`, with the bell weight
//!   `α(r) = (1 − r²/R²)²` inside the radius `R` and 0 beyond, `⟨·⟩` the positive part and
//!   `σ_I` the largest principal trial (undamaged) stress. The sums run over the particles of
//!   the law's materials that have not failed: a failed particle carries no stress and is no
//!   longer part of the material the average describes (the `Intact` choice of
//!   `damage/eigensoftening`, docs/design/damage.md), and an impactor of another material is
//!   not part of it at all.
//! - `R` and `l` are lengths of the material, in metres, whatever the grid: refined at fixed
//!   `R`, the band that fails keeps its width and the energy it dissipates converges
//!   (`scenes/tension_nonlocal.ron`: 1.147, 1.087 and 1.072 `A G_f` with `R` over 4, 8 and 16
//!   cells; `fractum verify --case tension_nonlocal_h025,tension_nonlocal_h0125,tension_nonlocal_h00625`).
//!   The grid must resolve `R` (4 cells or more; under one cell is refused). `l`, the width
//!   over which the law spends `G_f`, defaults to `2R`, the bell weight's support: an
//!   estimate of the band's width, with which the converged bar spends about 1.07 `A G_f`
//!   (docs/design/damage.md).
//! - Distances are measured between current positions, as the neighbour lists are built.
//! - The damage degrades the stress as in `damage/rankine` (`degradation`, eqs. 26–27 or the
//!   spectral split), with the same strength per particle (`tensile_strength` or `weibull`),
//!   and publishes the same columns: `damaged_particles`, `failed_particles` and
//!   `dissipated_energy`, the stored energy each step's damage growth released
//!   (`damage::degrading_update`).
//! - Jacobi: every particle's average reads the stresses and damage from before this update, so
//!   the result does not depend on particle order or thread count.
use super::degrading_update::{DegradingLaw, DegradingParticles, degrade_particles};
use super::rankine_law::{RankineSoftening, install_softening};
use super::tensile_degradation::{
    DEGRADATION_PARAM, Degradation, TENSILE_STRENGTH_PARAM, TensileDegradation, WEIBULL_PARAM,
    largest_trial_principal, require_stress_degrading_pipeline,
};
use super::weibull::WeibullOption;
use crate::neighbour::NeighbourParams;
use fractum_engine::decomposition::OwnedRows;
use fractum_engine::prelude::*;
use rayon::prelude::*;
use serde::Deserialize;

/// Registration of `damage/nonlocal_rankine`.
pub const REGISTRATION: Registration = Registration {
    name: "damage/nonlocal_rankine",
    summary: "Rankine damage (eq. 23) driven by the largest principal stress averaged over a \
              fixed radius (bell weight): a band width and dissipation independent of the grid; \
              needs a hyperelastic stress (stress/neo_hookean)",
    params: &[
        TENSILE_STRENGTH_PARAM,
        ParamDoc {
            name: "fracture_energy",
            ty: "f64",
            default: None,
            doc: "G_f (J/m²)",
        },
        ParamDoc {
            name: "radius",
            ty: "f64",
            default: None,
            doc: "R (m), the averaging radius: a length of the material, a few cells or more",
        },
        ParamDoc {
            name: "characteristic_length",
            ty: "f64",
            default: Some("2 × radius"),
            doc: "l (m), the width over which the softening law spends G_f: the failed band's",
        },
        WEIBULL_PARAM,
        DEGRADATION_PARAM,
    ],
    requires: &["neighbour/*"],
    install: generic_install!(install),
};

/// Parameters as written in the scene.
#[derive(Deserialize, Clone, Debug)]
#[serde(deny_unknown_fields)]
struct RawParams {
    tensile_strength: f64,
    fracture_energy: f64,
    radius: f64,
    #[serde(default)]
    characteristic_length: Option<f64>,
    #[serde(default)]
    weibull: Option<WeibullOption>,
    #[serde(default)]
    degradation: Degradation,
}

/// Installed parameters of `damage/nonlocal_rankine`.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct NonlocalRankineParams {
    /// Eq. (23) with G_f spent over l.
    pub softening: RankineSoftening,
    /// R (m).
    pub radius: f64,
    /// Slots of the published columns: damaged, failed, dissipated energy.
    pub columns: [usize; 3],
    /// Which materials this entry damages.
    pub materials: MaterialFilter,
    /// How the damage degrades the stress.
    pub degradation: TensileDegradation,
}

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let raw: RawParams = params.parse()?;
    require_stress_degrading_pipeline(installer, params, "damage/nonlocal_rankine")?;
    params.require_positive("radius", raw.radius, "expected R > 0 (m)")?;
    let length = raw.characteristic_length.unwrap_or(2.0 * raw.radius);
    params.require_positive("characteristic_length", length, "expected l > 0 (m)")?;
    require_reach::<D>(installer, params, raw.radius)?;
    let (softening, columns) = install_softening(
        (installer, "damage/nonlocal_rankine"),
        params,
        (raw.tensile_strength, raw.weibull),
        raw.fracture_energy,
        (length, raw.characteristic_length.is_some()),
    )?;
    let materials = installer.materials().clone();
    installer.insert_resource(NonlocalRankineParams {
        softening,
        radius: raw.radius,
        columns,
        materials,
        degradation: TensileDegradation::new(installer, raw.degradation),
    });
    installer.add_systems(nonlocal_rankine::<D>);
    Ok(())
}

/// Refuses a radius the stock neighbour systems' lists do not reach (a system of the user's
/// own, which inserts no `NeighbourParams`, is trusted to), and a radius the grid does not
/// resolve: below a cell, the average is the particle's own stress and the law is local.
fn require_reach<D: Dim>(
    installer: &Installer,
    params: &Params,
    radius: f64,
) -> Result<(), SceneError> {
    let h = installer.world().resource::<Grid<D>>().spacing;
    if radius < h {
        return Err(params.error(
            "radius",
            format!(
                "R = {radius:e} m is less than a cell ({h:e} m): the average would hold the \
                 particle alone; use a radius of a few cells or a finer grid"
            ),
        ));
    }
    if let Some(neighbours) = installer.world().get_resource::<NeighbourParams>() {
        let epsilon = neighbours.epsilon(h);
        if epsilon < radius {
            return Err(params.error(
                "radius",
                format!(
                    "the neighbour lists reach ε = {epsilon:e} m, less than the averaging \
                     radius R = {radius:e} m; give the neighbour system `radius: {radius:e}`"
                ),
            ));
        }
    }
    Ok(())
}

/// The bell weight `α = (1 − r²/R²)²` of a neighbour at squared distance `distance_squared`
/// (0 at and beyond `R`).
pub fn bell_weight(distance_squared: f64, radius: f64) -> f64 {
    let t = 1.0 - distance_squared / (radius * radius);
    if t > 0.0 { t * t } else { 0.0 }
}

/// The non-local equivalent stress of row `p`: the bell-weighted, volume-weighted mean of the
/// local equivalent stresses `local` over `neighbours`, those with `None` (other materials,
/// failed particles) left out; 0 when none takes part.
pub fn nonlocal_average<D: Dim>(
    p: usize,
    neighbours: &[u32],
    positions: &[Position<D>],
    volume: &[InitialVolume],
    local: &[Option<f64>],
    radius: f64,
) -> f64 {
    let x = positions[p].0;
    let (mut weighted, mut total) = (0.0, 0.0);
    for &q in neighbours {
        let q = q as usize;
        let Some(stress) = local[q] else { continue };
        let weight = bell_weight((positions[q].0 - x).length_squared(), radius) * volume[q].0;
        weighted += weight * stress;
        total += weight;
    }
    if total > 0.0 { weighted / total } else { 0.0 }
}

/// Each row's local equivalent stress, the positive part of its largest principal trial
/// stress, or `None` where the row takes no part in the average.
fn local_equivalents<D: Dim>(
    params: &NonlocalRankineParams,
    particles: &DegradingParticles<D>,
) -> Vec<Option<f64>> {
    particles
        .iter()
        .map(|(material, _, _, _, _, stress, _, damage, _)| {
            let part = params.materials.applies(*material) && damage.0 < 1.0;
            part.then(|| largest_trial_principal(&stress.0).max(0.0))
        })
        .collect()
}

/// The `damage/nonlocal_rankine` system.
pub fn nonlocal_rankine<D: Dim>(
    params: Res<NonlocalRankineParams>,
    neighbourhoods: Res<Neighbourhoods>,
    mut columns: ResMut<SeriesColumns>,
    owned: OwnedRows,
    positions: Query<(&Position<D>, &InitialVolume), With<Particle>>,
    mut particles: DegradingParticles<D>,
) {
    let p = &*params;
    let Some((positions, volume)) = single_table(positions.contiguous_iter(), "particles") else {
        return;
    };
    let local = local_equivalents(p, &particles);
    let listed = neighbourhoods.particle_count();
    let driving: Vec<f64> = (0..positions.len())
        .into_par_iter()
        .map(|row| {
            let neighbours = if row < listed {
                neighbourhoods.of(row)
            } else {
                &[]
            };
            nonlocal_average(row, neighbours, positions, volume, &local, p.radius)
        })
        .collect();
    let law = DegradingLaw {
        materials: &p.materials,
        degradation: &p.degradation,
        columns: p.columns,
        driving: Some(&driving),
    };
    let softening = |material, previous, average, strength| {
        p.softening.damage(material, previous, average, strength)
    };
    degrade_particles(&law, &mut columns, owned.get(), &mut particles, softening);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::damage::rankine_law::{rankine_damage, softening_modulus};
    use fractum_engine::testing::*;

    /// `fractum systems` documents exactly the fields its parameters read.
    #[test]
    fn parameter_docs_match_the_parameters() {
        assert_documented::<RawParams>(&REGISTRATION);
    }

    #[test]
    fn the_bell_weight_falls_from_one_to_zero_at_the_radius() {
        assert_eq!(bell_weight(0.0, 2.0), 1.0);
        assert_eq!(bell_weight(1.0, 2.0), 0.5625);
        assert_eq!(bell_weight(4.0, 2.0), 0.0);
        assert_eq!(bell_weight(9.0, 2.0), 0.0);
    }

    /// Three particles in a row, a second apart, R = 2: the middle one weighs its neighbours
    /// at 9/16; a failed or foreign neighbour (`None`) is left out of both sums.
    #[test]
    fn the_average_weighs_by_distance_and_volume_and_leaves_out_what_takes_no_part() {
        let positions: Vec<Position<Two>> = [0.0, 1.0, 2.0]
            .iter()
            .map(|&x| Position(DVec2::new(x, 0.0)))
            .collect();
        let volume = [InitialVolume(1.0), InitialVolume(1.0), InitialVolume(2.0)];
        let all = [0u32, 1, 2];
        let local = [Some(4.0), Some(1.0), Some(0.0)];
        let expected = (0.5625 * 4.0 + 1.0) / (0.5625 + 1.0 + 0.5625 * 2.0);
        let average = nonlocal_average(1, &all, &positions, &volume, &local, 2.0);
        assert!((average - expected).abs() < 1e-15, "{average} {expected}");
        let failed = [Some(4.0), Some(1.0), None];
        let expected = (0.5625 * 4.0 + 1.0) / (0.5625 + 1.0);
        let average = nonlocal_average(1, &all, &positions, &volume, &failed, 2.0);
        assert!((average - expected).abs() < 1e-15, "{average} {expected}");
        assert_eq!(
            nonlocal_average(1, &all, &positions, &volume, &[None; 3], 2.0),
            0.0
        );
    }

    fn insert_params(world: &mut World, radius: f64) -> [usize; 3] {
        let mut columns = SeriesColumns::default();
        let slots = [
            columns.declare("damaged_particles"),
            columns.declare("failed_particles"),
            columns.declare("dissipated_energy"),
        ];
        world.insert_resource(columns);
        world.insert_resource(NonlocalRankineParams {
            softening: RankineSoftening {
                fracture_energy: 0.01,
                characteristic_length: 0.05,
                youngs_modulus: vec![test_material().youngs_modulus],
            },
            radius,
            columns: slots,
            materials: MaterialFilter::all(),
            degradation: TensileDegradation {
                kind: Degradation::Published,
                lame: vec![test_material().lame()],
            },
        });
        slots
    }

    /// A row of five particles 0.1 apart, the middle one stressed to 5 (strength 1), the others
    /// unstressed: the local law would damage the middle one alone. Averaged over R = 0.25 the
    /// middle one's driving stress is 5 diluted by its neighbours, and its neighbours within R
    /// feel it: the damage is the law's at the average, on every particle the average lifts
    /// above the strength.
    #[test]
    fn system_damages_by_the_average_not_by_the_particles_own_stress() {
        let mut world = tiny_world::<Two>(4, 0.25, 1e-3);
        let slots = insert_params(&mut world, 0.25);
        let xs = [0.3, 0.4, 0.5, 0.6, 0.7];
        let peak = SymTensor2 {
            xx: 5.0,
            ..SymTensor2::ZERO
        };
        for (k, x) in xs.iter().enumerate() {
            let p = spawn_particle(&mut world, DVec2::new(*x, 0.5), DVec2::ZERO, 1.0, 0.01);
            world
                .entity_mut(p)
                .insert((Strength(1.0), DamageDissipation(0.0)));
            if k == 2 {
                world.get_mut::<Stress<Two>>(p).unwrap().0 = peak;
                world.get_mut::<Strain<Two>>(p).unwrap().0 = peak.scaled(0.01);
                world.get_mut::<StrainEnergyDensity>(p).unwrap().0 = 0.5 * 5.0 * 0.05;
            }
        }
        let mut lists = Neighbourhoods::default();
        let rows: Vec<Vec<u32>> = (0..5)
            .map(|p: usize| {
                (0..5u32)
                    .filter(|&q| (xs[p] - xs[q as usize]).abs() <= 0.25)
                    .collect()
            })
            .collect();
        lists.set_rows(&rows, 0.25);
        world.insert_resource(lists);
        run_system(&mut world, nonlocal_rankine::<Two>);
        let damage = particle_values::<Damage>(&mut world);
        let h = softening_modulus(1.0, 100.0, 0.01, 0.05);
        // Weights at 0, 0.1 and 0.2 of R = 0.25: 1, (1 − 0.16)² and (1 − 0.64)².
        let (w1, w2) = (0.84f64 * 0.84, 0.36f64 * 0.36);
        let centre = 5.0 / (1.0 + 2.0 * w1 + 2.0 * w2);
        let beside = 5.0 * w1 / (1.0 + 2.0 * w1 + w2);
        assert!(centre > 1.0 && beside > 1.0 && 5.0 * w2 / (1.0 + w1 + w2) < 1.0);
        let expected = [
            0.0,
            rankine_damage(0.0, beside, 1.0, h),
            rankine_damage(0.0, centre, 1.0, h),
            rankine_damage(0.0, beside, 1.0, h),
            0.0,
        ];
        for (k, d) in damage.iter().enumerate() {
            assert!(
                (d.0 - expected[k]).abs() < 1e-12,
                "{k}: {} {}",
                d.0,
                expected[k]
            );
        }
        let columns = world.resource::<SeriesColumns>();
        assert_eq!(columns.values[slots[0]], 3.0);
        assert_eq!(columns.values[slots[1]], 0.0);
        // Only the stressed particle stored energy: it alone released any.
        let dissipation = particle_values::<DamageDissipation>(&mut world);
        assert!(dissipation[2].0 > 0.0);
        assert_eq!(dissipation[1].0, 0.0);
    }
}
