//! Update-stress-last explicit scheme, grid part: particle-to-grid transfer, nodal forces and
//! the nodal velocity update.
//!
//! - Stage: predictor. Registration name: `predictor/usl`. Pairs with `advection/usl`.
//! - Implements eqs. (1)–(6) of Homel & Herbold (dfg-partitioning-mpm.md §1.1):
//!   `m_I = Σ N_Ip m_p`, `v_I = Σ N_Ip m_p v_p / m_I`,
//!   `f_I = Σ N_Ip m_p b − Σ (1 − D_p) V_p σ_p · ∇N_Ip`, `v̄_I = v_I + Δt f_I / m_I`,
//!   with essential boundary conditions held on `v_I` and `v̄_I`. The stress used is the one
//!   carried from the previous step (update stress last); the stress stage that follows
//!   evaluates the velocity gradient from `v̄_I` (eq. 7).
//! - Writes every velocity field of every node (each pair's field from the connectivity); the
//!   node acceleration is the one implied by the held velocities, `(v̄_I − v_I)/Δt`, so
//!   particles see the boundary conditions too. Publishes `GridIntegration::UpdateStressLast`:
//!   a contact law then corrects `v̄_I` in the step's `grid_update_correction` window, right
//!   after this grid update and before the stress stage reads it.
//! - Shape functions. With `basis/linear` a particle that has just entered a cell carries its
//!   full `∇N` to the new nodes but only `N ≈ 0` of its mass, so a node holding nothing else
//!   gets `v̄ = v + Δt f/m` growing as `1/N`, and the velocity gradient `Σ v̄ ⊗ ∇N` with it:
//!   a stressed particle crossing into an empty cell can invert (the cell-crossing instability
//!   of the tent functions). `basis/gimp`'s weight and gradient vanish together at the edge of
//!   the support, so it has no such term, nor has the Newmark predictor-corrector (its stress
//!   uses the predicted velocity `Σ N m v / m`; docs/history/development-log.md has the measured block). Use
//!   `basis/gimp` (or `basis/lme`) with this integrator when stressed surfaces move across
//!   the grid, as in sliding contact, or `scheme: Musl`.
//! - With `advection/usl`'s `transfer: Apic` the particles carry an affine velocity `C_p` and
//!   each node's momentum gains `Σ N_Ip m_p C_p (x_I − x_p)` (see `advection/usl`).
//! - `scheme: Musl`, modified update-stress-last (Sulsky, Zhou & Schreyer 1995): after eq. 6
//!   the particles' updated velocities `v_p + Δt Σ N_Ip a_I` are mapped back to the nodes and
//!   that velocity, `Σ N_Ip m_p v_p' / m_I`, replaces eq. 5's `v̄_I` for the rest of the step
//!   (the contact correction, the stress's velocity gradient, the motion). A node a particle
//!   has just reached then moves with that particle. With the tents, a disk translating or
//!   spinning rigidly across cells stays rigid (`tests/patch.rs`), where eq. 5's velocity
//!   amplifies round-off at each crossing until the run stops (a translating disk at step
//!   379). It costs one more particle-to-grid pass, and a distributed run's halo one more
//!   round trip.

use crate::transfer::{
    AffineInputs, ForceSources, GridStepInputs, NodeSums, NodeTransferQuery, ParticleSlices,
    add_affine_momentum, add_contribution, field_velocity,
};
use fractum_engine::prelude::*;
use rayon::prelude::*;
use serde::Deserialize;

/// Registration of `predictor/usl`.
pub const REGISTRATION: Registration = Registration {
    name: "predictor/usl",
    summary: "USL grid update: P2G of mass and momentum, nodal forces, v̄ = v + Δt f/m (eqs. 1-6)",
    params: &[
        ParamDoc {
            name: "min_node_mass",
            ty: "f64",
            default: Some("0.0"),
            doc: "nodes with less mass (kg) are treated as empty: zero velocity and acceleration",
        },
        ParamDoc {
            name: "scheme",
            ty: "Usl | Musl",
            default: Some("Usl"),
            doc: "Usl: the stress takes its velocity gradient from v̄ = v + Δt f/m (eqs. 5-7); \
                  Musl: from the velocities mapped back from the updated particle velocities, \
                  which keeps a body moving across cells stable with the tents",
        },
    ],
    requires: &["advection/usl"],
    install: generic_install!(install),
};

/// Parameters of `predictor/usl`.
#[derive(Resource, Deserialize, Clone, Copy, Debug, Default, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct UslPredictorParams {
    /// Nodes with no more mass than this are empty.
    #[serde(default)]
    pub min_node_mass: f64,
    /// Which end-of-step grid velocity the stress and the motion read.
    #[serde(default)]
    pub scheme: UslScheme,
}

/// The end-of-step grid velocity of `predictor/usl` (`scheme`).
#[derive(Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum UslScheme {
    /// `v̄_I = v_I + Δt f_I / m_I` (eq. 5), as the paper writes it.
    #[default]
    Usl,
    /// Modified update-stress-last (Sulsky et al.): the particles' updated velocities
    /// `v_p + Δt Σ N_Ip a_I`, mapped back to the nodes, `v̄_I = Σ N_Ip m_p v_p' / m_I`. A node a
    /// particle has just reached then moves with that particle, where eq. 5's velocity grows
    /// as `1/N` (see the module header).
    Musl,
}

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let parsed: UslPredictorParams = params.parse()?;
    params.require_non_negative(
        "min_node_mass",
        parsed.min_node_mass,
        "expected a finite mass >= 0",
    )?;
    installer.insert_resource(parsed);
    installer.insert_resource(GridIntegration::UpdateStressLast);
    // Mass, momentum and forces to the nodes, read back by the stress and the advection.
    installer.declare_grid_round_trip();
    if parsed.scheme == UslScheme::Musl {
        // The particles' updated velocities to the nodes, read back by the stress.
        installer.declare_grid_round_trip();
    }
    installer.add_systems(usl_predictor::<D>);
    Ok(())
}

/// Node columns written by the grid update, as plain slices in node-index order.
pub struct NodeColumns<'a, D: Dim> {
    /// Field masses.
    pub mass: &'a mut [NodeMass],
    /// Field momenta.
    pub momentum: &'a mut [NodeMomentum<D>],
    /// Field velocities.
    pub velocity: &'a mut [NodeVelocity<D>],
    /// Field accelerations.
    pub acceleration: &'a mut [NodeAcceleration<D>],
    /// Field forces.
    pub force: &'a mut [NodeForce<D>],
}

/// Boundary conditions, the time at the start of the step and the step size.
pub struct StepContext<'a> {
    /// Essential boundary conditions.
    pub bcs: &'a BoundaryConditions,
    /// Time at the start of the step.
    pub time: f64,
    /// Step size.
    pub dt: f64,
    /// Nodes with no more mass than this are empty.
    pub min_node_mass: f64,
}

/// Eqs. (5)–(6) on every field: stores the transfer sums, holds the boundary conditions on `v_I`,
/// updates `v̄_I = v_I + Δt f_I / m_I`, holds them again at the end of the step (measuring the
/// reactions) and sets `a_I = (v̄_I − v_I)/Δt`.
pub fn grid_update<D: Dim>(
    sums: &[NodeSums<D>],
    ctx: &StepContext,
    nodes: NodeColumns<D>,
    reactions: &mut Reactions<D>,
) {
    let zero = D::Vector::ZERO;
    nodes
        .mass
        .par_iter_mut()
        .zip(nodes.momentum.par_iter_mut())
        .zip(nodes.force.par_iter_mut())
        .zip(nodes.velocity.par_iter_mut())
        .zip(sums.par_iter())
        .for_each(|((((mass, momentum), force), velocity), s)| {
            *mass = NodeMass(s.mass);
            *momentum = NodeMomentum(s.momentum);
            *force = NodeForce(s.force);
            *velocity = NodeVelocity(std::array::from_fn(|k| {
                field_velocity(s, k, ctx.min_node_mass)
            }));
        });
    ctx.bcs.enforce(ctx.time, nodes.mass, nodes.velocity, None);
    // The acceleration column holds the start-of-step velocity until the end velocity is known.
    nodes
        .acceleration
        .par_iter_mut()
        .zip(nodes.velocity.par_iter_mut())
        .zip(sums.par_iter())
        .for_each(|((start, velocity), s)| {
            start.0 = velocity.0;
            for k in 0..MAX_FIELDS {
                let occupied = s.mass[k] > ctx.min_node_mass && s.mass[k] > 0.0;
                velocity.0[k] = if occupied {
                    start.0[k] + s.force[k] * ctx.dt / s.mass[k]
                } else {
                    zero
                };
            }
        });
    let end = ctx.time + ctx.dt;
    ctx.bcs
        .enforce(end, nodes.mass, nodes.velocity, Some((ctx.dt, reactions)));
    nodes
        .acceleration
        .par_iter_mut()
        .zip(nodes.velocity.par_iter())
        .for_each(|(a, v)| a.0 = std::array::from_fn(|k| (v.0[k] - a.0[k]) / ctx.dt));
}

/// The `predictor/usl` system.
pub fn usl_predictor<D: Dim>(
    inputs: GridStepInputs<D>,
    mut reactions: ResMut<Reactions<D>>,
    params: Res<UslPredictorParams>,
    particles: ForceSources<D>,
    affine: AffineInputs<D>,
    mut nodes: NodeTransferQuery<D>,
    mut sums: Local<Vec<NodeSums<D>>>,
) {
    let affine = affine.columns();
    let GridStepInputs {
        clock,
        body_force,
        bcs,
        connectivity,
    } = inputs;
    let Some(slices) = ParticleSlices::of(&particles) else {
        return;
    };
    let Some((node_mass, momentum, node_velocity, acceleration, force)) =
        single_table_mut(nodes.contiguous_iter_mut(), "nodes")
    else {
        return;
    };
    // Every slot is overwritten by the transfer: the buffer is only resized, never cleared.
    sums.resize(node_mass.len(), NodeSums::default());
    connectivity.accumulate_to_nodes(&mut sums, |sum, e, p| {
        add_contribution(sum, &connectivity, &slices, body_force.0, e, p);
        if let Some(affine) = affine {
            add_affine_momentum(sum, &connectivity, slices.mass, affine, e, p);
        }
    });
    let ctx = StepContext {
        bcs: &bcs,
        time: clock.time,
        dt: clock.dt,
        min_node_mass: params.min_node_mass,
    };
    // Each `&mut *column` marks the whole column changed once; indexing the bevy column inside
    // a loop would do that on every access (quadratic), so the kernel gets plain slices.
    let columns = NodeColumns {
        mass: node_mass,
        momentum,
        velocity: node_velocity,
        acceleration,
        force,
    };
    grid_update(&sums, &ctx, columns, &mut reactions);
    if params.scheme == UslScheme::Musl {
        remap_velocities(
            &connectivity,
            &slices,
            &ctx,
            (node_mass, acceleration),
            node_velocity,
        );
    }
}

/// Modified update-stress-last: the end-of-step velocity of each field mapped back from the
/// particles' updated velocities, `v̄_Ik = Σ N_Ip m_p (v_p + Δt Σ_J N_Jp a_J) / m_Ik` over the
/// particles of field `k`, the boundary conditions held on it again (their reactions are the
/// grid update's). The accelerations stay eq. 6's, which the advection adds to the particles.
pub fn remap_velocities<D: Dim>(
    c: &Connectivity<D>,
    slices: &ParticleSlices<D>,
    ctx: &StepContext,
    (mass, acceleration): (&[NodeMass], &[NodeAcceleration<D>]),
    velocity: &mut [NodeVelocity<D>],
) {
    let updated: Vec<D::Vector> = (0..c.particle_count())
        .into_par_iter()
        .map(|p| {
            let a = c.row(p).fold(D::Vector::ZERO, |a, e| {
                a + acceleration[c.nodes[e] as usize].0[c.field(e)] * c.weights[e]
            });
            slices.velocity[p].0 + a * ctx.dt
        })
        .collect();
    let mut momenta = vec![[D::Vector::ZERO; MAX_FIELDS]; mass.len()];
    c.accumulate_to_nodes(&mut momenta, |sum, e, p| {
        sum[c.field(e)] += updated[p] * (slices.mass[p].0 * c.weights[e]);
    });
    velocity
        .par_iter_mut()
        .zip(momenta.par_iter().zip(mass.par_iter()))
        .for_each(|(v, (p, m))| {
            v.0 = std::array::from_fn(|k| {
                let occupied = m.0[k] > ctx.min_node_mass && m.0[k] > 0.0;
                if occupied {
                    p[k] / m.0[k]
                } else {
                    D::Vector::ZERO
                }
            });
        });
    ctx.bcs.enforce(ctx.time + ctx.dt, mass, velocity, None);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `fractum systems` documents the fields its parameters read, and its documented defaults are theirs.
    #[test]
    fn parameter_docs_match_the_parameters() {
        fractum_engine::testing::assert_defaults::<UslPredictorParams>(&REGISTRATION);
    }
    use crate::basis::linear::linear_basis;
    use fractum_engine::boundary::BoundaryRegion;
    use fractum_engine::testing::*;

    /// Two particles, gravity along the last axis: mass is conserved, the grid momentum after
    /// the step is the particles' momentum plus the body-force impulse.
    fn transfer_conserves<D: Dim>(xs: [D::Vector; 2], vs: [D::Vector; 2])
    where
        D::Vector: SpaceVector,
    {
        let mut world = tiny_world::<D>(2, 0.5, 0.01);
        world.insert_resource(UslPredictorParams::default());
        let g = D::Vector::from_fn(|a| if a + 1 == D::N { -10.0 } else { 0.0 });
        world.insert_resource(BodyForce::<D>(g));
        spawn_particle(&mut world, xs[0], vs[0], 2.0, 0.1);
        spawn_particle(&mut world, xs[1], vs[1], 3.0, 0.1);
        run_system(&mut world, (linear_basis::<D>, usl_predictor::<D>).chain());
        let masses = node_values::<NodeMass>(&mut world);
        let velocities = node_values::<NodeVelocity<D>>(&mut world);
        let accelerations = node_values::<NodeAcceleration<D>>(&mut world);
        let total_mass: f64 = masses.iter().map(|m| m.0[0]).sum();
        let momentum: D::Vector = masses
            .iter()
            .zip(&velocities)
            .map(|(m, v)| v.0[0] * m.0[0])
            .sum();
        let impulse: D::Vector = masses
            .iter()
            .zip(&accelerations)
            .map(|(m, a)| a.0[0] * m.0[0])
            .sum();
        assert!((total_mass - 5.0).abs() < 1e-14);
        let expected = vs[0] * 2.0 + vs[1] * 3.0 + g * (5.0 * 0.01);
        assert!((momentum - expected).length() < 1e-12, "{momentum:?}");
        assert!((impulse - g * 5.0).length() < 1e-10);
        assert!(masses.iter().all(|m| m.0[1] == 0.0));
    }

    /// Modified update-stress-last: every node a lone particle reaches moves with the
    /// particle's updated velocity `v + Δt g`, however little of its mass the node holds,
    /// where eq. 5 gives each node `v + Δt g` too only because a lone particle carries no
    /// stress; under a stress a node holding `N ≈ 0` of the mass gets `Δt f / (N m)`.
    #[test]
    fn musl_nodes_move_with_the_particles_updated_velocity() {
        for scheme in [UslScheme::Usl, UslScheme::Musl] {
            let mut world = tiny_world::<Two>(2, 0.5, 0.01);
            world.insert_resource(UslPredictorParams {
                scheme,
                ..UslPredictorParams::default()
            });
            let g = DVec2::new(0.0, -10.0);
            world.insert_resource(BodyForce::<Two>(g));
            // Just inside the cell [0.5, 1] along x: the nodes at x = 1 hold 2% of its mass.
            let v = DVec2::new(1.0, 2.0);
            let p = spawn_particle(&mut world, DVec2::new(0.51, 0.3), v, 2.0, 0.1);
            world.entity_mut(p).insert(Stress::<Two>(SymTensor2 {
                xx: 1.0e3,
                ..SymTensor2::default()
            }));
            run_system(
                &mut world,
                (linear_basis::<Two>, usl_predictor::<Two>).chain(),
            );
            let masses = node_values::<NodeMass>(&mut world);
            let velocities = node_values::<NodeVelocity<Two>>(&mut world);
            let accelerations = node_values::<NodeAcceleration<Two>>(&mut world);
            let reached: Vec<usize> = (0..masses.len())
                .filter(|&i| masses[i].0[0] > 0.0)
                .collect();
            assert_eq!(reached.len(), 4);
            // The particle's updated velocity, from the nodes' accelerations.
            let c = world.resource::<Connectivity<Two>>();
            let a: DVec2 = c
                .row(0)
                .map(|e| accelerations[c.nodes[e] as usize].0[0] * c.weights[e])
                .sum();
            let updated = v + a * 0.01;
            let spread = reached
                .iter()
                .map(|&i| (velocities[i].0[0] - updated).length())
                .fold(0.0, f64::max);
            match scheme {
                UslScheme::Musl => assert!(spread < 1e-12, "{spread}"),
                UslScheme::Usl => assert!(spread > 1.0, "{spread}"),
            }
        }
    }

    #[test]
    fn transfer_conserves_mass_and_momentum_and_applies_body_force() {
        transfer_conserves::<Two>(
            [DVec2::new(0.3, 0.6), DVec2::new(0.8, 0.2)],
            [DVec2::new(1.0, 2.0), DVec2::new(-1.0, 0.5)],
        );
        transfer_conserves::<Three>(
            [DVec3::new(0.3, 0.6, 0.1), DVec3::new(0.8, 0.2, 0.7)],
            [DVec3::new(1.0, 2.0, -0.5), DVec3::new(-1.0, 0.5, 0.25)],
        );
    }

    #[test]
    fn tension_contracts_the_cell_and_fixed_nodes_report_the_reaction() {
        let mut world = tiny_world::<Two>(2, 0.5, 0.01);
        world.insert_resource(UslPredictorParams::default());
        world.insert_resource(BoundaryConditions {
            regions: vec![BoundaryRegion::fixed("centre", vec![4])],
            measured_nodes: None,
        });
        let p = spawn_particle(&mut world, DVec2::new(0.6, 0.6), DVec2::ZERO, 1.0, 0.25);
        world.get_mut::<Stress<Two>>(p).unwrap().0 = SymTensor2 {
            xx: 10.0,
            yy: 0.0,
            zz: 0.0,
            xy: 0.0,
        };
        run_system(
            &mut world,
            (linear_basis::<Two>, usl_predictor::<Two>).chain(),
        );
        let forces = node_values::<NodeForce<Two>>(&mut world);
        let velocities = node_values::<NodeVelocity<Two>>(&mut world);
        // Tension contracts the cell: its left nodes are pulled right, its right nodes left.
        assert!(forces[4].0[0].x > 0.0 && forces[5].0[0].x < 0.0);
        assert_eq!(velocities[4].0[0], DVec2::ZERO);
        // Internal forces sum to zero; the reaction holds the fixed node against its share.
        let total: DVec2 = forces.iter().map(|f| f.0[0]).sum();
        assert!(total.length() < 1e-12);
        let reaction = world.resource::<Reactions<Two>>().0[0];
        assert!((reaction + forces[4].0[0]).length() < 1e-12, "{reaction}");
    }
}
