//! Compressible neo-Hookean hyperelasticity in plane strain.
//!
//! - Stage: stress. Registration name: `stress/neo_hookean`.
//! - dfg-partitioning-mpm.md eq. (22): `σ = (λ ln J / J − μ / J) I + (μ / J) F Fᵀ`, with the
//!   deformation gradient updated from the nodal velocity field, `F ← (I + Δt L) F` (eq. 8),
//!   `L = Σ_I v_I ⊗ ∇N_I` (eq. 7). Plane strain: `F_zz = 1`, so `σ_zz = λ ln J / J`.
//! - Volume `V = J V₀`. Stored energy per reference volume, exact for this model:
//!   `W = μ/2 (tr FᵀF + 1 − 3) − μ ln J + λ/2 (ln J)²`.
//! - Wave speed from the tangent moduli at the current state, `c² = (λ + 2μ − 2λ ln J)/ρ₀`,
//!   which stiffens in compression and keeps a CFL time step stable.
//! - `Strain` accumulates `Δt sym(L)` (the integrated rate of deformation), for output.

use super::linear_elastic::velocity_gradient;
use fractum_engine::dim::SymTensor;
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// Registration of `stress/neo_hookean`.
pub const REGISTRATION: Registration = Registration {
    name: "stress/neo_hookean",
    summary: "compressible neo-Hookean (eq. 22), plane strain, F from the nodal velocity field",
    params: &[],
    requires: &[],
    install,
};

fn install(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    crate::no_params(params)?;
    installer.add_systems(neo_hookean_stress);
    Ok(())
}

/// Cauchy stress of eq. (22) for an in-plane deformation gradient (plane strain, `F_zz = 1`).
/// `None` when `J ≤ 0` (the material has inverted).
pub fn neo_hookean_stress_of(f: Matrix, lambda: f64, mu: f64) -> Option<SymTensor> {
    let j = f.determinant();
    // Also rejects a NaN determinant.
    let inverted = j.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater);
    if inverted {
        return None;
    }
    let b = f * f.transpose();
    let isotropic = (lambda * j.ln() - mu) / j;
    Some(SymTensor {
        xx: isotropic + mu / j * b.x_axis.x,
        yy: isotropic + mu / j * b.y_axis.y,
        zz: isotropic + mu / j,
        xy: mu / j * b.y_axis.x,
    })
}

/// Stored energy per unit reference volume.
pub fn neo_hookean_energy(f: Matrix, lambda: f64, mu: f64) -> f64 {
    let ln_j = f.determinant().ln();
    let trace_c = f.x_axis.length_squared() + f.y_axis.length_squared() + 1.0;
    0.5 * mu * (trace_c - 3.0) - mu * ln_j + 0.5 * lambda * ln_j * ln_j
}

/// Dilatational wave speed from the tangent moduli at `J`, for reference density `rho0`.
pub fn neo_hookean_wave_speed(j: f64, lambda: f64, mu: f64, rho0: f64) -> f64 {
    ((lambda + 2.0 * mu - 2.0 * lambda * j.ln()).max(mu) / rho0).sqrt()
}

type ParticleQuery<'w, 's> = Query<
    'w,
    's,
    (
        &'static MaterialId,
        &'static InitialVolume,
        &'static mut DeformationGradient,
        &'static mut Stress,
        &'static mut Strain,
        &'static mut Volume,
        &'static mut StrainEnergyDensity,
        &'static mut WaveSpeed,
    ),
    With<Particle>,
>;

/// The `stress/neo_hookean` system. An inverted particle (`J ≤ 0`) gets a non-finite stress, so
/// the engine's check stops the run naming it.
pub fn neo_hookean_stress(
    clock: Res<SimClock>,
    materials: Res<Materials>,
    connectivity: Res<Connectivity>,
    nodes: Query<&NodeVelocity, With<Node>>,
    mut particles: ParticleQuery,
) {
    let node_velocity = single_table(nodes.contiguous_iter(), "nodes").unwrap_or(&[]);
    let Some((material, v0, mut f, mut stress, mut strain, mut volume, mut energy, mut speed)) =
        single_table(particles.contiguous_iter_mut(), "particles")
    else {
        return;
    };
    let constants: Vec<(f64, f64, f64)> = materials
        .0
        .iter()
        .map(|m| {
            let (lambda, mu) = m.lame();
            (lambda, mu, m.density)
        })
        .collect();
    let dt = clock.dt;
    let c = &*connectivity;
    f.par_iter_mut()
        .zip(stress.par_iter_mut())
        .zip(strain.par_iter_mut())
        .zip(volume.par_iter_mut())
        .zip(energy.par_iter_mut())
        .zip(speed.par_iter_mut())
        .enumerate()
        .for_each(|(p, (((((f, s), e), v), w), cp))| {
            let (lambda, mu, rho0) = constants[material[p].0 as usize];
            let l = velocity_gradient(c, node_velocity, p);
            f.0 = (Matrix::IDENTITY + l * dt) * f.0;
            e.0 = e.0.add_scaled(&SymTensor::sym_of(l * dt), 1.0);
            let j = f.0.determinant();
            s.0 = neo_hookean_stress_of(f.0, lambda, mu).unwrap_or(SymTensor {
                xx: f64::NAN,
                yy: f64::NAN,
                zz: f64::NAN,
                xy: f64::NAN,
            });
            v.0 = j * v0[p].0;
            w.0 = neo_hookean_energy(f.0, lambda, mu);
            cp.0 = neo_hookean_wave_speed(j, lambda, mu, rho0);
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::linear::linear_basis;
    use fractum_engine::testing::*;
    use proptest::prelude::*;

    const LAMBDA: f64 = 40.0;
    const MU: f64 = 40.0;

    fn rotation(angle: f64) -> Matrix {
        Matrix::from_angle(angle)
    }

    #[test]
    fn unstrained_material_is_stress_free_with_zero_energy() {
        let s = neo_hookean_stress_of(Matrix::IDENTITY, LAMBDA, MU).unwrap();
        assert_eq!(s, SymTensor::ZERO);
        assert_eq!(neo_hookean_energy(Matrix::IDENTITY, LAMBDA, MU), 0.0);
        assert!(
            neo_hookean_stress_of(Matrix::from_diagonal(Vector::new(1.0, -1.0)), LAMBDA, MU)
                .is_none()
        );
    }

    #[test]
    fn small_strains_reduce_to_hookes_law() {
        let eps = 1e-7;
        let f = Matrix::from_cols(Vector::new(1.0 + eps, 0.0), Vector::new(0.5 * eps, 1.0));
        let s = neo_hookean_stress_of(f, LAMBDA, MU).unwrap();
        // Linear: σ = λ tr ε I + 2 μ ε with ε_xx = eps, ε_xy = eps/4.
        assert!((s.xx - (LAMBDA + 2.0 * MU) * eps).abs() < 1e-12);
        assert!((s.yy - LAMBDA * eps).abs() < 1e-12);
        assert!((s.zz - LAMBDA * eps).abs() < 1e-12);
        assert!((s.xy - 2.0 * MU * 0.25 * eps).abs() < 1e-12);
    }

    #[test]
    fn stress_is_the_derivative_of_the_stored_energy() {
        // Kirchhoff stress τ = J σ = (∂W/∂F) Fᵀ; check its in-plane part by central differences.
        let f = Matrix::from_cols(Vector::new(1.2, 0.1), Vector::new(-0.3, 0.9));
        let h = 1e-6;
        let mut dw = Matrix::ZERO;
        for col in 0..2 {
            for row in 0..2 {
                let mut plus = f;
                let mut minus = f;
                plus.col_mut(col)[row] += h;
                minus.col_mut(col)[row] -= h;
                let d = (neo_hookean_energy(plus, LAMBDA, MU)
                    - neo_hookean_energy(minus, LAMBDA, MU))
                    / (2.0 * h);
                dw.col_mut(col)[row] = d;
            }
        }
        let tau = dw * f.transpose();
        let sigma = neo_hookean_stress_of(f, LAMBDA, MU).unwrap().in_plane() * f.determinant();
        let error = (tau - sigma)
            .to_cols_array()
            .iter()
            .map(|v| v.abs())
            .fold(0.0, f64::max);
        assert!(error < 1e-6, "{tau} vs {sigma}");
    }

    proptest! {
        #[test]
        fn objectivity(a in 0.7f64..1.4, b in -0.3f64..0.3, c in -0.3f64..0.3, d in 0.7f64..1.4, angle in 0.0f64..6.3) {
            let f = Matrix::from_cols(Vector::new(a, c), Vector::new(b, d));
            prop_assume!(f.determinant() > 0.1);
            let q = rotation(angle);
            let s = neo_hookean_stress_of(f, LAMBDA, MU).unwrap();
            let rotated = neo_hookean_stress_of(q * f, LAMBDA, MU).unwrap();
            let expected = q * s.in_plane() * q.transpose();
            let error = (rotated.in_plane() - expected).to_cols_array().iter().map(|v| v.abs()).fold(0.0, f64::max);
            prop_assert!(error < 1e-11);
            prop_assert!((rotated.zz - s.zz).abs() < 1e-11);
            prop_assert!((neo_hookean_energy(q * f, LAMBDA, MU) - neo_hookean_energy(f, LAMBDA, MU)).abs() < 1e-12);
        }
    }

    #[test]
    fn system_updates_f_volume_and_wave_speed_from_the_nodal_field() {
        let mut world = tiny_world(2, 0.5, 0.01);
        spawn_particle(&mut world, Vector::new(0.3, 0.7), Vector::ZERO, 1.0, 0.1);
        // Uniform compression rate −1/s along x: F_xx = 0.99 after one step of 0.01 s.
        let positions = node_values::<NodePosition>(&mut world);
        let mut query = world.query::<(&NodeIndex, &mut NodeVelocity)>();
        for (index, mut v) in query.iter_mut(&mut world) {
            v.0[0] = Vector::new(-positions[index.0 as usize].0.x, 0.0);
        }
        run_system(&mut world, (linear_basis, neo_hookean_stress).chain());
        let f = particle_values::<DeformationGradient>(&mut world)[0].0;
        assert!((f.x_axis.x - 0.99).abs() < 1e-14 && (f.y_axis.y - 1.0).abs() < 1e-14);
        assert!((particle_values::<Volume>(&mut world)[0].0 - 0.099).abs() < 1e-14);
        let (lambda, mu) = test_material().lame();
        let c = particle_values::<WaveSpeed>(&mut world)[0].0;
        assert!(c > test_material().wave_speed());
        assert!((c - neo_hookean_wave_speed(0.99, lambda, mu, 1.0)).abs() < 1e-14);
        assert!(particle_values::<Stress>(&mut world)[0].0.xx < 0.0);
    }
}
