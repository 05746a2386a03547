//! Particle–grid transfer kernels shared by the integrators (not a system).
//!
//! - Particle to grid: lumped mass `m_I = Σ N_Ip m_p`, momentum `Σ N_Ip m_p v_p`, and force
//!   `f_I = Σ N_Ip m_p b − Σ (1 − D_p) V_p σ_p · ∇N_Ip` (dfg-partitioning-mpm.md eqs. 1–4;
//!   eigensoftening-lme-mpm.md Appendix A steps 1, 2 and 7, with the damage scaling of eq. 16).
//! - Grid to particle: `Σ N_Ip a_I` and `Σ N_Ip v_I` (eqs. 9–10; Appendix A step 9).
//!
//! - Velocity gradient `L_p = Σ v_I ⊗ ∇N_Ip` (eq. 7).
//! - The affine transfer (APIC, an advection's `transfer: Apic`): the grid-to-particle
//!   `C_p = B_p D_p⁻¹` ([`affine_interpolation`]) and the particle-to-grid share
//!   `N m C_p (x_I − x_p)` ([`add_affine_momentum`]), in `transfer/affine.rs`.
//!
//! Every transfer reads the velocity field of each particle–node pair from the connectivity
//! (`Connectivity::field`), so a partitioned run and a single-field run share this code: a
//! particle only ever sees, and contributes to, its own field at each node (Algorithm 2).
//! Generic over the dimension `D`.

use crate::row_map_transfer::{ParticleForce, mapped_field_forces, mapped_velocity_gradient};
use bevy_ecs::system::SystemParam;
use fractum_engine::prelude::*;
use rayon::prelude::*;

mod affine;
pub use affine::*;
pub use fractum_engine::resources::DamageInStress;

/// The particle columns a force transfer reads: mass, velocity, volume, stress, damage, loads.
type ForceColumns<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static Mass,
        &'static Velocity<D>,
        &'static Volume,
        &'static Stress<D>,
        &'static Damage,
        &'static ExternalForce<D>,
    ),
    With<Particle>,
>;

/// Particle data the force transfer reads, and whether damage already sits in the stress
/// ([`DamageInStress`]).
#[derive(SystemParam)]
pub struct ForceSources<'w, 's, D: Dim> {
    query: ForceColumns<'w, 's, D>,
    /// The viscous pressures of a shock viscosity, on no particle without one.
    viscous: Query<'w, 's, &'static ViscousPressure, With<Particle>>,
    damage_in_stress: Option<Res<'w, DamageInStress>>,
}

/// The read-only inputs every grid update of a step shares: the clock, the body force, the
/// boundary conditions and the connectivity.
#[derive(SystemParam)]
pub struct GridStepInputs<'w, D: Dim> {
    /// The clock (`dt` of this step).
    pub clock: Res<'w, SimClock>,
    /// The body force per unit mass.
    pub body_force: Res<'w, BodyForce<D>>,
    /// The essential boundary conditions.
    pub bcs: Res<'w, BoundaryConditions>,
    /// The particle–node connectivity of this step.
    pub connectivity: Res<'w, Connectivity<D>>,
}

/// Node data a particle-to-grid predictor writes.
pub type NodeTransferQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static mut NodeMass,
        &'static mut NodeMomentum<D>,
        &'static mut NodeVelocity<D>,
        &'static mut NodeAcceleration<D>,
        &'static mut NodeForce<D>,
    ),
    With<Node>,
>;

/// Particle state a grid-to-particle update moves.
pub type AdvectedQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static mut Position<D>,
        &'static mut Velocity<D>,
        &'static mut Acceleration<D>,
    ),
    With<Particle>,
>;

/// Node data a grid-to-particle update reads.
pub type NodeMotionQuery<'w, 's, D> =
    Query<'w, 's, (&'static NodeAcceleration<D>, &'static NodeVelocity<D>), With<Node>>;

/// Grid-to-particle update of every particle in parallel: `a_p = Σ N a_I`, then
/// `update(x, v, Σ N a_I, Σ N v_I)` moves the particle (the integrator's own rule).
pub fn advect_particles<D: Dim>(
    connectivity: &Connectivity<D>,
    nodes: &NodeMotionQuery<D>,
    particles: &mut AdvectedQuery<D>,
    update: impl Fn(&mut D::Vector, &mut D::Vector, D::Vector, D::Vector) + Sync,
) {
    advect_rows(connectivity, nodes, particles, |_, x, v, motion| {
        update(x, v, motion.acceleration, motion.velocity)
    });
}

/// The loop of [`advect_particles`], with the particle row handed to `update`.
fn advect_rows<D: Dim>(
    connectivity: &Connectivity<D>,
    nodes: &NodeMotionQuery<D>,
    particles: &mut AdvectedQuery<D>,
    update: impl Fn(usize, &mut D::Vector, &mut D::Vector, GridMotion<D::Vector>) + Sync,
) {
    let (node_acceleration, node_velocity) =
        single_table(nodes.contiguous_iter(), "nodes").unwrap_or((&[], &[]));
    let Some((position, velocity, acceleration)) =
        single_table_mut(particles.contiguous_iter_mut(), "particles")
    else {
        return;
    };
    position
        .par_iter_mut()
        .zip(velocity.par_iter_mut())
        .zip(acceleration.par_iter_mut())
        .enumerate()
        .for_each(|(p, ((x, v), a))| {
            let (a_grid, v_grid) = interpolate(connectivity, node_acceleration, node_velocity, p);
            let motion = GridMotion {
                acceleration: a_grid,
                previous_acceleration: a.0,
                velocity: v_grid,
                kick: D::Vector::ZERO,
            };
            a.0 = a_grid;
            update(p, &mut x.0, &mut v.0, motion);
        });
}

/// What the grid gives one particle in a grid-to-particle update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridMotion<V> {
    /// `Σ N a_I`, the particle's new acceleration.
    pub acceleration: V,
    /// The particle's acceleration from the previous step (before this update replaces it).
    pub previous_acceleration: V,
    /// `Σ N v_I`.
    pub velocity: V,
    /// `Σ N Δp_I/m_I`, the contact kick (zero without one).
    pub kick: V,
}

/// [`advect_particles`] with a per-node-field velocity kick (a contact impulse over the mass,
/// `Δp/m`) interpolated alongside, and the particle's previous acceleration:
/// `update(x, v, motion)`. An empty `kicks` slice means no kicks.
pub fn advect_particles_with_kicks<D: Dim>(
    connectivity: &Connectivity<D>,
    nodes: &NodeMotionQuery<D>,
    kicks: &[[D::Vector; MAX_FIELDS]],
    particles: &mut AdvectedQuery<D>,
    update: impl Fn(&mut D::Vector, &mut D::Vector, GridMotion<D::Vector>) + Sync,
) {
    let kick_of = |p: usize| {
        let (row, c) = (connectivity.row(p), connectivity);
        let entries = c.nodes[row.clone()].iter().zip(&c.fields[row.clone()]);
        (entries.zip(&c.weights[row])).fold(D::Vector::ZERO, |sum, ((&node, &k), &n)| {
            sum + kicks[node as usize][k as usize] * n
        })
    };
    advect_rows(connectivity, nodes, particles, |p, x, v, mut motion| {
        if !kicks.is_empty() {
            motion.kick = kick_of(p);
        }
        update(x, v, motion);
    });
}

/// Per-node, per-field sums of the particle-to-grid transfer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeSums<D: Dim> {
    /// Σ N m of each field.
    pub mass: [f64; MAX_FIELDS],
    /// Σ N m v of each field.
    pub momentum: [D::Vector; MAX_FIELDS],
    /// Σ N (m b + f_ext) − Σ (1 − D) V σ·∇N of each field.
    pub force: [D::Vector; MAX_FIELDS],
}

impl<D: Dim> Default for NodeSums<D> {
    fn default() -> Self {
        Self {
            mass: [0.0; MAX_FIELDS],
            momentum: [D::Vector::ZERO; MAX_FIELDS],
            force: [D::Vector::ZERO; MAX_FIELDS],
        }
    }
}

/// Particle state read by the transfer, as slices in particle-row order.
pub struct ParticleSlices<'a, D: Dim> {
    /// Masses.
    pub mass: &'a [Mass],
    /// Velocities.
    pub velocity: &'a [Velocity<D>],
    /// Volumes.
    pub volume: &'a [Volume],
    /// Stresses.
    pub stress: &'a [Stress<D>],
    /// Damage.
    pub damage: &'a [Damage],
    /// Forces of scene loads.
    pub external: &'a [ExternalForce<D>],
    /// Viscous pressures of a shock viscosity (`stress/shock_viscosity`), when the pipeline has
    /// one: the internal force then uses `σ − q I`.
    pub viscous: Option<&'a [ViscousPressure]>,
    /// Whether the internal force is scaled by `1 − D` (false where the damage system has
    /// degraded the stress itself, [`DamageInStress`]).
    pub damage_scales_force: bool,
}

impl<'a, D: Dim> ParticleSlices<'a, D> {
    /// The columns of the particle table a force transfer reads, or `None` without particles.
    pub fn of(sources: &'a ForceSources<'_, '_, D>) -> Option<Self> {
        let (mass, velocity, volume, stress, damage, external) =
            single_table(sources.query.contiguous_iter(), "particles")?;
        let viscous = single_table(sources.viscous.contiguous_iter(), "particles");
        Some(Self {
            mass,
            velocity,
            volume,
            stress,
            damage,
            external,
            viscous,
            damage_scales_force: sources.damage_in_stress.is_none(),
        })
    }
}

/// Adds entry `e` of particle `p` to its field of the node's sums (eqs. 1–4).
pub fn add_contribution<D: Dim>(
    sums: &mut NodeSums<D>,
    c: &Connectivity<D>,
    particles: &ParticleSlices<D>,
    body_force: D::Vector,
    e: usize,
    p: usize,
) {
    let (k, nm) = (c.field(e), c.weights[e] * particles.mass[p].0);
    sums.mass[k] += nm;
    sums.momentum[k] += particles.velocity[p].0 * nm;
    sums.force[k] += force_contribution(c, particles, body_force, e, p);
}

/// Velocity `momentum / mass` of field `k` of a node, zero for an empty field.
pub fn field_velocity<D: Dim>(sums: &NodeSums<D>, k: usize, min_mass: f64) -> D::Vector {
    if sums.mass[k] > min_mass && sums.mass[k] > 0.0 {
        sums.momentum[k] / sums.mass[k]
    } else {
        D::Vector::ZERO
    }
}

/// Internal, body and load force of connectivity entry `e` of particle `p` on its node: with a
/// shock viscosity the internal force uses `σ − q I`.
#[inline(always)]
pub fn force_contribution<D: Dim>(
    c: &Connectivity<D>,
    particles: &ParticleSlices<D>,
    body_force: D::Vector,
    e: usize,
    p: usize,
) -> D::Vector {
    let n = c.weights[e];
    let gradient = c.gradient(e, p);
    let traction = match particles.viscous {
        Some(q) => particles.stress[p].0.dot(gradient) - gradient * q[p].0,
        None => particles.stress[p].0.dot(gradient),
    };
    body_force * (n * particles.mass[p].0) + particles.external[p].0 * n
        - traction * internal_scale(particles, p)
}

/// The factor particle `p`'s internal force is scaled by: `(1 − D) V`, or `V` where the damage
/// sits in the stress ([`DamageInStress`]).
#[inline(always)]
fn internal_scale<D: Dim>(particles: &ParticleSlices<D>, p: usize) -> f64 {
    let intact = if particles.damage_scales_force {
        1.0 - particles.damage[p].0
    } else {
        1.0
    };
    intact * particles.volume[p].0
}

/// Particle `p`'s stress as the internal force reads it, `σ − q I` with a shock viscosity,
/// and the factor it is scaled by ([`internal_scale`]).
#[inline]
fn internal_stress<D: Dim>(particles: &ParticleSlices<D>, p: usize) -> (D::Matrix, f64) {
    let stress = particles.stress[p].0.to_matrix();
    let stress = match particles.viscous {
        Some(q) => stress - D::Matrix::IDENTITY * q[p].0,
        None => stress,
    };
    (stress, internal_scale(particles, p))
}

/// Per-field force sums `Σ N (m b + f_ext) − Σ (1 − D) V σ·∇N` (without `1 − D` under
/// [`DamageInStress`]) of every node, into `forces`
/// (resized to `node_count`; every slot is overwritten). Where the rows keep maps instead of
/// gradients (LME), each particle's map is applied once, its record kept in `records`
/// (`row_map_transfer.rs`).
pub fn field_forces<D: Dim>(
    c: &Connectivity<D>,
    particles: &ParticleSlices<D>,
    body_force: D::Vector,
    node_count: usize,
    (forces, records): (
        &mut Vec<[D::Vector; MAX_FIELDS]>,
        &mut Vec<ParticleForce<D>>,
    ),
) {
    forces.resize(node_count, [D::Vector::ZERO; MAX_FIELDS]);
    if c.gradients.is_empty() && !c.row_maps.is_empty() {
        let record = |p: usize, map| {
            let (stress, scale) = internal_stress(particles, p);
            let body = body_force * particles.mass[p].0 + particles.external[p].0;
            ParticleForce::new(body, stress, scale, map)
        };
        mapped_field_forces(c, record, records, forces);
        return;
    }
    c.accumulate_to_nodes(forces, |f: &mut [D::Vector; MAX_FIELDS], e, p| {
        f[c.field(e)] += force_contribution(c, particles, body_force, e, p);
    });
}

/// `(Σ N a_I, Σ N v_I)` over particle row `p`, each node's value taken from the particle's field.
pub fn interpolate<D: Dim>(
    c: &Connectivity<D>,
    acceleration: &[NodeAcceleration<D>],
    velocity: &[NodeVelocity<D>],
    p: usize,
) -> (D::Vector, D::Vector) {
    let row = c.row(p);
    // The row's columns as slices, so that the loop indexes no column by entry number.
    let entries = c.nodes[row.clone()].iter().zip(&c.fields[row.clone()]);
    entries.zip(&c.weights[row]).fold(
        (D::Vector::ZERO, D::Vector::ZERO),
        |(a, v), ((&node, &k), &n)| {
            let (node, k) = (node as usize, k as usize);
            (a + acceleration[node].0[k] * n, v + velocity[node].0[k] * n)
        },
    )
}

/// Velocity gradient `L_p = Σ v_I ⊗ ∇N_Ip` of particle row `p` (eq. 7), from the particle's
/// field at each node.
pub fn velocity_gradient<D: Dim>(
    c: &Connectivity<D>,
    node_velocity: &[NodeVelocity<D>],
    p: usize,
) -> D::Matrix {
    let row = c.row(p);
    let nodes = &c.nodes[row.clone()];
    let fields = &c.fields[row.clone()];
    let add = |l: D::Matrix, (node, field): (u32, u8), gradient: D::Vector| {
        l + D::Matrix::outer(node_velocity[node as usize].0[field as usize], gradient)
    };
    let entries = nodes.iter().copied().zip(fields.iter().copied());
    // One loop for each source of the gradients (`Connectivity::row_gradients`' two), chosen
    // once per row: the entries in the same order and the same sums either way.
    match c
        .gradients
        .get(row.clone())
        .filter(|stored| !stored.is_empty())
    {
        Some(stored) => entries
            .zip(stored)
            .fold(D::Matrix::ZERO, |l, (entry, &gradient)| {
                add(l, entry, gradient)
            }),
        None if nodes.is_empty() => D::Matrix::ZERO,
        // The row's map applied once to the row's sum (`row_map_transfer.rs`).
        None => mapped_velocity_gradient(
            c.row_maps[p],
            (nodes, fields, &c.weights[row]),
            &c.node_positions,
            node_velocity,
        ),
    }
}

/// Marks a pipeline whose transfer leaves each particle's velocity gradient in its
/// [`AffineVelocity`] (`predictor/mls`: `L_p = C_p`) and builds no connectivity.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GradientInAffineVelocity;

/// Where the stress stage reads each particle's velocity gradient: `Σ v_I ⊗ ∇N_Ip` from the
/// connectivity and the nodal velocities (eq. 7), or, under [`GradientInAffineVelocity`], the
/// particle's affine velocity. A stress system that reads its gradient here provides
/// [`fractum_engine::capability::ReadsTransferGradient`].
#[derive(SystemParam)]
pub struct VelocityGradients<'w, 's, D: Dim> {
    connectivity: Res<'w, Connectivity<D>>,
    nodes: Query<'w, 's, &'static NodeVelocity<D>, With<Node>>,
    in_affine: Option<Res<'w, GradientInAffineVelocity>>,
    affine: Query<'w, 's, &'static AffineVelocity<D>, With<Particle>>,
}

impl<'w, 's, D: Dim> VelocityGradients<'w, 's, D> {
    /// The reader for this step.
    pub fn reader(&self) -> GradientReader<'_, D> {
        if self.in_affine.is_some() {
            let affine = single_table(self.affine.contiguous_iter(), "particles").unwrap_or(&[]);
            return GradientReader::Affine(affine);
        }
        let nodes = single_table(self.nodes.contiguous_iter(), "nodes").unwrap_or(&[]);
        GradientReader::Grid(&self.connectivity, nodes)
    }
}

/// Each particle's velocity gradient, by particle row ([`VelocityGradients::reader`]).
pub enum GradientReader<'a, D: Dim> {
    /// `L_p = Σ v_I ⊗ ∇N_Ip` (eq. 7).
    Grid(&'a Connectivity<D>, &'a [NodeVelocity<D>]),
    /// `L_p = C_p`.
    Affine(&'a [AffineVelocity<D>]),
}

impl<D: Dim> GradientReader<'_, D> {
    /// `L_p` of particle row `p`.
    #[inline]
    pub fn at(&self, p: usize) -> D::Matrix {
        match self {
            GradientReader::Grid(c, nodes) => velocity_gradient(c, nodes, p),
            GradientReader::Affine(affine) => affine[p].0,
        }
    }
}

/// `$body` compiled once for each source of a [`GradientReader`], with `$at` bound to that
/// source's lookup by particle row (`|p| L_p`): the source is matched once per system run, not
/// once per particle. With the match inside the loop, the AVX2 copy of `stress/linear_elastic`
/// moved each `C_p` through the stack (one 32-byte store, then loads straddling its halves, which
/// the CPU cannot forward from the store), and a fifth of that kernel's samples waited there.
macro_rules! with_gradient_source {
    ($reader:expr, |$at:ident| $body:expr) => {
        match $reader {
            $crate::transfer::GradientReader::Grid(connectivity, nodes) => {
                let $at = |p: usize| $crate::transfer::velocity_gradient(connectivity, nodes, p);
                $body
            }
            $crate::transfer::GradientReader::Affine(affine) => {
                let $at = |p: usize| affine[p].0;
                $body
            }
        }
    };
}
pub(crate) use with_gradient_source;

#[cfg(test)]
mod tests {
    use super::*;
    use fractum_engine::connectivity::RowMap;
    use glam::{DMat2, DVec2};

    /// Two particle rows over four nodes, the second row's entries in two fields.
    fn two_rows() -> Connectivity<Two> {
        Connectivity {
            row_offsets: vec![0, 3, 6],
            nodes: vec![0, 1, 3, 1, 2, 3],
            weights: vec![0.5, 0.3, 0.2, 0.25, 0.25, 0.5],
            fields: vec![0, 0, 0, 1, 0, 1],
            node_positions: (0..4)
                .map(|i| DVec2::new(i as f64, 0.5 * i as f64))
                .collect(),
            ..Default::default()
        }
    }

    /// A map for each of [`two_rows`]' rows (`A` symmetric, as LME's `J⁻¹` is).
    fn two_maps() -> Vec<RowMap<Two>> {
        let map = |a: [f64; 4], point: DVec2| RowMap {
            matrix: DMat2::from_cols_array(&a),
            point,
        };
        vec![
            map([2.0, 0.5, 0.5, 3.0], DVec2::new(0.4, 0.3)),
            map([1.5, -0.2, -0.2, 1.0], DVec2::new(1.6, 0.9)),
        ]
    }

    fn nodes() -> (Vec<NodeVelocity<Two>>, Vec<NodeAcceleration<Two>>) {
        let v = |i: usize, k: usize| DVec2::new(1.0 + i as f64 + 0.1 * k as f64, -2.0 * i as f64);
        let velocity = (0..4)
            .map(|i| NodeVelocity(std::array::from_fn(|k| v(i, k))))
            .collect();
        let acceleration = (0..4)
            .map(|i| NodeAcceleration(std::array::from_fn(|k| v(i, 3 - k))))
            .collect();
        (velocity, acceleration)
    }

    /// `Σ v_I ⊗ ∇N_I` and `Σ N v_I` in entry order, as the connectivity's own readers give them.
    fn by_entries(c: &Connectivity<Two>, velocity: &[NodeVelocity<Two>], p: usize) -> DMat2 {
        c.row_gradients(p).fold(DMat2::ZERO, |l, (e, gradient)| {
            l + DMat2::outer(velocity[c.nodes[e] as usize].0[c.field(e)], gradient)
        })
    }

    /// The velocity gradient and the interpolation read each entry's own field, with the
    /// gradients stored or from the row's map, and sum the entries in row order.
    #[test]
    fn the_transfers_sum_each_entrys_field_in_row_order() {
        let (velocity, acceleration) = nodes();
        let mut stored = two_rows();
        stored.gradients = (0..6)
            .map(|e| DVec2::new(0.1 * e as f64, 1.0 - e as f64))
            .collect();
        let mut mapped = two_rows();
        mapped.row_maps = two_maps();
        for c in [&stored, &mapped] {
            for p in 0..2 {
                let (l, expected) = (
                    velocity_gradient(c, &velocity, p),
                    by_entries(c, &velocity, p),
                );
                if c.row_maps.is_empty() {
                    assert_eq!(l, expected);
                } else {
                    // The map applied to the row's sum (`row_map_transfer.rs`): round-off apart.
                    let scale = expected.max_abs();
                    assert!((l - expected).max_abs() <= 1e-14 * scale);
                }
                let (a, v) = interpolate(c, &acceleration, &velocity, p);
                let (mut a_sum, mut v_sum) = (DVec2::ZERO, DVec2::ZERO);
                for e in c.row(p) {
                    let (node, k) = (c.nodes[e] as usize, c.field(e));
                    a_sum += acceleration[node].0[k] * c.weights[e];
                    v_sum += velocity[node].0[k] * c.weights[e];
                }
                assert_eq!((a, v), (a_sum, v_sum));
            }
        }
        // Row 1 reads field 1 at nodes 1 and 3: the gradient differs from field 0's.
        let mut one_field = stored.clone();
        one_field.fields = vec![0; 6];
        assert_ne!(
            velocity_gradient(&stored, &velocity, 1),
            velocity_gradient(&one_field, &velocity, 1)
        );
    }

    /// Where the rows keep maps, `field_forces` (each map applied once per particle,
    /// `row_map_transfer.rs`) equals the entry-by-entry `force_contribution` to round-off,
    /// with the damage scaling the force or not and with a shock viscosity's pressure.
    #[test]
    fn mapped_rows_give_the_entry_by_entry_forces() {
        let mut c = two_rows();
        c.row_maps = two_maps();
        c.rebuild_transpose(4);
        let sigma = |xx: f64, yy: f64, xy: f64| {
            let zz = 0.3 * (xx + yy);
            Stress::<Two>(SymTensor2 { xx, yy, zz, xy })
        };
        let stress = [sigma(3.0e6, -1.0e6, 0.5e6), sigma(-2.0e6, 4.0e6, -0.7e6)];
        let (mass, volume) = ([Mass(2.0), Mass(3.0)], [Volume(0.2), Volume(0.25)]);
        let external = [
            ExternalForce(DVec2::new(5.0, 0.0)),
            ExternalForce(DVec2::ZERO),
        ];
        let velocity = [Velocity(DVec2::ZERO); 2];
        let (damage, q) = (
            [Damage(0.0), Damage(0.4)],
            [ViscousPressure(1.0e4), ViscousPressure(-2.0e5)],
        );
        let gravity = DVec2::new(0.0, -9.81);
        for (damage_scales_force, viscous) in [(true, None), (false, None), (true, Some(&q[..]))] {
            let particles = ParticleSlices {
                mass: &mass,
                velocity: &velocity,
                volume: &volume,
                stress: &stress,
                damage: &damage,
                external: &external,
                viscous,
                damage_scales_force,
            };
            let mut forces = Vec::new();
            field_forces(&c, &particles, gravity, 5, (&mut forces, &mut Vec::new()));
            let mut expected = vec![[DVec2::ZERO; MAX_FIELDS]; 5];
            for p in 0..2 {
                for e in c.row(p) {
                    expected[c.nodes[e] as usize][c.field(e)] +=
                        force_contribution(&c, &particles, gravity, e, p);
                }
            }
            let largest = expected
                .iter()
                .flatten()
                .map(|f| f.length())
                .fold(0.0, f64::max);
            assert!(largest > 1.0e5, "the stress is in play");
            for (got, want) in forces.iter().flatten().zip(expected.iter().flatten()) {
                assert!(
                    (*got - *want).length() <= 1e-14 * largest,
                    "{got:?} against {want:?}"
                );
            }
        }
    }
}
