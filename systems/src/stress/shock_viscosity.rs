//! Shock (artificial bulk) viscosity: a viscous pressure in compression that spreads a shock
//! over a few cells and damps the ringing behind it.
//!
//! - Stage: stress, after the constitutive update. Registration name: `stress/shock_viscosity`.
//! - The viscous pressure of the standard linear + quadratic artificial viscosity (von
//!   Neumann & Richtmyer's quadratic term with Landshoff's linear one, as LS-DYNA, Uintah and
//!   NairnMPM offer it), in compression only:
//!   `q = ρ ℓ (C_L c |ε̇_v| + C_Q ℓ ε̇_v²)` when `ε̇_v = tr L_p < 0`, else `q = 0`,
//!   with `L_p = Σ_I v_I ⊗ ∇N_Ip` this step's velocity gradient (dfg-partitioning-mpm.md eq. 7;
//!   read through `transfer::VelocityGradients`, so `C_p` under `predictor/mls`),
//!   `ρ = m/V` the particle's current density, `c` its dilatational wave speed
//!   ([`WaveSpeed`]) and `ℓ` the grid's smallest cell width. The defaults `C_L = 0.2`,
//!   `C_Q = 2.0` are Uintah's MPM defaults (LS-DYNA's element defaults are 0.06 and 1.5).
//! - Where it acts: the internal force of every transfer uses `σ − q I`
//!   (`transfer::force_contribution`, scaled by `1 − D` as the stress is). The material's own
//!   stress ([`Stress`]) is left as it is, so the constitutive update, the damage laws and the
//!   frames see the material; the frames get `viscous_pressure` as a column of its own.
//! - Energy: the viscous pressure's work is dissipated, `ΔD_p = −q ε̇_v V Δt ≥ 0` per step,
//!   accumulated in each particle's [`ViscousDissipation`] and published as the
//!   `viscous_dissipation` column of `series.csv`; `energy_residual` takes it out with the
//!   damage laws' `dissipated_energy`, so the account still closes.
//! - Time step: the linear term lowers the stable step to `√(1 + C_L²) − C_L` of the
//!   central-difference limit (`ℓ / (Q + √(Q² + c²))` with `Q = C_L c`); the quadratic term
//!   adds `C_Q ℓ |ε̇_v|` to `Q` in a shock, which the scene's CFL factor must cover.
//! - With USL the pressure of one step's stress stage acts in the next step's forces, as the
//!   stress does; with Newmark, in the same step's corrector.

use crate::transfer::VelocityGradients;
use fractum_engine::prelude::*;
use rayon::prelude::*;
use serde::Deserialize;

/// Registration of `stress/shock_viscosity`.
pub const REGISTRATION: Registration = Registration {
    name: "stress/shock_viscosity",
    summary: "artificial bulk viscosity: the linear + quadratic viscous pressure in compression \
              (C_L = 0.2, C_Q = 2.0), added to the internal force, its dissipation a column of \
              the energy balance",
    params: &[
        ParamDoc {
            name: "linear",
            ty: "f64",
            default: Some("0.2"),
            doc: "C_L, the linear coefficient: q gains rho * l * C_L * c * |tr L|",
        },
        ParamDoc {
            name: "quadratic",
            ty: "f64",
            default: Some("2.0"),
            doc: "C_Q, the quadratic coefficient: q gains rho * C_Q * (l * tr L)^2",
        },
    ],
    requires: &[],
    install: generic_install!(install),
};

/// Parameters of `stress/shock_viscosity`.
#[derive(Deserialize, Clone, Copy, Debug, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ShockViscosityParams {
    /// `C_L`, the linear coefficient.
    pub linear: f64,
    /// `C_Q`, the quadratic coefficient.
    pub quadratic: f64,
}

impl Default for ShockViscosityParams {
    fn default() -> Self {
        Self {
            linear: 0.2,
            quadratic: 2.0,
        }
    }
}

/// What the system reads besides the particles: coefficients, length, scope and its column.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct ShockViscosity {
    /// The coefficients.
    pub params: ShockViscosityParams,
    /// `ℓ`, the grid's smallest cell width (m).
    pub length: f64,
    /// The materials it acts on (the entry's `materials`; all when absent).
    pub materials: MaterialFilter,
    /// Slot of the `viscous_dissipation` column.
    pub column: usize,
}

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let parsed: ShockViscosityParams = params.parse()?;
    for (name, value) in [("linear", parsed.linear), ("quadratic", parsed.quadratic)] {
        params.require(
            name,
            value.is_finite() && value >= 0.0,
            "expected a coefficient >= 0 (0 leaves that term out)",
        )?;
    }
    let constitutive = installer
        .pipeline()
        .iter()
        .any(|name| name.starts_with("stress/") && *name != REGISTRATION.name);
    if !constitutive {
        return Err(params.error(
            "",
            "stress/shock_viscosity adds a viscous pressure to the stress of a material law; \
             the pipeline needs one too (stress/linear_elastic or stress/neo_hookean)",
        ));
    }
    let grid = installer.world().resource::<Grid<D>>();
    let length = (0..D::N)
        .flat_map(|a| (0..grid.cells[a]).map(move |i| grid.cell_width(a, i)))
        .fold(f64::INFINITY, f64::min);
    let linear = parsed.linear;
    installer.restrict_time_step(
        (1.0 + linear * linear).sqrt() - linear,
        format!("stress/shock_viscosity's linear term (C_L = {linear})"),
    );
    // It leaves the material's stress as it is, so the laws that require something of every
    // stress entry (damage/rankine's hyperelastic stress) ask it of the others.
    installer.provide::<fractum_engine::capability::Bystander>();
    installer.provide::<fractum_engine::capability::ReadsTransferGradient>();
    installer.add_particle_component(ViscousPressure(0.0));
    installer.add_particle_component(ViscousDissipation(0.0));
    installer.declare_real_time(
        REGISTRATION.name,
        "its viscous pressure, from the density and the real rate of compression",
    );
    installer.add_frame_scalar::<ViscousPressure>("viscous_pressure", |q| q.0);
    let column = installer.add_owned_sum_column("viscous_dissipation");
    let materials = installer.materials().clone();
    installer.insert_resource(ShockViscosity {
        params: parsed,
        length,
        materials,
        column,
    });
    installer.add_systems(shock_viscosity::<D>);
    Ok(())
}

/// The viscous pressure `q` at volumetric strain rate `rate = tr L` (1/s), density `rho`, wave
/// speed `c` and length `ℓ`: `ρ ℓ (C_L c |ε̇_v| + C_Q ℓ ε̇_v²)` in compression, zero otherwise.
pub fn viscous_pressure(
    params: &ShockViscosityParams,
    rate: f64,
    rho: f64,
    c: f64,
    length: f64,
) -> f64 {
    if rate >= 0.0 {
        return 0.0;
    }
    let speed = length * rate.abs();
    rho * (params.linear * c * speed + params.quadratic * speed * speed)
}

type ParticleQuery<'w, 's> = Query<
    'w,
    's,
    (
        &'static MaterialId,
        &'static Mass,
        &'static Volume,
        &'static WaveSpeed,
        &'static mut ViscousPressure,
        &'static mut ViscousDissipation,
    ),
    With<Particle>,
>;

/// The `stress/shock_viscosity` system: each particle's viscous pressure from this step's
/// velocity gradient, and the energy it dissipates over the step.
pub fn shock_viscosity<D: Dim>(
    clock: Res<SimClock>,
    viscosity: Res<ShockViscosity>,
    gradients: VelocityGradients<D>,
    mut columns: ResMut<SeriesColumns>,
    owned: OwnedRows,
    mut particles: ParticleQuery,
) {
    let gradients = gradients.reader();
    let Some((material, mass, volume, wave_speed, pressure, dissipation)) =
        single_table_mut(particles.contiguous_iter_mut(), "particles")
    else {
        return;
    };
    let (dt, v) = (clock.dt, &*viscosity);
    pressure
        .par_iter_mut()
        .zip(dissipation.par_iter_mut())
        .enumerate()
        .for_each(|(p, (q, dissipated))| {
            if !v.materials.applies(material[p]) {
                return;
            }
            let rate = gradients.at(p).trace();
            let rho = mass[p].0 / volume[p].0;
            q.0 = viscous_pressure(&v.params, rate, rho, wave_speed[p].0, v.length);
            dissipated.0 -= q.0 * rate * volume[p].0 * dt;
        });
    let owned = owned.get();
    columns.values[v.column] = dissipation
        .iter()
        .enumerate()
        .filter(|(p, _)| owned.particle(*p))
        .map(|(_, d)| d.0)
        .sum();
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::linear::linear_basis;
    use fractum_engine::testing::*;

    /// `fractum systems` documents the fields its parameters read, and its documented defaults
    /// are theirs.
    #[test]
    fn parameter_docs_match_the_parameters() {
        assert_defaults::<ShockViscosityParams>(&REGISTRATION);
    }

    /// Zero in expansion and at rest; in compression the two terms as written, each alone when
    /// the other coefficient is zero.
    #[test]
    fn the_pressure_acts_in_compression_only() {
        let params = ShockViscosityParams::default();
        assert_eq!(viscous_pressure(&params, 0.0, 1000.0, 5000.0, 0.01), 0.0);
        assert_eq!(viscous_pressure(&params, 50.0, 1000.0, 5000.0, 0.01), 0.0);
        // ε̇_v = −50/s, ℓ = 0.01 m: ℓ |ε̇_v| = 0.5 m/s.
        let linear = ShockViscosityParams {
            linear: 0.2,
            quadratic: 0.0,
        };
        let q = viscous_pressure(&linear, -50.0, 1000.0, 5000.0, 0.01);
        assert!((q - 1000.0 * 0.2 * 5000.0 * 0.5).abs() < 1e-9);
        let quadratic = ShockViscosityParams {
            linear: 0.0,
            quadratic: 2.0,
        };
        let q = viscous_pressure(&quadratic, -50.0, 1000.0, 5000.0, 0.01);
        assert!((q - 1000.0 * 2.0 * 0.25).abs() < 1e-12);
        let both = viscous_pressure(&params, -50.0, 1000.0, 5000.0, 0.01);
        assert!((both - 500_000.0 - 500.0).abs() < 1e-9);
    }

    /// Sets every node's velocity to `v = (rate / d) x`, whose divergence is `rate`.
    fn uniform_dilatation<D: Dim>(world: &mut World, rate: f64) {
        let positions = node_values::<NodePosition<D>>(world);
        let mut query = world.query::<(&NodeIndex, &mut NodeVelocity<D>)>();
        for (index, mut v) in query.iter_mut(world) {
            v.0[0] = positions[index.0 as usize].0 * (rate / D::N as f64);
        }
    }

    /// The system alone on a tiny world, in both dimensions: a uniform compression gives the
    /// particle the pressure of its rate and dissipates `−q ε̇_v V Δt`, which the column sums;
    /// a uniform expansion then sets the pressure back to zero and dissipates nothing.
    fn compression_then_expansion<D: Dim>()
    where
        D::Vector: SpaceVector,
    {
        let mut world = tiny_world::<D>(4, 0.25, 1e-3);
        let (mass, volume) = (2.0, 0.015625);
        let x = D::Vector::splat(0.4);
        let particle = spawn_particle(&mut world, x, D::Vector::ZERO, mass, volume);
        world.entity_mut(particle).insert((
            ViscousPressure(0.0),
            ViscousDissipation(0.0),
            WaveSpeed(100.0),
        ));
        let column = world
            .get_resource_or_init::<SeriesColumns>()
            .declare("viscous_dissipation");
        world.insert_resource(ShockViscosity {
            params: ShockViscosityParams::default(),
            length: 0.25,
            materials: MaterialFilter::all(),
            column,
        });
        run_system(&mut world, linear_basis::<D>);
        // ℓ |ε̇_v| = 0.125 m/s: q = ρ (0.2 · 100 · 0.125 + 2 · 0.125²) = 128 · 2.53125.
        uniform_dilatation::<D>(&mut world, -0.5);
        run_system(&mut world, shock_viscosity::<D>);
        let q = world.get::<ViscousPressure>(particle).unwrap().0;
        assert!((q - 128.0 * 2.53125).abs() < 1e-10, "{q}");
        let dissipated = q * 0.5 * volume * 1e-3;
        let state = world.get::<ViscousDissipation>(particle).unwrap().0;
        assert!(
            (state - dissipated).abs() < 1e-15,
            "{state} vs {dissipated}"
        );
        uniform_dilatation::<D>(&mut world, 0.5);
        run_system(&mut world, shock_viscosity::<D>);
        assert_eq!(world.get::<ViscousPressure>(particle).unwrap().0, 0.0);
        assert_eq!(world.get::<ViscousDissipation>(particle).unwrap().0, state);
        assert_eq!(world.resource::<SeriesColumns>().values[column], state);
    }

    /// The force transfer reads the pressure: a particle with no stress and a viscous pressure
    /// `q` pushes its nodes as the stress `−q I` would, in both dimensions.
    fn the_internal_force_uses_the_stress_less_q<D: Dim>()
    where
        D::Vector: SpaceVector,
    {
        use crate::transfer::{ParticleSlices, force_contribution};
        let mut world = tiny_world::<D>(4, 0.25, 1e-3);
        spawn_particle(
            &mut world,
            D::Vector::splat(0.3),
            D::Vector::ZERO,
            2.0,
            0.015625,
        );
        run_system(&mut world, linear_basis::<D>);
        let c = world.resource::<Connectivity<D>>();
        let (mass, velocity, volume) = ([Mass(2.0)], [Velocity::<D>::default()], [Volume(0.5)]);
        let (damage, external) = ([Damage(0.25)], [ExternalForce::<D>::default()]);
        let (unstressed, pressure) = ([Stress::<D>::default()], [ViscousPressure(3.0)]);
        let as_stress = [Stress::<D>(D::Sym::isotropic(-3.0))];
        let slices = |stress, viscous| ParticleSlices {
            mass: &mass,
            velocity: &velocity,
            volume: &volume,
            stress,
            damage: &damage,
            external: &external,
            viscous,
            damage_scales_force: true,
        };
        let (with_q, with_stress) = (
            slices(&unstressed, Some(&pressure)),
            slices(&as_stress, None),
        );
        for e in c.row(0) {
            let by_q = force_contribution(c, &with_q, D::Vector::ZERO, e, 0);
            let by_stress = force_contribution(c, &with_stress, D::Vector::ZERO, e, 0);
            assert!(by_q.length() > 0.0 && (by_q - by_stress).length() < 1e-15);
        }
    }

    #[test]
    fn the_internal_force_uses_the_stress_less_q_in_2d_and_3d() {
        the_internal_force_uses_the_stress_less_q::<Two>();
        the_internal_force_uses_the_stress_less_q::<Three>();
    }

    #[test]
    fn the_system_prices_compression_and_ignores_expansion_in_2d() {
        compression_then_expansion::<Two>();
    }

    #[test]
    fn the_system_prices_compression_and_ignores_expansion_in_3d() {
        compression_then_expansion::<Three>();
    }
}
