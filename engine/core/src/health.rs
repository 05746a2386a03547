//! Run health: after every stage, the engine checks particle and node state and stops the run
//! at the first non-finite value or the first particle outside the grid, naming the step, the
//! stage and the particle or node.
//!
//! A check looks only at the columns that something since the previous check can have written:
//! [`plan_checks`] reads every system's access from the initialised schedule (bevy records which
//! components each system may write) and gives each stage's check the union over the systems
//! that run between it and the check before. A column no system in that window may write is
//! as it was when last checked. The first check of a run checks everything (the state built
//! before the first step).

use crate::components::{
    Node, NodeForce, NodeIndex, NodeMass, NodeVelocity, Particle, ParticleId, Position, Stress,
    Velocity, Volume,
};
use crate::decomposition::Ownership;
use crate::dim::{Dim, SymOps, VectorOps};
use crate::resources::{Grid, SimClock};
use crate::stage::Stage;
use crate::storage::single_table;
use bevy_ecs::prelude::*;
use rayon::prelude::*;
use std::fmt;

/// Why a run stopped early.
#[derive(Clone, Debug, PartialEq)]
pub struct Blowup {
    /// Step being taken (completed steps + 1).
    pub step: u64,
    /// Stage after which the problem was found.
    pub stage: Stage,
    /// What was found, naming the particle or node.
    pub message: String,
    /// What kind of failure it is, for the usual cures a front end can name.
    pub cause: Cause,
}

/// The kind of a run's failure, where the check can tell.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Cause {
    /// A particle's volume is no longer positive or its stress no longer finite: the material
    /// inverted (`J ≤ 0`) under a deformation too large for one step.
    Inverted,
    /// A particle's velocity or position is no longer finite: a runaway, typically a stressed
    /// particle crossing into an empty cell with the linear tents, or a step too large.
    Runaway,
    /// A particle left the grid.
    LeftGrid,
    /// Anything else (a node's state, a shape function, a series value, the clock).
    #[default]
    Other,
}

impl Blowup {
    /// A failure at `step` after `stage`, of no particular [`Cause`].
    pub fn new(step: u64, stage: Stage, message: impl Into<String>) -> Self {
        Self {
            step,
            stage,
            message: message.into(),
            cause: Cause::Other,
        }
    }

    /// The same failure with its cause.
    pub fn because(self, cause: Cause) -> Self {
        Self { cause, ..self }
    }
}

impl fmt::Display for Blowup {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "step {}, stage {}: {}",
            self.step, self.stage, self.message
        )
    }
}

impl std::error::Error for Blowup {}

/// Health of the run; the first failure is kept and all later stages are skipped.
#[derive(Resource, Clone, Debug, Default)]
pub struct Health {
    /// The first failure, if any.
    pub failure: Option<Blowup>,
    /// Whether a check has looked at every column (the first check of a run does).
    pub checked_everything: bool,
}

impl Health {
    /// Reports a failure: the one path by which a system or check stops the run. The first
    /// failure of a step is kept; the stages after it are skipped.
    pub fn fail(&mut self, failure: Blowup) {
        self.failure.get_or_insert(failure);
    }
}

/// The columns a health check looks at, as a bit set.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Columns(u8);

impl Columns {
    /// Particle positions (finite, and inside the grid unless leaving is allowed).
    pub const POSITION: Columns = Columns(1);
    /// Particle velocities.
    pub const VELOCITY: Columns = Columns(2);
    /// Particle stresses.
    pub const STRESS: Columns = Columns(4);
    /// Particle volumes (finite and positive).
    pub const VOLUME: Columns = Columns(8);
    /// Nodal masses, velocities and forces of every field.
    pub const NODES: Columns = Columns(16);
    /// Nothing.
    pub const NONE: Columns = Columns(0);
    /// Everything.
    pub const ALL: Columns = Columns(31);

    /// Whether every column of `other` is in `self`.
    pub fn contains(self, other: Columns) -> bool {
        self.0 & other.0 == other.0
    }

    /// Whether some particle column is in `self`.
    fn any_particle(self) -> bool {
        self.0 & 15 != 0
    }
}

impl std::ops::BitOr for Columns {
    type Output = Columns;
    fn bitor(self, other: Columns) -> Columns {
        Columns(self.0 | other.0)
    }
}

impl std::ops::BitOrAssign for Columns {
    fn bitor_assign(&mut self, other: Columns) {
        self.0 |= other.0;
    }
}

/// What each stage's check looks at (see the module header). Without this resource every check
/// looks at everything.
#[derive(Resource, Clone, Debug, PartialEq, Eq)]
pub struct CheckPlan {
    /// Per stage, in [`Stage::ORDER`].
    pub columns: [Columns; Stage::ORDER.len()],
}

impl Default for CheckPlan {
    fn default() -> Self {
        Self {
            columns: [Columns::ALL; Stage::ORDER.len()],
        }
    }
}

impl CheckPlan {
    /// The columns the check after `stage` looks at.
    pub fn of(&self, stage: Stage) -> Columns {
        self.columns[stage as usize]
    }
}

/// The check plan of an initialised schedule: walks its systems in execution order, collecting
/// the checked columns each may write (an exclusive system, or one with deferred commands, may
/// write anything), and hands the collection to each stage check it meets. The systems after the last check run before the
/// first check of the next step, so they are added to that one. Returns `None` when the
/// schedule is not initialised.
pub fn plan_checks<D: Dim>(schedule: &Schedule, world: &World) -> Option<CheckPlan> {
    use bevy_ecs::schedule::SystemSet;
    use bevy_ecs::system::{System, SystemAccess};
    use std::collections::HashMap;
    let graph = schedule.graph();
    let mut checks = HashMap::new();
    for stage in Stage::ORDER {
        if let Ok(keys) = graph.systems_in_set(crate::stage::StageCheck(stage).intern()) {
            checks.extend(keys.iter().map(|&key| (key, stage)));
        }
    }
    let ids = [
        (world.component_id::<Position<D>>(), Columns::POSITION),
        (world.component_id::<Velocity<D>>(), Columns::VELOCITY),
        (world.component_id::<Stress<D>>(), Columns::STRESS),
        (world.component_id::<Volume>(), Columns::VOLUME),
        (world.component_id::<NodeMass>(), Columns::NODES),
        (world.component_id::<NodeVelocity<D>>(), Columns::NODES),
        (world.component_id::<NodeForce<D>>(), Columns::NODES),
    ];
    let writes = |access: &SystemAccess| match access {
        SystemAccess::None => Columns::NONE,
        SystemAccess::Exclusive => Columns::ALL,
        SystemAccess::Shared(set) => {
            let combined = set.combined_access();
            ids.iter()
                .filter(|(id, _)| id.is_none_or(|id| combined.has_write(id)))
                .fold(Columns::NONE, |all, (_, columns)| all | *columns)
        }
    };
    let mut plan = CheckPlan {
        columns: [Columns::NONE; Stage::ORDER.len()],
    };
    let (mut pending, mut first) = (Columns::NONE, None);
    for (key, system) in schedule.systems_with_access().ok()? {
        // Deferred commands may change any component when they are applied.
        let own = if system.has_deferred() {
            Columns::ALL
        } else {
            writes(system.access())
        };
        match checks.get(&key) {
            // A check's set may hold other engine systems (the removal of escaped particles):
            // whatever they write is credited to the check too.
            Some(&stage) => {
                plan.columns[stage as usize] |= pending | own;
                first.get_or_insert(stage);
                pending = Columns::NONE;
            }
            None => pending |= own,
        }
    }
    if let Some(stage) = first {
        plan.columns[stage as usize] |= pending;
    }
    Some(plan)
}

/// Run condition: no failure so far.
pub fn healthy(health: Res<Health>) -> bool {
    health.failure.is_none()
}

/// What happens to a particle that leaves the grid.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LeaveGrid {
    /// Stop the run, naming the particle and its position (default).
    #[default]
    Stop,
    /// Remove the particle (its mass and momentum leave the system) and go on; the count is
    /// reported at the end of the run.
    Remove,
}

/// `(x, y)` or `(x, y, z)` in scientific notation, for messages.
pub fn fmt_vector<V: VectorOps>(v: V, dimensions: usize) -> String {
    let parts: Vec<String> = v.to_3d()[..dimensions]
        .iter()
        .map(|c| format!("{c:e}"))
        .collect();
    format!("({})", parts.join(", "))
}

fn fmt_vec<D: Dim>(v: D::Vector) -> String {
    fmt_vector(v, D::N)
}

type ParticleCheckQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static ParticleId,
        &'static Position<D>,
        &'static Velocity<D>,
        &'static Stress<D>,
        &'static Volume,
    ),
    With<Particle>,
>;
type NodeCheckQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static NodeIndex,
        &'static NodeMass,
        &'static NodeVelocity<D>,
        &'static NodeForce<D>,
    ),
    With<Node>,
>;

/// Rows per block of the checks' fast pass.
const CHECK_BLOCK: usize = 4096;

/// Whether every particle is healthy in `columns`, without finding which is not: each block is
/// folded with non-short-circuit `&` over plain comparisons (no branches per particle, no
/// `floor`), one column at a time, so the common case costs one pass of arithmetic over the
/// columns asked for; [`first_bad_particle`] looks for the culprit only when a block fails.
/// Inside the grid means `0 ≤ (x − min)/h ≤ cells` on every axis, exactly [`Grid::contains`].
fn all_particles_healthy<D: Dim>(
    (positions, velocities, stresses, volumes): ParticleColumns<D>,
    columns: Columns,
    grid: &Grid<D>,
    outside_allowed: bool,
) -> bool {
    let upper = D::Vector::from_fn(|a| grid.cells[a] as f64);
    let blocks = positions.len().div_ceil(CHECK_BLOCK);
    (0..blocks).into_par_iter().all(|b| {
        let rows = b * CHECK_BLOCK..((b + 1) * CHECK_BLOCK).min(positions.len());
        let mut healthy = true;
        if columns.contains(Columns::POSITION) && grid.is_graded() {
            let (lo, hi) = (grid.min, grid.max());
            for x in &positions[rows.clone()] {
                let mut inside = true;
                for a in 0..D::N {
                    inside &= (x.0[a] >= lo[a]) & (x.0[a] <= hi[a]);
                }
                healthy &= x.0.is_finite() & (outside_allowed | inside);
            }
        } else if columns.contains(Columns::POSITION) {
            for x in &positions[rows.clone()] {
                let local = (x.0 - grid.min) / grid.spacing;
                let mut inside = true;
                for a in 0..D::N {
                    inside &= (local[a] >= 0.0) & (local[a] <= upper[a]);
                }
                healthy &= x.0.is_finite() & (outside_allowed | inside);
            }
        }
        if columns.contains(Columns::VELOCITY) {
            for v in &velocities[rows.clone()] {
                healthy &= v.0.is_finite();
            }
        }
        if columns.contains(Columns::STRESS) {
            for s in &stresses[rows.clone()] {
                healthy &= s.0.is_finite();
            }
        }
        if columns.contains(Columns::VOLUME) {
            for v in &volumes[rows] {
                healthy &= v.0.is_finite() & (v.0 > 0.0);
            }
        }
        healthy
    })
}

/// The particle columns a check reads: positions, velocities, stresses, volumes.
type ParticleColumns<'a, D> = (
    &'a [Position<D>],
    &'a [Velocity<D>],
    &'a [Stress<D>],
    &'a [Volume],
);

/// The first bad particle among those this rank owns (`owned` by row, every particle when
/// `None`: a distributed run's ghosts near the halo's outer face compute what no rank uses).
fn first_bad_particle<D: Dim>(
    particles: &ParticleCheckQuery<D>,
    columns: Columns,
    grid: &Grid<D>,
    outside_allowed: bool,
    owned: Option<&[bool]>,
) -> Option<(Cause, String)> {
    if !columns.any_particle() {
        return None;
    }
    let (ids, positions, velocities, stresses, volumes) =
        single_table(particles.contiguous_iter(), "particles")?;
    let checked = (positions, velocities, stresses, volumes);
    // Every row healthy means every owned row healthy: a rank's ghosts take the fast pass too,
    // and only a failed pass looks for an owned culprit (a ghost's bad state alone is no blow-up).
    if all_particles_healthy(checked, columns, grid, outside_allowed) {
        return None;
    }
    let (lo, hi) = (grid.min, grid.max());
    let bad = (0..ids.len()).into_par_iter().find_first(|&p| {
        let x = positions[p].0;
        owned.is_none_or(|o| o.get(p).copied().unwrap_or(false))
            && !(x.is_finite()
                && (outside_allowed || grid.contains(x))
                && velocities[p].0.is_finite()
                && stresses[p].0.is_finite()
                && volumes[p].0.is_finite()
                && volumes[p].0 > 0.0)
    })?;
    let (id, x, v) = (ids[bad].0, positions[bad].0, velocities[bad].0);
    Some(if !x.is_finite() {
        (
            Cause::Runaway,
            format!(
                "particle {id} has a non-finite position {}",
                fmt_vec::<D>(x)
            ),
        )
    } else if !grid.contains(x) {
        (
            Cause::LeftGrid,
            format!(
                "particle {id} left the grid: position {}, velocity {}, grid box {} to {}",
                fmt_vec::<D>(x),
                fmt_vec::<D>(v),
                fmt_vec::<D>(lo),
                fmt_vec::<D>(hi)
            ),
        )
    } else if !v.is_finite() {
        (
            Cause::Runaway,
            format!(
                "particle {id} at {} has a non-finite velocity {}",
                fmt_vec::<D>(x),
                fmt_vec::<D>(v)
            ),
        )
    } else if !stresses[bad].0.is_finite() {
        (
            Cause::Inverted,
            format!(
                "particle {id} at {} has a non-finite stress {:?}",
                fmt_vec::<D>(x),
                stresses[bad].0
            ),
        )
    } else {
        (
            Cause::Inverted,
            format!(
                "particle {id} at {} has an invalid volume {:e}",
                fmt_vec::<D>(x),
                volumes[bad].0
            ),
        )
    })
}

/// Whether every node's state is finite, per block: the block's values summed. An infinity or
/// a NaN makes every sum it enters non-finite (`∞ + x` is ±∞ or NaN, `NaN + x` is NaN), so a
/// finite sum means finite values: one add a value, where `is_finite` on each is a mask, a
/// compare and an `&` (a node holds twenty values in 2D, and an empty node is checked after
/// every stage that writes the nodes). Finite values whose sum overflows fail the pass
/// although none is bad; [`first_bad_node`] then searches and finds none.
fn all_nodes_finite<D: Dim>(
    masses: &[NodeMass],
    velocities: &[NodeVelocity<D>],
    forces: &[NodeForce<D>],
) -> bool {
    let blocks = masses.len().div_ceil(CHECK_BLOCK);
    (0..blocks).into_par_iter().all(|b| {
        let rows = b * CHECK_BLOCK..((b + 1) * CHECK_BLOCK).min(masses.len());
        let (mut mass, mut vectors) = (0.0, D::Vector::ZERO);
        for ((m, v), f) in masses[rows.clone()]
            .iter()
            .zip(&velocities[rows.clone()])
            .zip(&forces[rows])
        {
            for k in 0..crate::components::MAX_FIELDS {
                mass += m.0[k];
                vectors = vectors + v.0[k] + f.0[k];
            }
        }
        mass.is_finite() & vectors.is_finite()
    })
}

/// The first node with non-finite state among those this rank owns (`owned` by node index,
/// every node when `None`).
fn first_bad_node<D: Dim>(
    nodes: &NodeCheckQuery<D>,
    columns: Columns,
    owned: Option<&[bool]>,
) -> Option<String> {
    if !columns.contains(Columns::NODES) {
        return None;
    }
    let (indices, masses, velocities, forces) = single_table(nodes.contiguous_iter(), "nodes")?;
    if all_nodes_finite(masses, velocities, forces) {
        return None;
    }
    let bad = (0..indices.len()).into_par_iter().find_first(|&n| {
        owned.is_none_or(|o| o.get(indices[n].0 as usize).copied().unwrap_or(false))
            && !(masses[n].0.iter().all(|m| m.is_finite())
                && velocities[n].0.iter().all(|v| v.is_finite())
                && forces[n].0.iter().all(|f| f.is_finite()))
    })?;
    Some(format!(
        "node {} has non-finite state: mass {:?}, velocity {:?}, force {:?}",
        indices[bad].0, masses[bad].0, velocities[bad].0, forces[bad].0
    ))
}

/// The check system the engine runs after `stage`.
// The "complex type" is the returned system's parameter list, spelled out as bevy needs it.
#[allow(clippy::type_complexity)]
pub fn stage_check<D: Dim>(
    stage: Stage,
) -> impl FnMut(
    Res<SimClock>,
    Res<Grid<D>>,
    Option<Res<LeaveGrid>>,
    Option<Res<CheckPlan>>,
    Option<Res<Ownership>>,
    ResMut<Health>,
    ParticleCheckQuery<D>,
    NodeCheckQuery<D>,
) {
    move |clock, grid, policy, plan, ownership, mut health, particles, nodes| {
        let outside_allowed = policy.is_some_and(|p| *p == LeaveGrid::Remove);
        let columns = match plan {
            Some(plan) if health.checked_everything => plan.of(stage),
            _ => Columns::ALL,
        };
        health.checked_everything = true;
        let owned_particles = ownership.as_ref().map(|o| o.particles.as_slice());
        let owned_nodes = ownership.as_ref().map(|o| o.nodes.as_slice());
        let found =
            first_bad_particle(&particles, columns, &grid, outside_allowed, owned_particles)
                .or_else(|| {
                    first_bad_node(&nodes, columns, owned_nodes).map(|m| (Cause::Other, m))
                });
        if let Some((cause, message)) = found {
            health.fail(Blowup::new(clock.step + 1, stage, message).because(cause));
        }
    }
}

/// Particles removed because they left the grid (policy [`LeaveGrid::Remove`]).
#[derive(Resource, Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EscapedParticles {
    /// How many so far.
    pub count: u64,
    /// Their ids, in the order they were removed (a checkpoint removes them again in this
    /// order, which keeps the particles' storage order).
    pub removed: Vec<u32>,
    /// Id and position (x, y, z; z = 0 in 2D) of the first one removed.
    pub first: Option<(u32, [f64; 3])>,
}

impl EscapedParticles {
    /// The failure of a run whose every particle has left the grid, after step `step`.
    pub fn nothing_left(&self, step: u64) -> Blowup {
        let first = self.first.map_or(String::new(), |(id, x)| {
            format!(" (the first, particle {id}, at {x:?})")
        });
        Blowup::new(
            step,
            Stage::Advection,
            format!(
                "every particle has left the grid: {} removed{first}; nothing is left to \
                 simulate",
                self.count
            ),
        )
    }
}

/// Despawns the particles outside the grid (run after advection under [`LeaveGrid::Remove`]).
/// The removal takes effect at the end of the step; particle rows are renumbered, which every
/// system handles because per-row state is rebuilt when the particle count changes.
pub fn remove_escaped_particles<D: Dim>(
    grid: Res<Grid<D>>,
    mut escaped: ResMut<EscapedParticles>,
    particles: Query<(Entity, &ParticleId, &Position<D>), With<Particle>>,
    mut commands: Commands,
) {
    for (entity, id, x) in &particles {
        if !grid.contains(x.0) && x.0.is_finite() {
            escaped.count += 1;
            escaped.removed.push(id.0);
            escaped.first.get_or_insert((id.0, x.0.to_3d()));
            commands.entity(entity).despawn();
        }
    }
}

/// A rank's counterpart of [`remove_escaped_particles`] in a distributed run (run after
/// advection under [`LeaveGrid::Remove`]): the particles it owns that are outside the grid are
/// owned no more, so that nothing after advection counts them (the energy account's work), and
/// are listed in [`Ownership::escaped`] for the step's redistribution to drop and count. A
/// rank despawns none in the step: its rows would move.
pub fn mark_escaped_particles<D: Dim>(
    grid: Res<Grid<D>>,
    mut ownership: ResMut<Ownership>,
    particles: Query<(&ParticleId, &Position<D>), With<Particle>>,
) {
    let ownership = &mut *ownership;
    for (row, (id, x)) in particles.iter().enumerate() {
        if ownership.owns_particle(row) && !grid.contains(x.0) && x.0.is_finite() {
            ownership.particles[row] = false;
            ownership.escaped.push((id.0, x.0.to_3d()));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dim::{SymTensor2, Three, Two};
    use glam::DVec2;

    fn grid() -> Grid<Two> {
        Grid {
            min: DVec2::new(-1.0, 0.5),
            spacing: 0.25,
            cells: [8, 4],
            graded: None,
            window: None,
        }
    }

    /// The fast pass agrees with `Grid::contains` at and beyond the box, and catches every kind
    /// of bad value in any row of any block.
    #[test]
    fn the_fast_particle_pass_agrees_with_the_grid_and_catches_each_bad_value() {
        let grid = grid();
        let n = 2 * CHECK_BLOCK + 3;
        let inside = DVec2::new(0.0, 1.0);
        let positions = vec![Position::<Two>(inside); n];
        let velocities = vec![Velocity::<Two>(DVec2::ZERO); n];
        let stresses = vec![Stress::<Two>(SymTensor2::ZERO); n];
        let volumes = vec![Volume(1.0); n];
        let check =
            |pos: &[Position<Two>], vel: &[Velocity<Two>], s: &[Stress<Two>], v: &[Volume]| {
                all_particles_healthy((pos, vel, s, v), Columns::ALL, &grid, false)
            };
        assert!(check(&positions, &velocities, &stresses, &volumes));
        let row = CHECK_BLOCK + 1;
        for x in [
            grid.max(),
            grid.min,
            DVec2::new(1.0 + 1e-12, 1.0),
            DVec2::new(0.0, 0.5 - 1e-12),
            DVec2::new(f64::NAN, 1.0),
        ] {
            let mut moved = positions.clone();
            moved[row].0 = x;
            assert_eq!(
                check(&moved, &velocities, &stresses, &volumes),
                grid.contains(x),
                "{x}"
            );
        }
        let mut bad_velocity = velocities.clone();
        bad_velocity[n - 1].0.y = f64::INFINITY;
        assert!(!check(&positions, &bad_velocity, &stresses, &volumes));
        let mut bad_stress = stresses.clone();
        bad_stress[0].0.xy = f64::NAN;
        assert!(!check(&positions, &velocities, &bad_stress, &volumes));
        for volume in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let mut bad_volume = volumes.clone();
            bad_volume[row].0 = volume;
            assert!(!check(&positions, &velocities, &stresses, &bad_volume));
        }
        // Each column is looked at only when asked for.
        let columns = (
            &positions[..],
            &bad_velocity[..],
            &bad_stress[..],
            &volumes[..],
        );
        let only = |c| all_particles_healthy(columns, c, &grid, false);
        assert!(only(Columns::POSITION | Columns::VOLUME | Columns::NODES));
        assert!(!only(Columns::VELOCITY));
        assert!(!only(Columns::STRESS));
    }

    #[test]
    fn the_fast_node_pass_catches_a_bad_value_in_any_field() {
        let n = CHECK_BLOCK + 5;
        let masses = vec![NodeMass::default(); n];
        let velocities = vec![NodeVelocity::<Two>::default(); n];
        let forces = vec![NodeForce::<Two>::default(); n];
        assert!(all_nodes_finite(&masses, &velocities, &forces));
        let mut bad = forces.clone();
        bad[n - 1].0[3].x = f64::NAN;
        assert!(!all_nodes_finite(&masses, &velocities, &bad));
        let mut bad = masses.clone();
        bad[CHECK_BLOCK].0[1] = f64::NEG_INFINITY;
        assert!(!all_nodes_finite(&bad, &velocities, &forces));
        let mut bad = velocities.clone();
        bad[7].0[2].y = f64::INFINITY;
        assert!(!all_nodes_finite(&masses, &bad, &forces));
        // An infinity and its negative in one block are caught (their sum is NaN).
        let mut bad = velocities.clone();
        bad[1].0[0].x = f64::INFINITY;
        bad[2].0[0].x = f64::NEG_INFINITY;
        assert!(!all_nodes_finite(&masses, &bad, &forces));
        // Large, tiny and negative finite values pass; finite values whose sum overflows fail
        // the fast pass, and the search after it finds no bad node.
        let mut fine = velocities.clone();
        fine[3].0[0].x = f64::MAX;
        fine[4].0[1].y = -f64::MAX;
        fine[5].0[2].x = -f64::MIN_POSITIVE / 2.0;
        let mut heavy = masses.clone();
        heavy[6].0 = [f64::MAX, -1.0, -0.0, 1e-310];
        assert!(all_nodes_finite(&heavy, &fine, &forces));
        heavy[7].0[0] = f64::MAX;
        assert!(!all_nodes_finite(&heavy, &fine, &forces));
        // In 3D the third component counts too.
        let mut velocities = vec![NodeVelocity::<Three>::default(); n];
        let forces = vec![NodeForce::<Three>::default(); n];
        assert!(all_nodes_finite(&masses, &velocities, &forces));
        velocities[n - 2].0[0].z = f64::NAN;
        assert!(!all_nodes_finite(&masses, &velocities, &forces));
    }

    /// Nodes whose finite values overflow the fast pass's sum are searched and found healthy;
    /// an infinite force after them is named with its node.
    #[test]
    fn huge_finite_node_values_are_no_blow_up() {
        let mut world = crate::testing::tiny_world::<Two>(4, 0.25, 1e-3);
        let mut masses = world.query_filtered::<&mut NodeMass, With<Node>>();
        for mut mass in masses.iter_mut(&mut world).take(2) {
            mass.0[0] = f64::MAX;
        }
        crate::testing::run_system(&mut world, stage_check::<Two>(Stage::Predictor));
        assert!(world.resource::<Health>().failure.is_none());
        let mut forces = world.query_filtered::<(&NodeIndex, &mut NodeForce<Two>), With<Node>>();
        let (index, mut force) = forces.iter_mut(&mut world).nth(7).unwrap();
        let index = index.0;
        force.0[1].y = f64::INFINITY;
        crate::testing::run_system(&mut world, stage_check::<Two>(Stage::Predictor));
        let failure = world.resource::<Health>().failure.clone().unwrap();
        assert!(
            failure
                .message
                .starts_with(&format!("node {index} has non-finite state")),
            "{failure}"
        );
    }

    /// A rank's check: a ghost's bad stress is no blow-up (ghosts near the halo's outer face
    /// compute what no rank uses), an owned particle's is, named; the same on every check after
    /// the first (which looks at every column).
    #[test]
    fn a_rank_fails_on_its_own_particles_only() {
        use crate::components::ParticleBundle;
        use crate::decomposition::Layout;
        let mut world = crate::testing::tiny_world::<Two>(4, 0.25, 1e-3);
        for k in 0..3u32 {
            let x = DVec2::new(0.1 + 0.3 * f64::from(k), 0.5);
            let mut particle = ParticleBundle::<Two>::new(k, x, 1.0, 0.01, 0);
            if k == 2 {
                particle.stress.0.xy = f64::NAN;
            }
            world.spawn(particle);
        }
        let layout = Layout {
            axis: 0,
            slabs: vec![0..2, 2..4],
            halo: 1,
        };
        let mut ownership = Ownership::new(layout, 0, 2, 0..5);
        ownership.particles = vec![true, true, false];
        world.insert_resource(ownership);
        for _ in 0..2 {
            crate::testing::run_system(&mut world, stage_check::<Two>(Stage::Stress));
            assert!(world.resource::<Health>().failure.is_none());
        }
        world.resource_mut::<Ownership>().particles[2] = true;
        crate::testing::run_system(&mut world, stage_check::<Two>(Stage::Stress));
        let failure = world.resource::<Health>().failure.clone().unwrap();
        assert_eq!(failure.stage, Stage::Stress);
        assert!(failure.message.starts_with("particle 2 at "), "{failure}");
        assert!(failure.message.contains("non-finite stress"), "{failure}");
    }
}
