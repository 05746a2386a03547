//! Moving-least-squares MPM on quadratic B-splines (MLS-MPM, Hu, Fang, Ge, Qu, Zhu, Pradhana &
//! Jiang 2018): the particle-to-grid transfer with the stress folded into the affine momentum,
//! the grid update, and the grid-to-particle transfer of `v_p` and `C_p`, in one stage.
//!
//! - Stage: predictor. Registration name: `predictor/mls`. Pairs with `basis/mls` and
//!   `advection/mls`.
//! - No connectivity: `basis/mls` stores where each particle's stencil starts, and both
//!   transfers evaluate the quadratic B-spline weights from it ([`super::mls_kernel`]). The
//!   weights are `basis/bspline`'s (order 2), with its folded splines at the grid's faces.
//! - Particle to grid (APIC, Jiang et al. 2015, with MLS-MPM's force): `m_I = Σ N_Ip m_p` and
//!   `m_I v̄_I = Σ N_Ip [m_p v_p + Δt (m_p b + f_ext,p) + (m_p C_p − Δt (1 − D_p) V_p σ_p
//!   D_p⁻¹)(x_I − x_p)]`. The internal force `−Σ (1 − D) V σ ∇N` of dfg-partitioning-mpm.md
//!   eq. (4) takes MLS-MPM's gradient `∇N_Ip ≈ N_Ip D_p⁻¹ (x_I − x_p)`, `D_p = h²/4 I` inside
//!   the grid; eqs. (1)–(5) are otherwise the same, with the force already in the momentum
//!   (`v̄_I = v_I + Δt f_I / m_I`, eq. 5). With a shock viscosity the stress is `σ − q I`; with
//!   a damage law that degrades the stress itself ([`crate::transfer::DamageInStress`]) there
//!   is no `1 − D`.
//! - Essential boundary conditions are held on `v̄_I` at the end of the step, where their
//!   reactions are measured (as `predictor/usl` measures them).
//! - Grid to particle: `v_p = Σ N_Ip v̄_I`, `C_p = Σ N_Ip v̄_I ⊗ (x_I − x_p) D_p⁻¹`,
//!   `a_p = (v_p − v_p,old) / Δt`. The velocity gradient the stress stage reads is
//!   `L_p = C_p` ([`GradientInAffineVelocity`]), so the stress needs no second pass over the
//!   nodes. The particles move in the advection stage (`advection/mls`).
//! - Why it exists: speed. Per particle and step it computes the weights twice (a few
//!   multiplications per axis) and touches its nine (27) nodes twice, where `basis/bspline`
//!   with `predictor/usl` fills a connectivity (weights and gradients stored per pair) and
//!   reads it three times. The scatter runs in parallel over cell slabs in a fixed order, so
//!   the result does not depend on the number of threads.
//! - Each particle starts with `C_p` the gradient of its body's initial velocity (the scene
//!   builder), as under `advection/usl`'s `transfer: Apic`.
//! - Refused beside any basis but `basis/mls`, and beside every partition, contact or
//!   corrector system: those build or read the connectivity this transfer does not keep.

use super::mls_kernel::{
    Lattice, NodeSum, ParticleShare, gather_particle, scatter_particle, scatter_slabs, stencil_at,
};
use crate::basis::mls::MlsStencils;
use crate::transfer::{ForceSources, GradientInAffineVelocity, ParticleSlices};
use bevy_ecs::system::SystemParam;
use fractum_engine::prelude::*;
use rayon::prelude::*;
use serde::Deserialize;

/// Registration of `predictor/mls`.
pub const REGISTRATION: Registration = Registration {
    name: "predictor/mls",
    summary: "MLS-MPM on quadratic B-splines: weights on the fly, stress in the affine momentum, \
              v_p and C_p = L_p back to the particles; no connectivity (Hu et al. 2018)",
    params: &[ParamDoc {
        name: "min_node_mass",
        ty: "f64",
        default: Some("0.0"),
        doc: "nodes with less mass (kg) are treated as empty: zero velocity",
    }],
    requires: &["basis/mls", "advection/mls"],
    install: generic_install!(install),
};

/// Parameters of `predictor/mls`.
#[derive(Resource, Deserialize, Clone, Copy, Debug, Default, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MlsParams {
    /// Nodes with no more mass than this are empty.
    #[serde(default)]
    pub min_node_mass: f64,
}

/// The stages whose systems read or write the connectivity `predictor/mls` does not build
/// (besides `basis/mls`).
const CONNECTIVITY_STAGES: [&str; 4] = ["basis/", "partition/", "contact/", "corrector/"];

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let parsed: MlsParams = params.parse()?;
    params.require_non_negative(
        "min_node_mass",
        parsed.min_node_mass,
        "expected a finite mass >= 0",
    )?;
    if let Some(other) = installer.pipeline().iter().find(|name| {
        **name != "basis/mls" && CONNECTIVITY_STAGES.iter().any(|s| name.starts_with(s))
    }) {
        return Err(params.error(
            "",
            format!(
                "predictor/mls evaluates its B-spline weights inside the transfer (with \
                 basis/mls) and keeps no particle-node connectivity, which {other} builds or \
                 reads: remove {other}, or use basis/bspline with predictor/usl and \
                 advection/usl's `transfer: Apic`"
            ),
        ));
    }
    installer.declare_grid_round_trip();
    installer.insert_resource(parsed);
    installer.insert_resource(GradientInAffineVelocity);
    installer.add_particle_component(AffineVelocity::<D>::default());
    installer.add_systems((mls_particle_to_grid::<D>, mls_grid_to_particle::<D>).chain());
    Ok(())
}

/// The read-only inputs of the particle-to-grid system.
#[derive(SystemParam)]
pub struct MlsStepInputs<'w, D: Dim> {
    clock: Res<'w, SimClock>,
    body_force: Res<'w, BodyForce<D>>,
    bcs: Res<'w, BoundaryConditions>,
    grid: Res<'w, Grid<D>>,
    params: Res<'w, MlsParams>,
}

/// What particle `p` gives its nodes (see the module header): `m`, `m v + Δt (m b + f_ext)`
/// and `m C − Δt (1 − D) V (σ − q I) D⁻¹`.
#[inline(always)]
pub fn particle_share<D: Dim>(
    particles: &ParticleSlices<D>,
    affine: &[AffineVelocity<D>],
    (p, inverse_inertia): (usize, D::Vector),
    (dt, body_force): (f64, D::Vector),
) -> ParticleShare<D> {
    let mass = particles.mass[p].0;
    let intact = if particles.damage_scales_force {
        1.0 - particles.damage[p].0
    } else {
        1.0
    };
    let q = particles.viscous.map_or(0.0, |q| q[p].0);
    let sigma = &particles.stress[p].0;
    let scale = intact * particles.volume[p].0 * dt;
    // (σ − q I) D⁻¹ V Δt, column by column (D⁻¹ is diagonal).
    let force_matrix = D::Matrix::from_fn(|i, j| {
        let s = if i == j {
            sigma.get(i, j) - q
        } else {
            sigma.get(i, j)
        };
        s * (inverse_inertia[j] * scale)
    });
    ParticleShare {
        mass,
        momentum: particles.velocity[p].0 * mass
            + (body_force * mass + particles.external[p].0) * dt,
        affine: affine[p].0 * mass - force_matrix,
    }
}

/// The `predictor/mls` system's first half: particle to grid, the grid update and the
/// boundary conditions.
pub fn mls_particle_to_grid<D: Dim>(
    inputs: MlsStepInputs<D>,
    mut reactions: ResMut<Reactions<D>>,
    particles: ForceSources<D>,
    affine: Query<&AffineVelocity<D>, With<Particle>>,
    stencils: Res<MlsStencils<D>>,
    mut sums: Local<Vec<NodeSum<D>>>,
    mut nodes: Query<(&mut NodeMass, &mut NodeVelocity<D>), With<Node>>,
) {
    let Some(slices) = ParticleSlices::of(&particles) else {
        return;
    };
    let Some(affine) = single_table(affine.contiguous_iter(), "particles") else {
        return;
    };
    let Some((node_mass, node_velocity)) = single_table_mut(nodes.contiguous_iter_mut(), "nodes")
    else {
        return;
    };
    let lattice = Lattice::<D>::of(&inputs.grid);
    sums.resize(lattice.node_count(), NodeSum::default());
    let (dt, body_force) = (inputs.clock.dt, inputs.body_force.0);
    let origins = &stencils.origins;
    scatter_slabs(
        &mut sums,
        &stencils.order,
        lattice.row_len(),
        #[inline(always)]
        |p, piece, start| {
            let p = p as usize;
            if let Some(s) = stencil_at(&lattice, &origins[p]) {
                let share =
                    particle_share(&slices, affine, (p, s.inverse_inertia), (dt, body_force));
                scatter_particle(piece, start, (&s, &lattice), &share);
            }
        },
    );
    let min_mass = inputs.params.min_node_mass;
    let (masses, velocities) = (&mut *node_mass, &mut *node_velocity);
    masses
        .par_iter_mut()
        .zip(velocities.par_iter_mut())
        .zip(sums.par_iter())
        .for_each(|((m, v), sum)| {
            m.0 = [0.0; MAX_FIELDS];
            m.0[0] = sum.mass;
            v.0 = [D::Vector::ZERO; MAX_FIELDS];
            if sum.mass > min_mass && sum.mass > 0.0 {
                v.0[0] = sum.momentum / sum.mass;
            }
        });
    let end = inputs.clock.time + dt;
    inputs
        .bcs
        .enforce(end, masses, velocities, Some((dt, &mut reactions)));
}

/// Particle state the grid-to-particle half writes.
pub type MlsParticleQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static mut Velocity<D>,
        &'static mut Acceleration<D>,
        &'static mut AffineVelocity<D>,
    ),
    With<Particle>,
>;

/// The `predictor/mls` system's second half: `v_p`, `a_p` and `C_p` from the grid.
pub fn mls_grid_to_particle<D: Dim>(
    clock: Res<SimClock>,
    grid: Res<Grid<D>>,
    stencils: Res<MlsStencils<D>>,
    nodes: Query<&NodeVelocity<D>, With<Node>>,
    mut particles: MlsParticleQuery<D>,
) {
    let node_velocity = single_table(nodes.contiguous_iter(), "nodes").unwrap_or(&[]);
    let Some((velocity, acceleration, affine)) =
        single_table_mut(particles.contiguous_iter_mut(), "particles")
    else {
        return;
    };
    let lattice = Lattice::<D>::of(&grid);
    let inverse_dt = 1.0 / clock.dt;
    velocity
        .par_chunks_mut(BLOCK_ROWS)
        .zip(acceleration.par_chunks_mut(BLOCK_ROWS))
        .zip(affine.par_chunks_mut(BLOCK_ROWS))
        .zip(stencils.origins.par_chunks(BLOCK_ROWS))
        .for_each(|(((v, a), c), origins)| {
            vectorised(
                #[inline(always)]
                || {
                    for (((v, a), c), origin) in v.iter_mut().zip(a).zip(c).zip(origins) {
                        let Some(s) = stencil_at(&lattice, origin) else {
                            continue;
                        };
                        let (v_new, c_new) =
                            gather_particle(|i| node_velocity[i].0[0], (&s, &lattice));
                        a.0 = (v_new - v.0) * inverse_dt;
                        v.0 = v_new;
                        c.0 = c_new;
                    }
                },
            )
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::advection::round_trip::{scatter_affine_particles, set_grid_field};
    use crate::basis::mls::mls_basis;
    use fractum_engine::testing::*;

    /// A tiny world ready for `predictor/mls`: what its install and `basis/mls`'s insert.
    fn mls_world(cells: usize, h: f64, dt: f64) -> World {
        let mut world = tiny_world::<Two>(cells, h, dt);
        world.insert_resource(MlsStencils::<Two>::default());
        world.insert_resource(MlsParams::default());
        world.insert_resource(GradientInAffineVelocity);
        world
    }

    fn spawn_affine(world: &mut World, x: DVec2, v: DVec2, c: DMat2) {
        let p = spawn_particle(world, x, v, 1.0, 0.01);
        world.entity_mut(p).insert(AffineVelocity::<Two>(c));
    }

    fn transfer(world: &mut World) {
        run_system(
            world,
            (
                mls_basis::<Two>,
                mls_particle_to_grid::<Two>,
                mls_grid_to_particle::<Two>,
            )
                .chain(),
        );
    }

    /// Particles in an affine motion `v(x) = v0 + G x` keep it through the round trip: the
    /// quadratic B-splines reproduce an affine field, inside the grid and on its faces.
    #[test]
    fn an_affine_motion_survives_the_round_trip() {
        let mut world = mls_world(6, 0.5, 1e-3);
        let (v0, g) = (
            DVec2::new(0.3, -0.2),
            DMat2::from_cols(DVec2::new(0.1, 0.4), DVec2::new(-0.3, 0.2)),
        );
        // Two per cell everywhere, so every node of every stencil has mass; some on the faces.
        for i in 0..12 {
            for j in 0..12 {
                let x = DVec2::new(0.125 + 0.25 * i as f64, 0.125 + 0.25 * j as f64);
                spawn_affine(&mut world, x, v0 + g * x, g);
            }
        }
        for x in [
            DVec2::new(0.0, 1.3),
            DVec2::new(3.0, 0.02),
            DVec2::new(1.7, 3.0),
        ] {
            spawn_affine(&mut world, x, v0 + g * x, g);
        }
        transfer(&mut world);
        let x = particle_values::<Position<Two>>(&mut world);
        let v = particle_values::<Velocity<Two>>(&mut world);
        let c = particle_values::<AffineVelocity<Two>>(&mut world);
        for p in 0..x.len() {
            let expected = v0 + g * x[p].0;
            assert!((v[p].0 - expected).length() < 1e-13, "{p}: {:?}", v[p].0);
            for j in 0..2 {
                // On a face the folded row is one node's along that axis: C's column is 0.
                let on_face = x[p].0[j] == 0.0 || x[p].0[j] == 3.0;
                let expected = if on_face { DVec2::ZERO } else { g.col(j) };
                assert!(
                    (c[p].0.col(j) - expected).length() < 1e-12,
                    "{p}: {:?}",
                    c[p].0
                );
            }
        }
    }

    /// The transfers keep the grid's angular momentum (APIC's property): a grid field that is
    /// neither affine nor rigid, taken to the particles as `v_p, C_p` and back, has the same
    /// `Σ x_I × m_I v_I`.
    #[test]
    fn the_round_trip_keeps_angular_momentum() {
        let mut world = mls_world(6, 0.5, 1e-3);
        scatter_affine_particles(&mut world, 0.01);
        let to_grid = (mls_basis::<Two>, mls_particle_to_grid::<Two>).chain();
        run_system(&mut world, to_grid);
        let before = set_grid_field(&mut world);
        run_system(&mut world, mls_grid_to_particle::<Two>);
        run_system(
            &mut world,
            (mls_basis::<Two>, mls_particle_to_grid::<Two>).chain(),
        );
        let grid = world.resource::<Grid<Two>>().clone();
        let mut query = world.query::<(&NodeIndex, &NodeMass, &NodeVelocity<Two>)>();
        let after: f64 = query
            .iter(&world)
            .map(|(i, m, v)| m.0[0] * grid.node_position(i.0 as usize).perp_dot(v.0[0]))
            .sum();
        assert!(before.abs() > 0.1, "{before}");
        assert!(
            (after - before).abs() < 1e-13 * before.abs(),
            "{before} {after}"
        );
    }

    /// A block under a uniform stress: the nodes inside it get no force (MLS's gradient is
    /// consistent), those on its surface do, and the forces sum to zero.
    #[test]
    fn a_uniform_stress_loads_only_the_surface() {
        let dt = 1e-3;
        let mut world = mls_world(8, 0.5, dt);
        let sigma = SymTensor2 {
            xx: 2.0,
            yy: -1.0,
            zz: 0.3,
            xy: 0.7,
        };
        for i in 0..8 {
            for j in 0..8 {
                let x = DVec2::new(1.125 + 0.25 * i as f64, 1.125 + 0.25 * j as f64);
                spawn_affine(&mut world, x, DVec2::ZERO, DMat2::ZERO);
            }
        }
        let mut stresses = world.query::<&mut Stress<Two>>();
        for mut s in stresses.iter_mut(&mut world) {
            s.0 = sigma;
        }
        run_system(
            &mut world,
            (mls_basis::<Two>, mls_particle_to_grid::<Two>).chain(),
        );
        let grid = world.resource::<Grid<Two>>().clone();
        let mut query = world.query::<(&NodeIndex, &NodeMass, &NodeVelocity<Two>)>();
        let (mut total, mut largest) = (DVec2::ZERO, 0.0f64);
        for (i, m, v) in query.iter(&world) {
            let force = v.0[0] * m.0[0] / dt;
            total += force;
            largest = largest.max(force.length());
            let x = grid.node_position(i.0 as usize);
            // Nodes whose whole support (1.5 cells) lies in the block [1, 3]².
            if x.min_element() >= 1.75 && x.max_element() <= 2.25 {
                assert!(force.length() < 1e-13, "{x:?}: {force:?}");
            }
        }
        assert!(largest > 0.01, "{largest}");
        assert!(total.length() < 1e-14, "{total:?}");
    }

    /// The scatter sums each node in one order whatever the number of threads.
    #[test]
    fn the_transfer_does_not_depend_on_the_number_of_threads() {
        let run = |threads: usize| {
            let mut world = mls_world(16, 0.25, 1e-3);
            for k in 0..400 {
                let x = DVec2::new(0.3 + 0.0087 * k as f64, 0.2 + 0.37 * ((k * 7) % 10) as f64);
                let v = DVec2::new((x.y * 3.0).sin(), x.x.cos());
                spawn_affine(&mut world, x, v, DMat2::from_cols(v, -v));
            }
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| transfer(&mut world));
            let v = particle_values::<Velocity<Two>>(&mut world);
            let c = particle_values::<AffineVelocity<Two>>(&mut world);
            (v, c)
        };
        assert_eq!(run(1), run(2));
        assert_eq!(run(1), run(3));
    }
}
