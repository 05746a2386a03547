//! Small-strain isotropic linear elasticity in plane strain.
//!
//! - Stage: stress. Registration name: `stress/linear_elastic`.
//! - From the nodal velocity field left by the predictor (field 0), each particle's velocity
//!   gradient `L_p = Σ_I v_I ⊗ ∇N_Ip` (dfg-partitioning-mpm.md eq. 7) gives the strain increment
//!   `Δε = Δt sym(L_p)` (eigensoftening-lme-mpm.md Appendix A, step 4). Hooke's law in rate form,
//!   `Δσ = λ tr(Δε) I + 2μ Δε`, with `Δε_zz = 0` and `σ_zz` kept (plane strain).
//! - Volume follows the strain increment, `V ← V (1 + tr Δε)` (Appendix A, step 5, written for
//!   the volume: `ρ V = m` is constant); F follows `F ← (I + Δt L) F` (eq. 8).
//! - Stored energy per unit reference volume accumulates the stress work of each step,
//!   `ΔW = ½(σₙ + σₙ₊₁):Δε · V½/V₀`, so kinetic + stored energy is the scheme's own balance.

use fractum_engine::dim::{SymTensor, outer};
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// Registration of `stress/linear_elastic`.
pub const REGISTRATION: Registration = Registration {
    name: "stress/linear_elastic",
    summary: "small-strain Hooke's law, plane strain (σ_zz kept), from the nodal velocity field",
    params: &[],
    requires: &[],
    install,
};

fn install(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    crate::no_params(params)?;
    installer.add_systems(linear_elastic_stress);
    Ok(())
}

/// `Δσ = λ tr(Δε) I + 2μ Δε` for a plane-strain increment (`Δε_zz = 0`).
pub fn hooke_increment(strain_increment: &SymTensor, lambda: f64, mu: f64) -> SymTensor {
    let volumetric = lambda * strain_increment.trace();
    SymTensor {
        xx: volumetric + 2.0 * mu * strain_increment.xx,
        yy: volumetric + 2.0 * mu * strain_increment.yy,
        zz: volumetric + 2.0 * mu * strain_increment.zz,
        xy: 2.0 * mu * strain_increment.xy,
    }
}

/// Velocity gradient `Σ v_I ⊗ ∇N_I` of particle row `p` from field 0 of the nodes.
pub fn velocity_gradient(c: &Connectivity, node_velocity: &[NodeVelocity], p: usize) -> Matrix {
    c.row(p).fold(Matrix::ZERO, |l, e| {
        l + outer(node_velocity[c.nodes[e] as usize].0[0], c.gradients[e])
    })
}

/// State of one particle that the update changes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ElasticState {
    /// Cauchy stress.
    pub stress: SymTensor,
    /// Accumulated small strain.
    pub strain: SymTensor,
    /// Deformation gradient.
    pub deformation_gradient: Matrix,
    /// Current volume.
    pub volume: f64,
    /// Stored energy per unit reference volume.
    pub energy_density: f64,
}

/// One explicit update of `state` under velocity gradient `l` over `dt`, with Lamé constants
/// `(λ, μ)`; `initial_volume` is the particle's reference volume.
///
/// The stored energy is the work of the stress over the step, trapezoidal in the stress and at
/// the mid-step volume, per unit reference volume: `ΔW = ½(σₙ + σₙ₊₁):Δε · V½ / V₀`. That is the
/// work the internal forces (which use the current volume) actually do, so kinetic plus stored
/// energy is the scheme's own energy balance; for small strains it equals `½ σ:ε`.
pub fn update_elastic(
    state: &ElasticState,
    l: Matrix,
    dt: f64,
    (lambda, mu): (f64, f64),
    initial_volume: f64,
) -> ElasticState {
    let increment = SymTensor::sym_of(l * dt);
    let stress = state
        .stress
        .add_scaled(&hooke_increment(&increment, lambda, mu), 1.0);
    let volume = state.volume * (1.0 + increment.trace());
    let mean_stress_x2 = state.stress.add_scaled(&stress, 1.0);
    let mid_volume_ratio = 0.5 * (state.volume + volume) / initial_volume;
    let work = 0.5 * mean_stress_x2.double_dot(&increment) * mid_volume_ratio;
    ElasticState {
        stress,
        strain: state.strain.add_scaled(&increment, 1.0),
        deformation_gradient: (Matrix::IDENTITY + l * dt) * state.deformation_gradient,
        volume,
        energy_density: state.energy_density + work,
    }
}

type ParticleQuery<'w, 's> = Query<
    'w,
    's,
    (
        &'static MaterialId,
        &'static InitialVolume,
        &'static mut Stress,
        &'static mut Strain,
        &'static mut DeformationGradient,
        &'static mut Volume,
        &'static mut StrainEnergyDensity,
    ),
    With<Particle>,
>;

/// The `stress/linear_elastic` system.
pub fn linear_elastic_stress(
    clock: Res<SimClock>,
    materials: Res<Materials>,
    connectivity: Res<Connectivity>,
    nodes: Query<&NodeVelocity, With<Node>>,
    mut particles: ParticleQuery,
) {
    let node_velocity = single_table(nodes.contiguous_iter(), "nodes").unwrap_or(&[]);
    let Some((material, initial_volume, mut stress, mut strain, mut f, mut volume, mut energy)) =
        single_table(particles.contiguous_iter_mut(), "particles")
    else {
        return;
    };
    let lame: Vec<(f64, f64)> = materials.0.iter().map(Material::lame).collect();
    let dt = clock.dt;
    let c = &*connectivity;
    stress
        .par_iter_mut()
        .zip(strain.par_iter_mut())
        .zip(f.par_iter_mut())
        .zip(volume.par_iter_mut())
        .zip(energy.par_iter_mut())
        .enumerate()
        .for_each(|(p, ((((s, e), f), v), w))| {
            let l = velocity_gradient(c, node_velocity, p);
            let before = ElasticState {
                stress: s.0,
                strain: e.0,
                deformation_gradient: f.0,
                volume: v.0,
                energy_density: w.0,
            };
            let moduli = lame[material[p].0 as usize];
            let after = update_elastic(&before, l, dt, moduli, initial_volume[p].0);
            s.0 = after.stress;
            e.0 = after.strain;
            f.0 = after.deformation_gradient;
            v.0 = after.volume;
            w.0 = after.energy_density;
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::linear::linear_basis;
    use fractum_engine::testing::*;

    fn unstrained() -> ElasticState {
        ElasticState {
            stress: SymTensor::ZERO,
            strain: SymTensor::ZERO,
            deformation_gradient: Matrix::IDENTITY,
            volume: 1.0,
            energy_density: 0.0,
        }
    }

    #[test]
    fn uniaxial_strain_gives_plane_strain_hooke_stress() {
        let (lambda, mu) = test_material().lame();
        let state = unstrained();
        // Stretch along x at rate 0.1/s for 0.01 s: ε_xx = 1e-3.
        let l = Matrix::from_cols(Vector::new(0.1, 0.0), Vector::ZERO);
        let after = update_elastic(&state, l, 0.01, (lambda, mu), 1.0);
        assert!((after.stress.xx - (lambda + 2.0 * mu) * 1e-3).abs() < 1e-12);
        assert!((after.stress.yy - lambda * 1e-3).abs() < 1e-12);
        assert!((after.stress.zz - lambda * 1e-3).abs() < 1e-12);
        assert!((after.volume - 1.001).abs() < 1e-15);
        // ½ σ:ε at the mid-step volume 1.0005.
        let half_sigma_eps = 0.5 * (lambda + 2.0 * mu) * 1e-6;
        assert!((after.energy_density - half_sigma_eps * 1.0005).abs() < 1e-15);
    }

    #[test]
    fn rigid_rotation_rate_produces_no_stress() {
        let (lambda, mu) = test_material().lame();
        let state = unstrained();
        let spin = Matrix::from_cols(Vector::new(0.0, 1.0), Vector::new(-1.0, 0.0));
        let after = update_elastic(&state, spin, 1e-3, (lambda, mu), 1.0);
        assert_eq!(after.stress, SymTensor::ZERO);
    }

    #[test]
    fn system_reads_a_linear_nodal_velocity_field() {
        let mut world = tiny_world(2, 0.5, 0.01);
        spawn_particle(&mut world, Vector::new(0.3, 0.7), Vector::ZERO, 1.0, 0.1);
        // Nodal velocity v = (0.2 x, −0.1 y): L = diag(0.2, −0.1) exactly for a bilinear basis.
        let positions = node_values::<NodePosition>(&mut world);
        let mut query = world.query::<(&NodeIndex, &mut NodeVelocity)>();
        for (index, mut v) in query.iter_mut(&mut world) {
            let x = positions[index.0 as usize].0;
            v.0[0] = Vector::new(0.2 * x.x, -0.1 * x.y);
        }
        run_system(&mut world, (linear_basis, linear_elastic_stress).chain());
        let strain = particle_values::<Strain>(&mut world)[0].0;
        assert!((strain.xx - 0.002).abs() < 1e-15 && (strain.yy + 0.001).abs() < 1e-15);
        assert!(strain.xy.abs() < 1e-15);
        let (lambda, mu) = test_material().lame();
        let stress = particle_values::<Stress>(&mut world)[0].0;
        assert!((stress.xx - (lambda * 0.001 + 2.0 * mu * 0.002)).abs() < 1e-12);
    }
}
