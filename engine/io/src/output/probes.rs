//! Series rows: the energies, momentum and probe values of one `series.csv` row, and what the
//! `Force` probes remember between rows.

use super::{OutputPlan, ProbeKind};
use bevy_ecs::prelude::*;
use fractum_engine::boundary::{BoundaryConditions, Reactions};
use fractum_engine::components::{BodyId, Mass, Particle, ParticleId, Position, Velocity};
use fractum_engine::diagnostics::{Totals, totals};
use fractum_engine::dim::{Dim, Dimension, VectorOps};
use fractum_engine::quasi_static::{KineticWatch, kinetic_fraction};
use fractum_engine::resources::SimClock;
use fractum_engine::series::ForceProbeMemory;
use fractum_engine::with_dim;

/// The values of one `series.csv` row after the step column.
pub fn series_row(world: &mut World, plan: &OutputPlan) -> Vec<f64> {
    let parts = series_parts(world, plan);
    series_row_from(world, plan, &parts)
}

/// What this process adds to a series row: every quantity the row is made from that is a sum
/// over particles, nodes or regions (the totals, three values per probe, the system columns and
/// the energy account). One process's parts make its row; in a distributed run each rank gives
/// the part of what it owns, and the row is made from the sum of the ranks' parts
/// ([`series_row_from`]).
pub fn series_parts(world: &mut World, plan: &OutputPlan) -> Vec<f64> {
    with_dim!(plan.dimension, D => series_parts_of::<D>(world, plan))
}

/// The row made from `parts` ([`series_parts`], of this process or summed over ranks), with
/// what is the same on every rank (time, prescribed displacements) and what the `Force` probes
/// remember taken from `world`.
pub fn series_row_from(world: &mut World, plan: &OutputPlan, parts: &[f64]) -> Vec<f64> {
    with_dim!(plan.dimension, D => series_row_of::<D>(world, plan, parts))
}

/// Where each quantity lies in a row's parts ([`series_parts`]): the totals,
/// [`SeriesParts::PROBE`] values for each probe, the system columns, then the energy account.
struct SeriesParts {
    probes: usize,
    columns: usize,
}

impl SeriesParts {
    /// Kinetic, strain and contact energy, momentum (3) and mass.
    const TOTALS: usize = 7;
    /// A probe's three values, and for a `Track` probe how many of its particle and of its
    /// reference particle were found here (a particle is owned by one rank).
    const PROBE: usize = 5;

    fn of(plan: &OutputPlan) -> Self {
        Self {
            probes: Self::TOTALS,
            columns: Self::TOTALS + Self::PROBE * plan.probes.len(),
        }
    }

    fn probe(&self, slot: usize) -> usize {
        self.probes + Self::PROBE * slot
    }

    /// External work, initial energy and the damage laws' dissipated energy.
    fn account(&self, plan: &OutputPlan) -> usize {
        self.columns + plan.system_columns.len()
    }
}

/// The additive part of one probe ([`SeriesParts::PROBE`] values): a region's reaction, a
/// body's momentum (of which the run makes the `Force` probe's mean force), a tracked
/// displacement with the counts of its particles found here; zero for what the row takes from
/// the totals or the clock.
fn probe_part<D: Dim>(world: &mut World, probe: &ProbeKind) -> [f64; SeriesParts::PROBE] {
    let three = |v: D::Vector| -> [f64; SeriesParts::PROBE] {
        std::array::from_fn(|a| if a < D::N { v[a] } else { 0.0 })
    };
    match probe {
        ProbeKind::Reaction { index, .. } => three(
            world
                .resource::<Reactions<D>>()
                .0
                .get(*index)
                .copied()
                .unwrap_or_default(),
        ),
        ProbeKind::Force { index, .. } => {
            let mut query =
                world.query_filtered::<(&BodyId, &Mass, &Velocity<D>), With<Particle>>();
            let ownership = world.get_resource::<fractum_engine::decomposition::Ownership>();
            let momentum = query
                .iter(world)
                .enumerate()
                .filter(|(row, (b, _, _))| {
                    b.0 == *index && fractum_engine::decomposition::counts_here(ownership, *row)
                })
                .fold(D::Vector::ZERO, |p, (_, (_, m, v))| p + v.0 * m.0);
            three(momentum)
        }
        ProbeKind::Track {
            particle,
            reference,
            ..
        } => {
            let (moved, found) = tracked_displacement::<D>(world, particle);
            let mut part = match reference {
                Some(_) => {
                    let (base, base_found) = tracked_displacement::<D>(world, reference);
                    let mut part = three(moved - base);
                    part[4] = base_found;
                    part
                }
                None => three(moved),
            };
            part[3] = found;
            part
        }
        ProbeKind::CentreOfMassVelocity | ProbeKind::Displacement { .. } => [0.0; 5],
    }
}

/// The displacement since the start of the particle `tracked` (id and start position) where
/// this process owns it, and 1; zero and 0 where it does not (another rank owns it, or it was
/// removed).
fn tracked_displacement<D: Dim>(
    world: &mut World,
    tracked: &Option<(u32, [f64; 3])>,
) -> (D::Vector, f64) {
    let Some((id, origin)) = *tracked else {
        return (D::Vector::ZERO, 0.0);
    };
    let mut query = world.query_filtered::<(&ParticleId, &Position<D>), With<Particle>>();
    let ownership = world.get_resource::<fractum_engine::decomposition::Ownership>();
    let found = query.iter(world).enumerate().find(|(row, (p, _))| {
        p.0 == id && fractum_engine::decomposition::counts_here(ownership, *row)
    });
    match found {
        Some((_, (_, x))) => (D::Vector::from_fn(|a| x.0[a] - origin[a]), 1.0),
        None => (D::Vector::ZERO, 0.0),
    }
}

/// The value of one probe, one entry per axis, from its part of the row ([`probe_part`]).
fn probe_value<D: Dim>(
    world: &mut World,
    slot: usize,
    probe: &ProbeKind,
    part: [f64; SeriesParts::PROBE],
    totals: &Totals,
) -> D::Vector {
    let time = world.resource::<SimClock>().time;
    match probe {
        ProbeKind::Reaction { .. } => D::Vector::from_fn(|a| part[a]),
        // Each particle is owned once; one not found (removed) is no displacement.
        ProbeKind::Track { reference, .. } => {
            let found = part[3] == 1.0 && (reference.is_none() || part[4] == 1.0);
            D::Vector::from_fn(|a| if found { part[a] } else { f64::NAN })
        }
        ProbeKind::CentreOfMassVelocity => {
            let v = totals.centre_of_mass_velocity();
            D::Vector::from_fn(|a| v[a])
        }
        ProbeKind::Force { .. } => {
            let mut memory = world.get_resource_or_init::<ForceProbeMemory>();
            memory
                .mean_force(slot, time, [part[0], part[1], part[2]])
                .map_or(D::Vector::ZERO, |f| D::Vector::from_fn(|a| f[a]))
        }
        ProbeKind::Displacement { index, .. } => {
            let region = &world.resource::<BoundaryConditions>().regions[*index];
            D::Vector::from_fn(|a| {
                region.velocity[a]
                    .as_ref()
                    .map_or(0.0, |f| f.integral(time))
            })
        }
    }
}

/// The particle with the largest kinetic energy (or the first whose energy is not finite), for
/// a message about energy that overflowed.
pub fn largest_energy_particle(world: &mut World) -> String {
    let dimension = *world.resource::<Dimension>();
    with_dim!(dimension, D => {
        let mut query =
            world.query_filtered::<(&ParticleId, &Mass, &Velocity<D>), With<Particle>>();
        let worst = query
            .iter(world)
            .map(|(id, m, v)| (id.0, 0.5 * m.0 * v.0.dot(v.0), v.0.to_3d()))
            .max_by(|a, b| {
                let key = |e: f64| if e.is_finite() { e } else { f64::INFINITY };
                key(a.1).total_cmp(&key(b.1))
            });
        match worst {
            Some((id, energy, v)) => format!(
                "particle {id} has velocity {:?} m/s and kinetic energy {energy:e} J",
                &v[..D::N]
            ),
            None => "no particle is left".to_string(),
        }
    })
}

/// Whether entry `i` of a series row (time first) must be finite: all but a `Track` probe's,
/// which is NaN by design once its particle has left the grid.
pub fn must_be_finite(plan: &OutputPlan, i: usize) -> bool {
    let axes = plan.dimension.count();
    let probes_start = 4 + axes;
    match i.checked_sub(probes_start).map(|k| k / axes) {
        Some(probe) if probe < plan.probes.len() => {
            !matches!(plan.probes[probe], ProbeKind::Track { .. })
        }
        _ => true,
    }
}

/// The columns whose sum the energy residual takes out as dissipated: the damage laws' and the
/// shock viscosity's.
pub const DISSIPATION_COLUMNS: [&str; 2] = ["dissipated_energy", "viscous_dissipation"];

fn series_parts_of<D: Dim>(world: &mut World, plan: &OutputPlan) -> Vec<f64> {
    let t = totals(world);
    let layout = SeriesParts::of(plan);
    let mut parts = vec![t.kinetic_energy, t.strain_energy, t.contact_energy];
    parts.extend(t.momentum);
    parts.push(t.mass);
    debug_assert_eq!(parts.len(), SeriesParts::TOTALS);
    for probe in &plan.probes {
        parts.extend(probe_part::<D>(world, probe));
    }
    let mut dissipated = 0.0;
    if let Some(extra) = world.get_resource::<fractum_engine::series::SeriesColumns>() {
        parts.extend(
            plan.system_columns
                .iter()
                .map(|name| extra.value(name).unwrap_or(f64::NAN)),
        );
        dissipated = DISSIPATION_COLUMNS
            .iter()
            .map(|name| extra.value(name).unwrap_or(0.0))
            .sum();
    }
    let (work, initial) = world
        .get_resource::<fractum_engine::energy::EnergyAccount>()
        .map_or((f64::NAN, f64::NAN), |a| {
            (a.external_work, a.initial_energy)
        });
    parts.extend([work, initial, dissipated]);
    debug_assert_eq!(parts.len(), layout.account(plan) + 3);
    parts
}

/// The initial energy among series `parts` ([`series_parts`], or their sum over ranks): the
/// energy account's parts (work, initial energy, dissipation) end them.
pub fn initial_energy_part(parts: &[f64]) -> f64 {
    parts.len().checked_sub(2).map_or(f64::NAN, |i| parts[i])
}

fn series_row_of<D: Dim>(world: &mut World, plan: &OutputPlan, parts: &[f64]) -> Vec<f64> {
    let layout = SeriesParts::of(plan);
    let t = Totals {
        kinetic_energy: parts[0],
        strain_energy: parts[1],
        contact_energy: parts[2],
        momentum: [parts[3], parts[4], parts[5]],
        mass: parts[6],
    };
    let time = world.resource::<SimClock>().time;
    let mut row = vec![time, t.kinetic_energy, t.strain_energy, t.total_energy()];
    row.extend_from_slice(&t.momentum[..D::N]);
    for (slot, probe) in plan.probes.iter().enumerate() {
        let at = layout.probe(slot);
        let part = std::array::from_fn(|k| parts[at + k]);
        let value = probe_value::<D>(world, slot, probe, part, &t);
        row.extend((0..D::N).map(|a| value[a]));
    }
    let account = layout.account(plan);
    row.extend_from_slice(&parts[layout.columns..account]);
    if plan.kinetic_fraction {
        let floor = world
            .get_resource::<KineticWatch>()
            .map_or(0.0, |w| w.floor);
        let stored = t.strain_energy + t.contact_energy;
        row.push(kinetic_fraction(t.kinetic_energy, stored, floor));
    }
    let (work, initial, dissipated) = (parts[account], parts[account + 1], parts[account + 2]);
    row.push(work);
    row.push(work - (t.total_energy() - initial) - dissipated);
    row
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The force probe reports the mean force over each interval between rows, nothing at the
    /// first row, and repeats itself when asked twice at one time.
    #[test]
    fn force_probes_report_the_momentum_rate_between_rows() {
        let mut memory = ForceProbeMemory::default();
        assert_eq!(memory.mean_force(1, 0.0, [1.0, 2.0, 0.0]), None);
        let force = memory.mean_force(1, 0.5, [2.0, 1.0, 0.0]).unwrap();
        assert_eq!(force, [2.0, -2.0, 0.0]);
        assert_eq!(memory.mean_force(1, 0.5, [9.0, 9.0, 9.0]), Some(force));
        assert_eq!(
            memory.mean_force(1, 1.5, [3.0, 1.0, 0.0]),
            Some([1.0, 0.0, 0.0])
        );
        assert_eq!(memory.mean_force(0, 1.5, [3.0, 1.0, 0.0]), None);
    }
}
