//! Update-stress-last explicit scheme, particle part: grid-to-particle transfer and motion.
//!
//! - Stage: advection. Registration name: `advection/usl`. Pairs with `predictor/usl`.
//! - Implements eqs. (9)–(10) of Homel & Herbold (dfg-partitioning-mpm.md §1.1):
//!   `v_p ← v_p + Δt Σ N_Ip a_I` and `x_p ← x_p + Δt Σ N_Ip v̄_I`, reading each particle's own field of the
//!   nodes. The particle acceleration `Σ N_Ip a_I` is stored for output and for integrators
//!   that need it.
//! - Transfer (`transfer`). `Flip` (the default) is the update above, the paper's. `Apic` is
//!   the affine particle-in-cell transfer (Jiang, Schroeder, Selle, Teran & Stomakhin 2015):
//!   `v_p = Σ N_Ip v̄_I`, `C_p = B_p D_p⁻¹` of `v̄_I` (`transfer::affine_interpolation`),
//!   `x_p += Δt Σ N_Ip v̄_I`, and `predictor/usl` hands each node
//!   `Σ N m (v_p + C_p (x_I − x_p))`. The transfers then keep angular momentum, and a rotating
//!   body keeps its energy where `Flip` shakes it into the grid's modes. Not with
//!   `scheme: Musl`, whose remap rebuilds the nodes from the particles' FLIP velocities.
//!   Each particle starts with `C_p` the gradient of its body's initial velocity (the scene
//!   builder): `scenes/spinning_sphere.ron` keeps its energy to 1.0e-7 over its 1000 steps,
//!   where `Flip` loses 0.32% and a start from `C_p = 0` (a PIC first step) lost 2.6%
//!   (`tests/affine.rs`).

pub use super::Transfer;
use crate::predictor::usl::{UslPredictorParams, UslScheme};
use crate::transfer::{
    AdvectedQuery, AffineAdvectedQuery, NodeMotionQuery, NodePositionQuery, advect_particles,
    advect_particles_affine,
};
use fractum_engine::prelude::*;
use serde::Deserialize;

/// Registration of `advection/usl`.
pub const REGISTRATION: Registration = Registration {
    name: "advection/usl",
    summary: "USL particle update: v += Δt Σ N a_I, x += Δt Σ N v_I (eqs. 9-10), or the \
              affine (APIC) transfer",
    params: &[ParamDoc {
        name: "transfer",
        ty: "Flip | Apic",
        default: Some("Flip"),
        doc: "Flip: the particle velocity takes the grid's change (eq. 9); Apic: the particle \
              takes the grid velocity and an affine velocity C_p, and the transfers keep \
              angular momentum (not with predictor/usl's scheme: Musl)",
    }],
    requires: &["predictor/usl"],
    install: generic_install!(install),
};

/// Parameters of `advection/usl`.
#[derive(Resource, Deserialize, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[serde(deny_unknown_fields)]
pub struct UslAdvectionParams {
    /// Which grid-to-particle transfer.
    #[serde(default)]
    pub transfer: Transfer,
}

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let parsed: UslAdvectionParams = params.parse()?;
    installer.insert_resource(parsed);
    if parsed.transfer == Transfer::Flip {
        installer.add_systems(usl_advection::<D>);
        return Ok(());
    }
    let musl = installer
        .world()
        .get_resource::<UslPredictorParams>()
        .is_some_and(|p| p.scheme == UslScheme::Musl);
    if musl {
        return Err(params.error(
            "transfer",
            "`transfer: Apic` with predictor/usl's `scheme: Musl`: the remap rebuilds the \
             nodes from the particles' FLIP velocities; use `scheme: Usl` (the default) with \
             Apic",
        ));
    }
    installer.add_particle_component(AffineVelocity::<D>::default());
    installer.add_systems(usl_apic_advection::<D>);
    Ok(())
}

/// The `advection/usl` system with `transfer: Apic`: `v_p = Σ N v̄_I`, `a_p = Σ N a_I`,
/// `x_p += Δt v_p` and `C_p` of `v̄_I`.
pub fn usl_apic_advection<D: Dim>(
    clock: Res<SimClock>,
    node_positions: NodePositionQuery<D>,
    connectivity: Res<Connectivity<D>>,
    nodes: NodeMotionQuery<D>,
    mut particles: AffineAdvectedQuery<D>,
) {
    let steps = (clock.dt, 0.0, 0.0);
    advect_particles_affine(
        (&connectivity, &node_positions),
        &nodes,
        &mut particles,
        steps,
    );
}

/// The `advection/usl` system.
pub fn usl_advection<D: Dim>(
    clock: Res<SimClock>,
    connectivity: Res<Connectivity<D>>,
    nodes: NodeMotionQuery<D>,
    mut particles: AdvectedQuery<D>,
) {
    let dt = clock.dt;
    advect_particles(
        &connectivity,
        &nodes,
        &mut particles,
        |x, v, a_grid, v_grid| {
            *v += a_grid * dt;
            *x += v_grid * dt;
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::linear::linear_basis;
    use fractum_engine::testing::*;

    /// Particles in a uniform grid motion (node velocity `v`, acceleration `a`) move rigidly.
    fn rigid_motion<D: Dim>(xs: [D::Vector; 2], v: D::Vector, a: D::Vector)
    where
        D::Vector: SpaceVector,
    {
        let mut world = tiny_world::<D>(2, 0.5, 0.1);
        for x in xs {
            spawn_particle(&mut world, x, D::Vector::ONE, 1.0, 0.1);
        }
        let mut query = world.query::<(&mut NodeVelocity<D>, &mut NodeAcceleration<D>)>();
        for (mut nv, mut na) in query.iter_mut(&mut world) {
            nv.0[0] = v;
            na.0[0] = a;
        }
        run_system(&mut world, (linear_basis::<D>, usl_advection::<D>).chain());
        let positions = particle_values::<Position<D>>(&mut world);
        let velocities = particle_values::<Velocity<D>>(&mut world);
        for (k, x) in xs.iter().enumerate() {
            assert!((positions[k].0 - (*x + v * 0.1)).length() < 1e-14);
            assert!((velocities[k].0 - (D::Vector::ONE + a * 0.1)).length() < 1e-14);
        }
        assert!((particle_values::<Acceleration<D>>(&mut world)[1].0 - a).length() < 1e-14);
    }

    #[test]
    fn uniform_grid_motion_moves_particles_rigidly() {
        rigid_motion::<Two>(
            [DVec2::new(0.3, 0.7), DVec2::new(0.9, 0.1)],
            DVec2::new(1.5, -0.5),
            DVec2::new(5.0, -5.0),
        );
        rigid_motion::<Three>(
            [DVec3::new(0.3, 0.7, 0.2), DVec3::new(0.9, 0.1, 0.6)],
            DVec3::new(1.5, -0.5, 0.25),
            DVec3::new(5.0, -5.0, 2.0),
        );
    }
    /// `fractum systems` documents the fields its parameters read, and its documented defaults
    /// are theirs.
    #[test]
    fn parameter_docs_match_the_parameters() {
        fractum_engine::testing::assert_defaults::<UslAdvectionParams>(&REGISTRATION);
    }

    /// Under `transfer: Apic` a particle in an affine grid field `v̄_I = v₀ + G x_I` takes
    /// `v_p = v₀ + G x_p` and `C_p = G`, and moves by `Δt v_p`, in 2D and 3D.
    fn affine_field_is_taken_exactly<D: Dim>(x: D::Vector, v0: D::Vector)
    where
        D::Vector: SpaceVector,
    {
        let mut world = tiny_world::<D>(4, 0.5, 0.1);
        let p = spawn_particle(&mut world, x, D::Vector::ZERO, 1.0, 0.1);
        world.entity_mut(p).insert(AffineVelocity::<D>::default());
        let gradient = D::Matrix::from_fn(|i, j| 1.5 - i as f64 + 0.5 * j as f64);
        let grid = world.resource::<Grid<D>>().clone();
        let mut query = world.query::<(&NodeIndex, &mut NodeVelocity<D>)>();
        for (i, mut nv) in query.iter_mut(&mut world) {
            nv.0[0] = v0 + gradient * grid.node_position(i.0 as usize);
        }
        run_system(
            &mut world,
            (linear_basis::<D>, usl_apic_advection::<D>).chain(),
        );
        let speed = particle_values::<Velocity<D>>(&mut world)[0].0;
        assert!((speed - (v0 + gradient * x)).length() < 1e-12, "{speed:?}");
        let affine = particle_values::<AffineVelocity<D>>(&mut world)[0].0;
        assert!((affine - gradient).max_abs() < 1e-10, "{affine:?}");
        let moved = particle_values::<Position<D>>(&mut world)[0].0;
        assert!((moved - (x + speed * 0.1)).length() < 1e-12);
    }

    #[test]
    fn apic_takes_an_affine_grid_field_exactly() {
        affine_field_is_taken_exactly::<Two>(DVec2::new(0.8, 1.1), DVec2::new(1.0, -2.0));
        affine_field_is_taken_exactly::<Three>(
            DVec3::new(0.8, 1.1, 0.65),
            DVec3::new(1.0, -2.0, 0.5),
        );
    }

    /// The affine round trip keeps angular momentum: grid velocities handed to the particles
    /// (a zero step) and back (`predictor/usl`'s momenta) give the nodes the angular momentum
    /// they had, for any velocity field, here with GIMP.
    #[test]
    fn apic_round_trip_keeps_the_grids_angular_momentum() {
        use crate::advection::round_trip::{
            grid_angular_momentum, scatter_affine_particles, set_grid_field,
        };
        use crate::basis::gimp::gimp_basis;
        use crate::predictor::usl::{UslPredictorParams, usl_predictor};
        let mut world = tiny_world::<Two>(6, 0.5, 1e-3);
        world.insert_resource(UslPredictorParams::default());
        scatter_affine_particles(&mut world, 0.01);
        run_system(
            &mut world,
            (gimp_basis::<Two>, usl_predictor::<Two>).chain(),
        );
        let before = set_grid_field(&mut world);
        world.resource_mut::<SimClock>().dt = 0.0;
        run_system(&mut world, usl_apic_advection::<Two>);
        world.resource_mut::<SimClock>().dt = 1e-3;
        run_system(
            &mut world,
            (gimp_basis::<Two>, usl_predictor::<Two>).chain(),
        );
        let after = grid_angular_momentum(&mut world);
        assert!(
            (after - before).abs() < 1e-10 * before.abs(),
            "{before} {after}"
        );
    }
}
