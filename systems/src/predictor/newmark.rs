//! Explicit Newmark predictor-corrector, predictor part: lumped mass and nodal velocity
//! predictor.
//!
//! - Stage: predictor. Registration name: `predictor/newmark`. Pairs with `corrector/newmark`
//!   and `advection/newmark`.
//! - Implements eigensoftening-lme-mpm.md Appendix A (Algorithm 1), steps 1–3, eq. (1):
//!   `m_I = Σ N_Ip m_p`, `ṽ_I = Σ N_Ip m_p (v_p + (1 − γ) Δt a_p) / m_I`, then the essential
//!   boundary conditions are held on `ṽ_I`. The stress stage that follows computes the strain
//!   increment from `ṽ_I` (step 4).
//! - With `advection/newmark`'s `transfer: Apic` the particles carry an affine velocity `C_p`
//!   and each node's momentum gains `Σ N_Ip m_p C_p (x_I − x_p)` (the affine particle-in-cell
//!   transfer; see `advection/newmark`).
//! - Writes every velocity field (each pair's field from the connectivity); clears the nodal
//!   force, contact force and acceleration, which the contact and corrector stages fill.

use crate::transfer::{
    AffineInputs, GridStepInputs, NodeSums, NodeTransferQuery, add_affine_momentum, field_velocity,
};
use fractum_engine::prelude::*;
use rayon::prelude::*;
use serde::Deserialize;

/// Registration of `predictor/newmark`.
pub const REGISTRATION: Registration = Registration {
    name: "predictor/newmark",
    summary: "Newmark predictor: m_I and ṽ_I = Σ N m (v + (1-γ)Δt a) / m_I (Appendix A, eq. 1)",
    params: &[ParamDoc {
        name: "gamma",
        ty: "f64",
        default: Some("0.5"),
        doc: "Newmark γ in [0.5, 1]; 0.5 is second order, larger values damp high frequencies",
    }],
    requires: &["corrector/newmark", "advection/newmark"],
    install: generic_install!(install),
};

/// Parameters of `predictor/newmark`; it publishes γ to the corrector and to grid laws as
/// [`GridIntegration::PredictorCorrector`].
#[derive(Resource, Deserialize, Clone, Copy, Debug, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NewmarkParams {
    /// Newmark γ.
    #[serde(default = "default_gamma")]
    pub gamma: f64,
}

fn default_gamma() -> f64 {
    0.5
}

impl Default for NewmarkParams {
    fn default() -> Self {
        Self {
            gamma: default_gamma(),
        }
    }
}

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let parsed: NewmarkParams = params.parse()?;
    params.require(
        "gamma",
        (0.5..=1.0).contains(&parsed.gamma),
        "expected γ in [0.5, 1] (explicit Newmark is unstable below 0.5)",
    )?;
    installer.restrict_time_step(
        stability_factor(parsed.gamma),
        format!(
            "predictor/newmark with gamma = {} is stable to 1/(2 - gamma) of central differences",
            parsed.gamma
        ),
    );
    installer.insert_resource(parsed);
    // Mass and momentum to the nodes, read back by the stress.
    installer.declare_grid_round_trip();
    installer.insert_resource(GridIntegration::PredictorCorrector {
        gamma: parsed.gamma,
    });
    installer.add_systems(newmark_predictor::<D>);
    Ok(())
}

/// Fraction of the central-difference stable step this scheme allows: `1 / (2 − γ)`.
///
/// For one mode of frequency ω the step maps (strain, velocity) by a matrix with trace
/// `2 − (2 − γ) h²` and determinant `1 − (1 − γ) h²` (`h = ω Δt`): its eigenvalues stay on or
/// inside the unit circle while `h < 2 / (2 − γ)`, against `h < 2` for central differences. The
/// determinant below one is also the scheme's numerical damping, `≈ (1 − γ) h²` of the energy
/// per step.
pub fn stability_factor(gamma: f64) -> f64 {
    1.0 / (2.0 - gamma)
}

/// Adds the nodal mass and predictor momentum of entry `e` of particle `p` to its field (eq. 1).
#[inline(always)]
pub fn add_predictor_contribution<D: Dim>(
    sums: &mut NodeSums<D>,
    c: &Connectivity<D>,
    particle: (&[Mass], &[Velocity<D>], &[Acceleration<D>]),
    gamma_dt: (f64, f64),
    e: usize,
    p: usize,
) {
    let (mass, velocity, acceleration) = particle;
    let (gamma, dt) = gamma_dt;
    let (k, nm) = (c.field(e), c.weights[e] * mass[p].0);
    sums.mass[k] += nm;
    sums.momentum[k] += (velocity[p].0 + acceleration[p].0 * ((1.0 - gamma) * dt)) * nm;
}

type ParticleQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static Mass,
        &'static Velocity<D>,
        &'static mut Acceleration<D>,
        &'static ExternalForce<D>,
    ),
    With<Particle>,
>;

/// The acceleration a particle starts with, `b + f_ext / m`: the body force and its share of
/// the loads at the first step. The predictor's `(1 − γ) Δt a_p` needs an `a₀`; zero would make
/// a body falling under gravity lag `(1 − γ) g Δt` behind free fall for the whole run. Internal
/// forces start at zero (no scene gives an initial stress); a held boundary corrects the nodes
/// it holds within the step, as it does every step.
pub fn starting_acceleration<D: Dim>(
    body_force: D::Vector,
    external: D::Vector,
    mass: f64,
) -> D::Vector {
    body_force + external / mass
}

/// The `predictor/newmark` system.
pub fn newmark_predictor<D: Dim>(
    inputs: GridStepInputs<D>,
    params: Res<NewmarkParams>,
    mut particles: ParticleQuery<D>,
    affine: AffineInputs<D>,
    mut nodes: NodeTransferQuery<D>,
    mut sums: Local<Vec<NodeSums<D>>>,
) {
    let affine = affine.columns();
    let Some((mass, velocity, acceleration, external)) =
        single_table_mut(particles.contiguous_iter_mut(), "particles")
    else {
        return;
    };
    let (clock, bcs, connectivity) = (&inputs.clock, &inputs.bcs, &inputs.connectivity);
    if clock.step == 0 {
        for ((a, m), f) in acceleration.iter_mut().zip(mass).zip(external) {
            a.0 = starting_acceleration::<D>(inputs.body_force.0, f.0, m.0);
        }
    }
    let acceleration: &[Acceleration<D>] = acceleration;
    let Some((node_mass, momentum, node_velocity, node_acceleration, force)) =
        single_table_mut(nodes.contiguous_iter_mut(), "nodes")
    else {
        return;
    };
    // Every slot is overwritten by the transfer: the buffer is only resized, never cleared.
    sums.resize(node_mass.len(), NodeSums::default());
    let gamma_dt = (params.gamma, clock.dt);
    connectivity.accumulate_to_nodes(&mut sums, |sum, e, p| {
        add_predictor_contribution(
            sum,
            connectivity,
            (mass, velocity, acceleration),
            gamma_dt,
            e,
            p,
        );
        if let Some(affine) = affine {
            add_affine_momentum(sum, connectivity, mass, affine, e, p);
        }
    });
    node_mass
        .par_iter_mut()
        .zip(momentum.par_iter_mut())
        .zip(node_velocity.par_iter_mut())
        .zip(sums.par_iter())
        .for_each(|(((mass, momentum), velocity), s)| {
            *mass = NodeMass(s.mass);
            *momentum = NodeMomentum(s.momentum);
            *velocity = NodeVelocity(std::array::from_fn(|k| field_velocity(s, k, 0.0)));
        });
    node_acceleration
        .par_iter_mut()
        .for_each(|a| *a = NodeAcceleration::default());
    force.par_iter_mut().for_each(|f| *f = NodeForce::default());
    bcs.enforce(clock.time + clock.dt, node_mass, node_velocity, None);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `fractum systems` documents the fields its parameters read, and its documented defaults are theirs.
    #[test]
    fn parameter_docs_match_the_parameters() {
        fractum_engine::testing::assert_defaults::<NewmarkParams>(&REGISTRATION);
    }
    use crate::basis::linear::linear_basis;
    use fractum_engine::testing::*;

    #[test]
    fn predictor_carries_momentum_plus_the_old_acceleration_impulse() {
        let mut world = tiny_world::<Two>(2, 0.5, 0.1);
        world.insert_resource(NewmarkParams { gamma: 0.5 });
        // A step after the first, so that the particle's acceleration is the last step's.
        world.resource_mut::<SimClock>().step = 1;
        let p = spawn_particle(
            &mut world,
            DVec2::new(0.3, 0.6),
            DVec2::new(1.0, 0.0),
            2.0,
            0.1,
        );
        world.get_mut::<Acceleration<Two>>(p).unwrap().0 = DVec2::new(0.0, -4.0);
        spawn_particle(
            &mut world,
            DVec2::new(0.7, 0.2),
            DVec2::new(0.0, 1.0),
            1.0,
            0.1,
        );
        run_system(
            &mut world,
            (linear_basis::<Two>, newmark_predictor::<Two>).chain(),
        );
        let masses = node_values::<NodeMass>(&mut world);
        let velocities = node_values::<NodeVelocity<Two>>(&mut world);
        let momentum: DVec2 = masses
            .iter()
            .zip(&velocities)
            .map(|(m, v)| m.0[0] * v.0[0])
            .sum();
        // 2 kg at (1, 0 − 0.5·0.1·4) plus 1 kg at (0, 1).
        assert!(
            (momentum - DVec2::new(2.0, -0.4 + 1.0)).length() < 1e-14,
            "{momentum}"
        );
        assert!((masses.iter().map(|m| m.0[0]).sum::<f64>() - 3.0).abs() < 1e-14);
    }

    #[test]
    fn predictor_carries_the_z_component_in_3d() {
        let mut world = tiny_world::<Three>(2, 0.5, 0.1);
        world.insert_resource(NewmarkParams { gamma: 0.5 });
        world.resource_mut::<SimClock>().step = 1;
        let p = spawn_particle(&mut world, DVec3::new(0.3, 0.6, 0.8), DVec3::Z, 2.0, 0.1);
        world.get_mut::<Acceleration<Three>>(p).unwrap().0 = DVec3::new(0.0, 0.0, 4.0);
        run_system(
            &mut world,
            (linear_basis::<Three>, newmark_predictor::<Three>).chain(),
        );
        let masses = node_values::<NodeMass>(&mut world);
        let velocities = node_values::<NodeVelocity<Three>>(&mut world);
        let momentum: DVec3 = masses
            .iter()
            .zip(&velocities)
            .map(|(m, v)| v.0[0] * m.0[0])
            .sum();
        // 2 kg at (0, 0, 1 + 0.5·0.1·4).
        assert!(
            (momentum - DVec3::new(0.0, 0.0, 2.4)).length() < 1e-14,
            "{momentum}"
        );
    }

    /// At the first step the particle's acceleration is the body force and its load per mass,
    /// whatever it held: a body at rest under gravity predicts `(1 − γ) Δt g` on its nodes.
    #[test]
    fn the_first_step_starts_from_the_body_force_and_the_loads() {
        let mut world = tiny_world::<Two>(2, 0.5, 0.1);
        world.insert_resource(NewmarkParams { gamma: 0.5 });
        world.insert_resource(BodyForce::<Two>(DVec2::new(0.0, -10.0)));
        let p = spawn_particle(&mut world, DVec2::new(0.3, 0.6), DVec2::ZERO, 2.0, 0.1);
        world.get_mut::<Acceleration<Two>>(p).unwrap().0 = DVec2::new(7.0, 7.0);
        world.get_mut::<ExternalForce<Two>>(p).unwrap().0 = DVec2::new(4.0, 0.0);
        run_system(
            &mut world,
            (linear_basis::<Two>, newmark_predictor::<Two>).chain(),
        );
        let start = DVec2::new(2.0, -10.0);
        assert_eq!(world.get::<Acceleration<Two>>(p).unwrap().0, start);
        let masses = node_values::<NodeMass>(&mut world);
        let velocities = node_values::<NodeVelocity<Two>>(&mut world);
        let momentum: DVec2 = masses
            .iter()
            .zip(&velocities)
            .map(|(m, v)| v.0[0] * m.0[0])
            .sum();
        assert!(
            (momentum - start * (2.0 * 0.5 * 0.1)).length() < 1e-14,
            "{momentum}"
        );
    }
}
