//! Compressible neo-Hookean hyperelasticity, in plane strain (2D) or 3D.
//!
//! - Stage: stress. Registration name: `stress/neo_hookean`. Provides `HyperelasticStress`
//!   (the stress and its energy density from the potential below, afresh every step).
//! - dfg-partitioning-mpm.md eq. (22): `σ = (λ ln J / J − μ / J) I + (μ / J) F Fᵀ`, with the
//!   deformation gradient updated from the nodal velocity field, `F ← (I + Δt L) F` (eq. 8),
//!   `L = Σ_I v_I ⊗ ∇N_I` (eq. 7). Plane strain: `F_zz = 1`, so `σ_zz = λ ln J / J`.
//! - `L` is read through `transfer::VelocityGradients`: under `predictor/mls` it is the
//!   particle's `C_p` (MLS-MPM). Provides `ReadsTransferGradient`.
//! - Volume `V = J V₀`. Stored energy per reference volume, exact for this model:
//!   `W = μ/2 (tr FᵀF − 3) − μ ln J + λ/2 (ln J)²` (in plane strain `tr FᵀF` includes
//!   `F_zz² = 1`).
//! - Wave speed from the tangent moduli at the current state, `c² = (λ + 2μ − 2λ ln J)/ρ₀`,
//!   which stiffens in compression and keeps a CFL time step stable.
//! - `Strain` accumulates `Δt sym(L)` (the integrated rate of deformation), for output.

use crate::transfer::{VelocityGradients, with_gradient_source};
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// Registration of `stress/neo_hookean`.
pub const REGISTRATION: Registration = Registration {
    name: "stress/neo_hookean",
    summary: "compressible neo-Hookean (eq. 22), plane strain in 2D, F from the nodal velocity field",
    params: &[],
    requires: &[],
    install: generic_install!(install),
};

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    crate::no_params(params)?;
    let scope = NeoHookeanScope(installer.materials().clone());
    installer.insert_resource(scope);
    installer.provide::<HyperelasticStress>();
    installer.provide::<fractum_engine::capability::ReadsTransferGradient>();
    installer.add_systems(neo_hookean_stress::<D>);
    Ok(())
}

/// The materials `stress/neo_hookean` updates (the entry's `materials`; all when absent).
#[derive(Resource, Clone, Debug, Default, PartialEq)]
pub struct NeoHookeanScope(pub MaterialFilter);

/// Cauchy stress of eq. (22), `(λ ln J − μ)/J I + μ/J b` with `b = F Fᵀ` (in plane strain
/// `F_zz = 1`). `None` when `J ≤ 0` (the material has inverted).
#[inline(always)]
pub fn neo_hookean_stress_of<D: Dim>(f: D::Matrix, lambda: f64, mu: f64) -> Option<D::Sym> {
    let j = f.determinant();
    // Also rejects a NaN determinant.
    let inverted = j.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater);
    if inverted {
        return None;
    }
    let isotropic = (lambda * j.ln() - mu) / j;
    Some(D::Sym::isotropic(isotropic).add_scaled(&D::left_cauchy_green(f), mu / j))
}

/// Stored energy per unit reference volume.
#[inline(always)]
pub fn neo_hookean_energy<D: Dim>(f: D::Matrix, lambda: f64, mu: f64) -> f64 {
    let ln_j = f.determinant().ln();
    let trace_c = D::cauchy_green_trace(f);
    0.5 * mu * (trace_c - 3.0) - mu * ln_j + 0.5 * lambda * ln_j * ln_j
}

/// Dilatational wave speed from the tangent moduli at `J`, for reference density `rho0`.
#[inline(always)]
pub fn neo_hookean_wave_speed(j: f64, lambda: f64, mu: f64, rho0: f64) -> f64 {
    ((lambda + 2.0 * mu - 2.0 * lambda * j.ln()).max(mu) / rho0).sqrt()
}

type ParticleQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static MaterialId,
        &'static InitialVolume,
        &'static mut DeformationGradient<D>,
        &'static mut Stress<D>,
        &'static mut Strain<D>,
        &'static mut Volume,
        &'static mut StrainEnergyDensity,
        &'static mut WaveSpeed,
    ),
    With<Particle>,
>;

/// The `stress/neo_hookean` system. An inverted particle (`J ≤ 0`) gets a non-finite stress, so
/// the engine's check stops the run naming it.
pub fn neo_hookean_stress<D: Dim>(
    clock: Res<SimClock>,
    scope: Option<Res<NeoHookeanScope>>,
    materials: Res<Materials>,
    gradients: VelocityGradients<D>,
    mut particles: ParticleQuery<D>,
) {
    let Some((material, v0, f, stress, strain, volume, energy, speed)) =
        single_table_mut(particles.contiguous_iter_mut(), "particles")
    else {
        return;
    };
    let rows = NeoHookeanRows {
        material,
        initial_volume: v0,
        constants: materials
            .0
            .iter()
            .map(|m| {
                let (lambda, mu) = m.lame();
                (lambda, mu, m.density)
            })
            .collect(),
        scope: scope.as_deref(),
        dt: clock.dt,
    };
    let columns = (f, stress, strain, volume, energy, speed);
    with_gradient_source!(gradients.reader(), |at| rows.update(columns, at));
}

/// What every row of the update reads besides its own columns.
struct NeoHookeanRows<'a> {
    material: &'a [MaterialId],
    initial_volume: &'a [InitialVolume],
    /// λ, μ and the reference density of each material.
    constants: Vec<(f64, f64, f64)>,
    scope: Option<&'a NeoHookeanScope>,
    dt: f64,
}

/// The columns the update writes: F, stress, strain, volume, stored energy and wave speed.
type NeoHookeanColumns<'a, D> = (
    &'a mut [DeformationGradient<D>],
    &'a mut [Stress<D>],
    &'a mut [Strain<D>],
    &'a mut [Volume],
    &'a mut [StrainEnergyDensity],
    &'a mut [WaveSpeed],
);

impl NeoHookeanRows<'_> {
    /// Every row in scope, `at(p)` giving row `p`'s velocity gradient.
    fn update<D: Dim>(
        &self,
        columns: NeoHookeanColumns<'_, D>,
        at: impl Fn(usize) -> D::Matrix + Sync,
    ) {
        let (f, stress, strain, volume, energy, speed) = columns;
        let dt = self.dt;
        f.par_chunks_mut(BLOCK_ROWS)
            .zip(stress.par_chunks_mut(BLOCK_ROWS))
            .zip(strain.par_chunks_mut(BLOCK_ROWS))
            .zip(volume.par_chunks_mut(BLOCK_ROWS))
            .zip(energy.par_chunks_mut(BLOCK_ROWS))
            .zip(speed.par_chunks_mut(BLOCK_ROWS))
            .enumerate()
            .for_each(|(block, (((((f, s), e), v), w), cp))| {
                vectorised(
                    #[inline(always)]
                    || {
                        let rows = f.iter_mut().zip(s).zip(e).zip(v).zip(w).zip(cp);
                        for (i, (((((f, s), e), v), w), cp)) in rows.enumerate() {
                            let p = block * BLOCK_ROWS + i;
                            if self.scope.is_some_and(|s| !s.0.applies(self.material[p])) {
                                continue;
                            }
                            let (lambda, mu, rho0) = self.constants[self.material[p].0 as usize];
                            let l = at(p);
                            f.0 = (D::Matrix::IDENTITY + l * dt) * f.0;
                            e.0 = e.0.add_scaled(&D::Sym::sym_of(l * dt), 1.0);
                            let j = f.0.determinant();
                            s.0 = neo_hookean_stress_of::<D>(f.0, lambda, mu)
                                .unwrap_or_else(|| D::Sym::from_fn(|_, _| f64::NAN));
                            v.0 = j * self.initial_volume[p].0;
                            w.0 = neo_hookean_energy::<D>(f.0, lambda, mu);
                            cp.0 = neo_hookean_wave_speed(j, lambda, mu, rho0);
                        }
                    },
                )
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::linear::linear_basis;
    use fractum_engine::testing::*;
    use proptest::prelude::*;

    const LAMBDA: f64 = 40.0;
    const MU: f64 = 40.0;

    fn unstrained_is_stress_free<D: Dim>() {
        let s = neo_hookean_stress_of::<D>(D::Matrix::IDENTITY, LAMBDA, MU).unwrap();
        assert_eq!(s, D::Sym::ZERO);
        assert_eq!(
            neo_hookean_energy::<D>(D::Matrix::IDENTITY, LAMBDA, MU),
            0.0
        );
        let mirrored = D::Matrix::from_fn(|i, j| match (i, j) {
            (0, 0) => -1.0,
            _ if i == j => 1.0,
            _ => 0.0,
        });
        assert!(neo_hookean_stress_of::<D>(mirrored, LAMBDA, MU).is_none());
    }

    #[test]
    fn unstrained_material_is_stress_free_with_zero_energy() {
        unstrained_is_stress_free::<Two>();
        unstrained_is_stress_free::<Three>();
    }

    /// `F = I + ∇u` with ∇u small: σ = λ tr ε I + 2μ ε to first order.
    fn small_strain_is_hooke<D: Dim>() {
        let eps = 1e-7;
        let grad_u = D::Matrix::from_fn(|i, j| {
            eps * [[1.0, 0.5, 0.0], [0.0, -0.3, 0.2], [0.1, 0.0, 0.4]][i][j]
        });
        let f = D::Matrix::IDENTITY + grad_u;
        let s = neo_hookean_stress_of::<D>(f, LAMBDA, MU).unwrap();
        let strain = D::Sym::sym_of(grad_u);
        let hooke = strain.hooke(LAMBDA, MU);
        // The neglected terms are quadratic: O((λ + μ) |∇u|²), |∇u| ≤ 1.2 eps here.
        let second_order = 4.0 * (LAMBDA + MU) * eps * eps;
        for i in 0..3 {
            for j in i..3 {
                let error = (s.get(i, j) - hooke.get(i, j)).abs();
                assert!(error < second_order, "({i}, {j}): {error:e}");
            }
        }
    }

    #[test]
    fn small_strains_reduce_to_hookes_law() {
        small_strain_is_hooke::<Two>();
        small_strain_is_hooke::<Three>();
    }

    /// Kirchhoff stress τ = J σ = (∂W/∂F) Fᵀ (in plane strain, its in-plane block), by
    /// central differences of the stored energy.
    fn stress_is_energy_derivative<D: Dim>(f: D::Matrix) {
        let h = 1e-6;
        let dw = D::Matrix::from_fn(|row, col| {
            let bump = |s: f64| {
                D::Matrix::from_fn(|i, j| f.get(i, j) + if (i, j) == (row, col) { s } else { 0.0 })
            };
            (neo_hookean_energy::<D>(bump(h), LAMBDA, MU)
                - neo_hookean_energy::<D>(bump(-h), LAMBDA, MU))
                / (2.0 * h)
        });
        let tau = dw * f.transpose();
        let sigma = neo_hookean_stress_of::<D>(f, LAMBDA, MU)
            .unwrap()
            .to_matrix()
            * f.determinant();
        let error = (tau - sigma).max_abs();
        assert!(error < 1e-6, "{tau:?} vs {sigma:?}");
    }

    #[test]
    fn stress_is_the_derivative_of_the_stored_energy() {
        stress_is_energy_derivative::<Two>(DMat2::from_cols(
            DVec2::new(1.2, 0.1),
            DVec2::new(-0.3, 0.9),
        ));
        stress_is_energy_derivative::<Three>(DMat3::from_cols(
            DVec3::new(1.2, 0.1, -0.05),
            DVec3::new(-0.3, 0.9, 0.1),
            DVec3::new(0.2, 0.0, 1.1),
        ));
    }

    proptest! {
        #[test]
        fn objectivity(a in 0.7f64..1.4, b in -0.3f64..0.3, c in -0.3f64..0.3, d in 0.7f64..1.4, angle in 0.0f64..6.3) {
            let f = DMat2::from_cols(DVec2::new(a, c), DVec2::new(b, d));
            prop_assume!(f.determinant() > 0.1);
            let q = DMat2::from_angle(angle);
            let s = neo_hookean_stress_of::<Two>(f, LAMBDA, MU).unwrap();
            let rotated = neo_hookean_stress_of::<Two>(q * f, LAMBDA, MU).unwrap();
            let expected = q * s.to_matrix() * q.transpose();
            prop_assert!((rotated.to_matrix() - expected).max_abs() < 1e-11);
            prop_assert!((rotated.zz - s.zz).abs() < 1e-11);
            prop_assert!((neo_hookean_energy::<Two>(q * f, LAMBDA, MU) - neo_hookean_energy::<Two>(f, LAMBDA, MU)).abs() < 1e-12);
        }

        #[test]
        fn objectivity_in_3d(g in proptest::array::uniform9(-0.3f64..0.3), x in -3.2f64..3.2, y in -1.5f64..1.5, z in -3.2f64..3.2) {
            let f = DMat3::IDENTITY + DMat3::from_cols_array(&g);
            prop_assume!(f.determinant() > 0.1);
            let q = DMat3::from_euler(glam::EulerRot::ZYX, x, y, z);
            let s = neo_hookean_stress_of::<Three>(f, LAMBDA, MU).unwrap();
            let rotated = neo_hookean_stress_of::<Three>(q * f, LAMBDA, MU).unwrap();
            let expected = q * s.to_matrix() * q.transpose();
            prop_assert!((rotated.to_matrix() - expected).max_abs() < 1e-10);
            prop_assert!((neo_hookean_energy::<Three>(q * f, LAMBDA, MU) - neo_hookean_energy::<Three>(f, LAMBDA, MU)).abs() < 1e-11);
        }
    }

    #[test]
    fn system_updates_f_volume_and_wave_speed_from_the_nodal_field() {
        let mut world = tiny_world::<Two>(2, 0.5, 0.01);
        spawn_particle(&mut world, DVec2::new(0.3, 0.7), DVec2::ZERO, 1.0, 0.1);
        // Uniform compression rate −1/s along x: F_xx = 0.99 after one step of 0.01 s.
        let positions = node_values::<NodePosition<Two>>(&mut world);
        let mut query = world.query::<(&NodeIndex, &mut NodeVelocity<Two>)>();
        for (index, mut v) in query.iter_mut(&mut world) {
            v.0[0] = DVec2::new(-positions[index.0 as usize].0.x, 0.0);
        }
        run_system(
            &mut world,
            (linear_basis::<Two>, neo_hookean_stress::<Two>).chain(),
        );
        let f = particle_values::<DeformationGradient<Two>>(&mut world)[0].0;
        assert!((f.x_axis.x - 0.99).abs() < 1e-14 && (f.y_axis.y - 1.0).abs() < 1e-14);
        assert!((particle_values::<Volume>(&mut world)[0].0 - 0.099).abs() < 1e-14);
        let (lambda, mu) = test_material().lame();
        let c = particle_values::<WaveSpeed>(&mut world)[0].0;
        assert!(c > test_material().wave_speed());
        assert!((c - neo_hookean_wave_speed(0.99, lambda, mu, 1.0)).abs() < 1e-14);
        assert!(particle_values::<Stress<Two>>(&mut world)[0].0.xx < 0.0);
    }

    #[test]
    fn system_compresses_along_z_in_3d() {
        let mut world = tiny_world::<Three>(2, 0.5, 0.01);
        spawn_particle(&mut world, DVec3::new(0.3, 0.7, 0.6), DVec3::ZERO, 1.0, 0.1);
        let positions = node_values::<NodePosition<Three>>(&mut world);
        let mut query = world.query::<(&NodeIndex, &mut NodeVelocity<Three>)>();
        for (index, mut v) in query.iter_mut(&mut world) {
            v.0[0] = DVec3::new(0.0, 0.0, -positions[index.0 as usize].0.z);
        }
        run_system(
            &mut world,
            (linear_basis::<Three>, neo_hookean_stress::<Three>).chain(),
        );
        let f = particle_values::<DeformationGradient<Three>>(&mut world)[0].0;
        assert!((f.z_axis.z - 0.99).abs() < 1e-14 && (f.x_axis.x - 1.0).abs() < 1e-14);
        assert!((particle_values::<Volume>(&mut world)[0].0 - 0.099).abs() < 1e-14);
        let s = particle_values::<Stress<Three>>(&mut world)[0].0;
        assert!(s.zz < s.xx && s.xx < 0.0 && (s.xx - s.yy).abs() < 1e-12);
    }
}
