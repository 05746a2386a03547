//! Eigenerosion: energetic, non-local failure of brittle material points (Pandolfi & Ortiz).
//!
//! - Stage: damage. Registration name: `damage/eigenerosion`. Needs a `neighbour/*` system.
//! - eigensoftening-lme-mpm.md §2.3, eqs. (11)–(12), in the dimensionally consistent form of
//!   the authors' implementation (NL-PartSol, `EigenErosion.c`): for an intact particle in
//!   tension (largest principal stress > 0; in plane strain the in-plane one),
//!   `G_p = C_ε h · Σ_{q∈B_ε, intact} V_q W_q / Σ_{q∈B_ε} V_q`: the neighbourhood's average
//!   stored energy density times ε = C_ε h, an energy per unit crack area. (Read literally with
//!   W per unit mass and a dimensionless C_ε, eq. (11) is not an energy per area.) Failed
//!   points carry no stress and so no energy. When `G_p > G_F` the particle fails: damage 1,
//!   it keeps its mass and stops contributing internal force.
//! - Jacobi: every particle reads its neighbours' state from before this update.
//! - Publishes `failed_particles` and `dissipated_energy`, the stored energy the failed points
//!   held when they failed (the elastic energy the erosion removes): in a distributed run each
//!   rank counts and sums the particles it owns, and the run adds the ranks' columns.
//!
//! # Normalisation
//!
//! `normalisation: Published` (the default) is the formula above. It does not fail a point
//! when the energy release rate `G` of a sharp crack reaches `G_F`, but at about seven times
//! it. `normalisation: Griffith` multiplies `G_p` by the constant `k` for which a point at a
//! sharp crack tip fails when `G = G_F`. Derivation (linear elasticity, mode I):
//!
//! - Near the tip the strain energy density is `W = K² (1 + cos θ)(κ − cos θ) / (16 π μ r)`
//!   (Sih's strain-energy-density factor `a₁₁`), with `κ = 3 − 4ν` (plane strain and 3D).
//! - In 2D, over the disk `B_ε` centred at the tip, `∫ W dA = K² ε (2κ − 1) / (16 μ)`, since
//!   `∫_{−π}^{π} (1 + cos θ)(κ − cos θ) dθ = π (2κ − 1)`. The average is that over `π ε²`, so
//!   `G_p = ε · avg W = K² (2κ − 1) / (16 π μ)`: independent of ε, as it must be.
//! - Irwin: `G = K² (κ + 1) / (8 μ)`. Hence `G_p / G = (2κ − 1) / (2π (κ + 1))`, which is
//!   0.139 for ν = 1/3 (the point fails at `G ≈ 7.2 G_F`), and `k = 2π (κ + 1) / (2κ − 1)`.
//! - In 3D, over the ball `B_ε` centred on a straight front (plane strain in each section), the
//!   sections of radius `√(ε² − z²)` give `∫ W dV = K² (2κ − 1) π ε² / (32 μ)`; over `4π ε³/3`,
//!   `G_p / G = 3 (2κ − 1) / (16 (κ + 1))` and `k = 16 (κ + 1) / (3 (2κ − 1))`.
//!
//! The failed points of the crack lie where `W → 0` (θ = ±π) and still count in `Σ V_q`, as
//! in the derivation. `k` is taken per material from its Poisson ratio.

use fractum_engine::decomposition::OwnedRows;
use fractum_engine::prelude::*;
use rayon::prelude::*;
use serde::Deserialize;

/// Registration of `damage/eigenerosion`.
pub const REGISTRATION: Registration = Registration {
    name: "damage/eigenerosion",
    summary: "eigenerosion (eqs. 11-12): a point fails when its neighbourhood energy release exceeds G_F",
    params: &[
        ParamDoc {
            name: "fracture_energy",
            ty: "f64",
            default: None,
            doc: "G_F (J/m²)",
        },
        ParamDoc {
            name: "normalisation",
            ty: "Published | Griffith",
            default: Some("Published"),
            doc: "Published: G_p of eq. (11); Griffith: G_p scaled so a sharp crack tip fails at G = G_F",
        },
    ],
    requires: &["neighbour/*"],
    install: generic_install!(install),
};

/// Parameters as written in the scene.
#[derive(Deserialize, Clone, Copy, Debug)]
#[serde(deny_unknown_fields)]
struct RawParams {
    fracture_energy: f64,
    #[serde(default)]
    normalisation: Normalisation,
}

/// How `G_p` is normalised (see the module docs).
#[derive(Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Normalisation {
    /// Eq. (11) as published and as the authors' code computes it.
    #[default]
    Published,
    /// Eq. (11) times the constant that makes a sharp crack tip fail at `G = G_F`.
    Griffith,
}

/// The factor `k` that turns eq. (11) into a Griffith-consistent `G_p` for Poisson ratio `nu`
/// in `dimensions` 2 or 3 (module docs).
pub fn griffith_factor(nu: f64, dimensions: usize) -> f64 {
    let kappa = 3.0 - 4.0 * nu;
    if dimensions == 2 {
        2.0 * std::f64::consts::PI * (kappa + 1.0) / (2.0 * kappa - 1.0)
    } else {
        16.0 * (kappa + 1.0) / (3.0 * (2.0 * kappa - 1.0))
    }
}

/// Installed parameters and running totals of `damage/eigenerosion`.
#[derive(Resource, Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EigenerosionState {
    /// G_F.
    pub fracture_energy: f64,
    /// Stored energy removed by failures so far (in a distributed run, of this rank's owned
    /// particles).
    pub released: f64,
    /// Slots of the published columns: failed, dissipated energy.
    pub columns: [usize; 2],
    /// Which materials can fail: the entry's `materials`.
    pub materials: MaterialFilter,
    /// Factor on eq. (11) per material: 1 (published) or [`griffith_factor`].
    pub factor: Vec<f64>,
}

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let raw: RawParams = params.parse()?;
    params.require_positive("fracture_energy", raw.fracture_energy, "expected G_F > 0")?;
    let dimensions = installer.dimension().count();
    let factor: Vec<f64> = installer
        .world()
        .resource::<Materials>()
        .0
        .iter()
        .map(|m| match raw.normalisation {
            Normalisation::Published => 1.0,
            Normalisation::Griffith => griffith_factor(m.poisson_ratio, dimensions),
        })
        .collect();
    if factor.iter().any(|k| !(k.is_finite() && *k > 0.0)) {
        return Err(params.error(
            "normalisation",
            "Griffith needs every material's Poisson ratio below 0.5 (2κ − 1 > 0)",
        ));
    }
    let columns = [
        installer.add_owned_sum_column("failed_particles"),
        installer.add_owned_sum_column("dissipated_energy"),
    ];
    // Each rank of a distributed run releases the energy of the particles it owns.
    installer.insert_rank_state(EigenerosionState {
        fracture_energy: raw.fracture_energy,
        released: 0.0,
        columns,
        materials: installer.materials().clone(),
        factor,
    });
    installer.add_systems(eigenerosion::<D>);
    Ok(())
}

/// Energy release rate of eq. (11) for a neighbourhood of radius `epsilon`, given each
/// particle's current volume, stored energy (`W V₀`, J per unit thickness) and damage.
pub fn energy_release_rate(
    neighbours: &[u32],
    epsilon: f64,
    volume: &[Volume],
    stored: impl Fn(usize) -> f64,
    damage: &[Damage],
) -> f64 {
    let (mut energy, mut total) = (0.0, 0.0);
    for &q in neighbours {
        let q = q as usize;
        total += volume[q].0;
        if damage[q].0 < 1.0 {
            energy += stored(q);
        }
    }
    if total > 0.0 {
        epsilon * energy / total
    } else {
        0.0
    }
}

type ParticleQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static MaterialId,
        &'static Volume,
        &'static InitialVolume,
        &'static Stress<D>,
        &'static StrainEnergyDensity,
        &'static mut Damage,
    ),
    With<Particle>,
>;

/// The `damage/eigenerosion` system.
pub fn eigenerosion<D: Dim>(
    neighbourhoods: Res<Neighbourhoods>,
    mut state: ResMut<EigenerosionState>,
    mut columns: ResMut<SeriesColumns>,
    mut particles: ParticleQuery<D>,
    owned: OwnedRows,
) {
    let Some((material, volume, v0, stress, energy, damage)) =
        single_table_mut(particles.contiguous_iter_mut(), "particles")
    else {
        return;
    };
    let epsilon = neighbourhoods.radius;
    // The stored energy of a particle: W per reference volume times V₀.
    let stored = |q: usize| energy[q].0 * v0[q].0;
    let previous: &[Damage] = damage;
    let fails: Vec<bool> = (0..volume.len())
        .into_par_iter()
        .map(|p| {
            let tension = stress[p].0.largest_principal() > 0.0;
            if !state.materials.applies(material[p])
                || previous[p].0 >= 1.0
                || !tension
                || p >= neighbourhoods.particle_count()
            {
                return false;
            }
            let g = energy_release_rate(neighbourhoods.of(p), epsilon, volume, stored, previous);
            g * state.factor[material[p].0 as usize] > state.fracture_energy
        })
        .collect();
    for (p, fail) in fails.into_iter().enumerate() {
        if fail {
            if owned.particle(p) {
                state.released += stored(p);
            }
            damage[p].0 = 1.0;
        }
    }
    let failed = (damage.iter().enumerate())
        .filter(|(p, d)| d.0 >= 1.0 && owned.particle(*p))
        .count();
    let [f, e] = state.columns;
    columns.values[f] = failed as f64;
    columns.values[e] = state.released;
}

// The checkpoint key of this system's state (stable across builds).
fractum_engine::checkpoint_keys! { EigenerosionState => "eigenerosion/state" }

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
    fn release_rate_is_epsilon_times_the_average_intact_energy_density() {
        let volume = [Volume(1.0), Volume(3.0)];
        let stored = |q: usize| [2.0, 6.0][q];
        let g = energy_release_rate(&[0, 1], 0.5, &volume, stored, &[Damage(0.0), Damage(0.0)]);
        assert_eq!(g, 0.5 * 8.0 / 4.0);
        let g = energy_release_rate(&[0, 1], 0.5, &volume, stored, &[Damage(0.0), Damage(1.0)]);
        assert_eq!(g, 0.5 * 2.0 / 4.0);
    }

    /// Near-tip strain energy density of mode I (Sih): `K² (1 + cos θ)(κ − cos θ) / (16 π μ r)`.
    fn tip_energy_density(k: f64, mu: f64, kappa: f64, r: f64, theta: f64) -> f64 {
        k * k * (1.0 + theta.cos()) * (kappa - theta.cos()) / (16.0 * std::f64::consts::PI * mu * r)
    }

    #[test]
    fn griffith_factor_makes_eq_11_equal_g_at_a_sharp_crack_tip() {
        // Eq. (11) evaluated by quadrature over the singular tip field, times the factor,
        // against Irwin's G = K² (κ + 1) / (8 μ); ε drops out, so two radii are tried.
        let (k, mu) = (2.0, 0.4);
        for nu in [0.0, 0.25, 1.0 / 3.0, 0.45] {
            let kappa = 3.0 - 4.0 * nu;
            let g = k * k * (kappa + 1.0) / (8.0 * mu);
            for epsilon in [0.05, 0.3] {
                let (nr, nt) = (400, 720);
                let (dr, dt) = (epsilon / nr as f64, std::f64::consts::TAU / nt as f64);
                let (mut disk, mut ball) = (0.0, 0.0);
                for i in 0..nr {
                    let r = (i as f64 + 0.5) * dr;
                    for j in 0..nt {
                        let theta = -std::f64::consts::PI + (j as f64 + 0.5) * dt;
                        let w = tip_energy_density(k, mu, kappa, r, theta) * r * dr * dt;
                        disk += w;
                        // The ball: each section at distance z from the tip's plane has radius
                        // √(ε² − z²); a ring at r lies in the sections with |z| < √(ε² − r²).
                        ball += w * 2.0 * (epsilon * epsilon - r * r).sqrt();
                    }
                }
                let area = std::f64::consts::PI * epsilon * epsilon;
                let volume = 4.0 / 3.0 * std::f64::consts::PI * epsilon.powi(3);
                let g2 = griffith_factor(nu, 2) * epsilon * disk / area;
                let g3 = griffith_factor(nu, 3) * epsilon * ball / volume;
                assert!((g2 / g - 1.0).abs() < 1e-3, "2D, nu {nu}: {g2} against {g}");
                assert!((g3 / g - 1.0).abs() < 1e-3, "3D, nu {nu}: {g3} against {g}");
            }
        }
        // ν = 1/3: a published point fails at G ≈ 7.2 G_F.
        assert!((griffith_factor(1.0 / 3.0, 2) - 7.18).abs() < 0.01);
    }

    #[test]
    fn griffith_normalisation_fails_a_point_the_published_one_keeps() {
        let mut world = tiny_world::<Two>(4, 0.25, 1e-3);
        let mut columns = SeriesColumns::default();
        let slots = [columns.declare("failed"), columns.declare("dissipated")];
        world.insert_resource(columns);
        let mut neighbourhoods = Neighbourhoods::default();
        neighbourhoods.set_rows(&[vec![0]], 0.5);
        world.insert_resource(neighbourhoods);
        let p = spawn_particle(&mut world, DVec2::splat(0.5), DVec2::ZERO, 1.0, 1.0);
        world.get_mut::<StrainEnergyDensity>(p).unwrap().0 = 1.0;
        world.get_mut::<Stress<Two>>(p).unwrap().0.xx = 1.0;
        // G_p = 0.5 against G_F = 1: kept as published, failed with k = 7.2.
        for (factor, failed) in [(1.0, 0.0), (griffith_factor(1.0 / 3.0, 2), 1.0)] {
            world.insert_resource(EigenerosionState {
                fracture_energy: 1.0,
                released: 0.0,
                columns: slots,
                materials: MaterialFilter::all(),
                factor: vec![factor],
            });
            run_system(&mut world, eigenerosion::<Two>);
            assert_eq!(particle_values::<Damage>(&mut world)[0].0, failed);
        }
    }

    #[test]
    fn system_fails_the_particles_above_g_f_from_previous_step_state() {
        let mut world = tiny_world::<Two>(4, 0.25, 1e-3);
        let mut columns = SeriesColumns::default();
        let slots = [
            columns.declare("failed_particles"),
            columns.declare("dissipated_energy"),
        ];
        world.insert_resource(columns);
        world.insert_resource(EigenerosionState {
            fracture_energy: 0.25,
            released: 0.0,
            columns: slots,
            materials: MaterialFilter::all(),
            factor: vec![1.0],
        });
        let mut neighbourhoods = Neighbourhoods::default();
        neighbourhoods.set_rows(&[vec![0, 1], vec![0, 1], vec![2], vec![3]], 0.5);
        world.insert_resource(neighbourhoods);
        for (k, (w, sxx)) in [(0.5, 1.0), (0.3, 1.0), (0.3, 1.0), (0.9, -1.0)]
            .into_iter()
            .enumerate()
        {
            let p = spawn_particle(
                &mut world,
                DVec2::new(0.1 + 0.2 * k as f64, 0.5),
                DVec2::ZERO,
                1.0,
                1.0,
            );
            world.get_mut::<StrainEnergyDensity>(p).unwrap().0 = w;
            world.get_mut::<Stress<Two>>(p).unwrap().0.xx = sxx;
        }
        run_system(&mut world, eigenerosion::<Two>);
        // ε = 0.5. Particles 0, 1: G = 0.5 (0.5 + 0.3)/2 = 0.2; particle 2: 0.15; particle 3 has
        // G = 0.45 > G_F but is in compression.
        assert!(
            particle_values::<Damage>(&mut world)
                .iter()
                .all(|d| d.0 == 0.0)
        );
        let mut q = world.query::<(&ParticleId, &mut StrainEnergyDensity)>();
        for (id, mut w) in q.iter_mut(&mut world) {
            if id.0 == 0 {
                w.0 = 0.8;
            }
        }
        run_system(&mut world, eigenerosion::<Two>);
        // Both 0 and 1 see G = 0.5 (0.8 + 0.3)/2 = 0.275 > 0.25 and fail in the same (Jacobi)
        // update.
        let d: Vec<f64> = particle_values::<Damage>(&mut world)
            .iter()
            .map(|d| d.0)
            .collect();
        assert_eq!(d, vec![1.0, 1.0, 0.0, 0.0]);
        let state = world.resource::<EigenerosionState>().clone();
        assert!((state.released - 1.1).abs() < 1e-12);
    }

    #[test]
    fn only_tensile_points_erode_in_3d() {
        let mut world = tiny_world::<Three>(4, 0.25, 1e-3);
        let mut columns = SeriesColumns::default();
        let slots = [columns.declare("failed"), columns.declare("dissipated")];
        world.insert_resource(columns);
        world.insert_resource(EigenerosionState {
            fracture_energy: 0.1,
            released: 0.0,
            columns: slots,
            materials: MaterialFilter::all(),
            factor: vec![1.0],
        });
        let mut neighbourhoods = Neighbourhoods::default();
        neighbourhoods.set_rows(&[vec![0], vec![1]], 0.5);
        world.insert_resource(neighbourhoods);
        // Both store W = 1 (G = 0.5 > G_F). Particle 0 is under pure shear in the y-z plane
        // (principal values ±1: tensile); particle 1 under equal compression.
        for (k, stress) in [
            SymTensor3 {
                yz: 1.0,
                ..SymTensor3::ZERO
            },
            SymTensor3::isotropic(-1.0),
        ]
        .into_iter()
        .enumerate()
        {
            let p = spawn_particle(
                &mut world,
                DVec3::splat(0.2 + 0.4 * k as f64),
                DVec3::ZERO,
                1.0,
                1.0,
            );
            world.get_mut::<StrainEnergyDensity>(p).unwrap().0 = 1.0;
            world.get_mut::<Stress<Three>>(p).unwrap().0 = stress;
        }
        run_system(&mut world, eigenerosion::<Three>);
        let d: Vec<f64> = particle_values::<Damage>(&mut world)
            .iter()
            .map(|d| d.0)
            .collect();
        assert_eq!(d, vec![1.0, 0.0]);
    }
}
