//! The affine particle-in-cell transfer (APIC, Jiang et al. 2015), the transfer an
//! advection's `transfer: Apic` selects (not a system): the grid-to-particle update that gives
//! each particle its affine velocity `C_p = B_p D_p⁻¹` ([`affine_interpolation`],
//! [`advect_particles_affine`]) and the particle-to-grid share `N m C_p (x_I − x_p)` that the
//! predictors add to the nodal momentum ([`add_affine_momentum`]). Each entry reads its node's
//! position from the nodes' `NodePosition` column ([`NodePositionQuery`]). A part of
//! [`crate::transfer`], which re-exports it, and where the advections and predictors take it
//! from.

use super::{NodeMotionQuery, NodeSums};
use bevy_ecs::system::SystemParam;
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// What the grid gives one particle under the affine transfer (APIC): the interpolated
/// acceleration and velocity, and the affine velocity of the field the next predictor carries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AffineMotion<V, M> {
    /// `Σ N a_I`.
    pub acceleration: V,
    /// `Σ N v_I`.
    pub velocity: V,
    /// `C_p = B_p D_p⁻¹` of the carried field `w_I = v_I + carry a_I`.
    pub affine: M,
}

/// The affine grid-to-particle transfer of particle row `p` at `x_p` (Jiang et al. 2015's APIC,
/// with the inertia-like tensor of any basis):
/// `B_p = Σ N w_I ⊗ (x_I − x_p)`, `D_p = Σ N (x_I − x_p) ⊗ (x_I − x_p)`, `C_p = B_p D_p⁻¹`,
/// with `w_I = v_I + carry a_I` the field the next particle-to-grid transfer rebuilds
/// (`carry = (1 − γ) Δt` under Newmark's predictor). `D_p` is `h²/4 I` for quadratic B-splines;
/// for the tents it vanishes along an axis where the particle sits on a node line, and so does
/// `B_p` there, so the inverse is regularised by `10⁻¹² tr D_p` and such a column of `C_p` is
/// zero. `node_positions` is the nodes' column of [`NodePosition`] (`Grid::node_position` of
/// each, kept so that no entry converts a node index into lattice coordinates).
pub fn affine_interpolation<D: Dim>(
    c: &Connectivity<D>,
    node_positions: &[NodePosition<D>],
    (acceleration, velocity): (&[NodeAcceleration<D>], &[NodeVelocity<D>]),
    (p, x_p): (usize, D::Vector),
    carry: f64,
) -> AffineMotion<D::Vector, D::Matrix> {
    let mut motion = AffineMotion {
        acceleration: D::Vector::ZERO,
        velocity: D::Vector::ZERO,
        affine: D::Matrix::ZERO,
    };
    let mut inertia = D::Matrix::ZERO;
    for e in c.row(p) {
        let (node, k, n) = (c.nodes[e] as usize, c.field(e), c.weights[e]);
        let (a, v) = (acceleration[node].0[k], velocity[node].0[k]);
        let offset = node_positions[node].0 - x_p;
        motion.acceleration += a * n;
        motion.velocity += v * n;
        motion.affine += D::Matrix::outer((v + a * carry) * n, offset);
        inertia += D::Matrix::outer(offset * n, offset);
    }
    let regularised = inertia + D::Matrix::IDENTITY * (1e-12 * inertia.trace());
    if regularised.determinant() > 0.0 {
        motion.affine = motion.affine * regularised.inverse();
    } else {
        motion.affine = D::Matrix::ZERO;
    }
    motion
}

/// The particles' affine velocities and positions, on particles only where the advection uses
/// `transfer: Apic` (read by the predictors).
pub type AffineSources<'w, 's, D> =
    Query<'w, 's, (&'static Position<D>, &'static AffineVelocity<D>), With<Particle>>;

/// Particle state the affine grid-to-particle transfer moves.
pub type AffineAdvectedQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static mut Position<D>,
        &'static mut Velocity<D>,
        &'static mut Acceleration<D>,
        &'static mut AffineVelocity<D>,
    ),
    With<Particle>,
>;

/// The nodes' positions, which the affine transfer reads at every entry.
pub type NodePositionQuery<'w, 's, D> = Query<'w, 's, &'static NodePosition<D>, With<Node>>;

/// The affine grid-to-particle update of every particle in parallel ([`affine_interpolation`]
/// with `carry`): `v_p = Σ N v_I`, `a_p = Σ N a_I`, `C_p`, and `x_p += Δt (v_p − lag a_p)`, the
/// position moved by the velocity the step's stress saw (`lag = γ Δt` under Newmark's
/// predictor, 0 for update-stress-last).
pub fn advect_particles_affine<D: Dim>(
    (connectivity, node_positions): (&Connectivity<D>, &NodePositionQuery<D>),
    nodes: &NodeMotionQuery<D>,
    particles: &mut AffineAdvectedQuery<D>,
    (dt, carry, lag): (f64, f64, f64),
) {
    let node_columns = single_table(nodes.contiguous_iter(), "nodes").unwrap_or((&[], &[]));
    let node_positions = single_table(node_positions.contiguous_iter(), "nodes").unwrap_or(&[]);
    let Some((position, velocity, acceleration, affine)) =
        single_table_mut(particles.contiguous_iter_mut(), "particles")
    else {
        return;
    };
    position
        .par_iter_mut()
        .zip(velocity.par_iter_mut())
        .zip(acceleration.par_iter_mut())
        .zip(affine.par_iter_mut())
        .enumerate()
        .for_each(|(p, (((x, v), a), c))| {
            let motion =
                affine_interpolation(connectivity, node_positions, node_columns, (p, x.0), carry);
            x.0 += (motion.velocity - motion.acceleration * lag) * dt;
            v.0 = motion.velocity;
            a.0 = motion.acceleration;
            c.0 = motion.affine;
        });
}

/// What a predictor reads for the affine transfer: the node positions and the particles'
/// positions and affine velocities, where they carry them.
#[derive(SystemParam)]
pub struct AffineInputs<'w, 's, D: Dim> {
    nodes: NodePositionQuery<'w, 's, D>,
    particles: AffineSources<'w, 's, D>,
}

/// The affine transfer's columns for a particle-to-grid pass: node positions, particle
/// positions and affine velocities, or `None` where the particles carry none (a FLIP run).
pub type AffineColumns<'a, D> = (
    &'a [NodePosition<D>],
    &'a [Position<D>],
    &'a [AffineVelocity<D>],
);

impl<'w, 's, D: Dim> AffineInputs<'w, 's, D> {
    /// The columns, or `None` without the affine transfer.
    pub fn columns(&self) -> Option<AffineColumns<'_, D>> {
        let (position, affine) = single_table(self.particles.contiguous_iter(), "particles")?;
        let nodes = single_table(self.nodes.contiguous_iter(), "nodes").unwrap_or(&[]);
        Some((nodes, position, affine))
    }
}

/// The affine transfer's share of entry `e` of particle `p`: `N m C_p (x_I − x_p)` to the
/// momentum of its field (an advection's `transfer: Apic`).
#[inline(always)]
pub fn add_affine_momentum<D: Dim>(
    sums: &mut NodeSums<D>,
    c: &Connectivity<D>,
    mass: &[Mass],
    (nodes, position, affine): AffineColumns<D>,
    e: usize,
    p: usize,
) {
    let node = c.nodes[e] as usize;
    let offset = nodes[node].0 - position[p].0;
    sums.momentum[c.field(e)] += affine[p].0 * offset * (c.weights[e] * mass[p].0);
}
