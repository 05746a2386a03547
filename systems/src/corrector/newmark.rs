//! Explicit Newmark predictor-corrector, corrector part: nodal forces from the updated stress
//! and the velocity corrector.
//!
//! - Stage: corrector. Registration name: `corrector/newmark`. Pairs with `predictor/newmark`.
//! - Implements eigensoftening-lme-mpm.md Appendix A (Algorithm 1), steps 7–8, eq. (2):
//!   `f_I = Σ N_Ip m_p b − Σ (1 − D_p) V_p σ_p · ∇N_Ip` with the stress just updated, and
//!   `v_I = ṽ_I + γ Δt f_I / m_I`, on every velocity field, with γ from the predictor's
//!   `GridIntegration` (whose `end_of_step_velocity` is this formula). Held velocity components stay at
//!   their prescribed value and the force that holds them is the region's reaction. As in the authors' implementation the
//!   force, and so the acceleration handed to the particle update, is zero in held components:
//!   the particle update applies a full `Δt a_I`, so passing the holding acceleration
//!   `(v_I − ṽ_I)/(γ Δt)` would over-correct particles next to a moving boundary by `1/γ` and
//!   feed energy into the body.
//! - Contact. A contact stage before it has already given `ṽ_I` its impulse (the collision
//!   part) and leaves its force in `NodeContactForce`, which joins `f_I` and is integrated like
//!   any other force (see `contact/frictional`).

use crate::row_map_transfer::ParticleForce;
use crate::transfer::{ForceSources, GridStepInputs, ParticleSlices, field_forces};
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// Registration of `corrector/newmark`.
pub const REGISTRATION: Registration = Registration {
    name: "corrector/newmark",
    summary: "Newmark corrector: f_I from the new stress, v_I = ṽ_I + γ Δt f_I / m_I (eq. 2)",
    params: &[],
    requires: &["predictor/newmark"],
    install: generic_install!(install),
};

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    crate::no_params(params)?;
    // The new stresses' forces to the nodes, read back by the advection.
    installer.declare_grid_round_trip();
    installer.add_systems(newmark_corrector::<D>);
    Ok(())
}

type NodeQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static NodeMass,
        &'static mut NodeVelocity<D>,
        &'static mut NodeAcceleration<D>,
        &'static mut NodeForce<D>,
    ),
    With<Node>,
>;

/// The `corrector/newmark` system.
pub fn newmark_corrector<D: Dim>(
    inputs: GridStepInputs<D>,
    integration: Res<GridIntegration>,
    mut reactions: ResMut<Reactions<D>>,
    particles: ForceSources<D>,
    mut nodes: NodeQuery<D>,
    contact: Query<&NodeContactForce<D>, With<Node>>,
    mut buffers: Local<NodeBuffers<D>>,
) {
    let GridStepInputs {
        clock,
        body_force,
        bcs,
        connectivity,
    } = inputs;
    let Some(slices) = ParticleSlices::of(&particles) else {
        return;
    };
    // Contact forces exist where a contact system gave nodes them.
    let contact = single_table(contact.contiguous_iter(), "nodes");
    let Some((node_mass, node_velocity, accelerations, stored_forces)) =
        single_table_mut(nodes.contiguous_iter_mut(), "nodes")
    else {
        return;
    };
    let NodeBuffers {
        forces,
        records,
        held,
    } = &mut *buffers;
    field_forces(
        &connectivity,
        &slices,
        body_force.0,
        node_mass.len(),
        (forces, records),
    );
    let (integration, dt) = (*integration, clock.dt);
    let gamma_dt = integration.force_window(dt);
    correct_velocities(node_velocity, forces, node_mass, contact, (integration, dt));
    bcs.enforce(
        clock.time + clock.dt,
        node_mass,
        node_velocity,
        Some((gamma_dt, &mut reactions)),
    );
    bcs.fill_held_mask(forces.len(), held);
    accelerations
        .par_iter_mut()
        .zip(stored_forces.par_iter_mut())
        .zip(forces.par_iter())
        .zip(held.par_iter())
        .zip(node_mass.par_iter())
        .for_each(|((((acceleration, stored), force), held), mass)| {
            for (k, &m) in mass.0.iter().enumerate() {
                let mut f = if m > 0.0 { force[k] } else { D::Vector::ZERO };
                for (c, is_held) in held[..D::N].iter().enumerate() {
                    if *is_held {
                        f[c] = 0.0;
                    }
                }
                stored.0[k] = f;
                acceleration.0[k] = if m > 0.0 { f / m } else { D::Vector::ZERO };
            }
        });
}

/// Each field's end-of-step velocity from its mass, its velocity and its `forces` with the
/// contact force added (the forces keep the sum). An empty field's velocity does not depend on
/// its force, which nothing reads (its acceleration is zero): most of a grid's fields skip the
/// contact.
fn correct_velocities<D: Dim>(
    node_velocity: &mut [NodeVelocity<D>],
    forces: &mut [[D::Vector; MAX_FIELDS]],
    node_mass: &[NodeMass],
    contact: Option<&[NodeContactForce<D>]>,
    (integration, dt): (GridIntegration, f64),
) {
    node_velocity
        .par_iter_mut()
        .zip(forces.par_iter_mut())
        .zip(node_mass.par_iter())
        .enumerate()
        .for_each(|(i, ((v, f), m))| {
            for (k, fk) in f.iter_mut().enumerate() {
                let force = if m.0[k] > 0.0 {
                    // Without a contact system the force gains an exact zero, as it did when
                    // every node carried a zero contact force.
                    *fk += contact.map_or(D::Vector::ZERO, |c| c[i].0[k]);
                    *fk
                } else {
                    D::Vector::ZERO
                };
                v.0[k] = integration.end_of_step_velocity(m.0[k], v.0[k], force, dt);
            }
        });
}

/// The corrector's buffers, kept between steps: the nodes' forces and held components, and the
/// particles' force records of LME rows.
pub struct NodeBuffers<D: Dim> {
    forces: Vec<[D::Vector; MAX_FIELDS]>,
    records: Vec<ParticleForce<D>>,
    held: Vec<[bool; fractum_engine::boundary::MAX_COMPONENTS]>,
}

impl<D: Dim> Default for NodeBuffers<D> {
    fn default() -> Self {
        Self {
            forces: Vec::new(),
            records: Vec::new(),
            held: Vec::new(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::linear::linear_basis;
    use fractum_engine::boundary::BoundaryRegion;
    use fractum_engine::testing::*;

    #[test]
    fn corrector_adds_gamma_dt_times_acceleration_and_holds_fixed_nodes() {
        let mut world = tiny_world::<Two>(2, 0.5, 0.1);
        world.insert_resource(GridIntegration::PredictorCorrector { gamma: 0.5 });
        world.insert_resource(BodyForce::<Two>(DVec2::new(0.0, -10.0)));
        world.insert_resource(BoundaryConditions {
            regions: vec![BoundaryRegion::fixed("corner", vec![0])],
            measured_nodes: None,
        });
        spawn_particle(&mut world, DVec2::new(0.2, 0.2), DVec2::ZERO, 4.0, 0.1);
        let mut query = world.query::<(&NodeIndex, &mut NodeMass)>();
        for (i, mut m) in query.iter_mut(&mut world) {
            m.0[0] = if [0, 1, 3, 4].contains(&i.0) {
                1.0
            } else {
                0.0
            };
        }
        run_system(
            &mut world,
            (linear_basis::<Two>, newmark_corrector::<Two>).chain(),
        );
        let velocities = node_values::<NodeVelocity<Two>>(&mut world);
        let forces = node_values::<NodeForce<Two>>(&mut world);
        // Node 4 (N = 0.16) carries 0.16 · 4 kg · g; with unit nodal mass v = γ Δt f / m.
        assert!((velocities[4].0[0] - DVec2::new(0.0, 0.05 * -6.4)).length() < 1e-12);
        assert_eq!(velocities[0].0[0], DVec2::ZERO);
        // The corner's reaction cancels its share of the weight: N_0 = 0.36.
        let reaction = world.resource::<Reactions<Two>>().0[0];
        assert!(
            (reaction - DVec2::new(0.0, 0.36 * 40.0)).length() < 1e-12,
            "{reaction}"
        );
        assert_eq!(forces[0].0[0], DVec2::ZERO);
    }

    #[test]
    fn corrector_applies_the_body_force_along_z_in_3d() {
        let mut world = tiny_world::<Three>(2, 0.5, 0.1);
        world.insert_resource(GridIntegration::PredictorCorrector { gamma: 0.5 });
        world.insert_resource(BodyForce::<Three>(DVec3::new(0.0, 0.0, -10.0)));
        spawn_particle(&mut world, DVec3::splat(0.25), DVec3::ZERO, 8.0, 0.1);
        let mut query = world.query::<&mut NodeMass>();
        for mut m in query.iter_mut(&mut world) {
            m.0[0] = 1.0;
        }
        run_system(
            &mut world,
            (linear_basis::<Three>, newmark_corrector::<Three>).chain(),
        );
        let velocities = node_values::<NodeVelocity<Three>>(&mut world);
        // Each of the 8 corners carries 1/8 of 8 kg · g = 10 N down; v = γ Δt f / m.
        assert!((velocities[0].0[0] - DVec3::new(0.0, 0.0, -0.5)).length() < 1e-12);
    }
}
