//! Run health: after every stage, the engine checks particle and node state and stops the run
//! at the first non-finite value or the first particle outside the grid, naming the step, the
//! stage and the particle or node.

use crate::components::{
    Node, NodeForce, NodeIndex, NodeMass, NodeVelocity, Particle, ParticleId, Position, Stress,
    Velocity, Volume,
};
use crate::dim::Vector;
use crate::resources::{Grid, SimClock};
use crate::scene::LeaveGrid;
use crate::stage::Stage;
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
}

/// Run condition: no failure so far.
pub fn healthy(health: Res<Health>) -> bool {
    health.failure.is_none()
}

/// The slices of the one table that holds all particles (or all nodes), from a contiguous query.
///
/// The engine creates all particles (and all nodes) with one bundle and never adds or removes
/// components, so each lives in exactly one table and slice index equals row index (for nodes,
/// the node index). A second table means some code broke that rule, and continuing would
/// silently skip entities, so that is a panic naming the rule. `None` means there are no such
/// entities.
pub fn single_table<I: IntoIterator, E: std::fmt::Debug>(
    tables: Result<I, E>,
    what: &str,
) -> Option<I::Item> {
    let mut tables = tables
        .unwrap_or_else(|e| panic!("{what} components must use table storage: {e:?}"))
        .into_iter();
    let first = tables.next();
    assert!(
        tables.next().is_none(),
        "{what} are stored in more than one table: a component was added to or removed from only \
         some of them. Give every one of them the same components at creation."
    );
    first
}

fn fmt_vec(v: Vector) -> String {
    format!("({:e}, {:e})", v.x, v.y)
}

type ParticleCheckQuery<'w, 's> = Query<
    'w,
    's,
    (
        &'static ParticleId,
        &'static Position,
        &'static Velocity,
        &'static Stress,
        &'static Volume,
    ),
    With<Particle>,
>;
type NodeCheckQuery<'w, 's> = Query<
    'w,
    's,
    (
        &'static NodeIndex,
        &'static NodeMass,
        &'static NodeVelocity,
        &'static NodeForce,
    ),
    With<Node>,
>;

fn first_bad_particle(
    particles: &ParticleCheckQuery,
    grid: &Grid,
    outside_allowed: bool,
) -> Option<String> {
    let (ids, positions, velocities, stresses, volumes) =
        single_table(particles.contiguous_iter(), "particles")?;
    let (lo, hi) = (grid.min, grid.max());
    let bad = (0..ids.len()).into_par_iter().find_first(|&p| {
        let x = positions[p].0;
        !(x.is_finite()
            && (outside_allowed || grid.contains(x))
            && velocities[p].0.is_finite()
            && stresses[p].0.is_finite()
            && volumes[p].0.is_finite()
            && volumes[p].0 > 0.0)
    })?;
    let (id, x, v) = (ids[bad].0, positions[bad].0, velocities[bad].0);
    Some(if !x.is_finite() {
        format!("particle {id} has a non-finite position {}", fmt_vec(x))
    } else if !grid.contains(x) {
        format!(
            "particle {id} left the grid: position {}, velocity {}, grid box {} to {}",
            fmt_vec(x),
            fmt_vec(v),
            fmt_vec(lo),
            fmt_vec(hi)
        )
    } else if !v.is_finite() {
        format!(
            "particle {id} at {} has a non-finite velocity {}",
            fmt_vec(x),
            fmt_vec(v)
        )
    } else if !stresses[bad].0.is_finite() {
        format!(
            "particle {id} at {} has a non-finite stress {:?}",
            fmt_vec(x),
            stresses[bad].0
        )
    } else {
        format!(
            "particle {id} at {} has an invalid volume {:e}",
            fmt_vec(x),
            volumes[bad].0
        )
    })
}

fn first_bad_node(nodes: &NodeCheckQuery) -> Option<String> {
    let (indices, masses, velocities, forces) = single_table(nodes.contiguous_iter(), "nodes")?;
    let bad = (0..indices.len()).into_par_iter().find_first(|&n| {
        !(masses[n].0.iter().all(|m| m.is_finite())
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
pub fn stage_check(
    stage: Stage,
) -> impl FnMut(
    Res<SimClock>,
    Res<Grid>,
    Option<Res<LeaveGrid>>,
    ResMut<Health>,
    ParticleCheckQuery,
    NodeCheckQuery,
) {
    move |clock, grid, policy, mut health, particles, nodes| {
        let outside_allowed = policy.is_some_and(|p| *p == LeaveGrid::Remove);
        let found = first_bad_particle(&particles, &grid, outside_allowed)
            .or_else(|| first_bad_node(&nodes));
        if let Some(message) = found {
            health.failure = Some(Blowup {
                step: clock.step + 1,
                stage,
                message,
            });
        }
    }
}

/// Particles removed because they left the grid (policy [`LeaveGrid::Remove`]).
#[derive(Resource, Clone, Debug, Default, PartialEq)]
pub struct EscapedParticles {
    /// How many so far.
    pub count: u64,
    /// Id and position of the first one removed.
    pub first: Option<(u32, Vector)>,
}

/// Despawns the particles outside the grid (run after advection under [`LeaveGrid::Remove`]).
/// The removal takes effect at the end of the step; particle rows are renumbered, which every
/// system handles because per-row state is rebuilt when the particle count changes.
pub fn remove_escaped_particles(
    grid: Res<Grid>,
    mut escaped: ResMut<EscapedParticles>,
    particles: Query<(Entity, &ParticleId, &Position), With<Particle>>,
    mut commands: Commands,
) {
    for (entity, id, x) in &particles {
        if !grid.contains(x.0) && x.0.is_finite() {
            escaped.count += 1;
            escaped.first.get_or_insert((id.0, x.0));
            commands.entity(entity).despawn();
        }
    }
}
