//! Particle–grid transfer kernels shared by the integrators (not a system).
//!
//! - Particle to grid: lumped mass `m_I = Σ N_Ip m_p`, momentum `Σ N_Ip m_p v_p`, and force
//!   `f_I = Σ N_Ip m_p b − Σ (1 − D_p) V_p σ_p · ∇N_Ip` (dfg-partitioning-mpm.md eqs. 1–4;
//!   eigensoftening-lme-mpm.md Appendix A steps 1, 2 and 7, with the damage scaling of eq. 16).
//! - Grid to particle: `Σ N_Ip a_I` and `Σ N_Ip v_I` (eqs. 9–10; Appendix A step 9).
//!
//! All read field 0 of the nodes. Generic over the dimension `D`.

use fractum_engine::prelude::*;
use rayon::prelude::*;
use std::ops::AddAssign;

/// Particle data the force transfer reads: mass, velocity, volume, stress, damage.
pub type ForceSourceQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static Mass,
        &'static Velocity<D>,
        &'static Volume,
        &'static Stress<D>,
        &'static Damage,
    ),
    With<Particle>,
>;

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
    let (node_acceleration, node_velocity) =
        single_table(nodes.contiguous_iter(), "nodes").unwrap_or((&[], &[]));
    let Some((mut position, mut velocity, mut acceleration)) =
        single_table(particles.contiguous_iter_mut(), "particles")
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
            a.0 = a_grid;
            update(&mut x.0, &mut v.0, a_grid, v_grid);
        });
}

/// Per-node sums of the particle-to-grid transfer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeSums<D: Dim> {
    /// Σ N m.
    pub mass: f64,
    /// Σ N m v.
    pub momentum: D::Vector,
    /// Σ N m b − Σ (1 − D) V σ·∇N.
    pub force: D::Vector,
}

impl<D: Dim> Default for NodeSums<D> {
    fn default() -> Self {
        Self {
            mass: 0.0,
            momentum: D::Vector::ZERO,
            force: D::Vector::ZERO,
        }
    }
}

impl<D: Dim> AddAssign for NodeSums<D> {
    fn add_assign(&mut self, rhs: Self) {
        self.mass += rhs.mass;
        self.momentum += rhs.momentum;
        self.force += rhs.force;
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
}

impl<'a, D: Dim> ParticleSlices<'a, D> {
    /// The columns of the particle table a force transfer reads, or `None` without particles.
    pub fn of(query: &'a ForceSourceQuery<'_, '_, D>) -> Option<Self> {
        let (mass, velocity, volume, stress, damage) =
            single_table(query.contiguous_iter(), "particles")?;
        Some(Self {
            mass,
            velocity,
            volume,
            stress,
            damage,
        })
    }
}

/// Contribution of connectivity entry `e` of particle `p` to its node (eqs. 1–4).
pub fn contribution<D: Dim>(
    c: &Connectivity<D>,
    particles: &ParticleSlices<D>,
    body_force: D::Vector,
    e: usize,
    p: usize,
) -> NodeSums<D> {
    let n = c.weights[e];
    let m = particles.mass[p].0;
    NodeSums {
        mass: n * m,
        momentum: particles.velocity[p].0 * (n * m),
        force: force_contribution(c, particles, body_force, e, p),
    }
}

/// Velocity `momentum / mass` of a node, zero for an empty node.
pub fn node_velocity<D: Dim>(sums: &NodeSums<D>, min_mass: f64) -> D::Vector {
    if sums.mass > min_mass && sums.mass > 0.0 {
        sums.momentum / sums.mass
    } else {
        D::Vector::ZERO
    }
}

/// Internal plus body force of connectivity entry `e` of particle `p` on its node.
pub fn force_contribution<D: Dim>(
    c: &Connectivity<D>,
    particles: &ParticleSlices<D>,
    body_force: D::Vector,
    e: usize,
    p: usize,
) -> D::Vector {
    let intact = 1.0 - particles.damage[p].0;
    body_force * (c.weights[e] * particles.mass[p].0)
        - particles.stress[p].0.dot(c.gradients[e]) * (intact * particles.volume[p].0)
}

/// `(Σ N a_I, Σ N v_I)` over particle row `p`, from field 0.
pub fn interpolate<D: Dim>(
    c: &Connectivity<D>,
    acceleration: &[NodeAcceleration<D>],
    velocity: &[NodeVelocity<D>],
    p: usize,
) -> (D::Vector, D::Vector) {
    c.row(p)
        .fold((D::Vector::ZERO, D::Vector::ZERO), |(a, v), e| {
            let (node, n) = (c.nodes[e] as usize, c.weights[e]);
            (a + acceleration[node].0[0] * n, v + velocity[node].0[0] * n)
        })
}
