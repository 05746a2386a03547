//! Small-strain isotropic linear elasticity, in plane strain (2D) or 3D.
//!
//! - Stage: stress. Registration name: `stress/linear_elastic`.
//! - From the nodal velocity fields left by the predictor, each particle's velocity
//!   gradient `L_p = Σ_I v_I ⊗ ∇N_Ip` (dfg-partitioning-mpm.md eq. 7) gives the strain increment
//!   `Δε = Δt sym(L_p)` (eigensoftening-lme-mpm.md Appendix A, step 4). Hooke's law in rate form,
//!   `Δσ = λ tr(Δε) I + 2μ Δε`; in 2D with `Δε_zz = 0` and `σ_zz` kept (plane strain).
//! - The gradient is read through `transfer::VelocityGradients`: under `predictor/mls` it is
//!   the particle's `C_p` (MLS-MPM). Provides `ReadsTransferGradient`.
//! - Volume follows the strain increment, `V ← V (1 + tr Δε)` (Appendix A, step 5, written for
//!   the volume: `ρ V = m` is constant); F follows `F ← (I + Δt L) F` (eq. 8).
//! - Stored energy per unit reference volume accumulates the stress work of each step,
//!   `ΔW = ½(σₙ + σₙ₊₁):Δε · V½/V₀`, so kinetic + stored energy is the scheme's own balance.

use crate::transfer::{VelocityGradients, with_gradient_source};
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// Registration of `stress/linear_elastic`.
pub const REGISTRATION: Registration = Registration {
    name: "stress/linear_elastic",
    summary: "small-strain Hooke's law (plane strain with σ_zz in 2D), from the nodal velocity field",
    params: &[],
    requires: &[],
    install: generic_install!(install),
};

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    crate::no_params(params)?;
    let scope = LinearElasticScope(installer.materials().clone());
    installer.insert_resource(scope);
    installer.provide::<fractum_engine::capability::ReadsTransferGradient>();
    installer.add_systems(linear_elastic_stress::<D>);
    Ok(())
}

/// The materials `stress/linear_elastic` updates (the entry's `materials`; all when absent).
#[derive(Resource, Clone, Debug, Default, PartialEq)]
pub struct LinearElasticScope(pub MaterialFilter);

/// State of one particle that the update changes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ElasticState<D: Dim> {
    /// Cauchy stress.
    pub stress: D::Sym,
    /// Accumulated small strain.
    pub strain: D::Sym,
    /// Deformation gradient.
    pub deformation_gradient: D::Matrix,
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
#[inline(always)]
pub fn update_elastic<D: Dim>(
    state: &ElasticState<D>,
    l: D::Matrix,
    dt: f64,
    (lambda, mu): (f64, f64),
    initial_volume: f64,
) -> ElasticState<D> {
    let increment = D::Sym::sym_of(l * dt);
    let stress = state.stress.add_scaled(&increment.hooke(lambda, mu), 1.0);
    let volume = state.volume * (1.0 + increment.trace());
    let mean_stress_x2 = state.stress.add_scaled(&stress, 1.0);
    let mid_volume_ratio = 0.5 * (state.volume + volume) / initial_volume;
    let work = 0.5 * mean_stress_x2.double_dot(&increment) * mid_volume_ratio;
    ElasticState {
        stress,
        strain: state.strain.add_scaled(&increment, 1.0),
        deformation_gradient: (D::Matrix::IDENTITY + l * dt) * state.deformation_gradient,
        volume,
        energy_density: state.energy_density + work,
    }
}

type ParticleQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static MaterialId,
        &'static InitialVolume,
        &'static mut Stress<D>,
        &'static mut Strain<D>,
        &'static mut DeformationGradient<D>,
        &'static mut Volume,
        &'static mut StrainEnergyDensity,
    ),
    With<Particle>,
>;

/// The `stress/linear_elastic` system.
pub fn linear_elastic_stress<D: Dim>(
    clock: Res<SimClock>,
    scope: Option<Res<LinearElasticScope>>,
    materials: Res<Materials>,
    gradients: VelocityGradients<D>,
    mut particles: ParticleQuery<D>,
) {
    let Some((material, initial_volume, stress, strain, f, volume, energy)) =
        single_table_mut(particles.contiguous_iter_mut(), "particles")
    else {
        return;
    };
    let rows = ElasticRows {
        material,
        initial_volume,
        lame: materials.0.iter().map(Material::lame).collect(),
        scope: scope.as_deref(),
        dt: clock.dt,
    };
    let columns = (stress, strain, f, volume, energy);
    with_gradient_source!(gradients.reader(), |at| rows.update(columns, at));
}

/// What every row of the update reads besides its own columns.
struct ElasticRows<'a> {
    material: &'a [MaterialId],
    initial_volume: &'a [InitialVolume],
    lame: Vec<(f64, f64)>,
    scope: Option<&'a LinearElasticScope>,
    dt: f64,
}

/// The columns the update writes: stress, strain, F, volume and stored energy.
type ElasticColumns<'a, D> = (
    &'a mut [Stress<D>],
    &'a mut [Strain<D>],
    &'a mut [DeformationGradient<D>],
    &'a mut [Volume],
    &'a mut [StrainEnergyDensity],
);

impl ElasticRows<'_> {
    /// [`update_elastic`] on every row in scope, `at(p)` giving row `p`'s velocity gradient.
    fn update<D: Dim>(
        &self,
        columns: ElasticColumns<'_, D>,
        at: impl Fn(usize) -> D::Matrix + Sync,
    ) {
        let (stress, strain, f, volume, energy) = columns;
        stress
            .par_chunks_mut(BLOCK_ROWS)
            .zip(strain.par_chunks_mut(BLOCK_ROWS))
            .zip(f.par_chunks_mut(BLOCK_ROWS))
            .zip(volume.par_chunks_mut(BLOCK_ROWS))
            .zip(energy.par_chunks_mut(BLOCK_ROWS))
            .enumerate()
            .for_each(|(block, ((((s, e), f), v), w))| {
                vectorised(
                    #[inline(always)]
                    || {
                        let rows = s.iter_mut().zip(e).zip(f).zip(v).zip(w);
                        for (i, ((((s, e), f), v), w)) in rows.enumerate() {
                            let p = block * BLOCK_ROWS + i;
                            if self.scope.is_some_and(|s| !s.0.applies(self.material[p])) {
                                continue;
                            }
                            let before = ElasticState::<D> {
                                stress: s.0,
                                strain: e.0,
                                deformation_gradient: f.0,
                                volume: v.0,
                                energy_density: w.0,
                            };
                            let moduli = self.lame[self.material[p].0 as usize];
                            let after = update_elastic(
                                &before,
                                at(p),
                                self.dt,
                                moduli,
                                self.initial_volume[p].0,
                            );
                            s.0 = after.stress;
                            e.0 = after.strain;
                            f.0 = after.deformation_gradient;
                            v.0 = after.volume;
                            w.0 = after.energy_density;
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

    fn unstrained<D: Dim>() -> ElasticState<D> {
        ElasticState {
            stress: D::Sym::ZERO,
            strain: D::Sym::ZERO,
            deformation_gradient: D::Matrix::IDENTITY,
            volume: 1.0,
            energy_density: 0.0,
        }
    }

    /// Uniaxial strain ε_xx = 1e-3: σ_xx = (λ + 2μ) ε, every other normal stress λ ε (in plane
    /// strain that includes σ_zz), no shear.
    fn uniaxial_strain<D: Dim>() {
        let (lambda, mu) = test_material().lame();
        // Stretch along x at rate 0.1/s for 0.01 s.
        let l = D::Matrix::from_fn(|i, j| if i == 0 && j == 0 { 0.1 } else { 0.0 });
        let after = update_elastic::<D>(&unstrained(), l, 0.01, (lambda, mu), 1.0);
        assert!((after.stress.get(0, 0) - (lambda + 2.0 * mu) * 1e-3).abs() < 1e-12);
        for i in 1..3 {
            assert!((after.stress.get(i, i) - lambda * 1e-3).abs() < 1e-12);
        }
        assert_eq!(after.stress.get(0, 1), 0.0);
        assert!((after.volume - 1.001).abs() < 1e-15);
        // ½ σ:ε at the mid-step volume 1.0005.
        let half_sigma_eps = 0.5 * (lambda + 2.0 * mu) * 1e-6;
        assert!((after.energy_density - half_sigma_eps * 1.0005).abs() < 1e-15);
    }

    #[test]
    fn uniaxial_strain_gives_hookes_stress_in_plane_strain_and_3d() {
        uniaxial_strain::<Two>();
        uniaxial_strain::<Three>();
    }

    #[test]
    fn rigid_rotation_rate_produces_no_stress() {
        let (lambda, mu) = test_material().lame();
        let spin = DMat2::from_cols(DVec2::new(0.0, 1.0), DVec2::new(-1.0, 0.0));
        let after = update_elastic::<Two>(&unstrained(), spin, 1e-3, (lambda, mu), 1.0);
        assert_eq!(after.stress, SymTensor2::ZERO);
        let spin = DMat3::from_cols(
            DVec3::new(0.0, 0.0, -2.0),
            DVec3::Z,
            DVec3::new(2.0, -1.0, 0.0),
        );
        let after = update_elastic::<Three>(&unstrained(), spin, 1e-3, (lambda, mu), 1.0);
        assert_eq!(after.stress, SymTensor3::ZERO);
    }

    #[test]
    fn system_reads_a_linear_nodal_velocity_field() {
        let mut world = tiny_world::<Two>(2, 0.5, 0.01);
        spawn_particle(&mut world, DVec2::new(0.3, 0.7), DVec2::ZERO, 1.0, 0.1);
        // Nodal velocity v = (0.2 x, −0.1 y): L = diag(0.2, −0.1) exactly for a bilinear basis.
        let positions = node_values::<NodePosition<Two>>(&mut world);
        let mut query = world.query::<(&NodeIndex, &mut NodeVelocity<Two>)>();
        for (index, mut v) in query.iter_mut(&mut world) {
            let x = positions[index.0 as usize].0;
            v.0[0] = DVec2::new(0.2 * x.x, -0.1 * x.y);
        }
        run_system(
            &mut world,
            (linear_basis::<Two>, linear_elastic_stress::<Two>).chain(),
        );
        let strain = particle_values::<Strain<Two>>(&mut world)[0].0;
        assert!((strain.xx - 0.002).abs() < 1e-15 && (strain.yy + 0.001).abs() < 1e-15);
        assert!(strain.xy.abs() < 1e-15);
        let (lambda, mu) = test_material().lame();
        let stress = particle_values::<Stress<Two>>(&mut world)[0].0;
        assert!((stress.xx - (lambda * 0.001 + 2.0 * mu * 0.002)).abs() < 1e-12);
    }

    /// Limited to material 0 (`materials: [...]` on the entry), the system leaves a particle of
    /// material 1 alone.
    #[test]
    fn system_updates_only_the_materials_of_its_entry() {
        let mut world = tiny_world::<Two>(2, 0.5, 0.01);
        world.insert_resource(Materials(vec![test_material(), test_material()]));
        world.insert_resource(LinearElasticScope(MaterialFilter::only(vec![true, false])));
        spawn_particle(&mut world, DVec2::new(0.3, 0.7), DVec2::ZERO, 1.0, 0.1);
        let other = spawn_particle(&mut world, DVec2::new(0.6, 0.4), DVec2::ZERO, 1.0, 0.1);
        world.entity_mut(other).insert(MaterialId(1));
        let mut query = world.query::<&mut NodeVelocity<Two>>();
        let positions: Vec<DVec2> = node_values::<NodePosition<Two>>(&mut world)
            .iter()
            .map(|p| p.0)
            .collect();
        for (v, x) in query.iter_mut(&mut world).zip(&positions) {
            v.into_inner().0[0] = DVec2::new(0.2 * x.x, 0.0);
        }
        run_system(
            &mut world,
            (linear_basis::<Two>, linear_elastic_stress::<Two>).chain(),
        );
        let stress = particle_values::<Stress<Two>>(&mut world);
        assert!(stress[0].0.xx > 0.0);
        assert_eq!(stress[1].0, SymTensor2::ZERO);
    }

    /// Under `predictor/mls` (`GradientInAffineVelocity`) the system reads each particle's
    /// `C_p`, not the nodal field: here the nodes carry a stretch along x and `C_p` a shear.
    #[test]
    fn system_reads_the_affine_velocity_under_mls() {
        let mut world = tiny_world::<Two>(2, 0.5, 0.01);
        let particle = spawn_particle(&mut world, DVec2::new(0.3, 0.7), DVec2::ZERO, 1.0, 0.1);
        let shear = DMat2::from_cols(DVec2::ZERO, DVec2::new(0.4, 0.0));
        world
            .entity_mut(particle)
            .insert(AffineVelocity::<Two>(shear));
        world.insert_resource(crate::transfer::GradientInAffineVelocity);
        let mut query = world.query::<&mut NodeVelocity<Two>>();
        for mut v in query.iter_mut(&mut world) {
            v.0[0] = DVec2::new(1.0, 0.0);
        }
        run_system(&mut world, linear_elastic_stress::<Two>);
        let strain = particle_values::<Strain<Two>>(&mut world)[0].0;
        assert_eq!((strain.xx, strain.yy), (0.0, 0.0));
        assert!((strain.xy - 0.002).abs() < 1e-15, "{strain:?}");
        let (_, mu) = test_material().lame();
        let stress = particle_values::<Stress<Two>>(&mut world)[0].0;
        assert!((stress.xy - 2.0 * mu * 0.002).abs() < 1e-9, "{stress:?}");
    }

    #[test]
    fn system_reads_a_linear_nodal_velocity_field_in_3d() {
        let mut world = tiny_world::<Three>(2, 0.5, 0.01);
        spawn_particle(&mut world, DVec3::new(0.3, 0.7, 0.4), DVec3::ZERO, 1.0, 0.1);
        // v = (0, 0, 0.3 x): L_zx = 0.3, a shear rate ε_xz = 0.15.
        let positions = node_values::<NodePosition<Three>>(&mut world);
        let mut query = world.query::<(&NodeIndex, &mut NodeVelocity<Three>)>();
        for (index, mut v) in query.iter_mut(&mut world) {
            v.0[0] = DVec3::new(0.0, 0.0, 0.3 * positions[index.0 as usize].0.x);
        }
        run_system(
            &mut world,
            (linear_basis::<Three>, linear_elastic_stress::<Three>).chain(),
        );
        let strain = particle_values::<Strain<Three>>(&mut world)[0].0;
        assert!((strain.xz - 0.0015).abs() < 1e-15 && strain.xx.abs() < 1e-15);
        let (_, mu) = test_material().lame();
        let stress = particle_values::<Stress<Three>>(&mut world)[0].0;
        assert!((stress.xz - 2.0 * mu * 0.0015).abs() < 1e-12);
        assert!(stress.trace().abs() < 1e-12);
    }
}
